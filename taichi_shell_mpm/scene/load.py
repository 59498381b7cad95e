"""[[load]]: nodal forces and moments, totals or per length."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

from ..keys import Vec3, boolean, choice, curve_name, key, keys_of, node_set, show, vec3
from .reader import Reader


@dataclass(frozen=True)
class Load:
    nodes: str = key(node_set, "loaded nodes")
    force: Vec3 = key(vec3, "total force, spread over the set", default=(0.0, 0.0, 0.0), unit="force")
    moment: Vec3 = key(vec3, "total moment, spread over the set", default=(0.0, 0.0, 0.0), unit="force·length")
    distribute: Literal["area", "equal", "length"] = key(choice("area", "equal", "length"), default="area",
        doc="the nodes' shares: `area`: in proportion to each node's tributary shell area (a consistent edge load"
            " only where the elements behind the edge are equally deep); `equal`: the same share per node; "
            "`length`: half the length of each element edge joining the node to another node of the set (the "
            "consistent nodal loads of a uniform line load along those edges)")
    force_per_length: Vec3 = key(
        vec3, default=(0.0, 0.0, 0.0), unit="force/length", allowed="not with `force`/`moment`",
        doc="a line load: force per unit length along the element edges joining two nodes of the set; each node "
            "gets it times half the length of its edges (the total is the integrated load, whatever the mesh)")
    moment_per_length: Vec3 = key(vec3, default=(0.0, 0.0, 0.0), unit="force", allowed="not with `force`/`moment`",
        doc="moment per unit length, likewise")
    curve: str | None = key(curve_name, default=None,
        doc="the load is its value times the curve, of the time in a dynamic run and of the load factor in a "
            "static one; none: the load factor (1 in a dynamic run)")
    follower: bool = key(boolean, default=False,
        doc="the force and moment turn with each node: with its fibre (the reference normal turned by the node's "
            "rotation) and, about it, with the direction to a neighbouring node of its first element (drilling "
            "rotations, which the element does not resist, do not turn it; `stages/loads.py`)")


def read_load(r: Reader, path: str, data: Any) -> Load | None:
    mark = len(r.messages)
    v = r.read(path, data, keys_of(Load), Load)
    if v is None:
        return None
    total = [k for k in ("force", "moment") if k in data]
    line = [k for k in ("force_per_length", "moment_per_length") if k in data]
    if total and line:
        r.error(path, f"give either force/moment (totals) or force_per_length/moment_per_length "
                      f"(a line load), got {', '.join(total + line)}")
    elif line:
        if data.get("distribute", "length") != "length":
            r.error(f"{path}.distribute", f'a line load is distributed by length, got {show(data["distribute"])}')
        v["distribute"] = "length"
        if v.get("force_per_length") == (0, 0, 0) and v.get("moment_per_length") == (0, 0, 0):
            r.error(path, "force_per_length and moment_per_length are both zero")
    elif v.get("force") == (0, 0, 0) and v.get("moment") == (0, 0, 0):
        r.error(path, "force and moment are both zero (give a non-zero force and/or moment)")
    return r.build(mark, Load, v)
