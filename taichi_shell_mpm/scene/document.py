"""A scene: the tables read into one frozen Scene; loading a TOML file with --set overrides."""
from __future__ import annotations

import copy
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ..keys import Invalid, hint, key_path, one_line, show
from ..problems import SceneError
from .boundary import Boundary, read_boundary
from .contact import Contact, check_penalty_damping
from .contact_pair import MAX_CONTACT_PAIRS, ContactPair, read_contact_pair
from .crush import Crush, read_crush
from .curves import MAX_CURVES, Curve, read_curve
from .element import ElementOptions
from .gravity import Gravity
from .info import SceneInfo
from .joints import SpotWeld, Tie, read_spotweld, read_tie
from .initial import InitialVelocity
from .load import Load, read_load
from .material import AnyMaterial
from .mesh import MeshSpec, read_mesh
from .method import Method, read_method
from .motion import MAX_MOTIONS, Motion, read_motion
from .nodesets import NodeSet, read_nodesets
from .output import Output
from .parts import ElementSet, Part, read_parts
from .point_mass import PointMass, read_point_mass
from .pressure import Pressure, read_pressure
from .probe import Probe, read_probe
from .reader import TABLES, Reader
from .reference import Reference, read_reference
from .rigid_body import MAX_BODIES, RigidBody, read_rigid_body
from .section import Section
from .solve import Solve, read_solve
from .tool import Tool, read_tool
from .wall import Wall, read_wall


@dataclass(frozen=True)
class Scene:
    source: Path
    info: SceneInfo
    mesh: MeshSpec
    material: AnyMaterial | None
    """The one material of a scene without [[part]] (None with [materials.NAME] / a deck)."""
    section: Section | None
    element: ElementOptions
    method: Method
    solve: Solve
    output: Output
    nodesets: tuple[NodeSet, ...] = ()
    boundaries: tuple[Boundary, ...] = ()
    loads: tuple[Load, ...] = ()
    initial: tuple[InitialVelocity, ...] = ()
    probes: tuple[Probe, ...] = ()
    reference: Reference | None = None
    rigid_bodies: tuple[RigidBody, ...] = ()
    point_masses: tuple[PointMass, ...] = ()
    walls: tuple[Wall, ...] = ()
    tools: tuple[Tool, ...] = ()
    contact: Contact | None = None
    contact_pairs: tuple[ContactPair, ...] = ()
    """[[contact_pair]] interfaces (scene/contact_pair.py)."""
    crush: Crush | None = None
    ties: tuple[Tie, ...] = ()
    """[[tie]] entries (tied contact; scene/joints.py)."""
    spotwelds: tuple[SpotWeld, ...] = ()
    """[[spotweld]] entries (scene/joints.py)."""
    materials: dict[str, AnyMaterial] = field(default_factory=dict)
    """Named materials ([materials.NAME]); with [[part]]."""
    sections: dict[str, Section] = field(default_factory=dict)
    elementsets: tuple[ElementSet, ...] = ()
    parts: tuple[Part, ...] = ()
    """[[part]] entries; empty: one part over the mesh ([material] and [section], or the one
    named material and section, or an LS-DYNA deck's parts)."""
    curves: dict[str, Curve] = field(default_factory=dict)
    motions: tuple[Motion, ...] = ()
    pressures: tuple[Pressure, ...] = ()
    gravity: Gravity | None = None
    notes: tuple[str, ...] = ()
    """What reading the scene noted beyond its tables: an LS-DYNA deck's keywords that were not
    read, and values read with a stated difference of meaning (dyna/scene.py); warnings."""

    def nodeset(self, name: str) -> NodeSet:
        for s in self.nodesets:
            if s.name == name:
                return s
        if name == "all":
            return NodeSet(name="all", kind="all")
        raise KeyError(name)


