"""[[initial]]: the initial velocity field."""
from __future__ import annotations

from dataclasses import dataclass

from ..keys import Vec3, key, node_set, vec3


@dataclass(frozen=True)
class InitialVelocity:
    nodes: str = key(node_set, "nodes concerned", default="all")
    velocity: Vec3 = key(vec3, "translational velocity", default=(0.0, 0.0, 0.0), unit="length/time")
    angular_velocity: Vec3 = key(vec3, default=(0.0, 0.0, 0.0), unit="rad/time",
        doc="rigid-body angular velocity (rad per time unit)")
    center: Vec3 = key(vec3, "centre of that rotation", default=(0.0, 0.0, 0.0), unit="length")
