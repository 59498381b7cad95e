"""Belytschko-Tsay shell element (stage S7; paper eq 17-29, 37; method.md section 3).

One-point in-plane integration in the corotational frame, through-thickness points for
the stress, transverse shear with shear factor kappa on the resultants, hourglass
control (:mod:`.hourglass`), the drilling spring (:mod:`.drilling`; or, with
``drilling = "projection"``, the nodal normals of the paper's drilling projection,
method.md 2.3) and, with ``warping = "bwc"``, the Belytschko-Wong-Chiang warping
correction (:mod:`.warping`, method.md 3.8).  The same pass accumulates the element
energies (method.md 8) and the element time-step limit (section 5).  The triangles of a
mixed mesh run the C0 triangle of :mod:`.triangle`, which shares this element's
through-thickness stress update (:meth:`ShellElement.section_response`).
"""

import taichi as ti

from ..laws.failure import COLUMNS as FAILURE_COLUMNS
from ..laws.failure import CRITERIA as FAILURE
from ..state import STATUS_INVERTED, STATUS_OK, STATUS_RETURN_FAILED, State
from . import warping
from .accumulate import Accumulator, CornerLoads
from .material import ConstitutiveUpdate
from .rotation import mid_step, rotation_vector
from .drilling import DrillingSpring
from .hourglass import Hourglass
from .masses import MassUpdate
from .timestep import element_limit, zigzag_limit
from .triangle import TriangleElement


@ti.func
def corotational_frame(x):
    """Rows e1, e2, e3 of the BT frame for corner positions x (4x3): e3 from the diagonals,
    e1 along edge 1-2 projected into the plane (method.md 3.1)."""
    e3 = (ti.Vector([x[2, 0] - x[0, 0], x[2, 1] - x[0, 1], x[2, 2] - x[0, 2]]).cross(
        ti.Vector([x[3, 0] - x[1, 0], x[3, 1] - x[1, 1], x[3, 2] - x[1, 2]]))).normalized()
    r21 = ti.Vector([x[1, 0] - x[0, 0], x[1, 1] - x[0, 1], x[1, 2] - x[0, 2]])
    e1 = (r21 - r21.dot(e3) * e3).normalized()
    e2 = e3.cross(e1)
    return ti.Matrix.rows([e1, e2, e3])


@ti.func
def column(mat, j: ti.template()):
    return ti.Vector([mat[0, j], mat[1, j], mat[2, j], mat[3, j]])


@ti.func
def local_geometry(x):
    """BT frame and the corners' local coordinates (x^, y^, z^) about their centroid."""
    rot = corotational_frame(x)
    centre = ti.Vector([0.0, 0.0, 0.0])
    for a in ti.static(range(4)):
        centre += 0.25 * ti.Vector([x[a, 0], x[a, 1], x[a, 2]])
    xl = ti.Matrix.zero(ti.f64, 4, 3)
    for a in ti.static(range(4)):
        for d in ti.static(range(3)):
            xl[a, d] = x[a, d] - centre[d]
    xl = xl @ rot.transpose()
    return rot, column(xl, 0), column(xl, 1), column(xl, 2)


@ti.func
def increment_geometry(x, dx):
    """The mid-step of a large increment dx (4x3) that ends at x, in the corotational frame
    of x - dx/2 (returned first): the corners' coordinates, the mean of the start's and the
    end's, each in its own frame; their change in those frames (the increment less the
    frames' rigid motion); and the frames' rotation from start to end (a rotation vector,
    in the mid frame).  Why: x - dx/2 is the element shrunk by cos(alpha/2) across the axis
    of a rotation alpha of the increment, which overstates the strain increments by
    1/cos(alpha/2) (curvature) to 1/cos^2(alpha/2) (membrane) and lets a rigid rotation
    shear the element by alpha - 2 tan(alpha/2); negligible in an explicit step, a
    second-order error of the load increment in Newton's (docs/newton.md)."""
    rot0, x0, y0, z0 = local_geometry(x - dx)
    rot1, x1, y1, z1 = local_geometry(x)
    rot_m = corotational_frame(x - 0.5 * dx)
    change = ti.Matrix.zero(ti.f64, 4, 3)
    for a in ti.static(range(4)):
        change[a, 0] = x1[a] - x0[a]
        change[a, 1] = y1[a] - y0[a]
        change[a, 2] = z1[a] - z0[a]
    spin = rot_m @ rotation_vector(rot1.transpose() @ rot0)
    return rot_m, 0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * (z0 + z1), change, spin