def load_scene(path: str | Path, overrides: Sequence[str] = (), accept_unread: bool = False) -> Scene:
    """Read the scene at `path` (a TOML file, or an LS-DYNA deck: its keywords as the
    tables they mean, dyna/scene.py), apply ``--set`` `overrides`, validate, return the Scene.

    A TOML scene whose ``[mesh]`` is a deck takes the deck's keywords for what it does not
    say itself (:func:`merge_deck`).  A deck keyword that would change the physics and is not
    read is an error unless `accept_unread`.  Raises :class:`SceneError` with one line per
    problem: a single line for an unreadable file or a TOML syntax error, otherwise every
    problem found in the scene (a deck's values named by their file, line and keyword).
    """
    from ..dyna.scene import deck_document
    from .mesh import DECK_SUFFIXES
    path = Path(path)
    deck = None
    if path.suffix.lower() in DECK_SUFFIXES:
        if not path.is_file():
            raise SceneError(f"{path}: file not found" if not path.exists() else f"{path}: not a file")
        deck = deck_document(path)
        raw = copy.deepcopy(deck.raw)
    else:
        raw = _read_toml(path)
        mesh = raw.get("mesh")
        named = mesh.get("path") if isinstance(mesh, dict) and mesh.get("kind") == "file" else None
        if isinstance(named, str) and Path(named).suffix.lower() in DECK_SUFFIXES and (path.parent / named).is_file():
            deck = deck_document(path.parent / named)
            raw = merge_deck(raw, deck, path.name)
    try:
        raw = apply_overrides(raw, overrides)
    except SceneError as exc:
        raise SceneError([f"{path.name}: {m}" for m in exc.messages]) from None
    if deck is None:
        return parse_scene(raw, path)
    check_deck_mesh(raw, deck, path.name)
    problems = deck.problems(accept_unread)
    try:
        scene = parse_scene(raw, path)
    except SceneError as exc:
        raise SceneError(problems + [_from_deck(m, path.name, deck.origins) for m in exc.messages],
                         mesh=exc.mesh) from None
    if problems:
        raise SceneError(problems, mesh=scene.mesh)
    return replace(scene, notes=tuple(deck.warnings(accept_unread)))


def _read_toml(path: Path) -> dict:
    try:
        with path.open("rb") as f:
            return tomllib.load(f)
    except FileNotFoundError:
        raise SceneError(f"{path}: file not found") from None
    except OSError as exc:
        raise SceneError(f"{path.name}: cannot read the file ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise SceneError(f"{path.name}: not a UTF-8 text file") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path.name}: TOML syntax error: {one_line(exc)}") from None


def merge_deck(raw: dict, deck, file_name: str) -> dict:
    """The TOML document `raw` over the deck's (`deck`: dyna.scene.DeckDocument): a key the
    TOML gives wins, a table it does not give comes from the deck (named tables, such as
    [nodesets.NAME] and [curves.NAME], merged by name), and an array of tables ([[boundary]])
    holds the TOML's entries, then the deck's; `deck.origins` follows the deck's entries."""
    merged = copy.deepcopy(deck.raw)
    merged.pop("mesh", None)
    for name, value in raw.items():
        have = merged.get(name)
        if isinstance(value, list) and isinstance(have, list):
            head = f"[[{name}]]["
            deck.origins = {(f"{head}{int(k[len(head):-1]) + len(value)}]" if k.startswith(head) else k): v
                            for k, v in deck.origins.items()}
            merged[name] = value + have
        elif isinstance(value, dict) and isinstance(have, dict):
            merged[name] = {**have, **value}
        else:
            merged[name] = value
    return merged


def check_deck_mesh(raw: dict, deck, file_name: str) -> None:
    """A deck's keywords name its nodes by id and give lengths in its units: its mesh may be
    neither merged nor scaled (after --set)."""
    mesh = raw.get("mesh", {})
    keyworded = sorted(set(deck.raw) - {"scene", "mesh"})
    if not isinstance(mesh, dict) or not keyworded:
        return
    if mesh.get("merge_nodes") is True:
        raise SceneError(f"{file_name}: [mesh].merge_nodes: the deck's keywords name its nodes by id "
                         f"({', '.join(keyworded)}): merging nodes would renumber them")
    scale = mesh.get("scale", 1.0)
    if scale != 1.0:
        raise SceneError(f"{file_name}: [mesh].scale = {scale!r}: the deck's keywords give lengths and velocities "
                         f"in its own units ({', '.join(keyworded)}): scale the deck itself")


def _from_deck(message: str, file_name: str, origins: dict) -> str:
    """A scene message about a table the deck wrote, with the deck line it came from."""
    head = f"{file_name}: "
    if not message.startswith(head):
        return message
    rest = message[len(head):]
    for key in sorted(origins, key=len, reverse=True):
        if rest.startswith(key):
            return f"{origins[key]}: {rest}"
    return message


