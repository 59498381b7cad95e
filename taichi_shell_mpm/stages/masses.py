"""Element erosion and mass scaling: the nodal masses that change during a run
(issue 18, items 3 and 7), compiled only for scenes with either (Features.mass_update).

Erosion [choice, as LS-DYNA's FAIL / NUMFIP / TDEL].  An element fails in the step in
which ``failure_points`` of its through-thickness points reach the material's
``failure_strain`` (equivalent plastic strain), or its stable step falls below
``failure_min_dt`` (stages/shell.py decides).  From then on it carries no load (its
stress, hourglass and drilling resultants are zeroed and it writes no nodal loads), sets no
time step and is no contact segment (stages/contact.py).  Its mass shares leave its corner
nodes (:meth:`MassUpdate.node_masses`): the particle domain stops contributing to the grid
in ``mpm`` mode, and a node left without a live element has no mass, stands still and is
skipped by P2G, G2P, the contact and the walls.  The energy the element had absorbed
(internal, hourglass, drilling) and the kinetic energy of its mass shares are booked as
eroded energy (energy.py), so the balance closes.  Rigid-body slave nodes keep their mass
(it is the body's, state.bodies.total_mass).

Mass scaling [choice; conventional as LS-DYNA's DT2MS < 0].  An element whose stable step
alpha L_e / c_e falls below the target step ``[solve].target_dt`` gets the density factor
f_e = (target / dt_e)^2 (its step goes as sqrt(f_e)), so that its step is the target; the
factor only grows.  The added mass (f_e - 1) m_e goes to the element's corners in its CPDI2
shares, at the node's current velocity: the kinetic energy that gives the added mass is
booked (energy.py: mass_scaling, an energy put in, like external work).  With
``mass_scaling = "selective"`` f_e - 1 is instead the factor beta_e of the element's added
mass matrix, which adds no mass (stages/selective_mass.py): the lumped masses and rotary
inertias stay physical, and the kinetic energy given to the added mass as beta_e grows is
booked alike.  With ``sms_solve = "reciprocal"`` an element's step is raised to at most its
shear zigzags' step alpha h / c_s (stages/timestep.zigzag_limit; 2.4 times its own for a
square steel element): the reciprocal mass matrix leaves an element's rigid tilt or spin
against its neighbours at the lumped mass, so those modes are then the highest
(stages/selective_mass.py, Reciprocal; docs/mass_scaling.md).  Conventional scaling: the run stops
once the total added mass exceeds ``[solve].added_mass_limit`` percent of the shell's
physical mass (STATUS_MASS_ADDED).  The grid rule of ``dt_rule = "both"`` and the contact
limit are not changed: mass scaling acts on the element rule only.

Nodal masses are recomputed every step from the elements' shares and the node's
[[point_mass]] entries M_c (state.nodes.point_mass; rotary J^pm_c likewise),
m_c = sum_e f_e alive_e m_ea + M_c, in element order, then the point masses (the order of
model/assembly.py's sums, so an unchanged node keeps its mass to the bit), through the CSR node ->
element slots (state.elements.node_slots).  A point mass never erodes and takes no added
mass: a node whose elements have all eroded keeps it and moves on as a free point mass
(issue 28: the rebuild took element shares only, so a point mass was lost after the first
step while gravity and parts.csv still counted it).  With erosion under ``[gravity]`` the
physical mass that gravity acts on, m^phys_c = sum_e alive_e m_ea + M_c (no density
factors), is rebuilt alike: gravity acts on the mass that remains, so a node that lost an
eroded element's share accelerates at g, not at (m + m_ea)/m g.
"""
import taichi as ti

from ..state import STATUS_MASS_ADDED, STATUS_OK
from .accumulate import Accumulator


