"""Drilling spring: the nodal rotation about the shell normal as a tied degree of freedom
(option ``[element].drilling = "penalty"``; replaces the projection of method.md 2.3).

Why.  The paper sets the drilling rate to zero at every node (omega . n_c = 0).  A rigid
rotation q of a curved mesh then reaches each element as q - (q . n_c) n_c, whose
tangential part differs from corner to corner because the nodal normals n_c differ: a
spurious curvature ~ |q . n| / R that grows with the rotation and does not fall with
refinement.  Measured: a hemisphere cap spinning a quarter turn about its axis got
E_int/KE = 7.5e-2 (centrifugal strain: ~1e-6), and the hemisphere benchmark of Sze et al.
stayed 2-3 % too stiff at every mesh.  Setting the drilling rate from the neighbouring
elements' spin fixes the kinematics but is not energy-consistent (issue 4, stop 11: the
2.5 mm tube created 1.4 kJ).

What.  Each node keeps its full angular velocity; each element ties its corners' rotation
rate about its own normal e3 to its in-plane spin Omega = 1/2 (dv_y/dx - dv_x/dy) by a
rotational spring (Hughes & Brezzi 1989, penalty form), in the element's corotational frame:

    M_a' = k (theta_z,a - Omega),   k = alpha D A beta / (4 (1 + beta t^2 / 12)),   D = E t^3 / 12,

beta = B1.B1 + B2.B2, so that alpha = 1 is the bending stiffness one corner rotation meets
[choice]: scaled to bending (not to G t A) the spring never sets the time step, with scaled
or physical rotary inertia.  Its conjugate loads are the corner moments M_a about e3 and
the in-plane forces -+ 1/2 B sum M (the transpose of Omega), so the element's power
identity sum f.v + m.theta = sum M (theta_z - Omega) holds exactly; the spring's energy is
reported on its own (``drilling`` in energy.csv and the summary), apart from the hourglass
energy and its limits.  A rigid motion gives theta_z = Omega = q . e3 at every corner of
every element: zero rate, whatever the curvature; at a fold between elements the springs
of both sides fix two components of the nodal rotation and leave the fold's own rotation
free.

The factor 1 / (1 + beta t^2 / 12) (1.007 for the 5 mm tube) caps k at alpha E t A / 4 on
an element crushed to a width ~ t: through Omega the spring also stiffens the corners'
in-plane translations by ~ k beta, which grows like 1 / width^3 against the membrane's
1 / width and made a collapsing element run away before the time-step guard could stop it
(tests/test_reliability.py, dt_collapse).

alpha = 0.1 (``[element].drilling_stiffness``): the spring is artificial stiffness, and at
alpha = 1 it held 8-10 % of the 5 mm tube's internal energy in the first folds (hourglass
+ spring 20 % of E_int at 1.3 ms, hourglass alone 11 % with the projection; alpha = 0.1:
hourglass + spring 12 %); the hemisphere (16x16, fem, w_hourglass "bt") gave 0.28 / 0.51 %
mean error at alpha = 0.1, 0.43 / 0.73 % at 1, 0.55 / 0.91 % at 10.
"""

import taichi as ti


@ti.data_oriented
class DrillingSpring:
    """alpha D / 4 = alpha E t^3 / 48 is per element (state.sections.drilling_factor)."""

    def __init__(self, state):
        self.s = state

    @ti.func
    def rates(self, g1, g2, vx, vy, tz):
        """theta_z,a - Omega per corner (mid-step frame, like the membrane rate)."""
        spin = 0.5 * (g1.dot(vy) - g2.dot(vx))
        return tz - spin

    @ti.func
    def stiffness(self, e, area, beta):
        t = self.s.sections.thickness[e]
        return self.s.sections.drilling_factor[e] * area * beta / (1.0 + beta * (t * t / 12.0))

    @ti.func
    def nodal_loads(self, moment, b1, b2):
        """Resisting local forces and moments (corners x 3: 4 for a quad, 3 for a triangle) of
        the corner moments M_a: the transpose of `rates`."""
        f = ti.Matrix.zero(ti.f64, moment.n, 3)
        m = ti.Matrix.zero(ti.f64, moment.n, 3)
        total = moment.sum()
        for a in ti.static(range(moment.n)):
            f[a, 0] = 0.5 * b2[a] * total
            f[a, 1] = -0.5 * b1[a] * total
            m[a, 2] = moment[a]
        return f, m