@ti.func
def gradient_operators(xh, yh):
    """Area and B1, B2 of the one-point quad (paper eq 27): B_alpha = dN_a/dx_alpha at the centre."""
    area = 0.5 * ((xh[2] - xh[0]) * (yh[3] - yh[1]) + (xh[1] - xh[3]) * (yh[2] - yh[0]))
    inv2a = 0.5 / area
    b1 = inv2a * ti.Vector([yh[1] - yh[3], yh[2] - yh[0], yh[3] - yh[1], yh[0] - yh[2]])
    b2 = inv2a * ti.Vector([xh[3] - xh[1], xh[0] - xh[2], xh[1] - xh[3], xh[2] - xh[0]])
    return area, b1, b2


@ti.func
def strain_rates(g1, g2, vx, vy, vz, tx, ty):
    """Membrane rate, curvature rate and transverse shear rate of the BT element (method.md
    3.2) from the local corner velocities and angular velocities."""
    membrane_rate = ti.Vector([g1.dot(vx), g2.dot(vy), g2.dot(vx) + g1.dot(vy)])
    curvature_rate = ti.Vector([g1.dot(ty), -g2.dot(tx), g2.dot(ty) - g1.dot(tx)])
    shear_rate = ti.Vector([g1.dot(vz) + 0.25 * ty.sum(), g2.dot(vz) - 0.25 * tx.sum()])
    return membrane_rate, curvature_rate, shear_rate


@ti.func
def resultant_loads(area, b1, b2, n_res, m_res, q_res, kappa):
    """Resisting local nodal forces and moments (4x3 each; paper eq 21-26) of the resultants
    N, M' (paper sign) and Q: the transpose of `strain_rates`, sum_a f_a . v_a + m_a . theta_a
    = A (N . eps' - M' . kappa' + kappa Q . gamma') (tests/test_warping.py)."""
    f = ti.Matrix.zero(ti.f64, 4, 3)
    m = ti.Matrix.zero(ti.f64, 4, 3)
    for a in ti.static(range(4)):
        f[a, 0] = area * (b1[a] * n_res[0] + b2[a] * n_res[2])
        f[a, 1] = area * (b2[a] * n_res[1] + b1[a] * n_res[2])
        f[a, 2] = kappa * area * (b1[a] * q_res[0] + b2[a] * q_res[1])
        m[a, 0] = area * (b2[a] * m_res[1] + b1[a] * m_res[2] - 0.25 * kappa * q_res[1])
        m[a, 1] = -area * (b1[a] * m_res[0] + b2[a] * m_res[2] - 0.25 * kappa * q_res[0])
    return f, m


@ti.func
def tangled(xh, yh):
    """True when two or more corner Jacobians (x_(a+1) - x_a) x (x_(a-1) - x_a) in the local
    plane are <= 0: the quad crosses itself (a bow-tie) or has folded flat.  One reflex
    corner (a dart) is a distorted but valid quad for the one-point element and is let
    through [choice]: the 2.5 mm tube mesh stopped at 3.2 ms on a dart in its bottom fold
    (corner Jacobians 5.6, 1.2, -0.1, 4.3), which a crash code carries on with; the
    time-step collapse guard still stops an element that keeps degenerating.  The numpy
    twin is Simulation.element_distortion."""
    bad = 0
    for a in ti.static(range(4)):
        n, p = (a + 1) % 4, (a + 3) % 4
        if (xh[n] - xh[a]) * (yh[p] - yh[a]) - (yh[n] - yh[a]) * (xh[p] - xh[a]) <= 0.0:
            bad += 1
    return bad >= 2


