"""[[motion]]: prescribed displacement, velocity or acceleration of DOFs of a node set or a rigid body."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

from ..keys import (
    choice,
    curve_name,
    dof_list,
    hint,
    identifier,
    key,
    keys_of,
    node_set,
    non_negative,
    numbers,
    positive,
    show,
)
from .curves import Curve
from .reader import Reader
from .solve import Solve

MOTION_KINDS = ("displacement", "velocity", "acceleration")


MAX_MOTIONS = 64         # [[motion]] entries of a scene


@dataclass(frozen=True)
class Motion:
    """Prescribed motion of DOFs of a node set (stages/motion.py) or of a rigid body
    (stages/bodies.py): u, v or a = value x f."""
    name: str = key(identifier, allowed="an identifier, unique among motions",
        doc="force.csv columns `<name>.reaction_<dof>` and `<name>.work`, the `motions` block of summary.json")
    dofs: tuple[str, ...] = key(dof_list(allow_all=True), "prescribed DOFs", allowed="distinct DOFs")
    kind: Literal["displacement", "velocity", "acceleration"] = key(
        choice(*MOTION_KINDS), allowed="`displacement`, `velocity`, `acceleration`; a static solve: `displacement` only",
        doc="what `value` × f prescribes")
    value: tuple[float, ...] = key(numbers, "amplitude", allowed="one number (every DOF) or one per DOF")
    curve: str | None = key(curve_name, default=None,
        doc="f; none: the load factor λ in a static run (the displacement grows with the load steps), 1 in a "
            "dynamic run (a constant velocity or acceleration; a displacement in a dynamic run needs a curve that"
            " is 0 at t = 0)")
    nodes: str | None = key(node_set, "moved nodes", default=None, default_text="one of `nodes`, `body`")
    body: str | None = key(
        identifier, default=None, allowed="a `[[rigid_body]]` without `direction`; dynamic runs", default_text="one of `nodes`, `body`",
        doc="the body whose DOFs (global axes, rotations about its centre) are moved: its prescribed rotations "
            "need its other rotations fixed or prescribed too")
    start: float = key(non_negative, default=0.0, unit="time", allowed=">= 0, < `end`; dynamic runs; of a body: its translations only",
        doc="the DOFs are prescribed from this time on; before it they move freely (LS-DYNA's BIRTH)")
    end: float | None = key(positive, default=None, unit="time", default_text="never",
        allowed="> `start`; dynamic runs; of a body: its translations only",
        doc="the DOFs are released at this time and move freely after it, with the velocity they had (LS-DYNA's "
            "DEATH)")


def read_motion(r: Reader, path: str, data: Any, solve: Solve | None, curves: dict[str, Curve]) -> Motion | None:
    mark = len(r.messages)
    v = r.read(path, data, keys_of(Motion), Motion)
    if v is None:
        return None
    if ("nodes" in data) == ("body" in data):
        r.error(f"{path}.nodes", "give one of nodes (a node set) or body (a [[rigid_body]])")
    if "body" in data:
        listed = r.raw.get("rigid_body", [])
        bodies = {b["name"]: b for b in (listed if isinstance(listed, list) else [])
                  if isinstance(b, dict) and isinstance(b.get("name"), str)}
        if v.get("body") is not None and v["body"] not in bodies:
            r.error(f"{path}.body", f"no [[rigid_body]] named {v['body']!r}"
                    + hint(v["body"], list(bodies), "defined"))
        elif v.get("body") is not None and "direction" in bodies[v["body"]]:
            r.error(f"{path}.body", f"the [[rigid_body]] {v['body']!r} translates along its direction only: "
                                    "a body with a prescribed motion has six DOFs (leave out direction)")
        if solve is not None and solve.kind == "static":
            r.error(f"{path}.body", "a body's motion is prescribed in dynamic runs only")
    if ("start" in data or "end" in data) and solve is not None and solve.kind == "static":
        r.error(f"{path}.start" if "start" in data else f"{path}.end", "a time window (start, end) is for dynamic runs")
    if v.get("end") is not None and v.get("end") <= v.get("start", 0.0):
        r.error(f"{path}.end", f"expected a time > start = {v.get('start', 0.0):g}, got {v['end']:g}")
    chosen, value, kind, curve = v.get("dofs"), v.get("value"), v.get("kind"), v.get("curve")
    if chosen is not None and value is not None:
        if len(value) == 1:
            v["value"] = value * len(chosen)
        elif len(value) != len(chosen):
            r.error(f"{path}.value", f"expected one number or one per DOF ({len(chosen)}), got {len(value)}")
    if solve is not None and kind is not None:
        if solve.kind == "static" and kind != "displacement":
            r.error(f"{path}.kind", f'a static solve prescribes displacements only, got {show(kind)}')
        elif solve.kind == "dynamic" and kind == "displacement":
            if "curve" not in data:
                r.error(f"{path}.curve", "missing: a displacement in a dynamic run needs a curve "
                                         "(a constant displacement would jump at t = 0)")
            elif curve in curves and not r.messages:     # an invalid curve (start >= end, ...) is reported already
                from ..curves import evaluate
                start = evaluate(curves[curve], 0.0)
                if start != 0.0:
                    r.error(f"{path}.curve", f"the displacement curve {curve!r} is {start:g} at t = 0, not 0 "
                                             "(the nodes would jump at t = 0)")
    return r.build(mark, Motion, v)
