"""[[tool]]: rigid tools in penalty contact with the shell."""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from .contact import check_penalty_damping
from .curves import Curve
from ..keys import (
    Vec3,
    choice,
    curve_name,
    hint,
    identifier,
    key,
    key_path,
    keys_of,
    non_negative,
    nonzero_vec3,
    number,
    positive,
    scene_file,
    size2,
    unit_interval,
    vec3,
)
from .reader import Reader
from .solve import Solve

TOOL_KINDS = ("plane", "rectangle", "cylinder", "sphere", "mesh")     # tools.TOOL_KINDS


TOOL_KEYS = {"plane": (("normal",), ("center",)),
              "rectangle": (("normal", "size"), ("center", "axis")),
              "cylinder": (("axis", "radius", "length"), ("center",)),
              "sphere": (("radius",), ("center",)),
              "mesh": (("file",), ("center", "scale"))}


TOOL_SHAPE_KEYS = ("normal", "axis", "radius", "length", "size", "file", "scale")


@dataclass(frozen=True)
class Tool:
    """A rigid tool (stages/tools.py, docs/scenes.md [[tool]]): penalty contact with the
    shell's mid-surface at half its thickness, Coulomb friction; fixed, moving with a rigid
    body, or moved by a velocity or displacement (times a curve)."""
    name: str = key(identifier, "force.csv columns `<name>.*`", allowed="an identifier, unique")
    kind: Literal["plane", "rectangle", "cylinder", "sphere", "mesh"] = key(choice(*TOOL_KINDS), "the shape")
    center: Vec3 = key(vec3, default=(0.0, 0.0, 0.0), unit="length",
        doc="plane: a point of it; rectangle, cylinder, sphere: the centre; mesh: where the mesh's origin goes "
            "(at t = 0)")
    normal: Vec3 | None = key(nonzero_vec3, default=None, default_text="required for plane, rectangle",
        doc="the side the shell stays on")
    axis: Vec3 | None = key(
        nonzero_vec3, default=None, allowed="non-zero; not along `normal`", default_text="cylinder: required; rectangle: optional",
        doc="cylinder: its axis; rectangle: the direction of the first side (projected on the plane; default: "
            "any)")
    radius: float | None = key(positive, default=None, unit="length", default_text="required for cylinder, sphere",
        doc="radius")
    length: float | None = key(positive, default=None, unit="length", default_text="required for cylinder",
        doc="length along the axis (flat caps)")
    size: tuple[float, float] | None = key(
        size2, default=None, unit="length", allowed="> 0", default_text="required for rectangle",
        doc="side lengths (a along `axis`)")
    file: Path | None = key(
        scene_file, default=None, allowed="a file meshio reads, relative to the scene", default_text="required for mesh",
        doc="the surface (triangles, quads)")
    scale: float = key(positive, "mesh coordinates times this", default=1.0)
    stiffness: float = key(number(0, 1, lo_open=True), "α of the penalty k = α m / Δt²", default=0.1)
    damping: float = key(
        unit_interval, default=0.1, allowed="[0, 1], and `stiffness` + 2 `damping` √`stiffness` ≤ 2 (at `stiffness` = 1: ≤ 0.5)",
        doc="contact damping, a fraction of critical; the bound keeps a node from bouncing back faster than it "
            "came (docs/contact.md, \"Penalty parameters\")")
    friction: float = key(non_negative, "Coulomb coefficient μ (the force at most m |v_t| / Δt)", default=0.0)
    moves_with: str | None = key(identifier, default=None, allowed="a `[[rigid_body]]` name",
        doc="the tool moves (translates and turns) with that body")
    velocity: Vec3 | None = key(vec3, default=None, unit="length/time",
        doc="the tool moves at this velocity times `curve` (constant without one)")
    displacement: Vec3 | None = key(vec3, default=None, unit="length", allowed="needs `curve`, 0 at t = 0",
        doc="the tool is displaced by this times `curve`")
    curve: str | None = key(curve_name, default=None, allowed="a `[curves.NAME]`, with `velocity` or `displacement`",
        doc="the time function")


def read_tool(r: Reader, path: str, data: Any, solve: Solve | None, curves: dict[str, Curve]) -> Tool | None:
    """A [[tool]]: its kind's keys (a key of another kind is an error), at most one way to
    move, a surface mesh read here (so that an unusable file is a scene error)."""
    mark = len(r.messages)
    v = r.read(path, data, keys_of(Tool), Tool)
    if v is None:
        return None
    kind = v.get("kind")
    if kind in TOOL_KEYS:
        required, optional = TOOL_KEYS[kind]
        own = (*required, *optional)
        for name in data:
            if name in TOOL_SHAPE_KEYS and name not in own:
                r.error(f"{path}.{key_path(name)}", f'not used by kind = "{kind}" (its keys: {", ".join(own)})')
        for name in required:
            if name not in data:
                r.error(f"{path}.{name}", f'missing required key for kind = "{kind}"')
        if kind == "rectangle" and v.get("axis") is not None and v.get("normal") is not None:
            (a1, a2, a3), (n1, n2, n3) = v["axis"], v["normal"]
            cross = math.hypot(a2 * n3 - a3 * n2, a3 * n1 - a1 * n3, a1 * n2 - a2 * n1)
            if cross <= 1e-9 * math.hypot(a1, a2, a3) * math.hypot(n1, n2, n3):
                r.error(f"{path}.axis", "is parallel to normal (it gives the direction of the first side, "
                                           "in the rectangle's plane)")
    check_penalty_damping(r, path, v.get("stiffness", Tool.stiffness), v.get("damping", Tool.damping))
    moving = [key for key in ("moves_with", "velocity", "displacement") if key in data]
    if len(moving) > 1:
        r.error(f"{path}.{moving[1]}", f"a tool moves one way: give one of moves_with, velocity, "
                                          f"displacement, got {', '.join(moving)}")
    if "curve" in data and not ({"velocity", "displacement"} & set(data)):
        r.error(f"{path}.curve", "only with velocity or displacement (the curve scales them)")
    if v.get("moves_with") is not None:
        listed = r.raw.get("rigid_body", [])
        bodies = [b["name"] for b in (listed if isinstance(listed, list) else [])
                  if isinstance(b, dict) and isinstance(b.get("name"), str)]
        if v["moves_with"] not in bodies:
            r.error(f"{path}.moves_with", f"no [[rigid_body]] named {v['moves_with']!r}"
                       + hint(v["moves_with"], bodies, "defined"))
    if solve is not None and solve.kind == "static" and ({"velocity", "displacement"} & set(data)):
        r.error(f"{path}.{'velocity' if 'velocity' in data else 'displacement'}",
                   'a tool moved by a curve needs [solve].kind = "dynamic"')
    if "displacement" in data and len(r.messages) == mark:
        if "curve" not in data:
            r.error(f"{path}.curve", "missing: a displacement needs a curve (a constant displacement "
                                        "would jump at t = 0)")
        elif v.get("curve") in curves:
            from ..curves import evaluate
            start = evaluate(curves[v["curve"]], 0.0)
            if start != 0.0:
                r.error(f"{path}.curve", f"the displacement curve {v['curve']!r} is {start:g} at t = 0, "
                                            "not 0 (the tool would jump at t = 0)")
    if kind == "mesh" and v.get("file") is not None and len(r.messages) == mark:
        from ..tools import ToolMeshError, read_surface
        try:
            read_surface(v["file"], v.get("scale", 1.0))
        except ToolMeshError as exc:
            r.error(f"{path}.file", str(exc))
    return r.build(mark, Tool, v)
