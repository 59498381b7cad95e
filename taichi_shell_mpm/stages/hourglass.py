"""Belytschko-Tsay hourglass control, stiffness form (paper eq 30-36; method.md section 4).

All quantities are in the element's corotational frame.  gamma uses the LS-DYNA/BLT
normalisation (no 1/4) and the coefficients r scale the *elastic* E and G [choice].

Transverse (w) mode, ``[element].w_hourglass = "kirchhoff"`` (issue 4; the default; "bt" is
the paper's rate).
The paper's rate q_W = sum gamma_a w_a is not zero for a smooth bending field: on a
quad whose corners are not a rectangle's, the bilinear content of a quadratic w (a twist
w_xy x y, or w_xx x^2 on a trapezoid) is seen as hourglassing, so the element resists
plain bending or twist with an extra stiffness ~ r that does not fall with refinement.
The "kirchhoff" rate subtracts what the element's own curvature rate kappa implies: with the
BT curvature kappa = -(w_xx, w_yy, 2 w_xy), the Kirchhoff field through the corners is
w_a = -1/2 (kappa_xx x_a^2 + kappa_yy y_a^2 + kappa_xy x_a y_a) (linear parts are
orthogonal to gamma), so

    q_W = sum gamma_a w_a + 1/2 G . kappa,   G = sum gamma_a (x_a^2, y_a^2, x_a y_a),

which is zero for any quadratic Kirchhoff field and unchanged for the spurious mode
(w_a = h_a with zero rotations: kappa = 0).  Its conjugate adds nodal moments
1/2 Q_W dkappa/dtheta_a.  Measured on the hemisphere (Sze), 1/20 of the first load
(linear range): 32x32 quarter, d_out / d_in 0.0922 / 0.0933 with "bt" against Kratos's
0.0931 / 0.0942; the "bt" deficit stayed at 1 % from 16x16 to 32x32 and vanished as
r_w -> 0 (r_m or r_theta -> 0 changed nothing); with "kirchhoff" 0.0932 / 0.0943.
Nonlinear, 16x16 fem, mean / max error vs Sze: d_out 2.10 / 2.29 -> 1.83 / 2.06 %, d_in
2.60 / 3.18 -> 2.19 / 2.98 % (both with the drilling projection; with the drilling spring
of stages/drilling.py 0.43 / 0.69 -> 0.16 / 0.60 % and 0.73 / 0.84 -> 0.23 / 0.64 %).
"""

import taichi as ti

HOURGLASS_SIGN = (1.0, -1.0, 1.0, -1.0)


@ti.data_oriented
class Hourglass:
    """The element's coefficients are per element (state.sections: r E t / 8, r E t^3 / 192,
    r kappa G t^3 / 12 from its part's section and material, model/parts.py)."""

    def __init__(self, state, kirchhoff_w: bool):
        self.s = state
        self.kirchhoff_w = kirchhoff_w

    @ti.func
    def shape_vector(self, xh, yh, b1, b2):
        """gamma_a = h_a - (h.x)B1_a - (h.y)B2_a: orthogonal to linear fields."""
        h = ti.Vector(HOURGLASS_SIGN, dt=ti.f64)
        return h - h.dot(xh) * b1 - h.dot(yh) * b2

    @ti.func
    def quadratic_moments(self, gam, xh, yh):
        """G = sum gamma_a (x_a^2, y_a^2, x_a y_a), ordered like the curvature (xx, yy, xy)."""
        return ti.Vector([gam.dot(xh * xh), gam.dot(yh * yh), gam.dot(xh * yh)])

    @ti.func
    def warp_height(self, zh):
        """z_w = 1/4 sum h_a z_a (= z_1 = z_3 = -z_2 = -z_4 in the BT frame)."""
        return 0.25 * ti.Vector(HOURGLASS_SIGN, dt=ti.f64).dot(zh)

    @ti.func
    def rates(self, gam, zw, vx, vy, vz, tx, ty, moments, curvature_rate):
        """Hourglass strain rates q = (qMx, qMy, qW, qBx, qBy); the z_w terms make rigid
        rotations of a warped element produce none (method.md 4); qW less the Kirchhoff
        field's part when `kirchhoff_w` (module docstring)."""
        q_w = gam.dot(vz)
        if ti.static(self.kirchhoff_w):
            q_w += 0.5 * moments.dot(curvature_rate)
        return ti.Vector([gam.dot(vx) - zw * ty.sum(), gam.dot(vy) + zw * tx.sum(),
                          q_w, gam.dot(tx), gam.dot(ty)])

    @ti.func
    def stiffness(self, e, area, beta):
        """Per-component rate stiffness (C3, C3, C2, C1, C1) of Q = Q + C q dt of element e."""
        cm = self.s.sections.hourglass_membrane[e] * area * beta
        cb = self.s.sections.hourglass_bending[e] * area * beta
        return ti.Vector([cm, cm, self.s.sections.hourglass_transverse[e] * beta, cb, cb])

    @ti.func
    def nodal_loads(self, gam, zw, q, moments, b1, b2):
        """Resisting local hourglass forces (4x3) and moments (4x3, drilling 0) from Q: the
        transposes of `rates` (curvature rate (B1.ty, -B2.tx, B2.ty - B1.tx), shell.py)."""
        f = ti.Matrix.zero(ti.f64, 4, 3)
        m = ti.Matrix.zero(ti.f64, 4, 3)
        for a in ti.static(range(4)):
            f[a, 0] = gam[a] * q[0]
            f[a, 1] = gam[a] * q[1]
            f[a, 2] = gam[a] * q[2]
            m[a, 0] = gam[a] * q[3] + zw * q[1]
            m[a, 1] = gam[a] * q[4] - zw * q[0]
            if ti.static(self.kirchhoff_w):
                m[a, 0] -= 0.5 * q[2] * (moments[1] * b2[a] + moments[2] * b1[a])
                m[a, 1] += 0.5 * q[2] * (moments[0] * b1[a] + moments[2] * b2[a])
        return f, m
