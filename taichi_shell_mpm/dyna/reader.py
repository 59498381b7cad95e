"""LS-DYNA keyword decks (``.k``, ``.key``, ``.dyn``, ``.kw``): the shell mesh and its parts.

A small reader of its own (the keyword readers on PyPI read either nodes and elements only,
or not the plasticity materials this solver needs).  :func:`read_deck` returns the geometry
(points, elements with -1 in column 3 for a triangle), one element set per part and a
:class:`Deck` of plain data: parts, shell sections, materials (elastic, plastic kinematic,
piecewise linear plasticity) and load curves, with the deck's own node and element ids.

Read: ``*KEYWORD``, ``*TITLE``, ``*END`` (ends the file it is in), ``*INCLUDE`` (a path
relative to the including file's folder, else the main deck's), ``*COMMENT``, comment lines
(``$``), ``*NODE``, ``*ELEMENT_SHELL`` (also ``_THICKNESS``, ``_BETA``, ``_MCID`` and their
``_OFFSET`` forms), ``*PART`` (and ``*PART_CONTACT``, ``*PART_INERTIA``), ``*SECTION_SHELL[_TITLE]``,
``*MAT_ELASTIC`` / ``*MAT_001``, ``*MAT_PLASTIC_KINEMATIC`` / ``*MAT_003``, ``*MAT_RIGID`` / ``*MAT_020``,
``*MAT_PIECEWISE_LINEAR_PLASTICITY`` / ``*MAT_024``,
``*MAT_TRANSVERSELY_ANISOTROPIC_ELASTIC_PLASTIC`` / ``*MAT_037`` (each also ``_TITLE``) and
``*DEFINE_CURVE[_TITLE]``.  Cards are fixed format (10-character fields; ``*NODE`` 8, 16,
16, 16, 8, 8; ``*ELEMENT_SHELL`` 8 each; curve points 20 each) or free format (a line with
a comma is split at the commas); a blank field takes the keyword's default.  The long
(``+``, ``LONG=``) and 10-digit-id (``%``, ``I10=``) formats are not read (an error says so).
``*PARAMETER`` and ``*PARAMETER_EXPRESSION`` (dyna/parameters.py: a field ``&name`` or
``-&name`` takes the parameter's value).  Every other keyword is kept, with its cards, in
:attr:`Deck.keywords` for the scene reader (dyna/scene.py), which reads the supports, loads,
controls, contacts, rigid bodies and outputs and lists what it does not read.

Node and element ids are the deck's own: positions in ``points`` and ``elements`` follow the
order read, and :attr:`Deck.node_ids` / :attr:`Deck.element_ids` map positions back to ids.
A shell with n3 = n4 is a triangle.  Problems are :class:`~taichi_shell_mpm.scene.SceneError`
lines naming the file, the line and the keyword.  The values of materials and sections are
checked where they become scene values (model/deck.deck_specs, by the scene's own validators),
so each card keeps its ``where`` (file:line: *KEYWORD) for those messages.
"""
from __future__ import annotations

import hashlib
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

DYNA_SUFFIXES = (".k", ".key", ".dyn", ".kw")
"""File endings read as LS-DYNA keyword decks (any case)."""
from ..problems import SceneError
from .parameters import PARAMETER_KEYWORDS, read_parameters, substitute, using

MAX_INCLUDE_DEPTH = 20


# ---------------------------------------------------------------- the deck's data
@dataclass(frozen=True)
class DeckPart:
    """``*PART``: a heading and the ids of its section and material."""
    pid: int
    title: str
    secid: int
    mid: int
    hgid: int = 0
    """*HOURGLASS id (0: *CONTROL_HOURGLASS's, dyna/scene.py)."""
    inertia: dict | None = None
    """*PART_INERTIA's cards 3-5 (XC YC ZC TM IRCS NODEID, IXX..IZZ, VTX..VRZ) and ``where``:
    a rigid part's own mass and inertia (dyna/scene.py)."""


