"""An LS-DYNA deck as a scene: its keywords as the scene tables they mean.

:func:`deck_document` reads a deck (dyna/reader.py) and writes the scene document (the raw
tables a TOML scene would hold) that its keywords say, so the scene's own reader checks
every value as strictly as the same key in a TOML file, and a message about one names the
deck's file, line and keyword (:attr:`DeckDocument.origins`).  What is read, and as what:

=========================================  ===================================================
``*CONTROL_TERMINATION``                   ``[solve]`` dynamic, ``end_time`` = ENDTIM;
                                           ENDMAS -> ``added_mass_limit``
``*CONTROL_TIMESTEP``                      TSSFAC -> ``dt_safety``; DT2MS < 0 ->
                                           ``mass_scaling = "conventional"``, ``target_dt`` =
                                           TSSFAC |DT2MS| (IMSCL = 1: ``"selective"``)
``*CONTROL_HOURGLASS``, ``*HOURGLASS``     QH / QM -> ``[element].hourglass`` (one per scene)
``*CONTROL_SHELL``                         BWC = 1 -> ``warping = "bwc"``; INTGRD = 1 -> Lobatto
``*CONTROL_CONTACT``                       SLSFAC (x SFS) -> the contact ``stiffness``
``*BOUNDARY_SPC_NODE/_SET``                ``[[boundary]]``
``*BOUNDARY_PRESCRIBED_MOTION_NODE/_SET``  ``[[motion]]`` (VAD 0/1/2, DOF 1-3, 5-7, LCID, SF)
``*BOUNDARY_PRESCRIBED_MOTION_RIGID``      ``[[motion]]`` of the rigid part's body
``*INITIAL_VELOCITY(_NODE, _GENERATION)``  ``[[initial]]``
``*LOAD_NODE_POINT/_SET``                  ``[[load]]`` (each node SF x the curve)
``*LOAD_SHELL_ELEMENT/_SET``               ``[[pressure]]`` (positive: against the normal)
``*LOAD_BODY_X/Y/Z``                       ``[gravity]`` (the base acceleration, reversed)
``*RIGIDWALL_PLANAR``                      ``[[wall]]``; ``_FINITE``: a rectangle ``[[tool]]``;
                                           ``_MOVING``: moving with a ``[[rigid_body]]`` without nodes
``*MAT_RIGID`` parts                       ``[[rigid_body]]`` (CMO = 1: CON1, CON2 -> ``fixed``;
                                           ``*PART_INERTIA``: its own mass and inertia)
``*CONSTRAINED_NODAL_RIGID_BODY(_SPC)``    ``[[rigid_body]]`` (``_INERTIA``: its own mass and inertia)
``*CONSTRAINED_EXTRA_NODES_NODE/_SET``     nodes added to the rigid part's body
``*ELEMENT_MASS``, ``*ELEMENT_MASS_PART``  ``[[point_mass]]``
``*SET_NODE/_SHELL/_PART/_SEGMENT``        the sets the cards above name (``_LIST``,
                                           ``_GENERATE``, ``_TITLE``)
``*CONTACT_AUTOMATIC_SINGLE_SURFACE``      ``[contact]`` (FS, VDC, SFS, SST); of some parts:
                                           a ``[[contact_pair]]`` of them with themselves
``*CONTACT_AUTOMATIC_SURFACE_TO_SURFACE``  ``[[contact_pair]]`` (``_NODES_TO_SURFACE``: one-way)
``*CONTACT_TIED_..._TO_SURFACE``           ``[[tie]]`` (``_SHELL_EDGE_``: with rotations)
``*CONSTRAINED_SPOTWELD``                  ``[[spotweld]]``
``*LOAD_SEGMENT(_SET)``                    ``[[pressure]]`` on the shells the segments are
``*DATABASE_HISTORY_NODE(_SET)``           ``[[probe]]`` per node
``*DATABASE_BINARY_D3PLOT``                ``[output].frame_interval``
``*DATABASE_GLSTAT/_RCFORC/...``           ``[output].history_interval`` (the smallest DT)
=========================================  ===================================================

Every other keyword, and every field of a read keyword whose value says something these
tables cannot, is listed (:class:`Unread`) with its line and one sentence on what is
ignored.  One that changes the physics (``physics``) stops the scene unless the user accepts
it (``--accept-unread``); definitions (``*DEFINE_*``, other ``*SET_*``) and output requests
are listed only.  Node and element ids are the deck's own; the scene gets their positions
in the mesh (mesh.py keeps the shells' nodes in the order read and drops the others).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from ..problems import SceneError
from .reader import (
    INERTIA_TENSOR,
    INERTIA_VELOCITY,
    Block,
    Deck,
    Line,
    columns,
    data_cards,
    location,
    read_card,
    read_deck,
)
from .parameters import using

DOF_NAMES = {1: "ux", 2: "uy", 3: "uz", 5: "rx", 6: "ry", 7: "rz"}
"""LS-DYNA DOF codes of *BOUNDARY_PRESCRIBED_MOTION and *LOAD_NODE -> scene DOFs."""
CONSTRAINT_CODES = {0: "", 1: "x", 2: "y", 3: "z", 4: "xy", 5: "yz", 6: "zx", 7: "xyz"}
"""*MAT_RIGID CON1 / CON2 and *CONSTRAINED_NODAL_RIGID_BODY_SPC codes -> constrained axes."""
NEVER = 1e20
"""Birth/death and failure times at or beyond this are LS-DYNA's "never"."""


@dataclass(frozen=True)
class Unread:
    """A keyword, or a field of one, that the scene does not read."""
    where: str
    what: str
    physics: bool

    def line(self) -> str:
        return f"{self.where}: not read: {self.what}"


@dataclass
class DeckDocument:
    """A deck's scene document: the raw tables, where each came from, what was not read."""
    raw: dict
    origins: dict = field(default_factory=dict)
    """A table path of the document (``[[boundary]][2]``, ``[solve].end_time``) -> the
    ``file:line: *KEYWORD`` it was read from."""
    unread: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    """Values read with a stated difference of meaning (one line each)."""

    def problems(self, accept_unread: bool) -> list[str]:
        """The lines that stop the scene: unread keywords that change the physics."""
        if accept_unread:
            return []
        lines = [u.line() for u in self.unread if u.physics]
        if lines:
            lines.append(f"{len(lines)} keyword{'s' if len(lines) != 1 else ''} or field{'s' if len(lines) != 1 else ''}"
                         " above would change the physics and are not read: run with --accept-unread to run "
                         "without them")
        return lines

    def warnings(self, accept_unread: bool) -> list[str]:
        shown = [u for u in self.unread if accept_unread or not u.physics]
        return [u.line() for u in shown] + list(self.notes)


# ---------------------------------------------------------------- card layouts
def _ints(names: str, width: int = 10):
    return columns(names, width, "i")


_SET_HEAD = _ints("sid") + columns("da1 da2 da3 da4", 10)
_IDS = _ints("i1 i2 i3 i4 i5 i6 i7 i8")
_SEGMENT = _ints("n1 n2 n3 n4") + columns("a1 a2 a3 a4", 10)
_TERMINATION = columns("endtim", 10) + _ints("endcyc") + columns("dtmin endeng endmas", 10) + _ints("nosol")
_TIMESTEP = columns("dtinit tssfac", 10) + _ints("isdo") + columns("tslimt dt2ms", 10) + _ints("lctm erode ms1st")
_TIMESTEP_2 = columns("dt2msf", 10) + _ints("dt2mslc imscl unused1 unused2") + columns("rmscl", 10) + \
    _ints("unused3 ihdo")
