"""[[pressure]]: follower pressure on elements."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..keys import curve_name, hint, key, keys_of, nonempty, nonzero
from .mesh import FileMesh
from .reader import Reader


@dataclass(frozen=True)
class Pressure:
    """Follower pressure on elements: force p A n on each element along its current normal
    (the corner order's), shared by its corners (stages/loads.py)."""
    value: float = key(nonzero, "pressure p (force per unit area)", unit="force/length²", allowed="non-zero")
    elements: str = key(
        nonempty, default="all", allowed="an `[elementsets.NAME]`, a set of the mesh file (see *Parts*), or `\"all\"`",
        doc="loaded elements")
    curve: str | None = key(curve_name, "p times the curve; none: the load factor (1 in a dynamic run)", default=None)


def read_pressure(r: Reader, path: str, data: Any, mesh, elementsets) -> Pressure | None:
    mark = len(r.messages)
    v = r.read(path, data, keys_of(Pressure), Pressure)
    if v is None:
        return None
    names = [s.name for s in elementsets]
    if "elements" in v and v["elements"] != "all" and v["elements"] not in names and not isinstance(mesh, FileMesh):
        r.error(f"{path}.elements", f"no [elementsets.{v['elements']}]"
                + hint(v["elements"], names + ["all"], "defined"))
    return r.build(mark, Pressure, v)