@dataclass(frozen=True)
class DeckSection:
    """``*SECTION_SHELL``, with LS-DYNA's defaults for blank or zero fields applied."""
    secid: int
    elform: int
    """Element formulation (0 or blank: 2, Belytschko-Tsay)."""
    shear_factor: float
    """SHRF (0 or blank: 1.0)."""
    nip: int
    """Through-thickness integration points (0 or blank: 2)."""
    thickness: float
    """T1, the thickness at node 1 (the section's thickness when T1..T4 agree)."""
    thicknesses: tuple[float, float, float, float]
    """T1..T4 (a zero T2..T4 takes T1)."""
    quadrature: int = 0
    """QR/IRID: 0 Gauss, 1 trapezoidal, < 0 a user rule (*INTEGRATION_SHELL, not read)."""
    title: str = ""
    values: dict = field(default_factory=dict)
    """Every field of the two cards as read (lower-case LS-DYNA names), blanks as 0."""
    where: str = field(default="", compare=False)
    """``file:line: *KEYWORD`` of its first card, for messages about its values."""


@dataclass(frozen=True)
class DeckMaterial:
    """A material card: ``kind`` is ``"elastic"`` (*MAT_001), ``"plastic_kinematic"``
    (*MAT_003), ``"rigid"`` (*MAT_020: its part is a rigid body, dyna/scene.py),
    ``"piecewise_linear"`` (*MAT_024) or ``"transversely_anisotropic"`` (*MAT_037);
    ``values`` holds its fields by their
    lower-case LS-DYNA names (ro, e, pr, sigy, etan, ...; blanks as 0)."""
    mid: int
    kind: str
    title: str
    values: dict
    curve: tuple[tuple[float, float], ...] = ()
    """*MAT_024, *MAT_037: yield stress against effective plastic strain, (eps, sigma) pairs: the
    LCSS (HLCID) curve (scaled and offset as *DEFINE_CURVE says) or the EPS1..8 / ES1..8 points;
    empty when the material is bilinear (SIGY, ETAN) or its curve is missing (a warning)."""
    where: str = field(default="", compare=False)
    """``file:line: *KEYWORD`` of its first card, for messages about its values."""


@dataclass(frozen=True)
class Deck:
    """What an LS-DYNA deck says beyond the geometry, as plain data (user ids throughout)."""
    parts: dict
    """pid -> :class:`DeckPart`."""
    sections: dict
    """secid -> :class:`DeckSection`."""
    materials: dict
    """mid -> :class:`DeckMaterial`."""
    curves: dict
    """lcid -> ((abscissa, ordinate), ...), SFA/SFO/OFFA/OFFO applied:
    x = SFA (a + OFFA), y = SFO (o + OFFO)."""
    element_ids: np.ndarray
    """(m,) int64: the deck's id of each element of ``Mesh.elements``."""
    node_ids: np.ndarray
    """(n,) int64: the deck's id of each node of ``Mesh.points``."""
    element_parts: np.ndarray
    """(m,) int64: the part id (PID) of each element."""
    element_thickness: np.ndarray | None = None
    """(m, 4) float64 corner thicknesses of ``*ELEMENT_SHELL_THICKNESS`` (NaN where the
    card gives none, and for an element without it); None when no element has one."""
    title: str = ""
    """The ``*TITLE`` line."""
    keywords: tuple = ()
    """Every other keyword block (:class:`Block`: name, first line, data lines), in reading
    order: the scene's keywords (dyna/scene.py reads them and lists what it does not)."""
    parameters: dict = field(default_factory=dict)
    """*PARAMETER name (upper case) -> value, for the cards read later (dyna/parameters.using)."""
    used_nodes: np.ndarray | None = None
    """(n,) bool: which nodes of ``node_ids`` some shell uses (mesh.py drops the others)."""
    node_constraints: np.ndarray | None = None
    """(n, 2) int: *NODE's TC and RC codes (0 free .. 7 x, y and z; dyna/scene.py's supports)."""


# ---------------------------------------------------------------- card layouts
# (name, width, type) with type "i" integer or "f" real; a blank field is 0
def columns(names: str, width: int, kind: str = "f") -> list[tuple[str, int, str]]:
    return [(n, width, kind) for n in names.split()]


_NODE = [("nid", 8, "i"), ("x", 16, "f"), ("y", 16, "f"), ("z", 16, "f"), ("tc", 8, "f"), ("rc", 8, "f")]
_SHELL = columns("eid pid n1 n2 n3 n4 n5 n6 n7 n8", 8, "i")
_SHELL_THICKNESS = columns("thic1 thic2 thic3 thic4 beta", 16)
_SHELL_OFFSET = columns("offset", 16)
_PART = columns("pid secid mid eosid hgid grav adpopt tmid", 10, "i")
_PART_INERTIA = columns("xc yc zc tm", 10) + columns("ircs nodeid", 10, "i")
INERTIA_TENSOR = columns("ixx ixy ixz iyy iyz izz", 10)
INERTIA_VELOCITY = columns("vtx vty vtz vrx vry vrz", 10)
_PART_CONTACT = columns("fs fd dc vc optt sft ssf", 10)
_SECTION_1 = [("secid", 10, "i"), ("elform", 10, "i"), ("shrf", 10, "f"), ("nip", 10, "f"),
              ("propt", 10, "f"), ("qr", 10, "f"), ("icomp", 10, "i"), ("setyp", 10, "i")]