_CONTROL_HOURGLASS = _ints("ihq") + columns("qh", 10)
_HOURGLASS = _ints("hgid ihq") + columns("qm", 10) + _ints("ibq") + columns("q1 q2 qb qw", 10)
_CONTROL_SHELL = [("wrpang", 10, "f"), *_ints("esort irnxx istupd theory bwc miter proj")]
_CONTROL_SHELL_2 = [("rotascl", 10, "f"), *_ints("intgrd lamsht cstyp6 tshell")]
_CONTROL_CONTACT = columns("slsfac rwpnal", 10) + _ints("islchk shlthk penopt thkchg orien enmass")
_SPC = _ints("id cid dofx dofy dofz dofrx dofry dofrz")
_MOTION = _ints("id dof vad lcid") + columns("sf", 10) + _ints("vid") + columns("death birth", 10)
_INITIAL = _ints("nsid nsidex boxid irigid icid")
_VELOCITY = columns("vx vy vz vxr vyr vzr", 10)
_INITIAL_NODE = _ints("nid") + columns("vx vy vz vxr vyr vzr", 10) + _ints("icid")
_GENERATION = _ints("id styp") + columns("omega vx vy vz", 10) + _ints("ivatn icid")
_GENERATION_2 = columns("xc yc zc nx ny nz phase", 10) + _ints("irigid")
_LOAD_NODE = _ints("id dof lcid") + columns("sf", 10) + _ints("cid m1 m2 m3")
_LOAD_SHELL = _ints("id lcid") + columns("sf at", 10)
_LOAD_BODY = _ints("lcid") + columns("sf", 10) + _ints("lciddr") + columns("xc yc zc", 10) + _ints("cid")
_WALL = _ints("nsid nsidex boxid") + columns("offset birth death rwksf", 10)
_WALL_2 = columns("xt yt zt xh yh zh fric wvel", 10)
_WALL_FINITE = columns("xhev yhev zhev lenl lenm", 10)
_WALL_MOVING = columns("mass v0", 10)
_NODAL_RIGID = _ints("pid cid nsid pnode iprt drflag rrflag")
_RIGID_SPC = columns("cmo con1 con2", 10)
_RIGID_INERTIA = columns("xc yc zc tm", 10) + _ints("nodeid")
_EXTRA_NODES = _ints("pid id")
_ELEMENT_MASS = [("eid", 8, "i"), ("nid", 8, "i"), ("mass", 16, "f"), ("pid", 8, "i")]
_ELEMENT_MASS_PART = [("pid", 8, "i"), ("addmass", 16, "f"), ("finmass", 16, "f")]
_CONTACT_1 = _ints("ssid msid sstyp mstyp sboxid mboxid spr mpr")
_CONTACT_2 = columns("fs fd dc vc vdc", 10) + _ints("penchk") + columns("bt dt", 10)
_CONTACT_3 = columns("sfs sfm sst mst sfst sfmt fsf vsf", 10)
_DATABASE = columns("dt", 10) + _ints("binary lcur ioopt")
_D3PLOT = columns("dt", 10) + _ints("lcdt beam npltc psetid")

HISTORY_DATABASES = ("GLSTAT", "RCFORC", "MATSUM", "NODOUT", "SPCFORC", "SLEOUT", "RWFORC", "BNDOUT")
"""*DATABASE_<name> whose interval sets [output].history_interval (energy.csv, force.csv,
probes.csv and parts.csv are written at the same times)."""
LISTED_ONLY = ("DEFINE_", "SET_", "DATABASE_", "CONTROL_OUTPUT", "CONTROL_CPU", "CONTROL_MPP", "CONTROL_PARALLEL",
               "CONTROL_ENERGY", "CONTROL_SOLUTION", "CONTROL_ACCURACY", "CONTROL_REPORT", "CONTROL_DEBUG",
               "CONTROL_SOLID", "CONTROL_BULK_VISCOSITY")
"""Keywords that change nothing by themselves (definitions a card must refer to, output
requests, reports): listed, never an error."""
LISTED_WHY = {
    "DEFINE_": "a definition used only where a card refers to it (such a card is reported)",
    "SET_": "a set used only where a card refers to it (such a card is reported)",
    "DATABASE_": "an output request: not written",
    "CONTROL_ENERGY": "energies are always computed (energy.csv)",
    "CONTROL_ACCURACY": "the shells' stress update is objective at any rotation",
    "CONTROL_SOLID": "settings of solid elements (a shell model has none)",
    "CONTROL_BULK_VISCOSITY": "bulk viscosity acts in solid elements (LS-DYNA's shells only with TYPE < 0)",
}


