"""The optimal ANDES membrane triangle with corner drilling rotations ("OPT", Felippa &
Militello 1992; Felippa 2003), the membrane of the triangle ``[element].triangle = "opt"``
(stages/triangle.py; docs/element.md, "The OPT triangle").

Why [measured, issue 33].  On a curved shell in bending a flat-facet triangle must bend *in
its plane* wherever the surface bends inextensionally; the constant-strain membrane cannot,
and locks.  On Sze's pinched hemisphere in triangles (16x16, fem Newton) the C0 triangle is
8.69 / 13.65 % stiff; with its membrane stiffness alone scaled by 0.09 it was 0.88 / 1.90 %,
with its transverse shear scaled by 0.01 4.26 / 7.82 %, and the drilling spring's alpha from
0.01 to 1 moved it by 0.1 %: the membrane locks.  OPT represents in-plane bending with the
drilling rotations theta_z (the three-node element's quadratic in-plane field): the stiffness
of a rectangle of two triangles under pure in-plane bending is exact at any aspect ratio
(nu = 0; tests/test_triangle_opt.py).

The stiffness is K = K_b + K_h (Felippa 2003, eq 3.x; the code here is our own).

* Basic part: constant stress N over the element, lumped to the corners with Allman's
  drilling lumping (alpha_b = 3/2).  Its strain (the conjugate of N) is
      eps_b = (1 / 2A) sum_a (Lu_a u_a + Lv_a v_a + Lt_a theta_a),
  Lu_a = (y_jk, 0, x_kj), Lv_a = (0, x_kj, y_jk) (the constant-strain triangle, 2A B_a), and
      Lt_a = alpha_b (y_jk (y_ik - y_ji) / 6, x_kj (x_ki - x_ij) / 6, (x_ki y_ik - x_ij y_ji) / 3),
  a, j = a + 1, k = a + 2 cyclic, x_ij = x_i - x_j.  A linear field with theta = its spin
  gives the exact constant strain (the patch test); a rigid rotation, zero.  It goes to the
  through-thickness points as the membrane rate (plasticity included); the resisting loads
  are f = 1/2 (Lu, Lv, Lt) N.
* Higher-order part: the hierarchical rotations theta~_i = theta_i - Omega (Omega the
  constant-strain spin, the rate of the drilling spring, stages/drilling.py) give a linear
  deviatoric strain whose energy, 3-midpoint rule, is
      K_theta = 3/4 beta_0 E_s t A sum_(m = 4..6) Q_m^T T_e^T C T_e Q_m,
  C = [[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu)/2]], E_s = E / (1 - nu^2), T_e the natural
  (edge) to Cartesian strain map, Q_1..3 the corners' natural strains per theta~ with the
  optimal beta_1..9 = (1, 2, 1, 0, 1, -1, -1, -1, -2), Q_4..6 the mid-edge means, and
  beta_0 = max(1/2 (1 - 4 nu^2), 0.01).  In the rate form this is a drilling spring with a
  3x3 stiffness: the resultant q += dt phi K_theta theta~', conjugate loads m_z = q, in-plane
  f = -+ 1/2 B sum q (DrillingSpring.nodal_loads), stored in elements.drilling_moment (so
  restart and the Newton trial carry it as they carry the spring's), with the section's
  membrane modulus (laminate.Layup's effective isotropic E; nu the material's, 0.3 for a
  laminate or an orthotropic material); its energy is booked with the internal energy.

Plasticity [choice, measured].  The higher-order part carries the in-plane bending that the
constant stress cannot, outside the through-thickness points' return.  Kept elastic, it made
the 6 ms square tube with its +y face in OPT triangles fold at a mean force 2.11 % above the
all-quad tube's (C0 triangles: -0.05 %).  Its increment is therefore scaled by the section's
elastic fraction in the step, phi = r + (1 - r) (weight of the points whose plastic strain did
not grow) / (all weight), r the element's hourglass coefficient (``[element].hourglass``,
the elastic share the quads keep of their own unresisted modes; with phi = 0 the rotations
theta~ of a yielded triangle had no stiffness: -1.48 %, and the tube took 33 070 steps
against 24 360): -1.20 % in 26 610 steps.  Elastic sections: phi = 1 (compiled only with a
plastic material).

Transverse shear [choice, measured].  The C0 triangle's edge shear (MITC3 at the centroid)
still locks on a thin curved shell: its shear stiffness scaled by 0.01 took the hemisphere
from 8.69 / 13.65 to 4.26 / 7.82 %.  The option scales it by t^2 / (t^2 + alpha h^2), h the
longest edge, alpha = 0.1 (Lyly, Stenberg & Vihinen 1993, the stabilisation of MITC3 and
DSG3 triangles; the literature's value, not fitted here): the shear rate and its loads by the
square root (:func:`shear_scale`), so the power identity holds.  It vanishes as h -> 0 and
leaves a Kirchhoff field's zero shear zero.  Hemisphere 16x16: OPT alone 6.89 / 9.16 %, with
the stabilisation 4.36 / 6.87 %; 32x32 0.92 / 1.62 % and 0.39 / 1.08 %.

Time step [measured].  The drilling rotations carry the higher-order membrane stiffness (E t
scale) against the nodes' scaled rotary inertia m max(t^2/12, A/4) g (assembly): on 4000
random triangles (numpy: the membrane's 9x9 K_b + K_h with the lumped masses; angles down to
~0.1 deg, t from 1e-3 to 2 sqrt(A), nu in [0, 0.49]) omega_max^2 <= 3 c^2 beta (1 + g / 2)
held (largest ratio 0.9998; against 3 c^2 beta alone: 1.08 for a right isosceles triangle,
394 for a 1 deg sliver), so the triangle's length is L_e / sqrt(1 + g / 2)
(TriangleElement.limit, assembly.element_steps): 1.27x the steps of the C0 triangle on an
equilateral mesh, 1.32x on right isosceles ones.  The plate part is the C0 triangle's with a
softer shear.  With the physical rotary inertia (t^2/12) the drilling modes would set a step
~L / t times shorter: refused (a scene error).

The drilling spring is off on these triangles (OPT gives the drilling rotation its own
stiffness), and the option needs ``drilling = "penalty"`` (the nodes keep theta_z).

References: C. A. Felippa, "A study of optimal membrane triangles with drilling freedoms",
CMAME 192 (2003) 2125-2168; C. A. Felippa, C. Militello, "Membrane triangles with corner
drilling freedoms II: the ANDES element", Finite Elem. Anal. Des. 12 (1992) 189-201.
"""