_SECTION_2 = columns("t1 t2 t3 t4 nloc marea idof edgset", 10)
_ANGLES = columns("b1 b2 b3 b4 b5 b6 b7 b8", 10)
_CURVE = [("lcid", 10, "i"), ("sidr", 10, "i"), ("sfa", 10, "f"), ("sfo", 10, "f"), ("offa", 10, "f"),
          ("offo", 10, "f"), ("dattyp", 10, "i"), ("lcint", 10, "i")]
_POINT = columns("a o", 20)
_MATERIALS = {
    # kind: (names of the keyword, cards)
    "elastic": (("MAT_ELASTIC", "MAT_001"), [[("mid", 10, "i"), *columns("ro e pr da db k", 10)]]),
    "plastic_kinematic": (("MAT_PLASTIC_KINEMATIC", "MAT_003"),
                          [[("mid", 10, "i"), *columns("ro e pr sigy etan beta", 10)],
                           columns("src srp fs vp", 10)]),
    "piecewise_linear": (("MAT_PIECEWISE_LINEAR_PLASTICITY", "MAT_024"),
                         [[("mid", 10, "i"), *columns("ro e pr sigy etan fail tdel", 10)],
                          [*columns("c p", 10), ("lcss", 10, "i"), ("lcsr", 10, "i"), *columns("vp lcf", 10)],
                          columns("eps1 eps2 eps3 eps4 eps5 eps6 eps7 eps8", 10),
                          columns("es1 es2 es3 es4 es5 es6 es7 es8", 10)]),
    "rigid": (("MAT_RIGID", "MAT_020"), [[("mid", 10, "i"), *columns("ro e pr n couple m alias", 10)],
                                         columns("cmo con1 con2", 10), columns("lco a2 a3 v1 v2 v3", 10)]),
    "transversely_anisotropic": (("MAT_TRANSVERSELY_ANISOTROPIC_ELASTIC_PLASTIC", "MAT_037"),
                                 [[("mid", 10, "i"), *columns("ro e pr sigy etan r", 10), ("hlcid", 10, "i")]]),
}
_MATERIAL_NAMES = {name: kind for kind, (names, _) in _MATERIALS.items() for name in names}
_SHELL_OPTIONS = {"": (), "THICKNESS": ("thickness",), "BETA": ("thickness",), "MCID": ("thickness",),
                  "OFFSET": ("offset",), "THICKNESS_OFFSET": ("thickness", "offset"),
                  "BETA_OFFSET": ("thickness", "offset"), "MCID_OFFSET": ("thickness", "offset")}
_SKIPPED_QUIETLY = ("KEYWORD", "COMMENT", *PARAMETER_KEYWORDS)


# ---------------------------------------------------------------- lines and fields
@dataclass(frozen=True)
class Line:
    text: str
    file: Path
    number: int


@dataclass
class Block:
    """A keyword and its data lines (comments dropped)."""
    name: str
    line: Line
    cards: list


_FORTRAN_EXPONENT = re.compile(r"^([+-]?(?:\d+\.?\d*|\.\d+))([+-]\d+)$")


def location(line: Line, keyword: str) -> str:
    return f"{line.file}:{line.number}: *{keyword}"


def _number(text: str, kind: str):
    """The value of one field ('' is 0); raises ValueError."""
    if text == "":
        return 0 if kind == "i" else 0.0
    try:                                    # the common case first: plain Python syntax
        value = int(text) if kind == "i" else float(text)
    except ValueError:
        t = text.replace("d", "e").replace("D", "e")
        m = _FORTRAN_EXPONENT.match(t)
        if m:                               # Fortran's 1.5-3 for 1.5e-3
            t = f"{m.group(1)}e{m.group(2)}"
        value = float(t)
        if kind == "i":
            if not value.is_integer() or abs(value) >= 2**62:
                raise
            return int(value)
    if kind == "f" and not math.isfinite(value) or kind == "i" and abs(value) >= 2**62:
        raise ValueError(text)
    return value


