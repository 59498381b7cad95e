"""Belytschko-Wong-Chiang warping correction of the BT element (option
``[element].warping = "bwc"``; method.md 3.8).

Why.  The BT element takes a warped quad (corners at heights z_a = z_w h_a off the plane
of its diagonals, h = (1, -1, 1, -1)) for its flat projection: in-plane motion of the
corners never bends it.  On a warped surface it does: stretching or shearing the hyperbolic
paraboloid z = z_w h(x, y) through its corners turns its normals, a curvature rate the
flat element misses.  BWC proposed it for the twisted-beam test (MacNeal & Harder 1985),
where every element is warped; a crushed tube's elements warp severely.

What (Belytschko, Wong & Chiang 1992, CMAME 96:93-107, eq 30; the same B^c as in AERO-S's
BT shell, ``getbcmat1pt``; written here from the formula).  With z_gamma = 1/4 sum gamma_a z_a
(= z_w: gamma_a = h_a - (h.x)B1_a - (h.y)B2_a and B.h = 0),

    B^c_1 = (2 z_gamma / A^2) [x_13, x_42, x_31, x_24],  B^c_2 = (2 z_gamma / A^2) [y_13, y_42, y_31, y_24],

the curvature rate gains

    kappa' += (B^c_1 . v_x^d,  B^c_2 . v_y^d,  B^c_1 . v_y^d + B^c_2 . v_x^d),

applied to the in-plane corner velocities with the element's spin removed (the drill
projection of method.md 3.8 [choice]; AERO-S applies B^c to the raw velocities, with which a
rigid spin of a warped element about its normal bends it, tests/test_warping.py):

    Omega = 1/2 sum (B1_a v_y,a - B2_a v_x,a),  v_x^d = v_x + Omega y,  v_y^d = v_y - Omega x.

Check of the formula (done by hand for the docstring; tests/test_warping.py measures it):
on a rectangle of half-sides a, b the corners' surface is z = c x y with c = z_w / (a b);
an in-plane velocity gradient L turns its slope s = grad z at the rate -L^T s, i.e. a fibre
rotation whose gradient is exactly kappa' = c (L_yx, L_xy, L_xx + L_yy); the B^c sums above
give c (L_xy, L_yx, L_xx + L_yy), the same once the spin is removed (L symmetric).  A
rigid rotation about an in-plane axis moves the corners in-plane by z_a theta ~ h_a, which
B^c (B^c.h = 0) and the spin (B.h = 0) ignore; translations give nothing (sum B^c = 0).

Loads (the transpose, so that sum_a f_a . v_a = A M . kappa'_c exactly, M = -M' = int z sigma):
g_x,a = A (B^c_1,a M_xx + B^c_2,a M_xy), g_y,a = A (B^c_2,a M_yy + B^c_1,a M_xy), and the
drill projection's transpose with T_z = sum_a (x_a g_y,a - y_a g_x,a):
f_x,a = g_x,a + 1/2 B2_a T_z, f_y,a = g_y,a - 1/2 B1_a T_z.

The curvature rate of the hourglass "kirchhoff" w-rate (stages/hourglass.py) stays the BT
one (its conjugate moments are those of the BT curvature); like the BT rates, the rates
here use the mid-step geometry and the loads the end-of-step one (stages/shell.py).

Measured (docs/element.md, docs/crush.md): on this element (drilling spring, z_w terms in
the hourglass rates) it changes little.  Twisted beam 12x2, t = 0.32: tip error +3.34 /
+6.23 % (in-plane / out-of-plane load) without, +3.35 / +6.19 % with; t = 0.0032 the same
to six digits (its loads scale with t^3).  5 mm tube: mean crush force 8.913 -> 8.868 kN,
the same 9 lobes; the element stage costs 1-4 % more.  Off by default.
"""

import taichi as ti


@ti.func
def operators(xh, yh, zh, area):
    """B^c_1, B^c_2 (BWC eq 30) of the local corner coordinates; z_gamma = z_w."""
    zw = 0.25 * (zh[0] - zh[1] + zh[2] - zh[3])
    scale = 2.0 * zw / (area * area)
    bc1 = scale * ti.Vector([xh[0] - xh[2], xh[3] - xh[1], xh[2] - xh[0], xh[1] - xh[3]])
    bc2 = scale * ti.Vector([yh[0] - yh[2], yh[3] - yh[1], yh[2] - yh[0], yh[1] - yh[3]])
    return bc1, bc2


@ti.func
def curvature_rate(xh, yh, zh, area, b1, b2, vx, vy):
    """kappa'_c = (B^c_1 . v_x^d, B^c_2 . v_y^d, B^c_1 . v_y^d + B^c_2 . v_x^d) with the spin
    removed from the in-plane velocities (drill projection)."""
    bc1, bc2 = operators(xh, yh, zh, area)
    spin = 0.5 * (b1.dot(vy) - b2.dot(vx))
    vxd = vx + spin * yh
    vyd = vy - spin * xh
    return ti.Vector([bc1.dot(vxd), bc2.dot(vyd), bc1.dot(vyd) + bc2.dot(vxd)])


@ti.func
def nodal_loads(xh, yh, zh, area, b1, b2, m_res):
    """Resisting local in-plane forces (4x3, z column 0) conjugate to `curvature_rate` for the
    resultant moments M' (paper sign; the bending power is -A M' . kappa')."""
    bc1, bc2 = operators(xh, yh, zh, area)
    mxx, myy, mxy = -m_res[0], -m_res[1], -m_res[2]
    gx = area * (mxx * bc1 + mxy * bc2)
    gy = area * (myy * bc2 + mxy * bc1)
    torque = xh.dot(gy) - yh.dot(gx)
    f = ti.Matrix.zero(ti.f64, 4, 3)
    for a in ti.static(range(4)):
        f[a, 0] = gx[a] + 0.5 * b2[a] * torque
        f[a, 1] = gy[a] - 0.5 * b1[a] * torque
    return f
