"""[[point_mass]]: mass added to nodes."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..keys import identifier, key, keys_of, node_set, non_negative
from .reader import Reader


@dataclass(frozen=True)
class PointMass:
    """Mass (and rotary inertia) added to each node of a set, constraining nothing."""
    name: str = key(identifier, "parts.csv row `point_mass:NAME`, summary.json `parts`")
    nodes: str = key(node_set, "the nodes")
    mass: float | None = key(non_negative, default=None, unit="mass", allowed=">= 0; this or `total_mass`",
        doc="mass added at each node")
    total_mass: float | None = key(non_negative, default=None, unit="mass", allowed=">= 0; this or `mass`",
        doc="mass shared equally by the nodes")
    inertia: float = key(non_negative, default=0.0, unit="mass·length²",
        doc="rotary inertia added at each node (about every axis)")


def read_point_mass(r: Reader, path: str, data: Any) -> PointMass | None:
    mark = len(r.messages)
    v = r.read(path, data, keys_of(PointMass), PointMass)
    if v is None:
        return None
    if ("mass" in data) == ("total_mass" in data):
        r.error(f"{path}.mass", "give one of mass (each node's) or total_mass (shared equally by the nodes)")
    return r.build(mark, PointMass, v)