import taichi as ti

SHEAR_STABILISATION = 0.1          # alpha of Lyly, Stenberg & Vihinen (1993)
ALPHA_B = 1.5                                   # Allman's drilling lumping of the basic part
BETAS = (1.0, 2.0, 1.0, 0.0, 1.0, -1.0, -1.0, -1.0, -2.0)   # OPT's beta_1..9 (Felippa 2003)


@ti.func
def drilling_lumping(xh, yh):
    """Lt (3x3, row a): the drilling rows of the basic lumping, eps_b += (1/2A) sum Lt_a theta_a."""
    lt = ti.Matrix.zero(ti.f64, 3, 3)
    for i in ti.static(range(3)):
        j, k = (i + 1) % 3, (i + 2) % 3
        lt[i, 0] = ALPHA_B / 6.0 * (yh[j] - yh[k]) * ((yh[i] - yh[k]) - (yh[j] - yh[i]))
        lt[i, 1] = ALPHA_B / 6.0 * (xh[k] - xh[j]) * ((xh[k] - xh[i]) - (xh[i] - xh[j]))
        lt[i, 2] = ALPHA_B / 3.0 * ((xh[k] - xh[i]) * (yh[i] - yh[k]) - (xh[i] - xh[j]) * (yh[j] - yh[i]))
    return lt


@ti.func
def basic_drilling_rate(xh, yh, area, tz):
    """The drilling rotations' share of the basic membrane rate, (1/2A) sum Lt_a theta_a'."""
    lt = drilling_lumping(xh, yh)
    return (0.5 / area) * (lt.transpose() @ tz)


