"""Rotation helpers: the elements' frames, shared by the quad (:mod:`.shell`) and the
triangle (:mod:`.triangle`), and the unit quaternions of the nodes' and the rigid bodies'
orientations (:mod:`.constraints`, :mod:`.bodies`, solvers/tangent.py)."""

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


@ti.func
def quaternion_matrix(q):
    """R of the unit quaternion q = (w, x, y, z)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    return ti.Matrix([[1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
                      [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
                      [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)]])


@ti.func
def quaternion_product(a, b):
    """The quaternion product a b (a rotation b, then a), q = (w, x, y, z)."""
    return ti.Vector([a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
                      a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
                      a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
                      a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]])


@ti.func
def quaternion_exp(theta):
    """The quaternion of the rotation vector theta: (cos(phi/2), sin(phi/2) theta / phi)."""
    phi = theta.norm()
    s = 0.5                                   # sin(phi/2) / phi -> 1/2
    if phi > 1e-8:
        s = ti.sin(0.5 * phi) / phi
    else:
        s = 0.5 - phi * phi / 48.0
    return ti.Vector([ti.cos(0.5 * phi), s * theta[0], s * theta[1], s * theta[2]])


@ti.func
def rotate_vector(theta, v):
    """exp(theta^) v (Rodrigues)."""
    phi = theta.norm()
    out = v
    if phi > 0.0:
        k = theta / phi
        out = v * ti.cos(phi) + k.cross(v) * ti.sin(phi) + k * (k.dot(v) * (1.0 - ti.cos(phi)))
    return out


@ti.func
def cayley_velocity(w, dt):
    """The Cayley vector of the step's rotation exp(dt w^) over dt: (2 / dt) tan(phi / 2) w / |w|,
    phi = dt |w| (w itself as phi -> 0): the angular velocity whose Cayley (Crank-Nicolson)
    update turns by exactly that rotation."""
    out = w
    half = 0.5 * dt * w.norm()
    if half > 1e-8:
        out = w * (ti.tan(half) / half)
    return out
