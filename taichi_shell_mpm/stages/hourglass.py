"""Belytschko-Tsay hourglass control, stiffness form (paper eq 30-36; method.md section 4).

All quantities are in the element's corotational frame.  gamma uses the LS-DYNA/BLT
normalisation (no 1/4) and the coefficients r scale the *elastic* E and G [choice].
"""

import taichi as ti

HOURGLASS_SIGN = (1.0, -1.0, 1.0, -1.0)


@ti.data_oriented
class Hourglass:
    def __init__(self, E: float, shear_modulus: float, thickness: float, shear_factor: float, r: float):
        t = thickness
        self.bending = r * E * t ** 3 / 192.0          # x A beta -> C1 (Q^B)
        self.transverse = r * shear_factor * shear_modulus * t ** 3 / 12.0   # x beta -> C2 (Q^W)
        self.membrane = r * E * t / 8.0                # x A beta -> C3 (Q^M)

    @ti.func
    def shape_vector(self, xh, yh, b1, b2):
        """gamma_a = h_a - (h.x)B1_a - (h.y)B2_a: orthogonal to linear fields."""
        h = ti.Vector(HOURGLASS_SIGN, dt=ti.f64)
        return h - h.dot(xh) * b1 - h.dot(yh) * b2

    @ti.func
    def warp_height(self, zh):
        """z_w = 1/4 sum h_a z_a (= z_1 = z_3 = -z_2 = -z_4 in the BT frame)."""
        return 0.25 * ti.Vector(HOURGLASS_SIGN, dt=ti.f64).dot(zh)

    @ti.func
    def rates(self, gam, zw, vx, vy, vz, tx, ty):
        """Hourglass strain rates q = (qMx, qMy, qW, qBx, qBy); the z_w terms make rigid
        rotations of a warped element produce none (method.md 4)."""
        return ti.Vector([gam.dot(vx) - zw * ty.sum(), gam.dot(vy) + zw * tx.sum(),
                          gam.dot(vz), gam.dot(tx), gam.dot(ty)])

    @ti.func
    def stiffness(self, area, beta):
        """Per-component rate stiffness (C3, C3, C2, C1, C1) of Q = Q + C q dt."""
        cm = self.membrane * area * beta
        cb = self.bending * area * beta
        return ti.Vector([cm, cm, self.transverse * beta, cb, cb])

    @ti.func
    def nodal_loads(self, gam, zw, q):
        """Resisting local hourglass forces (4x3) and moments (4x3, drilling 0) from Q."""
        f = ti.Matrix.zero(ti.f64, 4, 3)
        m = ti.Matrix.zero(ti.f64, 4, 3)
        for a in ti.static(range(4)):
            f[a, 0] = gam[a] * q[0]
            f[a, 1] = gam[a] * q[1]
            f[a, 2] = gam[a] * q[2]
            m[a, 0] = gam[a] * q[3] + zw * q[1]
            m[a, 1] = gam[a] * q[4] - zw * q[0]
        return f, m