def apply_overrides(raw: dict, overrides: Sequence[str]) -> dict:
    """Return a copy of `raw` with each ``"a.b.c=VALUE"`` of `overrides` applied.

    VALUE is read as a TOML value (``20``, ``1e-3``, ``true``, ``[0, 0, 2]``,
    ``'text'``), or taken as a plain string when it is not one (``fem``).  Integer path
    components index arrays of tables (``load.1.force=[0,0,2]``).  The last key may be
    new, and missing tables on the way are created; validation then rejects what the
    scene does not know.  Raises :class:`SceneError` (``--set ITEM: problem`` lines) for
    an item without ``=``, an empty key, a path through a non-table or an index out of
    range.
    """
    result = copy.deepcopy(raw)
    errors = []
    for item in overrides:
        try:
            apply_override(result, item)
        except Invalid as exc:
            errors.append(f"--set {one_line(item)}: {exc}")
    if errors:
        raise SceneError(errors)
    return result


def parse_scene(raw: dict, source: Path) -> Scene:
    """Validate the TOML document `raw` of the scene file `source` into a :class:`Scene`.

    `source` names the file in messages and anchors relative paths (mesh and reference
    files).  Raises :class:`SceneError` listing every problem found.
    """
    return read_scene(Reader(raw, Path(source)))


def apply_override(document: dict, item: str) -> None:
    """Apply one ``KEY=VALUE`` override to `document` in place (raises Invalid)."""
    key, sep, text = item.partition("=")
    if not sep:
        raise Invalid("expected KEY=VALUE, e.g. mesh.nx=20")
    parts = [part.strip() for part in key.split(".")]
    if not all(parts):
        raise Invalid(f"empty key in {key.strip()!r}")
    node: Any = document
    for depth, part in enumerate(parts):
        where = ".".join(parts[:depth]) or "the scene"
        if isinstance(node, dict):
            slot: str | int = part
        elif isinstance(node, list):
            if not part.isdigit():
                raise Invalid(f"{where} is an array of tables; expected an index, got {part!r}")
            slot = int(part)
            if slot >= len(node):
                count = f"{len(node)} {'entry' if len(node) == 1 else 'entries'}"
                raise Invalid(f"index {slot} out of range ({where} has {count})")
        else:
            raise Invalid(f"{where} is not a table (it is {show(node)})")
        if depth == len(parts) - 1:
            node[slot] = override_value(text)
        else:
            if isinstance(node, dict) and slot not in node:
                node[slot] = {}
            node = node[slot]


def override_value(text: str) -> Any:
    """The TOML value written in `text`, or `text` itself (stripped) if it is none."""
    try:
        return tomllib.loads("v = " + text)["v"]
    except tomllib.TOMLDecodeError:
        return text.strip()


def check_entries(r: Reader, key: str, entries: list, most: int, counted: str) -> None:
    """The named entries of [[key]]: no name twice, at most `most` of them."""
    names = [e.name for e in entries if e is not None]
    for i, name in enumerate(names):
        if name in names[:i]:
            r.error(f"[[{key}]]", f"duplicate {key} name {name!r}")
    if len(entries) > most:
        r.error(f"[[{key}]]", f"expected at most {most} {counted}, got {len(entries)}")


def plain(r: Reader, key: str, cls: type) -> Any:
    """The top-level table `key` without cross-checks, as `cls` (an absent one: its defaults)."""
    return r.part(key, lambda data: r.table_object(f"[{key}]", data, cls))


