"""C0 triangular shell (stage S7 for 3-node elements; issue 17 item 4): the
Belytschko-Stolarski-Carpenter (1984) triangle of the Belytschko-Tsay family, next to the
quad of :mod:`.shell` in one mesh (docs/element.md, "Triangles").

Choice [measured]: this element rather than the quad of :mod:`.shell` with its 4th corner on
its 1st (the degenerate quad).  On Sze's cantilever with the 20x2 quads cut into 80
triangles (fem, `python -m benchmarks.triangle_element --mesh 20x2 --mesh 40x4`) the tip
W / -U mean errors are 0.02 / 0.06 % here against 38.7 / 56.8 % for the degenerate quad
(320 triangles: 0.04 / 0.13 % against 24.8 / 39.7 %): the quad's transverse shear, the
gradient of w plus the mean of its corner rotations, counts the doubled corner twice and
locks in bending.  The constant-strain membrane is the same in both.

Corotational frame (at the mid-step geometry for the rates, at x^(n+1) for the loads, as the
quad): e3 along (x2 - x1) x (x3 - x1), e1 along edge 1-2, local coordinates about the
centroid; a triangle is flat, z^ = 0 at its corners.  With the linear shape functions
N_a, B1_a = dN_a/dx^ = (y^_(a+1) - y^_(a+2)) / 2A, B2_a = dN_a/dy^ = (x^_(a+2) - x^_(a+1)) / 2A
(a cyclic), one point (the centroid):

* membrane rate (constant-strain triangle) and curvature rate from the linear rotations, the
  quad's definitions with the triangle's B (method.md 3.2):
  eps0' = (B1.vx, B2.vy, B2.vx + B1.vy),  kappa' = (B1.ty, -B2.tx, B2.ty - B1.tx);
* transverse shear [the C0 triangle's treatment]: one tangential shear rate per edge k (from
  corner k to k+1, edge vector e_k, midpoint m_k),
      s_k = (w_(k+1) - w_k) + 1/2 (beta_k + beta_(k+1)) . e_k,   beta_a = (theta_y, -theta_x)_a,
  exact for a linear w and a linear rotation along the edge, and at the centroid the
  constant part of the field whose tangential shear is constant along each edge:
      gamma' = (1 / A) sum_k (-y^(m_k), x^(m_k)) s_k
  (the m_k about the centroid).  This is the assumed transverse shear of the MITC3 triangle
  (Lee & Bathe 2004) sampled at the centroid, and the same numbers as the C0 triangle of
  OpenRadioss (C3CURV3, checked on random triangles to round-off; the code here is our own,
  derived from the edge field).  The w part is exactly B.w; the rotation part differs from
  the centroid mean (1/3) sum beta by a correction that makes a Kirchhoff field (quadratic w,
  beta = -grad w) give s_k = 0 on every edge, hence gamma' = 0 on any triangle.  The plain
  mean (the quad's 1/4 sum in a triangle) locks: on a strip of right triangles in bending it
  forces equal rotations at both ends of every element.

Loads (resisting, local; the exact transpose of the rates, so sum f.v + m.theta =
A (N.eps0' - M'.kappa' + kappa Q.gamma')): the membrane and bending part as the quad's
(paper eq 21-26 with the triangle's B); the shear part with T_k = kappa (-y^(m_k) Q_x +
x^(m_k) Q_y): f_z(k+1) += T_k, f_z(k) -= T_k, and on both corners of edge k the moment
(m_x, m_y) += 1/2 T_k (-e_ky, e_kx).

What is not in it.  No hourglass control: the constant-strain membrane has no spurious mode,
and the plate part has one per element alone -- rotations swirling about its centroid
(beta = omega (-y, x): zero curvature, zero centroid shear) -- which a neighbour sharing an
edge already rules out (both must take the same omega, and a continuous w cannot cancel the
shear that leaves in both; tests/test_triangles.py counts the zero-energy modes of a
patch).  No warping correction (flat).  The stress update, resultants, drilling spring (or
the nodal normals of the drilling projection) and energy booking are the quad's
(:class:`.shell.ShellElement`).

Time step [choice, measured]: alpha L_e / c_e as the quad, with
L_e = 2 / sqrt(3 beta) = 4A / sqrt(3 (l1^2 + l2^2 + l3^2)), beta = sum |grad N_a|^2
(assembly.element_length is its host twin).  The altitude over the longest edge, 2A / l_max
(LS-DYNA's triangle length), is not conservative for the constant-strain membrane with lumped
mass: on one element the largest frequency reached omega dt / 2 = 1.06-1.25 at alpha = 1
(equilateral, nu = 0.3: 1.21), and the 20x2 cantilever split into 80 triangles, at 0.92 with
alpha = 0.9, did not relax with FIRE (it did at alpha 0.8).  With 2 / sqrt(3 beta) the
membrane's omega_max^2 <= 3 c^2 beta held on 3000 random triangles (largest 2.996 c^2 beta,
nu in [0, 0.49]), i.e. omega dt / 2 <= alpha on one element, the mesh below it; it is 0.67
(equilateral) to 0.82 (sliver) of the altitude.  The plate part (edge shear against the
rotary inertia) is kept below it by the inertia: m max(t^2/12, A/4) g with the shear gain g
of assembly.triangle_shear_gain (largest omega dt / 2 of one element 0.81 alpha over random
shapes, slivers included); with the physical rotary inertia the step adds the rotational
frequency, scaled by g, as a square (timestep.triangle_limit).

Inside out.  A triangle has no corner of its own that can fold (its three corner Jacobians
are 2A in its own frame): it is flagged when its normal reverses within a step,
(x2 - x1) x (x3 - x1) at x^(n+1) against the mid-step one <= 0 (which includes collapsing to
a line).

Options (``[element].triangle``): ``opt`` replaces the membrane by Felippa's OPT
(:mod:`.opt_membrane`); ``ns`` smooths the constant-strain membrane rate over each node's
triangles and applies the transpose of that as the membrane loads (:mod:`.ns_membrane`: the
passes around the element loop and :meth:`TriangleElement.membrane_rate` here).

Reference: T. Belytschko, H. Stolarski, N. Carpenter, "A C0 triangular plate element with
one-point quadrature", IJNME 20 (1984) 787-802.
"""