_SLICES: dict[int, list[tuple[str, int, int, str]]] = {}


def _slices(layout) -> list[tuple[str, int, int, str]]:
    """(name, start, end, type) of each field of a fixed-format card."""
    key = id(layout)
    if key not in _SLICES:
        out, start = [], 0
        for name, width, kind in layout:
            out.append((name, start, start + width, kind))
            start += width
        _SLICES[key] = out
    return _SLICES[key]


def read_card(line: Line, layout, keyword: str) -> dict:
    """The fields of one card, free format when the line holds a comma, else fixed."""
    text = line.text
    free = "," in text
    if free:
        raw = [t.strip() for t in text.split(",")]
        raw += [""] * (len(layout) - len(raw))
    else:
        raw = [text[a:b].strip() for _, a, b, _ in _slices(layout)]
    out = {}
    for k, (name, a, b, kind) in enumerate(_slices(layout)):
        try:
            out[name] = _number(substitute(raw[k], line, keyword), kind)
        except (ValueError, OverflowError):
            expected = "an integer" if kind == "i" else "a number"
            at = f"field {k + 1}" if free else f"columns {a + 1}-{b}"
            raise SceneError(f"{location(line, keyword)}: {name.upper()} ({at}): expected {expected}, "
                             f"got {raw[k]!r}") from None
    return out


def _read_lines(path: Path, shown: Path) -> list[str]:
    try:
        return path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError as exc:
        raise SceneError(f"{shown}: cannot read LS-DYNA deck: {exc.strerror or exc}") from None


def _blocks(path: Path, main_dir: Path, depth: int = 0, seen: tuple = ()) -> tuple[list[Block], str]:
    """The keyword blocks of ``path`` and its includes, in reading order; and the title."""
    blocks: list[Block] = []
    title = ""
    current = None
    lines = _read_lines(path, path)
    i = 0
    while i < len(lines):
        text = lines[i]
        line = Line(text, path, i + 1)
        i += 1
        if text.startswith("$"):
            continue
        if text.startswith("*"):
            tokens = text[1:].split()
            name = tokens[0].upper() if tokens else ""
            rest = [t.upper() for t in tokens[1:]]
            if name.endswith(("+", "%")) or "+" in rest or "%" in rest or (
                    name == "KEYWORD" and any(t.startswith(("LONG=", "I10=")) and not t.endswith("=N")
                                              for t in rest)):
                raise SceneError(f"{path}:{i}: {text.strip()}: the long and 10-digit-id keyword formats are "
                                 "not read: write the deck in the standard format (LS-PrePost: "
                                 "File > Save As, standard format)")
            if name == "END":
                current = None
                break
            current = Block(name.rstrip("+%"), line, [])
            blocks.append(current)
            continue
        if current is not None:
            current.cards.append(line)
    result: list[Block] = []
    for block in blocks:
        if block.name == "TITLE":
            title = next((c.text.strip() for c in block.cards), title)
        elif block.name == "INCLUDE":
            names = [c for c in block.cards if c.text.strip()]
            if not names:
                raise SceneError(f"{location(block.line, 'INCLUDE')}: no file name on the next line")
            for card in names:
                name = card.text.strip()
                target = _include_path(name, path, main_dir, card)
                if depth >= MAX_INCLUDE_DEPTH or target.resolve() in seen + (path.resolve(),):
                    raise SceneError(f"{location(card, 'INCLUDE')}: {name} includes itself (directly or "
                                     "through other files)")
                sub, sub_title = _blocks(target, main_dir, depth + 1, seen + (path.resolve(),))
                text = _read_lines(target, target)
                if not any(t.startswith("*") for t in text) and any(t.strip() and not t.startswith("$") for t in text):
                    raise SceneError(f"{location(card, 'INCLUDE')}: {name} is not an LS-DYNA keyword file (no line "
                                     "starts with a '*' keyword)")
                result += sub
                title = title or sub_title
        else:
            result.append(block)
    return result, title


def _include_path(name: str, including: Path, main_dir: Path, line: Line) -> Path:
    """The file an *INCLUDE names: relative to the including file's folder, else the main
    deck's (each folder named once in the message when it is in neither)."""
    candidates = [Path(name)] if Path(name).is_absolute() else [including.parent / name, main_dir / name]
    candidates = list({str(c.resolve()): c for c in candidates}.values())
    for c in candidates:
        if c.is_file():
            return c
    folder = next((c for c in candidates if c.is_dir()), None)
    if folder is not None:
        raise SceneError(f"{location(line, 'INCLUDE')}: {name} is a folder ({folder.resolve()}), not a file: "
                         "name the deck file to include")
    raise SceneError(f"{location(line, 'INCLUDE')}: included file {name} not found (looked in "
                     f"{', '.join(str(c.parent) for c in candidates)})")