@ti.data_oriented
class ShellElement:
    """Element stage: strain rates -> stress at each point -> resultants -> nodal forces."""

    def __init__(self, state: State, cfg, energy):
        self.s = state
        self.cfg = cfg                  # config.Features
        columns = {name: i for i, name in enumerate(FAILURE_COLUMNS)}
        self.failure = tuple(c.kernel(state, cfg, columns) for c in FAILURE.values()) if cfg.erosion else ()
        self.material = ConstitutiveUpdate(state, cfg.materials)
        self.energy = energy            # energy.EnergyLedger
        self.hourglass = Hourglass(state, cfg.kirchhoff_w_hourglass)
        self.drilling = DrillingSpring(state)
        self.acc = Accumulator(cfg.serial)
        self.loads = CornerLoads(state, cfg)
        self.triangle = TriangleElement(self) if cfg.triangles else None
        self.masses = MassUpdate(state, cfg)

    @ti.func
    def gather(self, c, corners: ti.template()):
        """Corner positions, grid velocities and angular velocities as corners x 3 matrices."""
        x = ti.Matrix.zero(ti.f64, corners, 3)
        v = ti.Matrix.zero(ti.f64, corners, 3)
        w = ti.Matrix.zero(ti.f64, corners, 3)
        for a in ti.static(range(corners)):
            for d in ti.static(range(3)):
                x[a, d] = self.s.nodes.position[c[a]][d]
                v[a, d] = self.s.nodes.grid_velocity[c[a]][d]
                w[a, d] = self.s.nodes.omega[c[a]][d]
        return x, v, w

    @ti.func
    def element_pass(self):
        if ti.static(self.cfg.triangle_ns):      # the triangles' node-smoothed membrane rates (stages/ns_membrane.py)
            self.triangle.smoothing.rates()
        for e in range(self.s.elements.count[None]):
            if ti.static(self.cfg.erosion):          # stages/masses.py
                if self.s.elements.eroded[e] == 0:
                    self.element(e)
                else:
                    self.eroded(e)
            else:
                self.element(e)
        if ti.static(self.cfg.triangle_ns):      # and their loads, into the corners' slots before the gather
            self.triangle.smoothing.loads()
        self.loads.gather()

    @ti.func
    def element(self, e):
        """Element e's step: the quad's :meth:`update` or the triangle's (stages/triangle.py)."""
        if ti.static(self.cfg.triangles):       # a mesh with triangles: stages/triangle.py
            if self.s.elements.corners[e][3] < 0:
                self.triangle.update(e)
            else:
                self.update(e)
        else:
            self.update(e)

    @ti.func
    def eroded(self, e):
        """An eroded element's step (stages/masses.py): zero loads and a zero stagger term."""
        zero = ti.Vector([0.0, 0.0, 0.0])
        c = self.s.elements.corners[e]
        for a in ti.static(range(4)):
            if c[a] >= 0:
                self.loads.add(e, a, c[a], zero, zero, zero, 0.0)
        self.energy.element(e, 0.0, 0.0, 0.0, 0.0, 0.0)

    @ti.func
    def element_power(self, fg, mg, v, w, corners: ti.template()):
        """P_e = sum_a f_a . v_a + m_a . omega_a: the element's power with its (global) corner
        forces fg and moments mg at x^(n+1) and the step's velocities (energy.py's stagger term)."""
        out = 0.0
        for a, d in ti.static(ti.ndrange(corners, 3)):
            out += fg[a, d] * v[a, d] + mg[a, d] * w[a, d]
        return out

    @ti.func
    def failing_stagger(self, fg, mg, v, w, dt, corners: ti.template()):
        """The stagger term -dt/2 P_e of an element failing now, with the forces it would have
        written (fg, mg): booked into its internal energy, which becomes eroded energy
        (energy.py, "Erosion"), since it writes no loads and so has no stagger term of its own."""
        return -0.5 * dt * self.element_power(fg, mg, v, w, corners)

    @ti.func
    def step_limit(self, e, c, v, w, limit, zigzag, corners: ti.template()):
        """Element e's stable step `limit` (physical mass) with mass scaling (`zigzag`: its shear
        zigzags' step, the reciprocal mass matrix's cap: :meth:`quad_zigzag`,
        TriangleElement.zigzag), and
        whether the element fails now (erosion; then its stress, hourglass and drilling
        resultants are zeroed and the caller writes zero loads): stages/masses.py.  A failing
        element sets no step."""
        step = limit
        if ti.static(self.cfg.mass_scaling):
            step = self.masses.scale(e, c, v, w, limit, zigzag, corners)
        erode = False
        if ti.static(self.cfg.erosion):
            erode = self.fails(e, step)
            if erode:
                self.masses.erode(e, c, v, w, corners)
                for k in ti.static(range(self.cfg.points)):
                    self.s.points.stress[e, k] = ti.Vector.zero(ti.f64, 5)
                self.s.elements.hourglass_resultant[e] = ti.Vector.zero(ti.f64, 5)
                if ti.static(self.cfg.drilling_spring):
                    self.s.elements.drilling_moment[e] = ti.Vector.zero(ti.f64, 4)
        if not erode:
            self.acc.minimum(self.s.step.dt_next, step)
        return erode

    @ti.func
    def quad_zigzag(self, e, x, area):
        """The quad's zigzag step (stages/timestep.zigzag_limit), h = area / longest side, with the
        reciprocal mass matrix (0 without: not used)."""
        out = 0.0
        if ti.static(self.cfg.reciprocal_mass):
            side = 0.0
            for a in ti.static(range(4)):
                b = (a + 1) % 4
                side = ti.max(side, ti.Vector([x[b, 0] - x[a, 0], x[b, 1] - x[a, 1], x[b, 2] - x[a, 2]]).norm())
            out = zigzag_limit(self.s, e, area / side)
        return out

    @ti.func
    def quad_limit(self, e, x, area):
        """The quad's stable step (stages/timestep.element_limit) with the longest diagonal of
        its corners x."""
        d13 = ti.Vector([x[2, 0] - x[0, 0], x[2, 1] - x[0, 1], x[2, 2] - x[0, 2]]).norm()
        d24 = ti.Vector([x[3, 0] - x[1, 0], x[3, 1] - x[1, 1], x[3, 2] - x[1, 2]]).norm()
        return element_limit(self.s, self.cfg, e, area, ti.max(d13, d24))

    @ti.func
    def section_response(self, e, t, kappa, dt, membrane_rate, curvature_rate, shear_rate):
        """Stress update at element e's through-thickness points and its resultants (paper eq
        28-29, method.md 3.3-3.5) for the step's membrane, curvature and transverse shear rates;
        the quad and the triangle (:mod:`.triangle`) share it.  Returns N, M' = -int z sigma
        (paper sign), Q, the stress power per unit volume (mid-step stress, through-thickness
        mean x 2) and the plastic work likewise.
        One material over the thickness: its points are unrolled (Features.points).  A layered
        section (docs/laminates.md): a run-time loop over its points, each with its ply's
        material [choice, measured on a 20x2 CFRP strip: unrolled, 16 points (8 plies) compiled
        in 26 s and 32 points in 63 s, the loop in 11 s for either; 32 points stepped 0.96 against
        1.08 us per element-step]."""
        section = self.s.sections.section[e]
        n_res = ti.Vector([0.0, 0.0, 0.0])
        m_res = ti.Vector([0.0, 0.0, 0.0])       # M' = -int z sigma (paper sign)
        q_res = ti.Vector([0.0, 0.0])
        power = 0.0
        plastic_work = 0.0
        if ti.static(self.cfg.layered):
            for k in range(self.s.sections.point_count[section]):
                kind, row = self.material.point_material(section, k)
                n_res, m_res, q_res, power, plastic_work = self.point_response(
                    e, section, k, kind, row, t, kappa, dt, membrane_rate, curvature_rate, shear_rate,
                    n_res, m_res, q_res, power, plastic_work)
        else:
            kind, row = self.material.point_material(section, 0)
            for k in ti.static(range(self.cfg.points)):
                if k < self.s.sections.point_count[section]:
                    n_res, m_res, q_res, power, plastic_work = self.point_response(
                        e, section, k, kind, row, t, kappa, dt, membrane_rate, curvature_rate, shear_rate,
                        n_res, m_res, q_res, power, plastic_work)
        n_res *= 0.5 * t
        q_res *= 0.5 * t
        m_res *= 0.25 * t * t
        return n_res, m_res, q_res, power, plastic_work

    @ti.func
    def point_response(self, e, section, k, kind, row, t, kappa, dt, membrane_rate, curvature_rate, shear_rate,
                       n_res, m_res, q_res, power, plastic_work):
        """The stress update at point k of element e (method.md 3.4) with the material model
        `kind` and parameters `row` in the point's material axes; returns the running sums of
        section_response with the point's weighted share added."""
        zeta, weight = self.s.sections.zeta[section, k], self.s.sections.weight[section, k]
        axes = self.material.axes(e, section, k)
        d_inplane = membrane_rate + (0.5 * t * zeta) * curvature_rate
        old = self.s.points.stress[e, k]
        new = old
        if ti.static(self.material.plastic):
            updated, ep, work, converged = self.material.update(kind, row, axes, old, self.s.points.plastic_strain[e, k],
                                                                dt * d_inplane, dt * shear_rate, dt, e, k)
            new = updated
            self.s.points.plastic_strain[e, k] = ep
            plastic_work += weight * work
            if not converged and self.s.step.status[None] == STATUS_OK:
                self.s.step.status[None] = STATUS_RETURN_FAILED
                self.s.step.status_index[None] = e
        else:
            updated, _, _, _ = self.material.update(kind, row, axes, old, 0.0, dt * d_inplane, dt * shear_rate, dt, e, k)
            new = updated
        self.s.points.stress[e, k] = new
        mid = 0.5 * (old + new)
        power += weight * (mid[0] * d_inplane[0] + mid[1] * d_inplane[1] + mid[2] * d_inplane[2]
                           + kappa * (mid[3] * shear_rate[0] + mid[4] * shear_rate[1]))
        n_res += weight * ti.Vector([new[0], new[1], new[2]])
        m_res -= (weight * zeta) * ti.Vector([new[0], new[1], new[2]])
        q_res += weight * ti.Vector([new[3], new[4]])
        return n_res, m_res, q_res, power, plastic_work

    @ti.func
    def fails(self, e, limit):
        """Whether element e fails now (erosion, stages/masses.py): any failure criterion of
        laws/failure/ (its plastic strain at failure_points of its points, its stable step
        `limit` below the failure step; state.sections.failure)."""
        section = self.s.sections.section[e]
        failed = False
        for criterion in ti.static(self.failure):
            if criterion.fails(e, section, limit):
                failed = True
        return failed

    @ti.func
    def update(self, e):
        """The quad's step (paper eq 17-29, 37)."""
        t = self.s.sections.thickness[e]
        kappa = self.s.sections.shear_factor[e]
        dt = self.s.step.dt[None]
        c = self.s.elements.corners[e]
        x, v, w = self.gather(c, 4)
        # --- rates (method.md 3.2) on the mid-step geometry x^(n+1/2) = x^(n+1) - dt/2 v~
        # [choice]: frame, B and hourglass vectors of the mid-step make the strain increment
        # dt*d second-order accurate and exactly zero for a discrete rigid rotation
        # (Hughes-Winget). Evaluated at x^(n+1), a free plate spinning 1.5 revolutions
        # gained 0.9% spurious strain energy (tests/test_stability.py).
        rot_m, xm, ym, zm, vl, wl = mid_step(x, v, w, dt, self.cfg.finite_increment, local_geometry, increment_geometry)
        vx, vy, vz = column(vl, 0), column(vl, 1), column(vl, 2)
        tx, ty, tz = column(wl, 0), column(wl, 1), column(wl, 2)
        area_m, g1, g2 = gradient_operators(xm, ym)
        membrane_rate, curvature_rate, shear_rate = strain_rates(g1, g2, vx, vy, vz, tx, ty)
        gam_m = self.hourglass.shape_vector(xm, ym, g1, g2)
        q_rate = self.hourglass.rates(gam_m, self.hourglass.warp_height(zm), vx, vy, vz, tx, ty,
                                      self.hourglass.quadratic_moments(gam_m, xm, ym), curvature_rate)
        if ti.static(self.cfg.warping_correction):   # BWC (stages/warping.py), after the hourglass rate
            curvature_rate += warping.curvature_rate(xm, ym, zm, area_m, g1, g2, vx, vy)
        # --- geometry at x^(n+1) for the forces
        rot, xh, yh, zh = local_geometry(x)
        area, b1, b2 = gradient_operators(xh, yh)
        # inside out: two corner Jacobians <= 0 in the element's own frame (e3 along d13 x d24).
        # `area` is (d13 x d24).e3 / 2 >= 0 by construction, so it cannot flag a fold.
        # The first problem of a step wins (later stages check status == OK as well).
        if self.s.step.status[None] == STATUS_OK and tangled(xh, yh):
            self.s.step.status[None] = STATUS_INVERTED
            self.s.step.status_index[None] = e
        # --- through-thickness points: stress update, resultants (paper eq 28-29)
        n_res, m_res, q_res, power, plastic_work = self.section_response(e, t, kappa, dt, membrane_rate,
                                                                         curvature_rate, shear_rate)
        # --- local nodal forces and moments (paper eq 21-26)
        f, m = resultant_loads(area, b1, b2, n_res, m_res, q_res, kappa)
        if ti.static(self.cfg.warping_correction):
            f += warping.nodal_loads(xh, yh, zh, area, b1, b2, m_res)
        # --- hourglass (method.md 4)
        gam = self.hourglass.shape_vector(xh, yh, b1, b2)
        zw = self.hourglass.warp_height(zh)
        beta = b1.dot(b1) + b2.dot(b2)
        q_old = self.s.elements.hourglass_resultant[e]
        q_new = q_old + dt * self.hourglass.stiffness(e, area, beta) * q_rate
        self.s.elements.hourglass_resultant[e] = q_new
        fh, mh = self.hourglass.nodal_loads(gam, zw, q_new, self.hourglass.quadratic_moments(gam, xh, yh), b1, b2)
        f += fh
        m += mh
        drill_energy = 0.0
        if ti.static(self.cfg.drilling_spring):      # stages/drilling.py
            drill_rate = self.drilling.rates(g1, g2, vx, vy, tz)
            drill_old = self.s.elements.drilling_moment[e]
            drill_new = drill_old + dt * self.drilling.stiffness(e, area, beta) * drill_rate
            self.s.elements.drilling_moment[e] = drill_new
            fd, md = self.drilling.nodal_loads(drill_new, b1, b2)
            f += fd
            m += md
            drill_energy = dt * 0.5 * (drill_old + drill_new).dot(drill_rate)
        internal = dt * area_m * 0.5 * t * power
        if ti.static(self.cfg.erosion):              # erosion (stages/masses.py): decided before the
            if self.step_limit(e, c, v, w, self.quad_limit(e, x, area), self.quad_zigzag(e, x, area), 4):    # scatter, as a failing
                internal += self.failing_stagger(f @ rot, m @ rot, v, w, dt, 4)  # element writes no loads
                f = ti.Matrix.zero(ti.f64, 4, 3)
                m = ti.Matrix.zero(ti.f64, 4, 3)
        # --- to global (paper eq 37) and scatter
        fg = f @ rot
        mg = m @ rot
        e3 = ti.Vector([rot[2, 0], rot[2, 1], rot[2, 2]])
        for a in ti.static(range(4)):
            self.loads.add(e, a, c[a], ti.Vector([fg[a, 0], fg[a, 1], fg[a, 2]]), ti.Vector([mg[a, 0], mg[a, 1], mg[a, 2]]),
                           area * e3, area)
        # the element's power at x^(n+1) with the step's velocities: energy.py's stagger term
        element_power = self.element_power(fg, mg, v, w, 4)
        self.energy.element(e, internal, area_m * 0.5 * t * plastic_work,
                            dt * 0.5 * (q_old + q_new).dot(q_rate), drill_energy, -0.5 * dt * element_power)
        # --- element time-step limit (method.md 5), with selective mass scaling (stages/masses.py)
        # [choice: after the scatter without erosion, where it was before issue 18: Taichi's fast
        # math schedules the kernel by the source order, and plain scenes keep their bits]
        if ti.static(not self.cfg.erosion):
            self.step_limit(e, c, v, w, self.quad_limit(e, x, area), self.quad_zigzag(e, x, area), 4)
