"""A scene: the tables read into one frozen Scene; loading a TOML file with --set overrides."""
from __future__ import annotations

import copy
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..keys import Invalid, hint, key_path, one_line, show
from .boundary import Boundary, read_boundary
from .contact import Contact, check_penalty_damping
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


class SceneError(Exception):
    """A user mistake in a scene file or a mesh (one line per problem)."""

    def __init__(self, messages: list[str] | str, mesh: "MeshSpec | None" = None):
        self.messages = [messages] if isinstance(messages, str) else list(messages)
        self.mesh = mesh
        """The scene's valid [mesh] table when other tables had problems (so that the mesh can
        be checked as well and every problem reported at once), else None."""
        super().__init__("\n".join(self.messages))


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

    def nodeset(self, name: str) -> NodeSet:
        for s in self.nodesets:
            if s.name == name:
                return s
        if name == "all":
            return NodeSet(name="all", kind="all")
        raise KeyError(name)


def load_scene(path: str | Path, overrides: Sequence[str] = ()) -> Scene:
    """Read the TOML scene at `path`, apply ``--set`` `overrides`, validate, return the Scene.

    Raises :class:`SceneError` with one line per problem: a single line for an unreadable
    file or a TOML syntax error, otherwise every problem found in the scene.
    """
    path = Path(path)
    try:
        with path.open("rb") as f:
            raw = tomllib.load(f)
    except FileNotFoundError:
        raise SceneError(f"{path}: file not found") from None
    except OSError as exc:
        raise SceneError(f"{path.name}: cannot read the file ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise SceneError(f"{path.name}: not a UTF-8 text file") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path.name}: TOML syntax error: {one_line(exc)}") from None
    try:
        raw = apply_overrides(raw, overrides)
    except SceneError as exc:
        raise SceneError([f"{path.name}: {m}" for m in exc.messages]) from None
    return parse_scene(raw, path)


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
                 materials=materials, sections=sections, elementsets=tuple(elementsets), parts=tuple(parts),
                 curves=curves, motions=tuple(motions), pressures=tuple(pressures), gravity=gravity,
                 ties=tuple(ties), spotwelds=tuple(spotwelds))
