"""[[pressure]]: follower pressure on elements."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..keys import curve_name, key, keys_of, nonempty, nonzero
from .parts import check_element_set
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
    if "elements" in v:
        check_element_set(r, f"{path}.elements", v["elements"], [s.name for s in elementsets], mesh)
    return r.build(mark, Pressure, v)
