"""[[tool]]: rigid tools in penalty contact with the shell."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..keys import (
    Vec3,
    choice,
    curve_name,
    extended,
    hint,
    identifier,
    key,
    key_path,
    keys_of,
    non_negative,
    number,
    unit_interval,
    vec3,
)
from ..tool_kinds import KINDS
from .contact import check_penalty_damping
from .curves import Curve
from .reader import Reader
from .solve import Solve

TOOL_KINDS = tuple(KINDS)       # model/tools.TOOL_KINDS
TOOL_KEYS = {name: (kind.REQUIRED, kind.OPTIONAL) for name, kind in KINDS.items()}
"""The shape keys of each kind: (required, optional); a key of another kind is an error."""
SHAPE_KEYS = {name: k for kind in KINDS.values() for name, k in kind.KEYS.items()}
"""Every kind's own keys (declared in its file, tool_kinds/)."""


@dataclass(frozen=True)
class ToolKeys:
    """The keys every [[tool]] has; Tool adds the kinds' shape keys (tool_kinds/)."""
    name: str = key(identifier, "force.csv columns `<name>.*`", allowed="an identifier, unique")
    kind: str = key(choice(*TOOL_KINDS), "the shape (tool_kinds/<kind>.py)")
    center: Vec3 = key(vec3, default=(0.0, 0.0, 0.0), unit="length",
        doc="plane: a point of it; rectangle, cylinder, sphere: the centre; mesh: where the mesh's origin goes "
            "(at t = 0)")
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


Tool = extended(ToolKeys, "Tool", __name__, SHAPE_KEYS,
                "A rigid tool (stages/tools.py, docs/scenes.md [[tool]]): penalty contact with the shell's mid-surface at "
                "half its thickness, Coulomb friction; fixed, moving with a rigid body, or moved by a velocity or "
                "displacement (times a curve).  ToolKeys and the shape keys of the kinds (tool_kinds/).")


def read_tool(r: Reader, path: str, data: Any, solve: Solve | None, curves: dict[str, Curve]) -> Tool | None:
    """A [[tool]]: its kind's keys (a key of another kind is an error), at most one way to
    move, then its kind's rules (a mesh's surface is read there, so that an unusable file is a
    scene error)."""
    mark = len(r.messages)
    v = r.read(path, data, keys_of(Tool), Tool)
    if v is None:
        return None
    kind = v.get("kind")
    if kind in TOOL_KEYS:
        required, optional = TOOL_KEYS[kind]
        own = (*required, *optional)
        for name in data:
            if name in SHAPE_KEYS and name not in own:
                r.error(f"{path}.{key_path(name)}", f'not used by kind = "{kind}" (its keys: {", ".join(own)})')
        for name in required:
            if name not in data:
                r.error(f"{path}.{name}", f'missing required key for kind = "{kind}"')
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
    if kind in KINDS and hasattr(KINDS[kind], "rules"):     # the kind's own rules (clean: nothing else wrong)
        KINDS[kind].rules(r, path, data, v, len(r.messages) == mark)
    return r.build(mark, Tool, v)