@ti.func
def basic_drilling_moments(xh, yh, n_res):
    """Resisting drilling moments of the membrane resultant N: m_z,a = 1/2 Lt_a . N."""
    return 0.5 * (drilling_lumping(xh, yh) @ n_res)


@ti.func
def higher_order_stiffness(xh, yh, area, modulus, nu):
    """K_theta (3x3) for the hierarchical rotations; modulus = 3/4 beta_0 E t / (1 - nu^2)
    (state.sections.opt_modulus, model/parts.opt_higher_order)."""
    # edges 2-1, 3-2, 1-3 (0-based: 1-0, 2-1, 0-2)
    x12, x21, x13, x31, x23, x32 = xh[0] - xh[1], xh[1] - xh[0], xh[0] - xh[2], xh[2] - xh[0], xh[1] - xh[2], xh[2] - xh[1]
    y12, y21, y13, y31, y23, y32 = yh[0] - yh[1], yh[1] - yh[0], yh[0] - yh[2], yh[2] - yh[0], yh[1] - yh[2], yh[2] - yh[1]
    l21 = x21 * x21 + y21 * y21
    l32 = x32 * x32 + y32 * y32
    l13 = x13 * x13 + y13 * y13
    te = ti.Matrix([[y23 * y13 * l21, y31 * y21 * l32, y12 * y32 * l13],
                    [x23 * x13 * l21, x31 * x21 * l32, x12 * x32 * l13],
                    [(y23 * x31 + x32 * y13) * l21, (y31 * x12 + x13 * y21) * l32, (y12 * x23 + x21 * y32) * l13]])
    te /= 4.0 * area * area
    c = ti.Matrix([[1.0, nu, 0.0], [nu, 1.0, 0.0], [0.0, 0.0, 0.5 * (1.0 - nu)]])
    cn = te.transpose() @ c @ te
    b1, b2, b3, b4, b5, b6, b7, b8, b9 = ti.static(BETAS)
    inv = ti.Vector([1.0 / l21, 1.0 / l32, 1.0 / l13]) * (2.0 * area / 3.0)
    q1 = ti.Matrix([[b1 * inv[0], b2 * inv[0], b3 * inv[0]], [b4 * inv[1], b5 * inv[1], b6 * inv[1]],
                    [b7 * inv[2], b8 * inv[2], b9 * inv[2]]])
    q2 = ti.Matrix([[b9 * inv[0], b7 * inv[0], b8 * inv[0]], [b3 * inv[1], b1 * inv[1], b2 * inv[1]],
                    [b6 * inv[2], b4 * inv[2], b5 * inv[2]]])
    q3 = ti.Matrix([[b5 * inv[0], b6 * inv[0], b4 * inv[0]], [b8 * inv[1], b9 * inv[1], b7 * inv[1]],
                    [b2 * inv[2], b3 * inv[2], b1 * inv[2]]])
    q4, q5, q6 = 0.5 * (q1 + q2), 0.5 * (q2 + q3), 0.5 * (q3 + q1)
    k = q4.transpose() @ cn @ q4 + q5.transpose() @ cn @ q5 + q6.transpose() @ cn @ q6
    return (modulus * area) * k


@ti.func
def shear_scale(x, t):
    """sqrt(t^2 / (t^2 + alpha h^2)), h the longest edge of corners x (3x3): the transverse
    shear rate and its loads are scaled by it, the shear stiffness by its square (module
    docstring, "Transverse shear")."""
    h2 = ti.max((ti.Vector([x[1, 0] - x[0, 0], x[1, 1] - x[0, 1], x[1, 2] - x[0, 2]])).norm_sqr(),
                (ti.Vector([x[2, 0] - x[1, 0], x[2, 1] - x[1, 1], x[2, 2] - x[1, 2]])).norm_sqr(),
                (ti.Vector([x[0, 0] - x[2, 0], x[0, 1] - x[2, 1], x[0, 2] - x[2, 2]])).norm_sqr())
    return ti.sqrt(t * t / (t * t + SHEAR_STABILISATION * h2))
