"""[nodesets.NAME]: geometric selections of shell nodes."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

from ..keys import (
    BOX,
    BOX_KEYS,
    VEC3_SCHEMA,
    Check,
    Key,
    Vec3,
    key_path,
    keys,
    node_ids,
    nonzero_vec3,
    positive,
    show,
    true,
    vec3,
)
from .reader import Reader


@dataclass(frozen=True)
class NodeSet:
    """A geometric selection of shell nodes. Exactly one selector kind."""
    name: str
    kind: Literal["all", "box", "plane", "nearest", "ids"]
    box_min: Vec3 | None = None
    box_max: Vec3 | None = None
    point: Vec3 | None = None
    """plane: a point on it; nearest: the target point."""
    normal: Vec3 | None = None
    tol: float = 1e-6
    ids: tuple[int, ...] = ()


PLANE_KEYS = keys(Key("point", vec3, "a point of the plane", unit="length"),
                  Key("normal", nonzero_vec3, "its normal"),
                  Key("tol", positive, "nodes within this distance are on it", default=1e-6, unit="length"))
PLANE = Check(None, "table", "`{point = [..], normal = [..], tol = 1e-6}`",
              {"type": "object", "properties": {"point": VEC3_SCHEMA, "normal": VEC3_SCHEMA,
                                                "tol": {"type": "number", "exclusiveMinimum": 0}},
               "required": ["point", "normal"], "additionalProperties": False})
NODE_SET_KEYS = keys(
    Key("all", true, "every node", default_text="one selector", example=True),
    Key("box", BOX, default_text="one selector", doc="nodes inside the axis-aligned box (a flat box selects a plane's nodes)",
        example={"min": [9.5, -1.0, -1.0], "max": [10.5, 2.0, 1.0]}),
    Key("plane", PLANE, default_text="one selector", doc="nodes within `tol` of the plane through `point` with the non-zero `normal`",
        example={"point": [0.0, 0.0, 0.0], "normal": [1.0, 0.0, 0.0]}),
    Key("nearest", vec3, default_text="one selector", doc="the one node nearest to the point (an error when the point lies outside the mesh's "
                         "bounding box grown by 5% of its largest extent)", unit="length", example=[10.0, 0.0, 0.0]),
    Key("ids", node_ids, default_text="one selector", doc="these node indices", example=[0, 5, 7]),
    Key("tol", positive, "beside `box`: the tolerance of the box test", default=1e-6, unit="length"))
"""[nodesets.NAME]: exactly one selector (all, box, plane, nearest, ids), and tol beside box."""
SELECTORS = tuple(NODE_SET_KEYS)[:5]


def read_nodesets(r: Reader, data: Any) -> list[NodeSet | None]:
    if not isinstance(data, dict):
        r.error("[nodesets]", f"expected a table of node sets, got {show(data)}")
        return []
    return [read_nodeset(r, name, value) for name, value in data.items()]


def read_nodeset(r: Reader, name: str, data: Any) -> NodeSet | None:
    path = f"[nodesets.{key_path(name)}]"
    mark = len(r.messages)
    r.set_name(path, name, "a node set", "every node")
    v = r.read(path, data, {k: d for k, d in NODE_SET_KEYS.items() if k not in ("box", "plane")},
               extra=("box", "plane"))
    if v is None:
        return None
    given = [key for key in SELECTORS if key in data]
    if len(given) != 1:
        r.error(path, f"expected exactly one selector ({', '.join(SELECTORS)}), "
                      f"got {', '.join(given) or 'none'}")
        return None
    kind = given[0]
    if "tol" in data and kind != "box":
        r.error(f"{path}.tol", "allowed only beside box (a plane takes its tol inside plane = {...})")
    values = {"name": name, "kind": kind, **({"tol": v["tol"]} if "tol" in v else {})}
    if kind == "box":
        box = r.read(f"{path}.box", data["box"], BOX_KEYS, required=("min", "max"))
        if box:
            r.check_order(f"{path}.box", box.get("min"), box.get("max"), ("min", "max"), strict=False)
            values.update(box_min=box.get("min"), box_max=box.get("max"))
    elif kind == "plane":
        plane = r.read(f"{path}.plane", data["plane"], PLANE_KEYS, required=("point", "normal"))
        values.update(plane or {})
    elif kind == "nearest":
        values["point"] = v.get("nearest")
    elif kind == "ids":
        values["ids"] = v.get("ids")
    return r.build(mark, NodeSet, values)