def read_scene(r: Reader) -> Scene:
    """Every table of the scene, then the checks across them; raises SceneError listing
    every problem."""
    for key in r.raw:
        if key not in TABLES:
            r.error(f"[{key_path(key)}]", "unknown key" + hint(key, TABLES, "allowed"))
    info = plain(r, "scene", SceneInfo)
    mesh = r.part("mesh", lambda data: read_mesh(r, data))
    material, section, materials, sections, elementsets, parts = read_parts(r, mesh)
    element = plain(r, "element", ElementOptions)
    if element is not None and element.ns_blend != 0.0 and element.triangle != "ns":
        r.error("[element].ns_blend", 'blends the node-smoothed triangle\'s membrane: it needs [element].triangle = '
                '"ns"')
    if element is not None and element.triangle == "opt" and element.drilling == "projection":
        r.error("[element].triangle", '"opt" needs the drilling rotations ([element].drilling = "penalty"): the '
                "projection removes them")
    method = r.part("method", lambda data: read_method(r, data))
    nodesets = r.part("nodesets", lambda data: read_nodesets(r, data))
    boundaries = r.array("boundary", lambda path, data: read_boundary(r, path, data))
    curves = r.named("curves", lambda path, data: read_curve(r, path, data))
    if len(curves) > MAX_CURVES:
        r.error("[curves]", f"expected at most {MAX_CURVES} curves, got {len(curves)}")
    loads = r.array("load", lambda path, data: read_load(r, path, data))
    initial = r.array("initial", lambda path, data: r.table_object(path, data, InitialVelocity))
    probes = r.array("probe", lambda path, data: read_probe(r, path, data))            # before [reference], which refers to them
    reference = read_reference(r, r.raw["reference"]) if "reference" in r.raw else None
    solve = r.part("solve", lambda data: read_solve(r, data))
    if element is not None and solve is not None and element.triangle == "opt" and solve.physical_rotary_inertia:
        r.error("[element].triangle", '"opt" keeps the scaled rotary inertia: its drilling modes would set the step '
                'with the physical one ([solve].rotary_inertia = "physical")')
    output = plain(r, "output", Output)
    bodies = r.array("rigid_body", lambda path, data: read_rigid_body(r, path, data))
    if len(bodies) > MAX_BODIES:
        r.error("[[rigid_body]]", f"expected at most {MAX_BODIES} entries, got {len(bodies)}")
    point_masses = r.array("point_mass", lambda path, data: read_point_mass(r, path, data))
    walls = r.array("wall", lambda path, data: read_wall(r, path, data))
    tools = r.array("tool", lambda path, data: read_tool(r, path, data, solve, curves))
    from ..model.tools import MAX_TOOLS
    check_entries(r, "tool", tools, MAX_TOOLS, "tools")
    contact = r.table_object("[contact]", r.raw["contact"], Contact) if "contact" in r.raw else None
    if contact is not None:
        check_penalty_damping(r, "[contact]", contact.stiffness, contact.damping)
    contact_pairs = r.array("contact_pair", lambda path, data: read_contact_pair(r, path, data, mesh, elementsets))
    check_entries(r, "contact_pair", contact_pairs, MAX_CONTACT_PAIRS, "interfaces")
    crush = read_crush(r, r.raw["crush"], solve) if "crush" in r.raw else None
    if solve is not None and solve.kind == "static":
        named = [("[material]", material), *((f"[materials.{key_path(k)}]", m) for k, m in materials.items())]
        for path, spec in named:
            if spec is not None and getattr(spec, "rate_law", "none") != "none":
                r.error(f"{path}.rate_law", "a static solve has no physical time: a rate law needs "
                                            "[solve].kind = \"dynamic\"")
            for key in ("failure_strain", "failure_min_dt"):
                if spec is not None and getattr(spec, key, 0.0) > 0.0:
                    r.error(f"{path}.{key}", "erosion needs [solve].kind = \"dynamic\"")
    motions = r.array("motion", lambda path, data: read_motion(r, path, data, solve, curves))
    check_entries(r, "motion", motions, MAX_MOTIONS, "entries")
    pressures = r.array("pressure", lambda path, data: read_pressure(r, path, data, mesh, elementsets))
    gravity = r.table_object("[gravity]", r.raw["gravity"], Gravity) if "gravity" in r.raw else None
    ties = r.array("tie", lambda path, data: read_tie(r, path, data, mesh, elementsets))
    check_entries(r, "tie", ties, 1 << 20, "entries")
    spotwelds = r.array("spotweld", lambda path, data: read_spotweld(r, path, data))
    check_entries(r, "spotweld", spotwelds, 1 << 20, "entries")
    if (ties or spotwelds) and solve is not None and solve.kind == "dynamic" and solve.mass_scaling == "selective":
        r.error("[solve].mass_scaling", '"selective" does not take [[tie]] or [[spotweld]] (their masses are '
                'lumped on the master nodes, stages/joints.py): use "conventional" or "none"')
    if r.messages:
        raise SceneError(r.messages, mesh=mesh)
    return Scene(source=r.source, info=info, mesh=mesh, material=material, section=section,
                 element=element, method=method, solve=solve, output=output,
                 nodesets=tuple(nodesets), boundaries=tuple(boundaries), loads=tuple(loads),
                 initial=tuple(initial), probes=tuple(probes), reference=reference,
                 rigid_bodies=tuple(bodies), point_masses=tuple(point_masses), walls=tuple(walls),
                 tools=tuple(tools), contact=contact, crush=crush,
                 contact_pairs=tuple(contact_pairs),
                 materials=materials, sections=sections, elementsets=tuple(elementsets), parts=tuple(parts),
                 curves=curves, motions=tuple(motions), pressures=tuple(pressures), gravity=gravity,
                 ties=tuple(ties), spotwelds=tuple(spotwelds))