@ti.data_oriented
class MassUpdate:
    def __init__(self, state, cfg):
        self.s = state
        self.cfg = cfg
        self.acc = Accumulator(cfg.serial)

    @ti.func
    def alive(self, e):
        """1.0 for a live element, 0.0 for an eroded one."""
        out = 1.0
        if ti.static(self.cfg.erosion):
            if self.s.elements.eroded[e] != 0:
                out = 0.0
        return out

    @ti.func
    def factor(self, e):
        """The element's density factor f_e (1 without mass scaling)."""
        out = 1.0
        if ti.static(self.cfg.mass_scaling):
            out = self.s.elements.mass_factor[e]
        return out

    @ti.func
    def plane(self, e, vec):
        """vec without its component along element e's normal (P_e vec; stages/selective_mass.py)."""
        n = self.s.elements.sms_normal[e]
        return vec - vec.dot(n) * n

    @ti.func
    def unit_kinetic(self, e, v, w, corners: ti.template()):
        """Selective mass scaling: T_add^e / beta_e, the kinetic energy of element e's added
        mass per unit beta_e, with the corner velocities v and angular velocities w (corners x 3)
        and the element's geometry kept at the start of the step (stages/selective_mass.py)."""
        c = self.s.elements.corners[e]
        m = self.s.elements.corner_mass[e]
        mass = 0.0
        mean = ti.Vector([0.0, 0.0, 0.0])
        h = ti.Vector([0.0, 0.0, 0.0])
        for a in ti.static(range(corners)):
            if c[a] >= 0:
                va = ti.Vector([v[a, 0], v[a, 1], v[a, 2]])
                mass += m[a]
                mean += m[a] * va
                h += m[a] * self.s.elements.sms_arm[e, a].cross(va)
        mean /= mass
        spin = self.s.elements.sms_inverse_inertia[e] @ h
        rho2 = self.s.elements.sms_radius_sq[e]
        out = 0.0
        for a in ti.static(range(corners)):
            if c[a] >= 0:
                va = ti.Vector([v[a, 0], v[a, 1], v[a, 2]])
                wa = ti.Vector([w[a, 0], w[a, 1], w[a, 2]])
                d = va - mean - spin.cross(self.s.elements.sms_arm[e, a])
                out += m[a] * (d.norm_sqr() + rho2 * self.plane(e, wa - spin).norm_sqr())
        return 0.5 * out

    @ti.func
    def corner_kinetic(self, e, c, v, w, scale, corners: ti.template()):
        """scale x the kinetic energy of element e's mass shares at its corners c (velocities v,
        angular velocities w as corners x 3), rigid-body slaves left out (they keep their mass)."""
        m, inertia = self.s.elements.corner_mass[e], self.s.elements.corner_inertia[e]
        out = 0.0
        for a in ti.static(range(corners)):
            if self.s.nodes.body[c[a]] < 0:
                va = ti.Vector([v[a, 0], v[a, 1], v[a, 2]])
                wa = ti.Vector([w[a, 0], w[a, 1], w[a, 2]])
                out += 0.5 * scale * (m[a] * va.norm_sqr() + inertia[a] * wa.norm_sqr())
        return out

    @ti.func
    def erode(self, e, c, v, w, corners: ti.template()):
        """Element e fails now: flag it and book the kinetic energy of its mass shares, which
        leave its nodes at the end of the step (node_masses), and of its added mass under
        selective scaling (stages/selective_mass.py; it leaves the step's kinetic energy here)."""
        kinetic = 0.0
        if ti.static(self.cfg.selective_mass):
            added = 0.0
            if ti.static(self.cfg.reciprocal_mass):     # its running sum (stages/selective_mass.py)
                added = self.s.elements.sms_excess[e]
                self.s.elements.sms_excess[e] = 0.0
            else:
                added = (self.factor(e) - 1.0) * self.unit_kinetic(e, v, w, corners)
            self.acc.total(self.s.step.kinetic, -added)
            kinetic = self.corner_kinetic(e, c, v, w, 1.0, corners) + added
        else:
            kinetic = self.corner_kinetic(e, c, v, w, self.factor(e), corners)
        self.s.elements.eroded[e] = 1
        self.s.elements.mass_energy[e][0] += kinetic
        self.acc.total(self.s.step.eroded_kinetic, kinetic)

    @ti.func
    def scale(self, e, c, v, w, limit, zigzag, corners: ti.template()):
        """Mass scaling of element e whose stable step with its physical mass is `limit`: raise
        f_e so that its step is at least the target (with the reciprocal mass matrix, at most
        its zigzag step `zigzag`: module docstring); returns its step."""
        f_old = self.s.elements.mass_factor[e]
        target = self.s.step.target_dt[None]
        if ti.static(self.cfg.reciprocal_mass):
            target = ti.min(target, ti.max(zigzag, limit))
        step = limit * ti.sqrt(f_old)
        if step < target:
            f_new = (target / limit) ** 2
            self.s.elements.mass_factor[e] = f_new
            gain = 0.0
            if ti.static(self.cfg.selective_mass):      # no mass added: beta grows (stages/selective_mass.py)
                if ti.static(not self.cfg.reciprocal_mass):     # (the reciprocal's: a running sum)
                    added = (f_new - f_old) * self.unit_kinetic(e, v, w, corners)
                    self.acc.total(self.s.step.kinetic, added)
                    gain = added
            else:
                self.acc.total(self.s.step.added_mass, (f_new - f_old) * self.s.elements.corner_mass[e].sum())
                gain = self.corner_kinetic(e, c, v, w, f_new - f_old, corners)
            self.s.elements.mass_energy[e][1] += gain
            self.acc.total(self.s.step.mass_scaling_energy, gain)
            step = target
        return step

    @ti.func
    def node_masses(self):
        """m_c and J_c from the live elements' shares x f_e and the node's point masses, and
        with erosion under gravity the physical mass (module docstring); a node whose mass has
        gone stands still from now on.  Rigid-body slaves keep theirs.  The step's kinetic
        energy (booked by the node update with the old masses) is brought to the new ones, so
        that the balance guard sees the eroded and added kinetic energy once."""
        for c in range(self.s.nodes.count[None]):
            if self.s.nodes.body[c] < 0:
                mass, inertia, physical = 0.0, 0.0, 0.0
                for i in range(self.s.elements.node_slot_start[c], self.s.elements.node_slot_start[c + 1]):
                    slot = self.s.elements.node_slots[i]
                    e, a = slot // 4, slot % 4
                    share = self.factor(e) * self.alive(e)
                    if ti.static(self.cfg.selective_mass):      # the lumped masses stay physical
                        share = self.alive(e)
                    mass += self.s.elements.corner_mass[e][a] * share
                    inertia += self.s.elements.corner_inertia[e][a] * share
                    if ti.static(self.cfg.erosion and self.cfg.loads):
                        physical += self.s.elements.corner_mass[e][a] * self.alive(e)
                mass += self.s.nodes.point_mass[c]
                inertia += self.s.nodes.point_inertia[c]
                if ti.static(self.cfg.erosion and self.cfg.loads):
                    self.s.nodes.physical_mass[c] = physical + self.s.nodes.point_mass[c]
                self.acc.total(self.s.step.kinetic,
                               0.5 * ((mass - self.s.nodes.mass[c]) * self.s.nodes.grid_velocity[c].norm_sqr()
                                      + (inertia - self.s.nodes.inertia[c]) * self.s.nodes.omega[c].norm_sqr()))
                if mass <= 0.0:
                    self.s.nodes.grid_velocity[c] = ti.Vector([0.0, 0.0, 0.0])
                    self.s.nodes.velocity[c] = ti.Vector([0.0, 0.0, 0.0])
                    self.s.nodes.omega[c] = ti.Vector([0.0, 0.0, 0.0])
                    if ti.static(self.cfg.affine_transfer):
                        self.s.nodes.affine[c] = ti.Matrix.zero(ti.f64, 3, 3)
                    if ti.static(self.cfg.velocity_modes):
                        self.s.nodes.velocity_modes[c] = ti.Matrix.zero(ti.f64, 3, 4)
                self.s.nodes.mass[c] = mass
                self.s.nodes.inertia[c] = inertia

    @ti.func
    def guard(self):
        """Stop once the added mass exceeds its cap (STATUS_MASS_ADDED; a cap of 0: never)."""
        if ti.static(self.cfg.mass_scaling):
            cap = self.s.step.added_mass_cap[None]
            if cap > 0.0 and self.s.step.added_mass[None] > cap and self.s.step.status[None] == STATUS_OK:
                self.s.step.status[None] = STATUS_MASS_ADDED
                self.s.step.status_index[None] = -1
