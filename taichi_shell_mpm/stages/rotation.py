"""Rotation helpers shared by the quad (:mod:`.shell`) and the triangle (:mod:`.triangle`)."""

import taichi as ti


@ti.func
def rotation_vector(q):
    """The rotation vector (axis x angle, angle < pi) of the rotation matrix q."""
    w = 0.5 * ti.Vector([q[2, 1] - q[1, 2], q[0, 2] - q[2, 0], q[1, 0] - q[0, 1]])
    s = w.norm()
    c = 0.5 * (q[0, 0] + q[1, 1] + q[2, 2] - 1.0)
    scale = 1.0
    if s > 1e-12:
        scale = ti.atan2(s, c) / s
    return scale * w