import taichi as ti

from ..state import STATUS_INVERTED, STATUS_OK
from . import ns_membrane, opt_membrane
from .rotation import mid_step, rotation_vector
from .timestep import triangle_limit, zigzag_limit


@ti.func
def corner(x, a: ti.template()):
    return ti.Vector([x[a, 0], x[a, 1], x[a, 2]])


@ti.func
def column(mat, j: ti.template()):
    return ti.Vector([mat[0, j], mat[1, j], mat[2, j]])


@ti.func
def triangle_geometry(x):
    """Frame rows e1, e2, e3 for corner positions x (3x3), the corners' local coordinates
    (x^, y^) about the centroid, and the unnormalised normal (x2 - x1) x (x3 - x1) = 2A e3."""
    normal = (corner(x, 1) - corner(x, 0)).cross(corner(x, 2) - corner(x, 0))
    e3 = normal.normalized()
    r21 = corner(x, 1) - corner(x, 0)
    e1 = (r21 - r21.dot(e3) * e3).normalized()
    e2 = e3.cross(e1)
    centre = (corner(x, 0) + corner(x, 1) + corner(x, 2)) / 3.0
    xh = ti.Vector([0.0, 0.0, 0.0])
    yh = ti.Vector([0.0, 0.0, 0.0])
    for a in ti.static(range(3)):
        r = corner(x, a) - centre
        xh[a] = r.dot(e1)
        yh[a] = r.dot(e2)
    return ti.Matrix.rows([e1, e2, e3]), xh, yh, normal


@ti.func
def increment_geometry(x, dx):
    """The triangle's twin of shell.increment_geometry (a large increment dx ending at x): the
    mid-step frame, the mean of the start's and end's corner coordinates in their own frames,
    their change in those frames, the frames' rotation (in the mid frame), and the mid-step
    normal (the inside-out check)."""
    rot0, x0, y0, normal0 = triangle_geometry(x - dx)
    rot1, x1, y1, normal1 = triangle_geometry(x)
    rot_m, xm, ym, normal_m = triangle_geometry(x - 0.5 * dx)
    change = ti.Matrix.zero(ti.f64, 3, 3)
    for a in ti.static(range(3)):
        change[a, 0] = x1[a] - x0[a]
        change[a, 1] = y1[a] - y0[a]
    spin = rot_m @ rotation_vector(rot1.transpose() @ rot0)
    return rot_m, 0.5 * (x0 + x1), 0.5 * (y0 + y1), normal_m, change, spin


@ti.func
def gradient_operators(xh, yh):
    """Area and B1, B2 (dN_a/dx^, dN_a/dy^) of the linear triangle."""
    area = 0.5 * ((xh[1] - xh[0]) * (yh[2] - yh[0]) - (xh[2] - xh[0]) * (yh[1] - yh[0]))
    inv2a = 0.5 / area
    b1 = inv2a * ti.Vector([yh[1] - yh[2], yh[2] - yh[0], yh[0] - yh[1]])
    b2 = inv2a * ti.Vector([xh[2] - xh[1], xh[0] - xh[2], xh[1] - xh[0]])
    return area, b1, b2