def data_cards(block: Block) -> list[Line]:
    """The data lines of a block, trailing blank lines dropped."""
    cards = list(block.cards)
    while cards and not cards[-1].text.strip():
        cards.pop()
    return cards


def card_groups(block: Block, size: int) -> list[list[Line]]:
    """Cards in groups of ``size`` (a keyword that repeats its cards); trailing blank lines
    are cards (all fields default) as far as a group needs them, else spacing."""
    cards = data_cards(block)
    while len(cards) % size and len(cards) < len(block.cards):
        cards.append(block.cards[len(cards)])
    if len(cards) % size:
        cards = data_cards(block)
        raise SceneError(f"{location(cards[-1] if cards else block.line, block.name)}: incomplete card group "
                         f"({len(cards) % size} of {size} cards after the last complete one)")
    return [cards[k:k + size] for k in range(0, len(cards), size)]


def _split_title(name: str) -> tuple[str, bool]:
    return (name[:-len("_TITLE")], True) if name.endswith("_TITLE") else (name, False)


def _material_kind(name: str) -> str | None:
    if name in _MATERIAL_NAMES:
        return _MATERIAL_NAMES[name]
    m = re.fullmatch(r"MAT_0*(\d+)", name)
    return {1: "elastic", 3: "plastic_kinematic", 20: "rigid", 24: "piecewise_linear",
            37: "transversely_anisotropic"}.get(int(m.group(1))) if m else None


# ---------------------------------------------------------------- the reader
def read_deck(path: Path) -> tuple[np.ndarray, np.ndarray, dict, Deck, tuple[str, ...]]:
    """Read an LS-DYNA keyword deck: (points (n, 3), elements (m, 4) int64 with -1 in
    column 3 for triangles, element sets {"part:<pid>", heading: ids}, :class:`Deck`,
    warnings).  Raises SceneError (one line) for what cannot be read."""
    path = Path(path)
    key = str(path.resolve())
    cached = _READ.get(key)
    if cached is not None and all(_stamp(f) == stamp for f, stamp in cached[0].items()):
        points, elements, sets, deck, warnings = cached[1]
        return points.copy(), elements.copy(), {k: v.copy() for k, v in sets.items()}, deck, warnings
    blocks, title = _blocks(path, path.parent)
    parameters = read_parameters(blocks)
    with using(parameters):
        result = _read_blocks(path, blocks, title, parameters)
    files = {path, *(b.line.file for b in blocks)}
    _READ.clear()                 # the last deck only: a scene reads it, then its mesh
    _READ[key] = ({f: _stamp(f) for f in files}, result)
    points, elements, sets, deck, warnings = result
    return points.copy(), elements.copy(), {k: v.copy() for k, v in sets.items()}, deck, warnings


_READ: dict = {}
"""The last deck read (its files' digests, the result): the scene reads a deck's
keywords (dyna/scene.py) and then its mesh (mesh.py) from one reading [choice: measured on a
99 856-shell deck, 1.2 s per reading]."""


def _stamp(path: Path) -> str:
    """A digest of the file's bytes (not its modification time: a file rewritten within the
    file system's time resolution with the same size would look unchanged)."""
    try:
        return hashlib.blake2b(Path(path).read_bytes(), digest_size=16).hexdigest()
    except OSError:
        return ""


