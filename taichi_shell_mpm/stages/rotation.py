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


@ti.func
def mid_step(x, v, w, dt, large: ti.template(), geometry: ti.template(), increment: ti.template()):
    """The element's frame for its strain rates, its corners' local coordinates there (and
    the third local vector `geometry` returns: z^ of the quad, the normal of the triangle),
    and the corners' local velocities and angular velocities (n x 3).  An explicit step
    (`large` False): `geometry` of x - dt/2 v, v^_a = R v~_a, theta^_a = R omega_a.  One large
    increment (Newton's trial, Features.finite_increment): `increment` (the mean of the start
    and end coordinates, each in its own frame), the corners' motion and rotation less the
    frame's.  One function for the quad and the triangle (`x.n` corners)."""
    if ti.static(large):
        rot_m, xm, ym, third, change, spin = increment(x, dt * v)
        wl = w @ rot_m.transpose()
        for a, d in ti.static(ti.ndrange(x.n, 3)):
            wl[a, d] -= spin[d] / dt
        return rot_m, xm, ym, third, change / dt, wl
    else:
        rot_m, xm, ym, third = geometry(x - (0.5 * dt) * v)
        return rot_m, xm, ym, third, v @ rot_m.transpose(), w @ rot_m.transpose()