@ti.func
def strain_rates(xh, yh, area, b1, b2, vx, vy, vz, tx, ty):
    """Membrane, curvature and (edge) transverse shear rates (module docstring)."""
    membrane_rate = ti.Vector([b1.dot(vx), b2.dot(vy), b2.dot(vx) + b1.dot(vy)])
    curvature_rate = ti.Vector([b1.dot(ty), -b2.dot(tx), b2.dot(ty) - b1.dot(tx)])
    shear = ti.Vector([0.0, 0.0])
    for k in ti.static(range(3)):
        j = (k + 1) % 3
        edge_rate = vz[j] - vz[k] + 0.5 * ((ty[k] + ty[j]) * (xh[j] - xh[k]) - (tx[k] + tx[j]) * (yh[j] - yh[k]))
        shear += edge_rate * ti.Vector([-0.5 * (yh[k] + yh[j]), 0.5 * (xh[k] + xh[j])])
    return membrane_rate, curvature_rate, shear / area


@ti.func
def resultant_loads(xh, yh, area, b1, b2, n_res, m_res, q_res, kappa):
    """Resisting local nodal forces and moments (3x3 each) of N, M' (paper sign) and Q: the
    transpose of :func:`strain_rates` (module docstring)."""
    f = ti.Matrix.zero(ti.f64, 3, 3)
    m = ti.Matrix.zero(ti.f64, 3, 3)
    for a in ti.static(range(3)):
        f[a, 0] = area * (b1[a] * n_res[0] + b2[a] * n_res[2])
        f[a, 1] = area * (b2[a] * n_res[1] + b1[a] * n_res[2])
        m[a, 0] = area * (b2[a] * m_res[1] + b1[a] * m_res[2])
        m[a, 1] = -area * (b1[a] * m_res[0] + b2[a] * m_res[2])
    for k in ti.static(range(3)):
        j = (k + 1) % 3
        edge_force = kappa * (-0.5 * (yh[k] + yh[j]) * q_res[0] + 0.5 * (xh[k] + xh[j]) * q_res[1])
        f[j, 2] += edge_force
        f[k, 2] -= edge_force
        for a in ti.static((k, j)):
            m[a, 0] -= 0.5 * edge_force * (yh[j] - yh[k])
            m[a, 1] += 0.5 * edge_force * (xh[j] - xh[k])
    return f, m


@ti.func
def shear_gain(xh, yh, area):
    """g = 3 sigma_max^2 of the rotation part of the edge shear, from the local coordinates
    (assembly.triangle_shear_gain, its host twin and docstring)."""
    p = ti.Matrix.zero(ti.f64, 2, 2)
    for a in ti.static(range(3)):
        pa = ti.Matrix.zero(ti.f64, 2, 2)
        for k in ti.static((a, (a + 2) % 3)):          # the two edges k -> k+1 at corner a
            j = (k + 1) % 3
            lever = ti.Vector([-0.5 * (yh[k] + yh[j]), 0.5 * (xh[k] + xh[j])])
            pa += lever.outer_product(ti.Vector([xh[j] - xh[k], yh[j] - yh[k]]))
        p += pa @ pa.transpose()
    p /= (2.0 * area) ** 2
    half_trace = 0.5 * (p[0, 0] + p[1, 1])
    return 3.0 * (half_trace + ti.sqrt(ti.max(half_trace * half_trace - (p[0, 0] * p[1, 1] - p[0, 1] * p[1, 0]), 0.0)))