def _read_blocks(path: Path, blocks: list, title: str, parameters: dict):
    node_ids, coords, node_lines, codes = [], [], [], []
    shells, shell_lines, thick_rows = [], [], {}
    parts, sections, materials, curves, material_lines = {}, {}, {}, {}, {}
    keywords: list[Block] = []
    offsets = higher = 0
    for block in blocks:
        name = block.name
        base, titled = _split_title(name)
        if name == "NODE":
            for card in data_cards(block):
                if not card.text.strip():
                    continue
                v = read_card(card, _NODE, name)
                node_ids.append(v["nid"])
                coords.append((v["x"], v["y"], v["z"]))
                node_lines.append(card)
                codes.append((v["tc"], v["rc"]))
        elif name.startswith("ELEMENT_SHELL"):
            option = name[len("ELEMENT_SHELL"):].lstrip("_")
            if option not in _SHELL_OPTIONS:
                raise SceneError(f"{location(block.line, name)}: this option of *ELEMENT_SHELL is not read "
                                 f"(read: {', '.join('*ELEMENT_SHELL' + ('_' + o if o else '') for o in _SHELL_OPTIONS)})")
            extra = _SHELL_OPTIONS[option]
            cards = [c for c in data_cards(block) if c.text.strip() or extra]
            for group in card_groups(Block(name, block.line, cards), 1 + len(extra)):
                v = read_card(group[0], _SHELL, name)
                shells.append((v["eid"], v["pid"], v["n1"], v["n2"], v["n3"], v["n4"]))
                shell_lines.append(group[0])
                higher += any(v[f"n{k}"] for k in range(5, 9))
                for card, what in zip(group[1:], extra):
                    if what == "thickness":
                        t = read_card(card, _SHELL_THICKNESS, name)
                        row = [t[f"thic{k}"] for k in range(1, 5)]
                        if min(row) < 0.0:       # 0 (blank) is the section's thickness; < 0 is no thickness
                            k = int(np.argmin(row))
                            raise SceneError(f"{location(card, name)}: element {v['eid']}: THIC{k + 1} = {row[k]:g}: "
                                             "expected a thickness > 0 (or 0/blank: the section's T1)")
                        if any(row):
                            thick_rows[len(shells) - 1] = [x if x > 0 else np.nan for x in row]
                    else:
                        offsets += read_card(card, _SHELL_OFFSET, name)["offset"] != 0
        elif name in ("PART", "PART_CONTACT"):
            for group in card_groups(block, 2 if name == "PART" else 3):
                heading = group[0].text.strip()
                v = read_card(group[1], _PART, name)
                _unique(parts, v["pid"], DeckPart(v["pid"], heading, v["secid"], v["mid"], v["hgid"]), group[1], name, "part")
        elif name == "PART_INERTIA":
            cards, k = data_cards(block), 0         # heading, *PART card, cards 3-5 (+ 6 with IRCS = 1)
            while k < len(cards):
                group = cards[k:k + 5]
                if len(group) < 4:
                    raise SceneError(f"{location(group[-1], name)}: incomplete card group ({len(group)} of 5 cards)")
                v = read_card(group[1], _PART, name)
                values = read_card(group[2], _PART_INERTIA, name)
                values.update(read_card(group[3], INERTIA_TENSOR, name))
                values.update(read_card(group[4], INERTIA_VELOCITY, name) if len(group) > 4 else
                              dict.fromkeys(("vtx", "vty", "vtz", "vrx", "vry", "vrz"), 0.0))
                values["where"] = location(group[2], name)
                _unique(parts, v["pid"], DeckPart(v["pid"], group[0].text.strip(), v["secid"], v["mid"], v["hgid"],
                                                  values), group[1], name, "part")
                k += 5 + (values["ircs"] == 1)
        elif base == "SECTION_SHELL":
            _read_sections(block, titled, sections)
        elif _material_kind(base) is not None:
            kind = _material_kind(base)
            layout = _MATERIALS[kind][1]
            for group in card_groups(block, len(layout) + titled):
                heading = group[0].text.strip() if titled else ""
                values = {}
                for card, cl in zip(group[titled:], layout):
                    values.update(read_card(card, cl, name))
                mid = values.pop("mid")
                values = {k: float(x) for k, x in values.items()}
                _unique(materials, mid, DeckMaterial(mid, kind, heading, values, where=location(group[titled], name)),
                        group[titled], name, "material")
                material_lines[mid] = (group[titled], name)
        elif base == "DEFINE_CURVE":
            cards = data_cards(block)
            cards = cards[1:] if titled else cards
            if not cards:
                raise SceneError(f"{location(block.line, name)}: no curve card")
            v = read_card(cards[0], _CURVE, name)
            sfa, sfo = v["sfa"] or 1.0, v["sfo"] or 1.0
            pts = [read_card(c, _POINT, name) for c in cards[1:] if c.text.strip()]
            curve = tuple((sfa * (p["a"] + v["offa"]), sfo * (p["o"] + v["offo"])) for p in pts)
            _unique(curves, v["lcid"], curve, cards[0], name, "curve")
        elif name in _SKIPPED_QUIETLY:
            continue
        else:
            keywords.append(block)

    warnings = []
    if not shells:
        raise SceneError(f"{path}: deck has no *ELEMENT_SHELL cards")
    constraints = np.array(codes, dtype=np.float64).reshape(-1, 2)
    bad = np.nonzero(~np.isin(constraints, np.arange(8)).all(axis=1))[0]
    if len(bad):
        raise SceneError(f"{location(node_lines[bad[0]], 'NODE')}: TC, RC = {constraints[bad[0], 0]:g}, "
                         f"{constraints[bad[0], 1]:g}: expected constraint codes 0..7")
    if offsets:
        warnings.append(f"{path}: the OFFSET of {offsets} *ELEMENT_SHELL_..._OFFSET elements is not read: "
                        "they lie on their nodes")
    if higher:
        warnings.append(f"{path}: {higher} shells with nodes N5..N8 used as 4-node shells: those nodes are "
                        "dropped and curved edges become straight")

    # nodes: user ids -> positions
    nids = np.array(node_ids, dtype=np.int64)
    table = np.array(shells, dtype=np.int64).reshape(-1, 6)
    for ids, lines, keyword, what in ((nids, node_lines, "NODE", "NID"), (table[:, 0], shell_lines, "ELEMENT_SHELL", "EID"),
                                      (table[:, 1], shell_lines, "ELEMENT_SHELL", "PID")):
        bad = np.nonzero(ids <= 0)[0]
        if len(bad):
            raise SceneError(f"{location(lines[bad[0]], keyword)}: {what} must be > 0, got {ids[bad[0]]}")
    order = np.argsort(nids, kind="stable")
    dup = np.nonzero(nids[order][1:] == nids[order][:-1])[0]
    if len(dup):
        a, b = sorted((order[dup[0]], order[dup[0] + 1]))
        raise SceneError(f"{location(node_lines[b], 'NODE')}: node {nids[b]} is defined twice (also on "
                         f"{node_lines[a].file}:{node_lines[a].number})")
    eids, pids, corners = table[:, 0], table[:, 1], table[:, 2:]
    eorder = np.argsort(eids, kind="stable")
    dup = np.nonzero(eids[eorder][1:] == eids[eorder][:-1])[0]
    if len(dup):
        a, b = sorted((eorder[dup[0]], eorder[dup[0] + 1]))
        raise SceneError(f"{location(shell_lines[b], 'ELEMENT_SHELL')}: element {eids[b]} is defined twice "
                         f"(also on {shell_lines[a].file}:{shell_lines[a].number})")
    sorted_ids = nids[order]
    pos = np.minimum(np.searchsorted(sorted_ids, corners), len(sorted_ids) - 1)
    found = sorted_ids[pos] == corners if len(sorted_ids) else np.zeros(corners.shape, dtype=bool)
    if not found.all():
        bad = np.nonzero(~found.all(axis=1))[0]
        e = bad[0]
        nid = corners[e][~found[e]][0]
        more = f" ({len(bad)} elements reference undefined nodes)" if len(bad) > 1 else ""
        raise SceneError(f"{location(shell_lines[e], 'ELEMENT_SHELL')}: element {eids[e]} references node {nid}, "
                         f"which no *NODE defines{more}")
    elements = order[pos].astype(np.int64)
    # n3 = n4: a triangle
    tri = corners[:, 2] == corners[:, 3]
    elements[tri, 3] = -1
    points = np.array(coords, dtype=np.float64).reshape(-1, 3)

    thickness = None
    if thick_rows:
        thickness = np.full((len(shells), 4), np.nan)
        rows = np.fromiter(thick_rows.keys(), dtype=np.int64)
        thickness[rows] = np.array(list(thick_rows.values()))

    # element sets, one per part
    sets = {}
    headings = [p.title for p in parts.values() if p.title]
    for pid in np.unique(pids):
        ids = np.nonzero(pids == pid)[0].astype(np.int64)
        sets[f"part:{pid}"] = ids
        part = parts.get(int(pid))
        if part is not None and part.title and headings.count(part.title) == 1 and part.title not in sets:
            sets[part.title] = ids

    # materials: resolve MAT_024 / MAT_037 curves; parts used by shells: say what is missing
    for mid, mat in list(materials.items()):
        if mat.kind == "transversely_anisotropic" and int(mat.values["hlcid"]) > 0:
            hlcid = int(mat.values["hlcid"])
            if hlcid in curves:
                materials[mid] = _replace_curve(mat, curves[hlcid])
            else:
                warnings.append(f"{location(*material_lines[mid])}: material {mid}: HLCID {hlcid} is not a "
                                "*DEFINE_CURVE of this deck: no stress-strain curve")
        if mat.kind != "piecewise_linear":
            continue
        lcss = int(mat.values["lcss"])
        if lcss > 0:
            if lcss in curves:
                materials[mid] = _replace_curve(mat, curves[lcss])
            else:
                warnings.append(f"{location(*material_lines[mid])}: material {mid}: LCSS {lcss} is not a "
                                "*DEFINE_CURVE of this deck (a *DEFINE_TABLE is not read): no stress-strain curve")
        else:
            pts = [(mat.values[f"eps{k}"], mat.values[f"es{k}"]) for k in range(1, 9)]
            curve = []
            for eps, sig in pts:
                if sig <= 0.0 or (curve and eps <= curve[-1][0]):
                    break
                curve.append((eps, sig))
            if len(curve) >= 2:
                materials[mid] = _replace_curve(mat, tuple(curve))
    problems = []
    for pid in np.unique(pids):
        part = parts.get(int(pid))
        n = int((pids == pid).sum())
        if part is None:
            problems.append(f"{path}: part {pid} ({n} shell{'s' if n != 1 else ''}) has no *PART card")
            continue
        if part.secid not in sections:
            problems.append(f"{path}: part {pid} ({part.title or 'no heading'}): section {part.secid} is not a "
                            "*SECTION_SHELL of this deck")
        if part.mid not in materials:
            problems.append(f"{path}: part {pid} ({part.title or 'no heading'}): material {part.mid} is not one "
                            "this reader reads (*MAT_001, *MAT_003, *MAT_020, *MAT_024, *MAT_037)")
    if len(problems) > 10:
        problems = problems[:10] + [f"{path}: ... and {len(problems) - 10} more"]
    warnings += problems

    deck = Deck(parts=parts, sections=sections, materials=materials, curves=curves,
                element_ids=eids.copy(), node_ids=nids.copy(), element_parts=pids.copy(),
                element_thickness=thickness, title=title, keywords=tuple(keywords), parameters=parameters,
                used_nodes=np.isin(np.arange(len(nids)), elements[elements >= 0]),
                node_constraints=constraints.astype(np.int64))
    return points, elements, sets, deck, tuple(warnings)


