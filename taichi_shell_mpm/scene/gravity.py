"""[gravity]: a body force on every node."""
from __future__ import annotations

from dataclasses import dataclass

from ..keys import Vec3, curve_name, key, nonzero_vec3


@dataclass(frozen=True)
class Gravity:
    """Body force m g on every node (its physical mass)."""
    acceleration: Vec3 = key(nonzero_vec3, "g", unit="length/time²")
    curve: str | None = key(curve_name, "g times the curve; none: the load factor (1 in a dynamic run)", default=None)