# ---------------------------------------------------------------- the translator
class _Translator:
    def __init__(self, path: Path, deck: Deck, elements: np.ndarray):
        self.path = path
        self.deck = deck
        self.elements = elements
        self.doc = DeckDocument(raw={})
        self.node_sets: dict[int, tuple[list[int], str]] = {}
        self.shell_sets: dict[int, tuple[list[int], str]] = {}
        self.part_sets: dict[int, tuple[list[int], str]] = {}
        self.segment_sets: dict[int, tuple[list[tuple], str]] = {}
        self.rigid_parts: dict[int, str] = {}
        self.bodies: dict[str, dict] = {}
        self.windows: list[tuple] = []
        """(where, BIRTH, DEATH) of each rigid part's prescribed rotation with a window (not read)."""
        self.npltc = None

    # -- ids -> mesh positions (built when a keyword first needs them: a deck of mesh cards only
    #    parses in the time of its reading)
    @cached_property
    def position(self) -> np.ndarray:
        """(n,) mesh position of each node read (-1: no shell uses it, the mesh drops it)."""
        deck = self.deck
        used = deck.used_nodes if deck.used_nodes is not None else np.ones(len(deck.node_ids), dtype=bool)
        return np.where(used, np.cumsum(used) - 1, -1)

    @cached_property
    def node_index(self) -> dict[int, int]:
        return {int(n): int(p) for n, p in zip(self.deck.node_ids, self.position) if p >= 0}

    @cached_property
    def unused_nodes(self) -> set[int]:
        return {int(n) for n, p in zip(self.deck.node_ids, self.position) if p < 0}

    @cached_property
    def element_index(self) -> dict[int, int]:
        return {int(e): k for k, e in enumerate(self.deck.element_ids)}

    @cached_property
    def corners(self) -> np.ndarray:
        """(m, 4) mesh positions of each shell's corners (-1: a triangle's fourth)."""
        return np.where(self.elements >= 0, self.position[np.maximum(self.elements, 0)], -1)

    # -- helpers
    def origin(self, key: str, where: str) -> None:
        self.doc.origins[key] = where

    def unread(self, where: str, what: str, physics: bool = True) -> None:
        self.doc.unread.append(Unread(where, what, physics))

    def note(self, where: str, what: str) -> None:
        self.doc.notes.append(f"{where}: {what}")

    def table(self, name: str) -> dict:
        return self.doc.raw.setdefault(name, {})

    def append(self, name: str, entry: dict, where: str) -> None:
        entries = self.doc.raw.setdefault(name, [])
        self.origin(f"[[{name}]][{len(entries)}]", where)
        entries.append(entry)

    def set_value(self, table: str, key: str, value, where: str) -> None:
        self.table(table)[key] = value
        self.origin(f"[{table}].{key}", where)

    def positions(self, nids, where: str, what: str) -> list[int]:
        """Mesh positions of deck node ids (an undefined id is an error; a node no shell uses
        is dropped with a note: the mesh has no such node)."""
        out, dropped = [], []
        for nid in nids:
            if nid in self.node_index:
                out.append(self.node_index[nid])
            elif nid in self.unused_nodes:
                dropped.append(nid)
            else:
                raise SceneError(f"{where}: {what}: node {nid} is not defined by a *NODE card")
        if dropped:
            self.note(where, f"{what}: {len(dropped)} node{'s' if len(dropped) != 1 else ''} that no shell uses "
                             f"(e.g. {dropped[0]}) left out: the mesh has only the shells' nodes")
        return sorted(set(out))

    def nodeset(self, name: str, ids: list[int], where: str) -> str:
        """A [nodesets.NAME] of mesh positions; its name."""
        sets = self.table("nodesets")
        if name not in sets:
            sets[name] = {"ids": ids}
            self.origin(f"[nodesets.{name}]", where)
        return name

    def node_set(self, sid: int, where: str, what: str) -> str:
        """The scene node set of a deck *SET_NODE id (0: every node)."""
        if sid == 0:
            return "all"
        if sid not in self.node_sets:
            raise SceneError(f"{where}: {what} {sid} is not a *SET_NODE of this deck")
        nids, at = self.node_sets[sid]
        ids = self.positions(nids, at, f"*SET_NODE {sid}")
        if not ids:
            raise SceneError(f"{where}: {what} {sid}: the set holds no node of a shell")
        return self.nodeset(f"set_{sid}", ids, at)

    def single_node(self, nid: int, where: str) -> str:
        ids = self.positions([nid], where, "NID")
        if not ids:
            raise SceneError(f"{where}: node {nid} is not a node of any shell (the mesh has only the shells' nodes)")
        return self.nodeset(f"node_{nid}", ids, where)

    def part_nodes(self, pids, where: str) -> list[int]:
        """Mesh positions of the nodes of the shells of parts `pids`."""
        deck = self.deck
        for pid in pids:
            if pid not in deck.parts and not np.any(deck.element_parts == pid):
                raise SceneError(f"{where}: part {pid} is not a *PART of this deck")
        rows = np.nonzero(np.isin(deck.element_parts, list(pids)))[0]
        return self.element_nodes(rows)

    def element_nodes(self, rows) -> list[int]:
        corners = self.corners[rows]
        return sorted({int(c) for c in corners.ravel() if c >= 0})

    def part_set(self, sid: int, where: str) -> list[int]:
        if sid not in self.part_sets:
            raise SceneError(f"{where}: part set {sid} is not a *SET_PART of this deck")
        return self.part_sets[sid][0]

    def curve(self, lcid: int, where: str, shift: float = 0.0) -> str:
        """[curves.lc_<lcid>] from the deck's *DEFINE_CURVE (abscissae shifted by `shift`)."""
        if lcid not in self.deck.curves:
            raise SceneError(f"{where}: load curve {lcid} is not a *DEFINE_CURVE of this deck")
        name = f"lc_{lcid}" if shift == 0.0 else f"lc_{lcid}_at_{shift:g}".replace(".", "p").replace("-", "m")
        curves = self.table("curves")
        if name not in curves:
            points = [[float(a) + shift, float(o)] for a, o in self.deck.curves[lcid]]
            if shift > 0.0:
                points = [[0.0, 0.0], [shift, 0.0]] + [p for p in points if p[0] > shift] \
                    if points and points[0][0] >= shift else points
            curves[name] = {"points": points}
            self.origin(f"[curves.{name}]", where)
        return name

    # -- the deck
    def run(self) -> DeckDocument:
        deck, doc = self.deck, self.doc
        blocks = list(deck.keywords)
        # sets first: cards anywhere in the deck may name them
        rest = []
        for block in blocks:
            if block.name.startswith("SET_") and self._read_set(block):
                continue
            rest.append(block)
        name = self.path.stem if self.path.stem.replace("-", "_").replace(".", "_").isidentifier() else "deck"
        doc.raw["scene"] = {"name": name, "units": "the deck's consistent units (an LS-DYNA deck does not state them)",
                            "description": deck.title}
        doc.raw["mesh"] = {"kind": "file", "path": self.path.name}
        self._rigid_parts()
        self._node_constraints()
        for block in rest:
            handler = self._handler(block.name)
            if handler is None:
                self._not_read(block)
            else:
                handler(block)
        for name, body in self.bodies.items():
            where = body.pop("_where")
            extra = body.pop("_extra")
            body["nodes"] = self.nodeset(f"body_{name}", sorted(set(body.pop("_nodes")) | set(extra)), where)
            self.append("rigid_body", body, where)
        self.finish()
        return doc

    def _handler(self, name: str):
        base = name
        for suffix in ("_TITLE", "_ID"):
            if base.endswith(suffix):
                base = base[: -len(suffix)]
        table = {
            "CONTROL_TERMINATION": self._termination, "CONTROL_TIMESTEP": self._timestep,
            "CONTROL_HOURGLASS": self._control_hourglass, "HOURGLASS": self._hourglass,
            "CONTROL_SHELL": self._control_shell, "CONTROL_CONTACT": self._control_contact,
            "BOUNDARY_SPC_NODE": self._spc, "BOUNDARY_SPC_SET": self._spc,
            "BOUNDARY_PRESCRIBED_MOTION_NODE": self._motion, "BOUNDARY_PRESCRIBED_MOTION_SET": self._motion,
            "BOUNDARY_PRESCRIBED_MOTION_RIGID": self._motion,
            "INITIAL_VELOCITY": self._initial, "INITIAL_VELOCITY_NODE": self._initial_node,
            "INITIAL_VELOCITY_GENERATION": self._generation,
            "LOAD_NODE_POINT": self._load_node, "LOAD_NODE_SET": self._load_node, "LOAD_NODE": self._load_node,
            "LOAD_SHELL_ELEMENT": self._load_shell, "LOAD_SHELL_SET": self._load_shell,
            "LOAD_SEGMENT": self._load_segment, "LOAD_SEGMENT_SET": self._load_segment,
            "LOAD_BODY_X": self._load_body, "LOAD_BODY_Y": self._load_body, "LOAD_BODY_Z": self._load_body,
            "RIGIDWALL_PLANAR": self._wall, "RIGIDWALL_PLANAR_FINITE": self._wall,
            "RIGIDWALL_PLANAR_MOVING": self._wall, "RIGIDWALL_PLANAR_FINITE_MOVING": self._wall,
            "CONSTRAINED_NODAL_RIGID_BODY": self._nodal_rigid, "CONSTRAINED_NODAL_RIGID_BODY_SPC": self._nodal_rigid,
            "CONSTRAINED_NODAL_RIGID_BODY_INERTIA": self._nodal_rigid,
            "CONSTRAINED_EXTRA_NODES_NODE": self._extra_nodes, "CONSTRAINED_EXTRA_NODES_SET": self._extra_nodes,
            "ELEMENT_MASS": self._element_mass, "ELEMENT_MASS_PART": self._element_mass_part,
            "CONTACT_AUTOMATIC_SINGLE_SURFACE": self._single_surface,
            "CONTACT_AUTOMATIC_SURFACE_TO_SURFACE": self._interface,
            "CONTACT_AUTOMATIC_NODES_TO_SURFACE": self._interface,
            "CONTACT_TIED_NODES_TO_SURFACE": self._tie, "CONTACT_TIED_NODES_TO_SURFACE_OFFSET": self._tie,
            "CONTACT_TIED_SHELL_EDGE_TO_SURFACE": self._tie, "CONTACT_TIED_SHELL_EDGE_TO_SURFACE_OFFSET": self._tie,
            "CONSTRAINED_SPOTWELD": self._spotweld,
            "DATABASE_HISTORY_NODE": self._history, "DATABASE_HISTORY_NODE_SET": self._history,
            "DATABASE_BINARY_D3PLOT": self._d3plot,
        }
        if base in table:
            return table[base]
        if base.startswith("DATABASE_") and base[len("DATABASE_"):] in HISTORY_DATABASES:
            return self._history_interval
        return None

    def _not_read(self, block: Block) -> None:
        where = location(block.line, block.name)
        for prefix in LISTED_ONLY:
            if block.name.startswith(prefix):
                why = next((w for p, w in LISTED_WHY.items() if block.name.startswith(p)), "settings we have no "
                           "counterpart for (they change no result)")
                self.unread(where, why, physics=False)
                return
        self.unread(where, "a keyword this reader has no counterpart for (it may change the physics)")

    @staticmethod
    def _titled(block: Block, keep_blank: bool = False) -> list[Line]:
        """The data cards, a first *_ID / *_TITLE heading card dropped; blank lines dropped
        too, or kept as cards of defaults (`keep_blank`)."""
        cards = data_cards(block)
        if block.name.endswith(("_ID", "_TITLE")) and cards:
            cards = cards[1:]
        return cards if keep_blank else [c for c in cards if c.text.strip()]

    def _one(self, block: Block, layouts) -> tuple[dict, str]:
        """The fields of a keyword of one card group (later cards optional: defaults)."""
        cards = self._titled(block)
        where = location(block.line, block.name)
        if not cards:
            raise SceneError(f"{where}: no data card")
        values = {}
        for card, layout in zip(cards, layouts):
            values.update(read_card(card, layout, block.name))
        for layout in layouts[len(cards):]:
            values.update({n: (0 if k == "i" else 0.0) for n, _, k in layout})
        return values, location(cards[0], block.name)

    def _each(self, block: Block, layout):
        """(fields, where) of each card of a keyword that repeats one card."""
        for card in self._titled(block):
            yield read_card(card, layout, block.name), location(card, block.name)

    # -- sets
    def _read_set(self, block: Block) -> bool:
        name = block.name
        titled = name.endswith("_TITLE")
        base = name[: -len("_TITLE")] if titled else name
        kinds = {"SET_NODE": "node", "SET_NODE_LIST": "node", "SET_NODE_LIST_GENERATE": "node_gen",
                 "SET_SHELL": "shell", "SET_SHELL_LIST": "shell", "SET_SHELL_LIST_GENERATE": "shell_gen",
                 "SET_SHELL_GENERATE": "shell_gen", "SET_PART": "part", "SET_PART_LIST": "part",
                 "SET_PART_LIST_GENERATE": "part_gen", "SET_SEGMENT": "segment"}
        if base not in kinds:
            return False
        kind = kinds[base]
        cards = [c for c in data_cards(block)]
        if titled:
            cards = cards[1:]
        cards = [c for c in cards if c.text.strip()]
        if not cards:
            raise SceneError(f"{location(block.line, name)}: no set card")
        head = read_card(cards[0], _SET_HEAD, name)
        sid, where = head["sid"], location(cards[0], name)
        if sid <= 0:
            raise SceneError(f"{where}: SID must be > 0, got {sid}")
        table = {"node": self.node_sets, "shell": self.shell_sets, "part": self.part_sets,
                 "segment": self.segment_sets}[kind.split("_")[0]]
        if sid in table:
            raise SceneError(f"{where}: {base.replace('_LIST', '').replace('_GENERATE', '')} {sid} is defined twice "
                             f"(also {table[sid][1]})")
        if kind == "segment":
            items = [tuple(v[f"n{k}"] for k in range(1, 5)) for v in (read_card(c, _SEGMENT, name) for c in cards[1:])]
        else:
            items = []
            for card in cards[1:]:
                v = read_card(card, _IDS, name)
                values = [v[f"i{k}"] for k in range(1, 9)]
                if kind.endswith("_gen"):
                    for a, b in zip(values[0::2], values[1::2]):
                        if a == 0 and b == 0:
                            continue
                        if a <= 0 or b < a:
                            raise SceneError(f"{location(card, name)}: range {a}..{b}: expected 0 < begin <= end")
                        if b - a > 10_000_000:
                            raise SceneError(f"{location(card, name)}: range {a}..{b} is longer than 10 000 000 ids")
                        items.extend(range(a, b + 1))
                else:
                    items.extend(x for x in values if x != 0)
            if kind == "node_gen":       # a generated range may pass ids that no *NODE defines
                items = [i for i in items if i in self.node_index or i in self.unused_nodes]
            elif kind == "shell_gen":
                items = [i for i in items if i in self.element_index]
        table[sid] = (items, where)
        return True

    # -- controls
    def _termination(self, block: Block) -> None:
        v, where = self._one(block, [_TERMINATION])
        self.set_value("solve", "kind", "dynamic", where)
        self.set_value("solve", "end_time", v["endtim"], where)
        for key, what in (("endcyc", "ENDCYC (a step count that ends the run)"),
                          ("dtmin", "DTMIN (a smallest time step that ends the run)"),
                          ("endeng", "ENDENG (an energy change that ends the run)")):
            if v[key]:
                self.unread(where, f"{what} = {v[key]:g}: the run ends at ENDTIM only", physics=False)
        if v["endmas"] > 0.0:
            self.endmas = (v["endmas"], where)      # with conventional mass scaling (finish)

    def _timestep(self, block: Block) -> None:
        v, where = self._one(block, [_TIMESTEP, _TIMESTEP_2])
        tssfac = v["tssfac"] or 0.9
        self.set_value("solve", "dt_safety", tssfac, where)
        if v["dt2ms"] != 0.0:
            kind = "selective" if v["imscl"] != 0 else "conventional"
            self.set_value("solve", "mass_scaling", kind, where)
            self.set_value("solve", "target_dt", tssfac * abs(v["dt2ms"]), where)
            if v["dt2ms"] > 0.0:
                self.unread(where, f"DT2MS = {v['dt2ms']:g} > 0 also takes mass away from elements whose step is "
                                   "above TSSFAC DT2MS: read as DT2MS < 0 (mass only added)")
            if v["imscl"] < 0:
                self.unread(where, f"IMSCL = {v['imscl']}: selective mass scaling of a part set only: read as "
                                   "every part's")
        for key, what in (("isdo", "ISDO (another shell time-step formula)"),
                          ("tslimt", "TSLIMT (a step floor for plastic shells)"), ("lctm", "LCTM (a step ceiling curve)"),
                          ("erode", "ERODE (erosion of elements whose step is small)"),
                          ("ms1st", "MS1ST (mass scaling fixed at the first step)"),
                          ("dt2msf", "DT2MSF (a target step from a factor)"),
                          ("dt2mslc", "DT2MSLC (a target step curve)"), ("rmscl", "RMSCL (rotational scaling)"),
                          ("ihdo", "IHDO (another step formula)")):
            if v[key]:
                self.unread(where, f"{what} = {v[key]:g}")
        if v["dtinit"]:
            self.unread(where, f"DTINIT = {v['dtinit']:g}: the first step is the stable one", physics=False)

    def _control_hourglass(self, block: Block) -> None:
        v, where = self._one(block, [_CONTROL_HOURGLASS])
        self.hourglass_default = (v["qh"] or 0.1, v["ihq"] or 1, where)

    def _hourglass(self, block: Block) -> None:
        self.hourglass_cards = getattr(self, "hourglass_cards", {})
        for v, where in self._each(block, _HOURGLASS):
            self.hourglass_cards[v["hgid"]] = (v["qm"] or 0.1, v["ihq"], where)

    def _control_shell(self, block: Block) -> None:
        v, where = self._one(block, [_CONTROL_SHELL, _CONTROL_SHELL_2])
        if v["bwc"] == 1:
            self.set_value("element", "warping", "bwc", where)
        elif v["bwc"] not in (0, 2):
            self.unread(where, f"BWC = {v['bwc']}: read as 2 (no warping correction)")
        if v["intgrd"] == 1:
            self.unread(where, "INTGRD = 1: Lobatto points through every section's thickness: each section keeps "
                               "its own rule (QR)")
        if v["istupd"]:
            self.unread(where, f"ISTUPD = {v['istupd']}: the shells' thickness does not change with the membrane strain")
        if v["theory"] not in (0, 2):
            self.note(where, f"THEORY = {v['theory']}: every shell is the Belytschko-Tsay element (THEORY 2)")
        if v["lamsht"]:
            self.unread(where, f"LAMSHT = {v['lamsht']}: laminated shell theory")
        for key, default in (("esort", 0), ("irnxx", -1), ("miter", 1), ("proj", 0), ("cstyp6", 1), ("tshell", 0)):
            if v[key] not in (0, default):
                self.unread(where, f"{key.upper()} = {v[key]}: not read", physics=False)

    def _control_contact(self, block: Block) -> None:
        v, where = self._one(block, [_CONTROL_CONTACT])
        self.slsfac = (v["slsfac"] or 0.1, where)
        for key in ("rwpnal", "islchk", "shlthk", "penopt", "thkchg", "orien", "enmass"):
            if v[key]:
                self.unread(where, f"{key.upper()} = {v[key]:g}: a contact setting we have no counterpart for",
                            physics=False)

    # -- supports and motions
    def _node_constraints(self) -> None:
        """*NODE's TC and RC codes as [[boundary]] supports, one per combination."""
        codes = self.deck.node_constraints
        if codes is None or not codes.any():
            return
        where = f"{self.path}: *NODE"
        positions = self.position
        for tc, rc in sorted({(int(a), int(b)) for a, b in codes if a or b}):
            rows = (codes[:, 0] == tc) & (codes[:, 1] == rc) & (positions >= 0)
            if not rows.any():
                continue
            fix = [f"u{a}" for a in CONSTRAINT_CODES[tc]] + [f"r{a}" for a in CONSTRAINT_CODES[rc]]
            self.append("boundary", {"nodes": self.nodeset(f"tc{tc}_rc{rc}", sorted(positions[rows].tolist()), where),
                                     "fix": fix}, where)

    def _spc(self, block: Block) -> None:
        if "BIRTH_DEATH" in block.name:
            self.unread(location(block.line, block.name), "supports with birth and death times")
            return
        by_set = block.name.startswith("BOUNDARY_SPC_SET")
        groups: dict[tuple, list] = {}
        for v, where in self._each(block, _SPC):
            if v["cid"] != 0:
                self.unread(where, f"CID = {v['cid']}: a support in a local system is not read")
                continue
            fix = tuple(d for d, k in zip(("ux", "uy", "uz", "rx", "ry", "rz"),
                                          ("dofx", "dofy", "dofz", "dofrx", "dofry", "dofrz")) if v[k] != 0)
            if not fix:
                continue
            if by_set:
                nodes = self.node_set(v["id"], where, "NSID")
                self.append("boundary", {"nodes": nodes, "fix": list(fix)}, where)
            else:
                groups.setdefault(fix, []).append((v["id"], where))
        self._per_group(groups, "boundary", "spc",
                        lambda fix, nodes, where: self.append("boundary", {"nodes": nodes, "fix": list(fix)}, where))

    def _per_group(self, groups: dict, table: str, prefix: str, add) -> None:
        """Cards of single nodes grouped by what they say: one node set per group, named
        ``<prefix>_<k>`` (k: the index its entry takes in `table`), given to add(key, set, where)."""
        for key, cards in groups.items():
            where = cards[0][1]
            ids = self.positions([nid for nid, _ in cards], where, "NID")
            if ids:
                add(key, self.nodeset(f"{prefix}_{len(self.doc.raw.get(table, []))}", ids, where), where)

    def _motion(self, block: Block) -> None:
        rigid = "RIGID" in block.name
        by_set = "_SET" in block.name
        groups: dict[tuple, list] = {}
        for v, where in self._each(block, _MOTION):
            dof, vad = v["dof"], v["vad"]
            if dof not in DOF_NAMES:
                self.unread(where, f"DOF = {dof}: a motion along a vector (4, 8) or of several DOFs is not read")
                continue
            if vad not in (0, 1, 2):
                self.unread(where, f"VAD = {vad}: only velocity (0), acceleration (1) and displacement (2) are read")
                continue
            if v["vid"]:
                self.unread(where, f"VID = {v['vid']}: a direction vector is not read")
            sf = v["sf"] if v["sf"] != 0.0 else 1.0
            death = v["death"] if 0.0 < v["death"] < NEVER else None
            key = (DOF_NAMES[dof], ("velocity", "acceleration", "displacement")[vad], v["lcid"], sf, v["birth"], death)
            if rigid:
                if DOF_NAMES[dof].startswith("r") and (v["birth"] > 0.0 or death is not None):
                    self.windows.append((where, v["birth"], death))     # a body's rotation has no window
                    key = key[:4] + (0.0, None)
                pid = v["id"]
                if pid not in self.rigid_parts:
                    raise SceneError(f"{where}: PID {pid} is not a part of *MAT_RIGID material")
                self._add_motion(key, {"body": self.rigid_parts[pid]}, where)
            elif by_set:
                self._add_motion(key, {"nodes": self.node_set(v["id"], where, "NSID")}, where)
            else:
                groups.setdefault(key, []).append((v["id"], where))
        self._per_group(groups, "motion", "motion",
                        lambda key, nodes, where: self._add_motion(key, {"nodes": nodes}, where))

    def _add_motion(self, key: tuple, target: dict, where: str) -> None:
        """A [[motion]]; BIRTH > 0 and a DEATH are its window (start, end: node sets in fem, a
        body's translations)."""
        dof, kind, lcid, sf, birth, death = key
        k = len(self.doc.raw.get("motion", []))
        entry = {"name": f"motion_{k}", "dofs": [dof], "kind": kind, "value": sf, **target}
        if lcid:
            entry["curve"] = self.curve(lcid, where)
        if birth > 0.0:
            entry["start"] = birth
        if death is not None:
            entry["end"] = death
        self.append("motion", entry, where)

    # -- initial velocities
    def _initial(self, block: Block) -> None:
        cards = self._titled(block)
        k = 0
        while k < len(cards):
            head = read_card(cards[k], _INITIAL, block.name)
            where = location(cards[k], block.name)
            if k + 1 >= len(cards):
                raise SceneError(f"{where}: incomplete card group (the velocity card is missing)")
            v = read_card(cards[k + 1], _VELOCITY, block.name)
            exempt = None
            if head["nsidex"]:
                if k + 2 >= len(cards):
                    raise SceneError(f"{where}: NSIDEX = {head['nsidex']} needs a third card (the exempted nodes' "
                                     "velocity)")
                exempt = read_card(cards[k + 2], _VELOCITY, block.name)
            k += 3 if exempt is not None else 2
            if head["boxid"]:
                self.unread(where, f"BOXID = {head['boxid']}: the velocity is given to the whole set, not a box's nodes")
            if head["icid"]:
                self.unread(where, f"ICID = {head['icid']}: a velocity in a local system is not read")
            for values in (v, exempt):
                if values is not None and any(values[c] for c in ("vxr", "vyr", "vzr")):
                    self.unread(where, "VXR, VYR, VZR: nodal spin without the matching translations is not read "
                                       "(*INITIAL_VELOCITY_GENERATION gives a rigid rotation)")
            nodes = self.node_set(head["nsid"], where, "NSID")
            self.append("initial", {"nodes": nodes, "velocity": [v["vx"], v["vy"], v["vz"]]}, where)
            if exempt is not None:
                ex = self.node_set(head["nsidex"], where, "NSIDEX")
                self.append("initial", {"nodes": ex, "velocity": [exempt["vx"], exempt["vy"], exempt["vz"]]}, where)

    def _initial_node(self, block: Block) -> None:
        groups: dict[tuple, list] = {}
        for v, where in self._each(block, _INITIAL_NODE):
            if v["icid"] or any(v[c] for c in ("vxr", "vyr", "vzr")):
                self.unread(where, "ICID, VXR, VYR, VZR: a local system or nodal spin is not read")
            groups.setdefault((v["vx"], v["vy"], v["vz"]), []).append((v["nid"], where))
        self._per_group(groups, "initial", "initial", lambda velocity, nodes, where: self.append(
            "initial", {"nodes": nodes, "velocity": list(velocity)}, where))

    def _generation(self, block: Block) -> None:
        cards = self._titled(block)
        for k in range(0, len(cards), 2):
            one = read_card(cards[k], _GENERATION, block.name)
            where = location(cards[k], block.name)
            if k + 1 >= len(cards):
                raise SceneError(f"{where}: incomplete card group (the second card is missing)")
            two = read_card(cards[k + 1], _GENERATION_2, block.name)
            styp, sid = one["styp"], one["id"]
            if styp == 3:
                nodes = self.node_set(sid, where, "ID (node set)")
            elif styp in (1, 2):
                pids = [sid] if styp == 2 else self.part_set(sid, where)
                ids = self.part_nodes(pids, where) if sid else list(range(len(self.node_index)))
                nodes = self.nodeset(f"{'part' if styp == 2 else 'partset'}_{sid}_nodes", ids, where)
            else:
                raise SceneError(f"{where}: STYP = {styp}: expected 1 (part set), 2 (part) or 3 (node set)")
            axis = np.array([two["nx"], two["ny"], two["nz"]])
            if one["omega"] != 0.0 and not np.any(axis):
                raise SceneError(f"{where}: OMEGA = {one['omega']:g} about the axis NX, NY, NZ = 0, 0, 0")
            spin = (one["omega"] * axis / np.linalg.norm(axis)).tolist() if one["omega"] else [0.0, 0.0, 0.0]
            for key in ("ivatn", "icid"):
                if one[key]:
                    self.unread(where, f"{key.upper()} = {one[key]}: not read")
            if two["phase"] or two["irigid"]:
                self.unread(where, "PHASE, IRIGID: not read")
            self.append("initial", {"nodes": nodes, "velocity": [one["vx"], one["vy"], one["vz"]],
                                    "angular_velocity": spin, "center": [two["xc"], two["yc"], two["zc"]]}, where)

    # -- loads
    def _load_node(self, block: Block) -> None:
        by_set = "SET" in block.name
        groups: dict[tuple, list] = {}
        for v, where in self._each(block, _LOAD_NODE):
            dof = v["dof"]
            if dof not in DOF_NAMES:
                self.unread(where, f"DOF = {dof}: a follower or vector load is not read")
                continue
            if v["cid"]:
                self.unread(where, f"CID = {v['cid']}: a load in a local system is not read")
                continue
            if not v["lcid"]:
                raise SceneError(f"{where}: LCID: a nodal load needs a load curve")
            sf = v["sf"] if v["sf"] != 0.0 else 1.0
            key = (dof, v["lcid"], sf)
            if by_set:
                self._add_load(key, self.node_set(v["id"], where, "NSID"), where)
            else:
                groups.setdefault(key, []).append((v["id"], where))
        self._per_group(groups, "load", "load", self._add_load)

    def _add_load(self, key: tuple, nodes: str, where: str) -> None:
        dof, lcid, sf = key
        count = len(self.doc.raw["nodesets"][nodes]["ids"]) if nodes != "all" else len(self.node_index)
        vector = [0.0, 0.0, 0.0]
        vector[(dof - 1) % 4] = sf * count          # each node gets SF x the curve: the set's total
        entry = {"nodes": nodes, ("force" if dof <= 3 else "moment"): vector, "distribute": "equal",
                 "curve": self.curve(lcid, where)}
        self.append("load", entry, where)

    def _load_shell(self, block: Block) -> None:
        by_set = "SET" in block.name
        groups: dict[tuple, list] = {}
        for v, where in self._each(block, _LOAD_SHELL):
            if not v["lcid"]:
                raise SceneError(f"{where}: LCID: a pressure needs a load curve")
            sf = v["sf"] if v["sf"] != 0.0 else 1.0
            key = (v["lcid"], sf, v["at"])
            if by_set:
                if v["id"] not in self.shell_sets:
                    raise SceneError(f"{where}: ESID {v['id']} is not a *SET_SHELL of this deck")
                eids, at = self.shell_sets[v["id"]]
                self._add_pressure(key, self._element_set(f"shells_{v['id']}", eids, at), where)
            else:
                groups.setdefault(key, []).append((v["id"], where))
        for key, cards in groups.items():
            where = cards[0][1]
            k = len(self.doc.raw.get("pressure", []))
            self._add_pressure(key, self._element_set(f"pressure_{k}", [e for e, _ in cards], where), where)

    def _load_segment(self, block: Block) -> None:
        """*LOAD_SEGMENT (LCID SF AT N1..N4 per card) / _SET (SSID LCID SF AT) as [[pressure]]:
        LS-DYNA's positive pressure acts against the segment's normal (its corner order), so a
        segment ordered against its shell's corners takes the opposite sign."""
        by_set = block.name.startswith("LOAD_SEGMENT_SET")
        layout = _ints("id lcid") + columns("sf at", 10) if by_set else \
            _ints("lcid") + columns("sf at", 10) + _ints("n1 n2 n3 n4")
        groups: dict[tuple, list] = {}
        for v, where in self._each(block, layout):
            if not v["lcid"]:
                raise SceneError(f"{where}: LCID: a pressure needs a load curve")
            sf = v["sf"] if v["sf"] != 0.0 else 1.0
            if by_set:
                if v["id"] not in self.segment_sets:
                    raise SceneError(f"{where}: SSID {v['id']} is not a *SET_SEGMENT of this deck")
                segments = self.segment_sets[v["id"]][0]
            else:
                segments = [tuple(v[f"n{k}"] for k in range(1, 5))]
            for seg in segments:
                row, along = self.segment_shell(seg, where)
                groups.setdefault((v["lcid"], sf if along else -sf, v["at"]), []).append((row, where))
        for (lcid, sf, at), rows in groups.items():
            where = rows[0][1]
            k = len(self.doc.raw.get("pressure", []))
            self._add_pressure((lcid, sf, at), self._rows_set(f"pressure_{k}", [r for r, _ in rows], where), where)

    def _element_set(self, name: str, eids, where: str) -> str:
        rows = []
        for eid in eids:
            if eid not in self.element_index:
                raise SceneError(f"{where}: element {eid} is not an *ELEMENT_SHELL of this deck")
            rows.append(self.element_index[eid])
        sets = self.table("elementsets")
        if name not in sets:
            sets[name] = {"ids": sorted(set(rows))}
            self.origin(f"[elementsets.{name}]", where)
        return name

    def _add_pressure(self, key: tuple, elements: str, where: str) -> None:
        lcid, sf, at = key
        # LS-DYNA: a positive pressure acts against the normal of the corner order (into the shell)
        self.append("pressure", {"value": -sf, "elements": elements, "curve": self.curve(lcid, where, shift=at)},
                    where)

    def _load_body(self, block: Block) -> None:
        v, where = self._one(block, [_LOAD_BODY])
        axis = "XYZ".index(block.name[-1])
        if v["cid"] or v["lcid"] == 0:
            self.unread(where, "CID (a local system) or LCID = 0: not read")
            return
        if v["lciddr"]:
            self.note(where, f"LCIDDR = {v['lciddr']}: no dynamic-relaxation phase is run")
        gravity = self.doc.raw.get("gravity")
        curve = self.curve(v["lcid"], where)
        sf = v["sf"] if v["sf"] != 0.0 else 1.0
        if gravity is None:
            gravity = {"acceleration": [0.0, 0.0, 0.0], "curve": curve}
            self.doc.raw["gravity"] = gravity
            self.origin("[gravity]", where)
        elif gravity["curve"] != curve:
            self.unread(where, "a body load on another curve than the first *LOAD_BODY's: one gravity curve per scene")
            return
        gravity["acceleration"][axis] = -sf          # LS-DYNA gives the base acceleration: gravity is its reverse

    # -- walls
    def _wall(self, block: Block) -> None:
        """*RIGIDWALL_PLANAR(_FINITE)(_MOVING): a [[wall]], or a rectangle [[tool]] when finite;
        _MOVING gives it a body of its own: a [[rigid_body]] without nodes of mass MASS, moving
        along the normal only, starting at V0 along it, which the wall moves with."""
        finite, moving = "FINITE" in block.name, "MOVING" in block.name
        cards = self._titled(block)
        size = 2 + finite + moving
        for group in (cards[k:k + size] for k in range(0, len(cards), size)):
            where = location(group[0], block.name)
            if len(group) < size:
                raise SceneError(f"{where}: incomplete card group ({len(group)} of {size} cards)")
            one = read_card(group[0], _WALL, block.name)
            two = read_card(group[1], _WALL_2, block.name)
            tail = np.array([two["xt"], two["yt"], two["zt"]])
            normal = np.array([two["xh"], two["yh"], two["zh"]]) - tail
            if not np.any(normal):
                raise SceneError(f"{where}: the head XH, YH, ZH equals the tail XT, YT, ZT: no normal")
            n = normal / np.linalg.norm(normal)
            if one["nsid"] or one["nsidex"] or one["boxid"]:
                self.unread(where, "NSID, NSIDEX, BOXID: the wall holds back every node, not a set's")
            if one["birth"] or (one["death"] and one["death"] < NEVER):
                self.unread(where, "BIRTH, DEATH: the wall is there for the whole run")
            if two["wvel"]:
                self.unread(where, f"WVEL = {two['wvel']:g}: nodes welding to the wall above a critical "
                                   "velocity is not modelled")
            if one["offset"]:
                self.note(where, f"OFFSET = {one['offset']:g}: every node is checked against the wall")
            body = None
            if moving:
                m = read_card(group[-1], _WALL_MOVING, block.name)
                body = f"rigidwall_{len(self.doc.raw.get('rigid_body', []))}"
                self.note(where, f"a moving wall is a [[rigid_body]] '{body}' without nodes (MASS, V0 along the "
                                 "normal) that the wall moves with")
                self.append("rigid_body", {"name": body, "mass": m["mass"], "center": tail.tolist(),
                                           "direction": n.tolist(), "velocity": (m["v0"] * n).tolist()}, where)
            if not finite:
                if two["fric"]:
                    self.unread(where, f"FRIC = {two['fric']:g}: the wall is frictionless")
                self.note(where, "the wall keeps the shells' mid-surface half a thickness away (LS-DYNA's: the nodes)")
                self.append("wall", {"point": tail.tolist(), "normal": normal.tolist(),
                                     **({"moves_with": body} if body else {})}, where)
                continue
            f = read_card(group[2], _WALL_FINITE, block.name)
            first = np.array([f["xhev"], f["yhev"], f["zhev"]]) - tail
            first = first - (first @ n) * n
            if not np.any(first) or f["lenl"] <= 0.0 or f["lenm"] <= 0.0:
                raise SceneError(f"{where}: XHEV, YHEV, ZHEV must give an edge off the normal and LENL, LENM > 0")
            l_axis = first / np.linalg.norm(first)
            m_axis = np.cross(n, l_axis)
            center = tail + 0.5 * f["lenl"] * l_axis + 0.5 * f["lenm"] * m_axis
            k = len(self.doc.raw.get("tool", []))
            self.note(where, "a finite wall is a rectangle [[tool]] (penalty contact, stiffness 0.1)")
            self.append("tool", {"name": f"wall_{k}", "kind": "rectangle", "normal": n.tolist(),
                                 "axis": l_axis.tolist(), "size": [f["lenl"], f["lenm"]], "center": center.tolist(),
                                 "friction": two["fric"], **({"moves_with": body} if body else {})}, where)

    # -- rigid bodies and masses
    def _rigid_parts(self) -> None:
        deck = self.deck
        for pid, part in sorted(deck.parts.items()):
            mat = deck.materials.get(part.mid)
            if mat is None or mat.kind != "rigid" or not np.any(deck.element_parts == pid):
                if part.inertia is not None:
                    self.unread(part.inertia["where"], f"part {pid} is not rigid: *PART_INERTIA's mass, inertia and "
                                                       "velocities are read for *MAT_RIGID parts only")
                continue
            name = f"part_{pid}"
            where = mat.where
            body: dict = {"name": name, "_where": where, "_extra": [],
                          "_nodes": self.part_nodes([pid], where)}
            cmo = int(mat.values.get("cmo", 0.0))
            if cmo == 1:
                body["fixed"] = self._constrained(mat.values.get("con1", 0.0), mat.values.get("con2", 0.0), where)
            elif cmo != 0:
                self.unread(where, f"CMO = {cmo}: constraints in a local system are not read")
            for key in ("n", "couple", "m", "alias"):
                if mat.values.get(key):
                    self.unread(where, f"{key.upper()}: coupling fields of *MAT_RIGID are not read")
            if part.inertia is not None:
                self._own_inertia(body, part.inertia, part.inertia["where"])
            self.rigid_parts[pid] = name
            self.bodies[name] = body

    def _constrained(self, con1: float, con2: float, where: str) -> list[str]:
        fixed = []
        for code, prefix in ((int(con1), "u"), (int(con2), "r")):
            if code not in CONSTRAINT_CODES:
                raise SceneError(f"{where}: constraint code {code}: expected 0..7")
            fixed += [prefix + a for a in CONSTRAINT_CODES[code]]
        return fixed

    def _nodal_rigid(self, block: Block) -> None:
        """*CONSTRAINED_NODAL_RIGID_BODY (_SPC, _INERTIA) as a [[rigid_body]] over NSID; _SPC's
        CMO/CON1/CON2 -> fixed; _INERTIA's own mass TM at (XC, YC, ZC), inertia tensor and
        initial velocities -> mass_from_nodes = false, mass, center, inertia, velocity, spin."""
        spc = block.name.startswith("CONSTRAINED_NODAL_RIGID_BODY_SPC")
        inertia = "INERTIA" in block.name
        cards = self._titled(block, keep_blank=inertia)     # _INERTIA: a velocity card may be left blank
        start = 0
        while start < len(cards):
            v = read_card(cards[start], _NODAL_RIGID, block.name)
            where = location(cards[start], block.name)
            # _INERTIA: cards 2-3, the velocity card 4 and, with a CID, card 5 (the last body's
            # trailing blank cards may be left out)
            size = 4 + bool(v["cid"]) if inertia else 1 + spc
            group = cards[start:start + size]
            start += size
            name = f"nrb_{v['pid']}"
            if name in self.bodies:
                raise SceneError(f"{where}: nodal rigid body {v['pid']} is defined twice")
            if v["cid"] and inertia:
                self.unread(where, "CID: an inertia tensor in a local system is not read (give it in global axes)")
            elif v["cid"] or v["pnode"]:
                self.note(where, "CID, PNODE (output and local axes) are not read")
            body = {"name": name, "_where": where, "_extra": [],
                    "_nodes": self.positions(self.node_sets.get(v["nsid"], ([], ""))[0], where, "NSID")
                    if v["nsid"] in self.node_sets else self._missing_set(v["nsid"], where)}
            if spc:
                if len(group) < 2:
                    raise SceneError(f"{where}: incomplete card group (the SPC card is missing)")
                s = read_card(group[1], _RIGID_SPC, block.name)
                if int(s["cmo"]) == 1:
                    body["fixed"] = self._constrained(s["con1"], s["con2"], where)
                elif int(s["cmo"]) != 0:
                    self.unread(where, f"CMO = {s['cmo']:g}: constraints in a local system are not read")
            if inertia:
                if len(group) < 3:
                    raise SceneError(f"{where}: incomplete card group ({len(group)} of 3 cards: XC..TM, IXX..IZZ)")
                values = read_card(group[1], _RIGID_INERTIA, block.name)
                values.update(read_card(group[2], INERTIA_TENSOR, block.name))
                if len(group) >= 4:
                    values.update(read_card(group[3], INERTIA_VELOCITY, block.name))
                self._own_inertia(body, values, where)
            self.bodies[name] = body

    def _own_inertia(self, body: dict, v: dict, where: str) -> None:
        """A body's own mass TM at (XC, YC, ZC), inertia tensor (its entries IXX..IZZ, global
        axes) and, when not all zero, initial velocities VTX..VRZ (*PART_INERTIA,
        *CONSTRAINED_NODAL_RIGID_BODY_INERTIA): the slaves' nodal masses do not count."""
        if v.get("nodeid"):
            self.unread(where, f"NODEID = {v['nodeid']}: the centre is read from XC, YC, ZC only")
        if v.get("ircs"):
            self.unread(where, "IRCS = 1: an inertia tensor in a local system is not read (give it in global axes)")
        body.update({"mass_from_nodes": False, "mass": v["tm"], "center": [v["xc"], v["yc"], v["zc"]],
                     "inertia": [v["ixx"], v["iyy"], v["izz"], v["ixy"], v["iyz"], v["ixz"]]})
        if any(v.get(k) for k in ("vtx", "vty", "vtz")):
            body["velocity"] = [v["vtx"], v["vty"], v["vtz"]]
        if any(v.get(k) for k in ("vrx", "vry", "vrz")):
            body["spin"] = [v["vrx"], v["vry"], v["vrz"]]

    def _missing_set(self, sid: int, where: str):
        raise SceneError(f"{where}: NSID {sid} is not a *SET_NODE of this deck")

    def _extra_nodes(self, block: Block) -> None:
        by_set = block.name.startswith("CONSTRAINED_EXTRA_NODES_SET")
        for v, where in self._each(block, _EXTRA_NODES):
            if v["pid"] not in self.rigid_parts:
                raise SceneError(f"{where}: PID {v['pid']} is not a part of *MAT_RIGID material")
            if by_set:
                if v["id"] not in self.node_sets:
                    self._missing_set(v["id"], where)
                nids = self.node_sets[v["id"]][0]
            else:
                nids = [v["id"]]
            self.bodies[self.rigid_parts[v["pid"]]]["_extra"] += self.positions(nids, where, "extra node")

    def _element_mass(self, block: Block) -> None:
        at_node: dict[int, list] = {}               # mesh position -> [mass, where]: masses on one node add
        for v, where in self._each(block, _ELEMENT_MASS):
            if v["mass"] < 0.0:
                raise SceneError(f"{where}: element {v['eid']}: MASS = {v['mass']:g}: expected >= 0")
            if v["nid"] in self.unused_nodes:
                self.unread(where, f"element {v['eid']}: node {v['nid']} belongs to no shell: its mass is not read")
                continue
            node = self.positions([v["nid"]], where, f"element {v['eid']}")[0]
            at_node.setdefault(node, [0.0, where])[0] += v["mass"]
        groups: dict[float, list] = {}
        for node, (mass, where) in at_node.items():
            groups.setdefault(mass, []).append((node, where))
        for mass, nodes in groups.items():
            where = nodes[0][1]
            k = len(self.doc.raw.get("point_mass", []))
            ids = sorted(node for node, _ in nodes)
            self.append("point_mass", {"name": f"mass_{k}", "nodes": self.nodeset(f"mass_{k}", ids, where),
                                       "mass": mass}, where)

    def _element_mass_part(self, block: Block) -> None:
        for v, where in self._each(block, _ELEMENT_MASS_PART):
            if v["finmass"]:
                self.unread(where, f"FINMASS = {v['finmass']:g}: a final part mass is not read")
            if v["addmass"] <= 0.0:
                continue
            k = len(self.doc.raw.get("point_mass", []))
            ids = self.part_nodes([v["pid"]], where)
            self.note(where, f"ADDMASS of part {v['pid']} is shared equally by its {len(ids)} nodes (LS-DYNA shares it "
                             "in proportion to their masses)")
            self.append("point_mass", {"name": f"mass_{k}", "nodes": self.nodeset(f"mass_{k}", ids, where),
                                       "total_mass": v["addmass"]}, where)

    # -- contact
    def _single_surface(self, block: Block) -> None:
        """*CONTACT_AUTOMATIC_SINGLE_SURFACE: [contact] when its surface is every part, else a
        [[contact_pair]] of that surface with itself (self-contact within those parts)."""
        v, where = self._one(block, [_CONTACT_1, _CONTACT_2, _CONTACT_3])
        surface = self._surface(v["ssid"], v["sstyp"], where, "SSID")
        parts = [int(p) for p in np.unique(self.deck.element_parts)]
        if surface == "all" or parts == [v["ssid"]] and v["sstyp"] == 3:
            if "contact" in self.doc.raw:
                self.unread(where, "a second single-surface contact over every part: one [contact] per scene")
                return
            entry = self._law(v, where)
            if v["sst"] > 0.0:
                entry["thickness"] = v["sst"] * (v["sfst"] or 1.0)
            self.doc.raw["contact"] = entry
            self.origin("[contact]", where)
            return
        k = len(self.doc.raw.get("contact_pair", []))
        entry = {"name": f"interface_{k}", "slave": surface, "master": surface, **self._law(v, where)}
        if v["sst"] > 0.0:
            entry["slave_thickness"] = entry["master_thickness"] = v["sst"] * (v["sfst"] or 1.0)
        self.append("contact_pair", entry, where)

    def _surface(self, sid: int, styp: int, where: str, side: str) -> str:
        """The element set of a contact's side: SSTYP/MSTYP 0 segment set (the shells whose
        corners the segments are), 1 shell set, 2 part set, 3 part, 5 (or id 0) every part."""
        if styp == 5 or sid == 0:
            return "all"
        if styp == 3:
            if not np.any(self.deck.element_parts == sid):
                raise SceneError(f"{where}: {side} part {sid} has no shells")
            return f"part:{sid}"
        if styp == 2:
            rows = np.nonzero(np.isin(self.deck.element_parts, self.part_set(sid, where)))[0]
            return self._rows_set(f"partset_{sid}", rows, where)
        if styp == 1:
            if sid not in self.shell_sets:
                raise SceneError(f"{where}: {side} {sid} is not a *SET_SHELL of this deck")
            eids, at = self.shell_sets[sid]
            return self._element_set(f"shells_{sid}", eids, at)
        if styp == 0:
            if sid not in self.segment_sets:
                raise SceneError(f"{where}: {side} {sid} is not a *SET_SEGMENT of this deck")
            segments, at = self.segment_sets[sid]
            rows = [self.segment_shell(seg, at)[0] for seg in segments]
            return self._rows_set(f"segments_{sid}", np.array(rows), at)
        raise SceneError(f"{where}: {side} type {styp}: expected 0 (segment set), 1 (shell set), 2 (part set), "
                         "3 (part) or 5 (all)")

    @cached_property
    def shells_by_corners(self) -> dict:
        """frozenset of a shell's corner node ids (the deck's) -> (its row, the ids in order)."""
        ids, out = self.deck.node_ids, {}
        for row, corners in enumerate(self.elements):
            order = tuple(int(ids[c]) for c in corners if c >= 0)
            out.setdefault(frozenset(order), (row, order))
        return out

    def segment_shell(self, segment, where: str) -> tuple[int, bool]:
        """The shell whose face a segment (N1..N4; N3 = N4 or N4 = 0 a triangle) is, and whether
        the segment's corner order runs the shell's way (its normal along the shell's)."""
        order = tuple(n for n in segment if n)
        if len(order) == 4 and order[2] == order[3]:
            order = order[:3]
        found = self.shells_by_corners.get(frozenset(order))
        if found is None:
            raise SceneError(f"{where}: segment {list(segment)} is not the face of a shell of this deck")
        row, corners = found
        k = corners.index(order[0])
        return row, order[1] == corners[(k + 1) % len(corners)]

    def _rows_set(self, name: str, rows, where: str) -> str:
        sets = self.table("elementsets")
        if name not in sets:
            if len(rows) == 0:
                raise SceneError(f"{where}: {name.replace('_', ' ')} holds no shell")
            sets[name] = {"ids": sorted({int(r) for r in rows})}
            self.origin(f"[elementsets.{name}]", where)
        return name

    def _law(self, v: dict, where: str) -> dict:
        """A contact's friction (FS), damping (VDC, percent of critical) and penalty scale
        (SLSFAC x SFS as the stiffness alpha), with what is listed as not read."""
        slsfac = getattr(self, "slsfac", (0.1, ""))[0]
        if v["fd"] and v["fd"] != v["fs"] and v["dc"]:
            self.note(where, f"FD = {v['fd']:g} with DC = {v['dc']:g}: the friction coefficient is FS = {v['fs']:g} "
                             "at every slip speed")
        if v["bt"] or (v["dt"] and v["dt"] < NEVER):
            self.unread(where, "BT, DT: the contact acts over the whole run")
        for key in ("sboxid", "mboxid"):
            if v[key]:
                self.unread(where, f"{key.upper()}: contact boxes are not read")
        return {"friction": v["fs"], "damping": v["vdc"] / 100.0, "stiffness": min(1.0, slsfac * (v["sfs"] or 1.0))}

    def _interface(self, block: Block) -> None:
        """*CONTACT_AUTOMATIC_SURFACE_TO_SURFACE (symmetric) / _NODES_TO_SURFACE (one-way) as a
        [[contact_pair]]: SST, MST (x SFST, SFMT) the sides' thickness overrides; a one-way
        slave side of SSTYP = 4 is its node set (slave_nodes)."""
        v, where = self._one(block, [_CONTACT_1, _CONTACT_2, _CONTACT_3])
        one_way = "NODES_TO_SURFACE" in block.name
        k = len(self.doc.raw.get("contact_pair", []))
        if one_way and v["sstyp"] == 4:          # the slave side a node set
            slave = {"slave_nodes": self.node_set(v["ssid"], where, "SSID")}
        else:
            slave = {"slave": self._surface(v["ssid"], v["sstyp"], where, "SSID")}
        entry = {"name": f"interface_{k}", **slave, "master": self._surface(v["msid"], v["mstyp"], where, "MSID"),
                 "symmetric": not one_way, **self._law(v, where)}
        if v["sst"] > 0.0:
            entry["slave_thickness"] = v["sst"] * (v["sfst"] or 1.0)
        if v["mst"] > 0.0:
            entry["master_thickness"] = v["mst"] * (v["sfmt"] or 1.0)
        self.append("contact_pair", entry, where)

    def _tie(self, block: Block) -> None:
        """*CONTACT_TIED_NODES_TO_SURFACE / _SHELL_EDGE_TO_SURFACE (and _OFFSET) as a [[tie]]:
        the slave nodes (SSTYP 4 node set, 2 part set, 3 part) on the master shells."""
        v, where = self._one(block, [_CONTACT_1, _CONTACT_2, _CONTACT_3])
        styp, sid = v["sstyp"], v["ssid"]
        if styp == 4:
            nodes = self.node_set(sid, where, "SSID")
        elif styp in (2, 3):
            pids = [sid] if styp == 3 else self.part_set(sid, where)
            nodes = self.nodeset(f"{'part' if styp == 3 else 'partset'}_{sid}_nodes", self.part_nodes(pids, where),
                                 where)
        else:
            raise SceneError(f"{where}: SSTYP = {styp}: a tie's slave side is a node set (4), a part set (2) or a "
                             "part (3)")
        k = len(self.doc.raw.get("tie", []))
        entry = {"name": f"tie_{k}", "nodes": nodes, "surface": self._surface(v["msid"], v["mstyp"], where, "MSID"),
                 "rotations": "SHELL_EDGE" in block.name}
        if not block.name.endswith("_OFFSET") and not block.name.endswith(("_OFFSET_ID", "_OFFSET_TITLE")):
            self.note(where, "the slaves keep their offset from the surface (LS-DYNA's non-_OFFSET tie moves them "
                             "onto it first)")
        self.append("tie", entry, where)

    def _spotweld(self, block: Block) -> None:
        """*CONSTRAINED_SPOTWELD: welds of equal SN, SS, N, M, TF as one [[spotweld]] group."""
        layout = _ints("n1 n2") + columns("sn ss n m tf ep", 10)
        cards = self._titled(block)
        if block.name.endswith("_ID"):       # each weld has its own id card first
            cards = [c for k, c in enumerate(data_cards(block)) if k % 2 == 1 and c.text.strip()]
        groups: dict[tuple, list] = {}
        for card in cards:
            v = read_card(card, layout, block.name)
            where = location(card, block.name)
            if v["ep"] and v["ep"] < NEVER:
                self.unread(where, f"EP = {v['ep']:g}: failure by plastic strain is not read")
            pair = self.positions([v["n1"]], where, "N1") + self.positions([v["n2"]], where, "N2")
            if len(pair) != 2:
                raise SceneError(f"{where}: N1, N2 = {v['n1']}, {v['n2']}: a weld joins two nodes of shells")
            key = (v["sn"], v["ss"], v["n"], v["m"], v["tf"] if 0.0 < v["tf"] < NEVER else 0.0)
            groups.setdefault(key, []).append((pair, where))
        for (sn, ss, n, m, tf), welds in groups.items():
            where = welds[0][1]
            if sn <= 0.0 or ss <= 0.0:       # LS-DYNA: a blank SN or SS, no failure by that force
                self.note(where, "SN or SS blank: the welds do not fail by that force (read as 1e30)")
                sn, ss = sn if sn > 0.0 else 1e30, ss if ss > 0.0 else 1e30
            k = len(self.doc.raw.get("spotweld", []))
            entry = {"name": f"welds_{k}", "pairs": [list(p) for p, _ in welds], "normal_strength": sn,
                     "shear_strength": ss, **({"n": n} if n else {}), **({"m": m} if m else {}),
                     **({"failure_time": tf} if tf else {})}
            self.append("spotweld", entry, where)

    # -- output
    def _history(self, block: Block) -> None:
        by_set = block.name.startswith("DATABASE_HISTORY_NODE_SET")
        for card in self._titled(block):
            v = read_card(card, _IDS, block.name)
            where = location(card, block.name)
            for nid in (v[f"i{k}"] for k in range(1, 9)):
                if not nid:
                    continue
                if by_set:
                    nodes = self.node_set(nid, where, "NSID")
                    name = f"set_{nid}"
                else:
                    nodes = self.single_node(nid, where)
                    name = f"node_{nid}"
                self.append("probe", {"name": name, "nodes": nodes}, where)

    def _d3plot(self, block: Block) -> None:
        v, where = self._one(block, [_D3PLOT])
        if v["dt"] > 0.0:
            self.set_value("output", "frame_interval", v["dt"], where)
        elif v["npltc"] > 0:
            self.npltc = (v["npltc"], where)       # frames = end time / NPLTC (finish)
        if v["lcdt"]:
            self.unread(where, "LCDT: a curve of output intervals is not read", physics=False)

    def _history_interval(self, block: Block) -> None:
        v, where = self._one(block, [_DATABASE])
        if v["dt"] <= 0.0:
            return
        current = self.doc.raw.get("output", {}).get("history_interval")
        if current is None or v["dt"] < current:
            self.set_value("output", "history_interval", v["dt"], where)

    # -- the part-wide settings, after every keyword
    def finish(self) -> None:
        deck = self.deck
        default = getattr(self, "hourglass_default", None)
        cards = getattr(self, "hourglass_cards", {})
        used_parts = [int(p) for p in np.unique(deck.element_parts) if int(p) not in self.rigid_parts]
        values = {}
        for pid in used_parts:
            part = deck.parts.get(pid)
            hgid = getattr(part, "hgid", 0) if part is not None else 0
            if hgid and hgid in cards:
                values[pid] = cards[hgid]
            elif default is not None:
                values[pid] = default
        if values:
            coefficients = sorted({q for q, _, _ in values.values()})
            q, ihq, where = values[used_parts[0]] if used_parts[0] in values else next(iter(values.values()))
            if len(coefficients) > 1:
                self.unread(where, f"hourglass coefficients differ between parts ({', '.join(f'{c:g}' for c in coefficients)}): "
                                   f"one per scene, {q:g}")
            self.set_value("element", "hourglass", min(q, 1.0), where)
            if ihq not in (4, 5, 8):
                self.note(where, f"IHQ = {ihq} (a viscous form) is read as the Belytschko-Tsay stiffness form, "
                                 f"coefficient {q:g}")
        endmas = getattr(self, "endmas", None)
        if endmas and self.doc.raw.get("solve", {}).get("mass_scaling") == "conventional":
            self.set_value("solve", "added_mass_limit", endmas[0], endmas[1])
        elif endmas:
            self.unread(endmas[1], f"ENDMAS = {endmas[0]:g}: no conventional mass scaling to limit", physics=False)
        end = self.doc.raw.get("solve", {}).get("end_time", math.inf)
        for where, birth, death in self.windows:          # a rigid body's rotation has no window
            if birth > 0.0 or (death is not None and death < end):
                self.unread(where, f"BIRTH = {birth:g}, DEATH = {death:g}: a rigid part's prescribed rotation holds "
                                   "over the whole run (a window is for node sets and a body's translations)")
        if self.npltc and end < math.inf:
            npltc, where = self.npltc
            self.set_value("output", "frame_interval", end / npltc, where)
        slsfac = getattr(self, "slsfac", None)
        if slsfac and "contact" not in self.doc.raw:
            self.note(slsfac[1], "SLSFAC is used by the contacts only, and the deck has none that is read")


def deck_document(path: Path) -> DeckDocument:
    """The scene document an LS-DYNA deck says (module docstring); SceneError for a card
    that cannot be read or names what the deck does not define."""
    path = Path(path)
    points, elements, sets, deck, warnings = read_deck(path)
    translator = _Translator(path, deck, elements)
    with using(deck.parameters):
        doc = translator.run()
    return doc


__all__ = ["DeckDocument", "Unread", "deck_document"]