def _replace_curve(mat: DeckMaterial, curve) -> DeckMaterial:
    return DeckMaterial(mat.mid, mat.kind, mat.title, mat.values, tuple((float(a), float(b)) for a, b in curve),
                        where=mat.where)


def _unique(table: dict, key: int, value, line: Line, keyword: str, what: str) -> None:
    if key in table:
        raise SceneError(f"{location(line, keyword)}: {what} {key} is defined twice")
    table[key] = value


def _read_sections(block: Block, titled: bool, sections: dict) -> None:
    """Every section of one *SECTION_SHELL keyword (title, 2 cards, angle cards if ICOMP = 1)."""
    cards = data_cards(block)
    k = 0
    name = block.name
    while k < len(cards):
        heading = ""
        if titled:
            heading = cards[k].text.strip()
            k += 1
        if k + 2 > len(cards):
            raise SceneError(f"{location(cards[-1], name)}: incomplete section (2 cards expected after "
                             f"{'the title' if titled else 'the keyword'})")
        one, two = read_card(cards[k], _SECTION_1, name), read_card(cards[k + 1], _SECTION_2, name)
        line = cards[k]
        k += 2
        elform = one["elform"] or 2
        if 101 <= elform <= 105:
            raise SceneError(f"{location(line, name)}: section {one['secid']}: user-defined element ELFORM "
                             f"{elform} is not read")
        nip = int(one["nip"]) or 2
        if one["icomp"] == 1:
            k += math.ceil(nip / 8)             # material angles B1..B8 per card: not read
            if k > len(cards):
                raise SceneError(f"{location(cards[-1], name)}: section {one['secid']}: ICOMP = 1 needs "
                                 f"{math.ceil(nip / 8)} card(s) of angles")
        t1 = two["t1"]
        ts = (t1, *(t if t > 0 else t1 for t in (two["t2"], two["t3"], two["t4"])))
        values = {k: float(x) for k, x in {**one, **two}.items() if k != "secid"}
        _unique(sections, one["secid"], DeckSection(
            secid=one["secid"], elform=elform, shear_factor=one["shrf"] or 1.0, nip=nip, thickness=t1,
            thicknesses=ts, quadrature=int(one["qr"]), title=heading, values=values, where=location(line, name)),
        line, name, "section")