@ti.data_oriented
class TriangleElement:
    """Element stage of the triangles of a mesh; ``quad`` (shell.ShellElement) lends it the
    through-thickness stress update and resultants, the corner loads, the drilling spring,
    the energy ledger and the time-step accumulator."""

    def __init__(self, quad):
        self.s = quad.s
        self.cfg = quad.cfg
        self.quad = quad
        self.smoothing = ns_membrane.NodeSmoothedMembrane(self) if self.cfg.triangle_ns else None

    @ti.func
    def membrane_rate(self, e):
        """The constant-strain membrane rate of triangle e on its mid-step geometry, with the
        frame and area (stages/ns_membrane.py, pass 1)."""
        c = self.s.elements.corners[e]
        x, v, w = self.quad.gather(c, 3)
        rot_m, xm, ym, normal_m, vl, wl = mid_step(x, v, w, self.s.step.dt[None], self.cfg.finite_increment,
                                                   triangle_geometry, increment_geometry)
        area_m, g1, g2 = gradient_operators(xm, ym)
        vx, vy = column(vl, 0), column(vl, 1)
        return rot_m, area_m, ti.Vector([g1.dot(vx), g2.dot(vy), g2.dot(vx) + g1.dot(vy)])

    @ti.func
    def zigzag(self, e, x, area):
        """The triangle's zigzag step (stages/timestep.zigzag_limit), h = 2 A / longest edge, with
        the reciprocal mass matrix (0 without: not used)."""
        out = 0.0
        if ti.static(self.cfg.reciprocal_mass):
            edge = ti.max((corner(x, 1) - corner(x, 0)).norm(), (corner(x, 2) - corner(x, 1)).norm(),
                          (corner(x, 0) - corner(x, 2)).norm())
            out = zigzag_limit(self.s, e, 2.0 * area / edge)
        return out

    @ti.func
    def limit(self, e, x, xh, yh, area):
        """The triangle's stable step, L_e = 4A / sqrt(3 sum l^2) (module docstring;
        timestep.triangle_limit)."""
        edges_sq = ((corner(x, 1) - corner(x, 0)).norm_sqr() + (corner(x, 2) - corner(x, 1)).norm_sqr()
                    + (corner(x, 0) - corner(x, 2)).norm_sqr())
        gain = 1.0
        if ti.static(self.cfg.physical_rotary_inertia or self.cfg.triangle_opt):
            gain = shear_gain(xh, yh, area)
        length = 4.0 * area / ti.sqrt(3.0 * edges_sq)
        if ti.static(self.cfg.triangle_opt):        # OPT's drilling modes (stages/opt_membrane.py, "Time step")
            length /= ti.sqrt(1.0 + 0.5 * gain)
        return triangle_limit(self.s, self.cfg, e, length, gain)

    @ti.func
    def update(self, e):
        t = self.s.sections.thickness[e]
        kappa = self.s.sections.shear_factor[e]
        dt = self.s.step.dt[None]
        c = self.s.elements.corners[e]
        x, v, w = self.quad.gather(c, 3)
        # --- rates on the mid-step geometry (as the quad: shell.ShellElement.update)
        rot_m, xm, ym, normal_m, vl, wl = mid_step(x, v, w, dt, self.cfg.finite_increment, triangle_geometry, increment_geometry)
        vx, vy, vz = column(vl, 0), column(vl, 1), column(vl, 2)
        tx, ty, tz = column(wl, 0), column(wl, 1), column(wl, 2)
        area_m, g1, g2 = gradient_operators(xm, ym)
        membrane_rate, curvature_rate, shear_rate = strain_rates(xm, ym, area_m, g1, g2, vx, vy, vz, tx, ty)
        shear_scale = 1.0
        if ti.static(self.cfg.triangle_opt):        # OPT's basic membrane: Allman's drilling share
            membrane_rate += opt_membrane.basic_drilling_rate(xm, ym, area_m, tz)
            shear_scale = opt_membrane.shear_scale(x, t)
            shear_rate *= shear_scale
        if ti.static(self.cfg.triangle_ns):         # the node-smoothed membrane rate (stages/ns_membrane.py)
            membrane_rate = self.smoothing.smoothed_rate(c, rot_m, membrane_rate)
        # --- geometry at x^(n+1) for the loads; a normal reversed within the step: inside out
        rot, xh, yh, normal = triangle_geometry(x)
        area, b1, b2 = gradient_operators(xh, yh)
        if self.s.step.status[None] == STATUS_OK and normal.dot(normal_m) <= 0.0:
            self.s.step.status[None] = STATUS_INVERTED
            self.s.step.status_index[None] = e
        yield_before = ti.Vector.zero(ti.f64, self.cfg.points)
        if ti.static(self.cfg.triangle_opt and self.cfg.plastic):     # OPT's elastic fraction, below
            for k in ti.static(range(self.cfg.points)):
                yield_before[k] = self.s.points.plastic_strain[e, k]
        n_res, m_res, q_res, power, plastic_work = self.quad.section_response(e, t, kappa, dt, membrane_rate,
                                                                              curvature_rate, shear_rate)
        membrane_loads = n_res
        if ti.static(self.cfg.triangle_ns):         # its loads come from the node means (ns_membrane, pass 3)
            self.smoothing.stresses(e, rot, area, b1, b2, n_res)
            membrane_loads = self.smoothing.own_share(c) * n_res     # its own strain's share (corners next to quads)
        f, m = resultant_loads(xh, yh, area, b1, b2, membrane_loads, m_res, shear_scale * q_res, kappa)
        drill_energy = 0.0
        higher_energy = 0.0
        if ti.static(self.cfg.triangle_opt):        # OPT (stages/opt_membrane.py): basic drilling moments,
            # and the higher-order part as a 3x3 drilling spring on theta_z - Omega (elastic)
            mz = opt_membrane.basic_drilling_moments(xh, yh, n_res)
            drilling = self.quad.drilling
            rate = drilling.rates(g1, g2, vx, vy, tz)
            stiff = opt_membrane.higher_order_stiffness(xm, ym, area_m, self.s.sections.opt_modulus[e],
                                                        self.s.sections.opt_poisson[e])
            stored = self.s.elements.drilling_moment[e]
            q_old = ti.Vector([stored[0], stored[1], stored[2]])
            elastic = 1.0
            if ti.static(self.cfg.plastic):         # the section's elastic fraction (opt_membrane, "Plasticity")
                section = self.s.sections.section[e]
                total = 0.0
                kept = 0.0
                for k in ti.static(range(self.cfg.points)):
                    if k < self.s.sections.point_count[section]:
                        weight = self.s.sections.weight[section, k]
                        total += weight
                        if self.s.points.plastic_strain[e, k] <= yield_before[k]:
                            kept += weight
                floor = self.s.sections.opt_floor[e]
                elastic = floor + (1.0 - floor) * kept / total
            q_new = q_old + dt * elastic * (stiff @ rate)
            self.s.elements.drilling_moment[e] = ti.Vector([q_new[0], q_new[1], q_new[2], 0.0])
            fd, md = drilling.nodal_loads(q_new, b1, b2)
            for a in ti.static(range(3)):
                md[a, 2] += mz[a]
            f += fd
            m += md
            higher_energy = dt * 0.5 * (q_old + q_new).dot(rate)
        elif ti.static(self.cfg.drilling_spring):    # stages/drilling.py, corners 1-3 of the 4 slots
            drilling = self.quad.drilling
            drill_rate = drilling.rates(g1, g2, vx, vy, tz)
            stored = self.s.elements.drilling_moment[e]
            drill_old = ti.Vector([stored[0], stored[1], stored[2]])
            drill_new = drill_old + dt * drilling.stiffness(e, area, b1.dot(b1) + b2.dot(b2)) * drill_rate
            self.s.elements.drilling_moment[e] = ti.Vector([drill_new[0], drill_new[1], drill_new[2], 0.0])
            fd, md = drilling.nodal_loads(drill_new, b1, b2)
            f += fd
            m += md
            drill_energy = dt * 0.5 * (drill_old + drill_new).dot(drill_rate)
        internal = dt * area_m * 0.5 * t * power + higher_energy
        if ti.static(self.cfg.erosion):              # erosion: before the scatter (ShellElement.update)
            if self.quad.step_limit(e, c, v, w, self.limit(e, x, xh, yh, area), self.zigzag(e, x, area), 3):
                internal += self.quad.failing_stagger(f @ rot, m @ rot, v, w, dt, 3)
                f = ti.Matrix.zero(ti.f64, 3, 3)
                m = ti.Matrix.zero(ti.f64, 3, 3)
                if ti.static(self.cfg.triangle_ns):     # out of this step's load means too
                    self.s.elements.ns_tensor[e] = ti.Matrix.zero(ti.f64, 3, 3)
                    self.s.elements.ns_weight[e] = 0.0
        # --- to global and scatter
        fg = f @ rot
        mg = m @ rot
        e3 = ti.Vector([rot[2, 0], rot[2, 1], rot[2, 2]])
        for a in ti.static(range(3)):
            self.quad.loads.add(e, a, c[a], ti.Vector([fg[a, 0], fg[a, 1], fg[a, 2]]),
                                ti.Vector([mg[a, 0], mg[a, 1], mg[a, 2]]), area * e3, area)
        element_power = self.quad.element_power(fg, mg, v, w, 3)
        self.quad.energy.element(e, internal, area_m * 0.5 * t * plastic_work, 0.0,
                                 drill_energy, -0.5 * dt * element_power)
        # --- time-step limit, with selective mass scaling (shell.ShellElement.step_limit; after the
        # scatter without erosion, as ShellElement.update)
        if ti.static(not self.cfg.erosion):
            self.quad.step_limit(e, c, v, w, self.limit(e, x, xh, yh, area), self.zigzag(e, x, area), 3)
