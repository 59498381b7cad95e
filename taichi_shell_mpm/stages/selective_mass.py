"""Selective mass scaling (issue 29; docs/mass_scaling.md): an added mass matrix on the
deformation modes of each element below the target step, and the solve
(M + M_add) [a, alpha] = [f, mu] of the step's node update (``fem`` mode), compiled only for
scenes with ``[solve].mass_scaling = "selective"`` (Features.selective_mass).

Added mass [choice, measured in docs/mass_scaling.md].  Element e, whose factor
f_e = (target / dt_e)^2 >= 1 is kept by stages/masses.py (it only grows), adds the kinetic
energy

    T_add^e = beta_e / 2 (sum_a m_a |d_a|^2 + sum_a j_a |P_e (omega_a - Omega_e)|^2),  beta_e = f_e - 1,

m_a the element's CPDI2 shares of its mass (model/assembly.py), j_a = m_a rho_e^2 with
rho_e^2 = sum_a m_a |r_a|^2 / (2 m_e) (its mean moment of inertia per unit mass about an
axis in its plane), r_a = x_a - xbar_e the corners about their mass centre at the start of
the step.  The element's rigid motion is fitted to its corners' velocities v_a in the mass
metric: vbar_e their mean, Omega_e = J_e^-1 sum_a m_a r_a x v_a (J_e = sum_a m_a (|r_a|^2 I -
r_a r_a^T)); d_a = v_a - vbar_e - Omega_e x r_a is what is left (the membrane and warping
modes), and P_e (omega_a - Omega_e), P_e = I - n_e n_e^T the projection on the element's
plane, is how far a node's rotation departs from the element's rigid rotation (the
transverse-shear modes; the drilling rotation carries no stiffness of a BT quad or a C0
triangle).  An OPT triangle ([element].triangle = "opt") bends in its plane through its corner
drilling rotations, so there P_e = I: its normal is kept as zero (elements.sms_normal) and the
drilling modes are scaled with the rest [measured in docs/mass_scaling.md, "OPT triangles":
with P_e the matrix's sheet in OPT triangles at ten times its step ran away at step 5].  T_add is zero on every
rigid motion of the element (translation and rotation), and on a smooth bending mode, whose
corners move as the element turns with its nodes: so total mass, linear and angular momentum
are those of the lumped masses M (its translational rows and its moments sum to zero), and
the low modes keep their physical inertia (up to their nodes' rotations departing from the
elements' mean tilts on a curved mode, a share growing as beta (k h)^4: visible on a coarse
mesh, docs/mass_scaling.md, the spectrum study), while each mode that deforms one element sees
(1 + beta_e) its mass and its frequency, and so the step, goes by sqrt(f_e).  The lumped
masses and rotary inertias stay physical (the nodal rotation modes are scaled by the j_a
term): scaling the rotary inertia by f_e, or a translation-only matrix beta (m_e/n)(I -
1 1^T/n) (Olovsson, Simonsson & Unosson, IJNME 63, 2005), which loads each element's
rotation about its own centre, moved a coarse strip's lowest bending period by 39 % and
94 % at 10x the step (docs/mass_scaling.md: on a coarse shell mesh the low bending modes
are element rotations).  M_add = d^2 T_add / dv^2 is applied matrix-free (:meth:`SelectiveMass.product`):
per element vbar, Omega and J^-1 g, g = sum_a j_a P (omega_a - Omega); then at each corner
beta m_a (d_a + r_a x J^-1 g) on the translations and beta j_a P (omega_a - Omega) on the
rotations, gathered per node through the node -> element slots.

Geometry.  r_a, J_e^-1, n_e and rho_e^2 are those of the start of the step (positions x^n),
kept per element (and checkpointed), so the step's matrix is one matrix.  When the next step
moves them, T_add at the same velocities changes: that change is booked as mass-scaling
energy (energy put in, like the kinetic energy given to beta_e as it grows), so the balance
closes (:meth:`SelectiveMass.geometry`).

Constraints.  The solve runs over the free DOFs: a DOF held by a [[boundary]] or a
[[motion]] and a node without mass are left out, and a node's
rotation is kept normal to its drilling normal where the drilling projection applies
(P M P, P the orthogonal projection on the free DOFs).  A held node's support reaction takes
the added mass's inertial force too (state.nodes.sms_product), so reactions use the scaled
mass matrix.  A rigid body's slaves are in the solve through their body (Bodies, below).

Bodies [choice, measured in docs/mass_scaling.md].  With rigid bodies (Features.bodies) each
body's translation A and rotation Alpha are unknowns of the same solve: a slave's rows are
its body's rigid field, a_s = A + Alpha x r_s and alpha_s = Alpha (r_s = x_s - x_c at t^n;
:meth:`SelectiveMass.spread`), so the matrix is P^T (M + M_add) P with P that map, whose body
rows are M_tot A + sum_s (M_add a)_s and I Alpha + sum_s (r_s x (M_add a)_s + (M_add alpha)_s)
on the body's free DOFs (its projectors; :meth:`SelectiveMass.body_product`) against its
load F, M at t^n (RigidBodies.loads_on); the preconditioner's body block is M_tot and I (the
slaves' lumped masses are in them).  The solve runs before RigidBodies.update
(:meth:`SelectiveMass.prepare`), whose kick takes M_tot A on the free translations (so the
momentum correction below, which moves the bodies with the nodes, makes
sum m a + sum M_tot A = sum f exact) and M less the added mass's inertial moment at the
slaves for the rotation (the body's own integrator keeps its gyroscopic terms, which the
solve's linear rows leave out: the slaves' actual velocities differ from v_s + dt a_s by
them, and constraint_work books that difference).  The slaves are then free DOFs for
constraint_work (their added mass's work is in the body's kick).  Leaving the slaves out of
the solve let the momentum of the feature matrix's sheet with a spinning bar on one edge
drift 0.026 m/s per unit mass; the added mass's force at the slaves given to the body as an
impulse at the end of the step (a partitioned coupling, one step late) kept the momentum but
sent the balance to 61 % (the added-mass instability).  In the solve: momentum to 1e-15,
balance 2.3e-5 (tests/test_selective_mass.py).

A step that changes [choice, measured in docs/mass_scaling.md].  With the averaged kick
h = (dt^(n-1/2) + dt^(n+1/2)) / 2 (stages/timestep.impulse_time) and linear forces, the
balance's conserved quantity E^n = 1/2 v^(n+1/2) M v^(n+1/2) + 1/2 x^n K x^(n+1) (the kinetic
energy, the stored energy and energy.py's stagger term) changes in a step by exactly
(dt^(n+1/2) - dt^(n-1/2)) h / 4 f_int . a (f_int = K x^n the internal forces, a the step's
solved accelerations; M the scaled mass matrix): zero at a constant step, and where a tool or
contact shortens the step, a jump of the balance by an (omega dt)^2-sized share of the
energy of the modes at omega dt ~ 1, where selective scaling puts the low modes (the feature
matrix's sheet with a sphere tool: a step cut by 30 % read +5 % of the absorbed energy as
created, and the guard stopped it).  :meth:`SelectiveMass.step_change` books it as
mass-scaling energy, so the balance stays a check on instabilities and bookkeeping.  What
it does not hide: the motion's own energy does change at a step change (a harmonic
oscillator at omega dt = 0.78 cut to 0.55: its amplitude^2 by -0.7 to -7.4 % with the
phase; -4.3 % when the step is ramped down over 10 to 1000 steps, the adiabatic invariant
being E / omega~, not E), so a step that changes slowly would not remove the jump, only its
phase dependence.

Solve [choice, measured in docs/mass_scaling.md].  Conjugate gradients preconditioned with
the element blocks' exact inverses (additive, element by element): each live element takes
its shares of the residual (m_a / m_c of a node's force, J_a / J_c of its moment, J_a its
share of the rotary inertia), inverts its own block of M + M_add on them in closed form
(:meth:`SelectiveMass.element_block_inverse`: rigid translation, a 3 x 3 solve for its spin,
the deformation over (1 + beta_e), the rotations), and returns the result in the same
shares; a node's point masses add res / m_c in their share.  Symmetric, positive definite and
exact for beta = 0.  A smooth field, which the added mass does not see, passes as it is, where
a diagonal (Jacobi) divides it by ~(1 + beta) [measured on the 16 x 2 strip at 10x the step,
tolerance 1e-5: Jacobi ~120 iterations per step, the block inverses 23].  The solve starts
from the last step's accelerations (or from zero where that is worse) and stops once
|res|_P^-1 <= sms_tolerance |rhs|_P^-1 (1e-5 by default: at 1e-3 the strip's balance grew to
5 % of the absorbed energy and the guard stopped it); not converged in sms_max_iterations:
STATUS_SMS_SOLVE.  The iterations run in one serial block of the step's kernel (a
``for _ in range(1)``: Taichi runs the loops nested in it on one thread) [choice]: the
iteration count is a run-time decision, a kernel cannot launch parallel loops from inside a
loop, and a launch per iteration from Python costs ~100 us against a few us of work.  After
the solve the translational accelerations get the uniform correction sum(res) / sum(m) per
axis over the free DOFs, which makes sum m_c a_c = sum f_c (the linear momentum) exact
whatever the tolerance, since M_add's translational rows sum to zero.

Reciprocal [choice, measured in docs/mass_scaling.md; ``sms_solve = "reciprocal"``].  The
preconditioner P^-1 above is itself a mass matrix's inverse: symmetric, positive definite,
sparse (element blocks), and exact on rigid motions (an element block returns a rigid field
as it is, and the shares sum to one at a node), so a = P^-1 f keeps the linear and angular
momenta of the lumped masses to round-off (1^T M P^-1 = 1^T) while each element's
deformation modes see (1 + beta_e) their mass: a reciprocal mass matrix (Tkachuk & Bischoff,
IJNME 101, 2015, build such inverses directly), applied with no iterations
(:meth:`apply_reciprocal`, parallel loops).  What it cannot see: an element tilted or spun
rigidly against its neighbours (shear zigzags, transverse with the nodes' rotations still, and
in-plane) is a rigid motion of each block, so those modes keep the lumped mass, and their
frequencies ~2 c_s / h (c_s = sqrt(G / rho), h the element's narrowest width) cap the step:
stages/masses.py raises an element's step to at most alpha h / c_s
(stages/timestep.zigzag_limit) [measured in docs/mass_scaling.md: with sqrt(kappa G / rho)
the 16 x 2 strip of square elements ran at the cap, 2.62x its own step, and the guard stopped
it at 1.1x, where the free plate's highest in-plane mode sat at omega dt / 2 = 0.90].  Kinetic
energy: 1/2 v^T P v cannot be formed without a solve, so each element keeps the running sum
of its share of the step's change of 1/2 v^T (P - M) v, h v_mid . (f - M a) at its corners
(state.elements.sms_excess; :meth:`reciprocal_kinetic`): exact for a constant matrix, while
the change of P with the geometry and with beta_e is not booked (the consistent matrix books
it as mass-scaling energy).  A rigid body's slaves take no part in the element blocks' input
(their loads are the body's); what the blocks hand them, m_s z_s, goes to the body within the
step, which keeps the momentum exact and the balance closed (the tube's ram: balance -0.57 J
of 480 J absorbed when the body took M_tot^-1 F alone; 1e-3 J with the hand-over).
"""
import taichi as ti

from ..state import STATUS_OK, STATUS_SMS_SOLVE
from .accumulate import Accumulator, serial_loop
from .bodies import constrained_omega
from .timestep import impulse_time


@ti.func
def zero3():
    """A zero 3-vector (a local that loops may add to)."""
    return ti.Vector([0.0, 0.0, 0.0])


@ti.data_oriented
class SelectiveMass:
    def __init__(self, state, cfg, masses, nodes, bodies):
        self.s = state
        self.cfg = cfg
        self.masses = masses            # stages/masses.MassUpdate: f_e and alive_e
        self.nodes = nodes              # stages/constraints.NodeUpdate: held DOFs, forces
        self.bodies = bodies            # stages/bodies.RigidBodies: the rigid bodies' DOFs join the solve
        self.coupled = cfg.bodies       # (module docstring, Bodies)
        self.reciprocal = cfg.reciprocal_mass     # (module docstring, Reciprocal)
        self.rows = state.bodies        # the bodies' rows of the solve (placed in every run; used when coupled)
        self.acc = Accumulator(cfg.serial)

    # ------------------------------------------------------------------ one element
    @ti.func
    def beta(self, e):
        """beta_e = f_e - 1 of a live element (0 for an eroded one)."""
        return (self.s.elements.mass_factor[e] - 1.0) * self.masses.alive(e)

    @ti.func
    def node_kinetic(self, e):
        """T_add^e / beta_e at the nodes' velocities now (a quad's or a triangle's corners)."""
        c = self.s.elements.corners[e]
        v = ti.Matrix.zero(ti.f64, 4, 3)
        w = ti.Matrix.zero(ti.f64, 4, 3)
        for a in ti.static(range(4)):
            if c[a] >= 0:
                for d in ti.static(range(3)):
                    v[a, d] = self.s.nodes.grid_velocity[c[a]][d]
                    w[a, d] = self.s.nodes.omega[c[a]][d]
        return self.masses.unit_kinetic(e, v, w, 4)

    @ti.func
    def corner_mean(self, e, field: ti.template()):
        """Element e's mass sum_a m_a and the mass-weighted mean of a node field over its
        corners, sum_a m_a field_a / sum_a m_a (m_a its shares)."""
        c = self.s.elements.corners[e]
        m = self.s.elements.corner_mass[e]
        mass = 0.0
        total = zero3()
        for a in ti.static(range(4)):
            if c[a] >= 0:
                mass += m[a]
                total += m[a] * field[c[a]]
        return mass, total / mass

    @ti.func
    def geometry(self):
        """At the start of the step: each live element's geometry (:meth:`element_geometry`),
        and the change of T_add this brings at the present velocities, booked as
        mass-scaling energy (module docstring).  (The reciprocal matrix forms it in its own
        element loop, :meth:`apply_reciprocal`.)"""
        for e in range(self.s.elements.count[None]):
            if self.masses.alive(e) > 0.0:
                b = self.beta(e)
                before = b * self.node_kinetic(e)
                self.element_geometry(e)
                if b > 0.0:
                    change = b * self.node_kinetic(e) - before
                    self.s.elements.mass_energy[e][1] += change
                    self.acc.total(self.s.step.mass_scaling_energy, change)

    @ti.func
    def element_geometry(self, e):
        """Element e's r_a, J_e^-1, n_e and rho_e^2 at x^n, and the spin block (J_e + gamma P)^-1
        of its inverse (:meth:`element_block_inverse`) with this step's beta_e."""
        b = self.beta(e)
        c = self.s.elements.corners[e]
        m = self.s.elements.corner_mass[e]
        mass, centre = self.corner_mean(e, self.s.nodes.position)
        inertia = ti.Matrix.zero(ti.f64, 3, 3)
        spread = 0.0
        for a in ti.static(range(4)):
            r = zero3()
            if c[a] >= 0:
                r = self.s.nodes.position[c[a]] - centre
                inertia += m[a] * (r.norm_sqr() * ti.Matrix.identity(ti.f64, 3) - r.outer_product(r))
                spread += m[a] * r.norm_sqr()
            self.s.elements.sms_arm[e, a] = r
        x0, x1, x2 = self.s.nodes.position[c[0]], self.s.nodes.position[c[1]], self.s.nodes.position[c[2]]
        normal = (x1 - x0).cross(x2 - x0)
        if c[3] >= 0:
            normal = (x2 - x0).cross(self.s.nodes.position[c[3]] - x1)
        unit = normal.normalized()
        if ti.static(self.cfg.triangle_opt):
            if c[3] < 0:        # an OPT triangle's drilling rotations carry its membrane: scaled too
                unit = zero3()
        self.s.elements.sms_normal[e] = unit
        self.s.elements.sms_inverse_inertia[e] = inertia.inverse()
        rho2 = spread / (2.0 * mass)
        self.s.elements.sms_radius_sq[e] = rho2
        gamma = 0.0
        for a in ti.static(range(4)):
            if c[a] >= 0:
                ja = b * m[a] * rho2
                gamma += ja * self.s.elements.corner_inertia[e][a] / (self.s.elements.corner_inertia[e][a] + ja)
        self.s.elements.sms_spin_block[e] = (inertia + gamma * (ti.Matrix.identity(ti.f64, 3)
                                                                - unit.outer_product(unit))).inverse()

    # ------------------------------------------------------------------ the product M p
    @ti.func
    def rigid_fit(self, p: ti.template(), q: ti.template()):
        """Per element: vbar, Omega and J^-1 g of the node fields (p, q), and from them each
        corner's share of M_add [p, q], beta m_a (p_a - vbar - Omega x r_a + r_a x J^-1 g) and
        beta m_a rho^2 P (q_a - Omega), in sms_corner_step, sms_corner_turn (zero without added
        mass) for :meth:`added_at` [choice: formed here, where the element's fit is at hand, so
        the node loop only sums them instead of reading the fit again per slot; the pcg tube's
        tables to 0.3 ms were the same to the bit but for round-off in the support's x and y
        reactions, 4e-15 kN of zero, the compiler's fused multiply-adds falling elsewhere]."""
        for e in range(self.s.elements.count[None]):
            c = self.s.elements.corners[e]
            b = self.beta(e)
            mean, spin, coupling = zero3(), zero3(), zero3()
            if b > 0.0:
                m = self.s.elements.corner_mass[e]
                _, mean = self.corner_mean(e, p)
                h = zero3()
                for a in ti.static(range(4)):
                    if c[a] >= 0:
                        h += m[a] * self.s.elements.sms_arm[e, a].cross(p[c[a]])
                spin = self.s.elements.sms_inverse_inertia[e] @ h
                g = zero3()
                for a in ti.static(range(4)):
                    if c[a] >= 0:
                        g += m[a] * self.masses.plane(e, q[c[a]] - spin)
                coupling = self.s.elements.sms_inverse_inertia[e] @ (self.s.elements.sms_radius_sq[e] * g)
            for a in ti.static(range(4)):
                force, moment = zero3(), zero3()
                if b > 0.0 and c[a] >= 0:
                    share = b * self.s.elements.corner_mass[e][a]
                    r = self.s.elements.sms_arm[e, a]
                    force = share * (p[c[a]] - mean - spin.cross(r) + r.cross(coupling))
                    moment = share * self.s.elements.sms_radius_sq[e] * self.masses.plane(e, q[c[a]] - spin)
                self.s.elements.sms_corner_step[e, a] = force
                self.s.elements.sms_corner_turn[e, a] = moment

    @ti.func
    def added_at(self, c):
        """(M_add [p, q]) at node c, translation and rotation: the sum of its elements' corner
        shares (:meth:`rigid_fit` of p, q holds them), in ascending element order."""
        force, moment = zero3(), zero3()
        for i in range(self.s.elements.node_slot_start[c], self.s.elements.node_slot_start[c + 1]):
            slot = self.s.elements.node_slots[i]
            force += self.s.elements.sms_corner_step[slot // 4, slot % 4]
            moment += self.s.elements.sms_corner_turn[slot // 4, slot % 4]
        return force, moment

    @ti.func
    def free_translation(self, c, vec):
        """vec with node c's held translations dropped."""
        return self.s.nodes.free_dofs[c] * vec

    @ti.func
    def free_rotation(self, c, vec):
        """The orthogonal projection of vec on node c's free rotations: its held axes dropped,
        and its component along the drilling normal (masked as well) where that applies."""
        out = self.s.nodes.free_rotations[c] * vec
        n = self.s.nodes.sms_drill_normal[c]
        return out - out.dot(n) * n

    @ti.func
    def product(self, p: ti.template(), q: ti.template(), bp: ti.template(), bq: ti.template()):
        """sms_product, sms_moment = P (M + M_add) P [p, q] (p, q already free); with bodies
        (``coupled``) the slaves' rows of p, q are first set from their bodies' bp, bq, and
        the bodies' rows of the product are formed (:meth:`body_product`)."""
        if ti.static(self.coupled):
            self.spread(p, q, bp, bq)
        self.rigid_fit(p, q)
        for c in range(self.s.nodes.count[None]):
            force, moment = self.added_at(c)
            self.s.nodes.sms_product[c] = self.free_translation(c, self.s.nodes.mass[c] * p[c] + force)
            self.s.nodes.sms_moment[c] = self.free_rotation(c, self.s.nodes.inertia[c] * q[c] + moment)
        if ti.static(self.coupled):
            self.body_product(p, q, bp, bq)

    # ------------------------------------------------------------------ rigid bodies in the solve
    @ti.func
    def body_copy(self, out: ti.template(), a: ti.template(), scale, b: ti.template(), keep=1.0):
        """out = keep a + scale b over the bodies' rows (the solve's vector updates)."""
        for k in range(self.s.bodies.count[None]):
            out[k] = keep * a[k] + scale * b[k]

    @ti.func
    def body_inertia(self, b):
        """Body b's rotary inertia about its centre in space axes at t^n, R J R^T."""
        r = self.bodies.rotation_matrix(b)
        return r @ self.s.bodies.inertia[b] @ r.transpose()

    @ti.func
    def spread(self, p: ti.template(), q: ti.template(), bp: ti.template(), bq: ti.template()):
        """The slaves' rows of [p, q] from their bodies' [bp, bq]: p_s = P_b + Q_b x r_s,
        q_s = Q_b (0 for a body that does not turn), r_s = x_s - x_c at t^n."""
        for b in range(self.s.bodies.count[None]):
            x_c = self.bodies.center(b)
            turn = zero3()
            if ti.static(self.cfg.body_rotation):
                turn = bq[b]
            for i in range(self.s.bodies.first_slave[b], self.s.bodies.first_slave[b] + self.s.bodies.slave_count[b]):
                c = self.s.bodies.slave_nodes[i]
                p[c] = bp[b] + turn.cross(self.s.nodes.position[c] - x_c)
                q[c] = turn

    @ti.func
    def slave_sum(self, b, force: ti.template(), moment: ti.template()):
        """sum_s force_s and sum_s (r_s x force_s + moment_s) over body b's slaves (the
        transpose of :meth:`spread`; the moment 0 for a body that does not turn)."""
        x_c = self.bodies.center(b)
        total, turn = zero3(), zero3()
        for i in range(self.s.bodies.first_slave[b], self.s.bodies.first_slave[b] + self.s.bodies.slave_count[b]):
            c = self.s.bodies.slave_nodes[i]
            total += force[c]
            if ti.static(self.cfg.body_rotation):
                turn += (self.s.nodes.position[c] - x_c).cross(force[c]) + moment[c]
        return total, turn

    @ti.func
    def body_product(self, p: ti.template(), q: ti.template(), bp: ti.template(), bq: ti.template()):
        """Each body's rows of P^T (M + M_add) P: M_tot P_b + sum_s (M_add [p, q])_s and
        I Q_b + sum_s (r_s x (M_add [p, q])_s + its moment_s), on the body's free DOFs (its
        projectors; rigid_fit holds the fits of p, q).  The slaves' own lumped masses are in
        M_tot and I (model/bodies.py), not added again."""
        for b in range(self.s.bodies.count[None]):
            x_c = self.bodies.center(b)
            force = self.s.bodies.total_mass[b] * bp[b]
            torque = zero3()
            if ti.static(self.cfg.body_rotation):
                torque = self.body_inertia(b) @ bq[b]
            for i in range(self.s.bodies.first_slave[b], self.s.bodies.first_slave[b] + self.s.bodies.slave_count[b]):
                c = self.s.bodies.slave_nodes[i]
                f, moment = self.added_at(c)
                force += f
                if ti.static(self.cfg.body_rotation):
                    torque += (self.s.nodes.position[c] - x_c).cross(f) + moment
            self.s.bodies.sms_product[b] = self.s.bodies.translation_free[b] @ force
            self.s.bodies.sms_moment[b] = self.s.bodies.rotation_free[b] @ torque

    @ti.func
    def body_forces(self):
        """Each body's right-hand side, its load F and moment M at t^n on its free DOFs
        (RigidBodies.loads_on, with the applied moment), and its first guess, the last step's
        accelerations."""
        for b in range(self.s.bodies.count[None]):
            force, moment, _w, _l, _lm, _c, _cm = self.bodies.loads_on(b, self.bodies.center(b))
            free, turn = self.s.bodies.translation_free[b], self.s.bodies.rotation_free[b]
            self.s.bodies.sms_force[b] = free @ force
            self.s.bodies.sms_acceleration[b] = free @ self.s.bodies.sms_acceleration[b]
            torque = zero3()
            if ti.static(self.cfg.body_rotation):
                torque = turn @ (moment + self.s.bodies.applied_moment[b])
                self.s.bodies.sms_angular_acceleration[b] = turn @ self.s.bodies.sms_angular_acceleration[b]
            self.s.bodies.sms_torque[b] = torque

    @ti.func
    def body_precondition(self):
        """Each body's block of the preconditioner, its own mass and inertia on its free DOFs:
        sms_step = P_t res / M_tot, (P_r I P_r)^+ res_moment; returns their res . P^-1 res.
        [choice, measured on the matrix's sheet with a spinning bar: 23.7 iterations per step,
        the sheet alone 13.7; the body's exact diagonal block P^T (M + M_add) P, with the added
        mass its slaves meet moving alone, took 49: the body moves with its neighbours, whose
        joint rigid motion the added mass does not see, so the block that charges it is the
        worse guess.]"""
        out = 0.0
        for b in range(self.s.bodies.count[None]):
            z = self.s.bodies.translation_free[b] @ self.s.bodies.sms_residual[b] / self.s.bodies.total_mass[b]
            zr = zero3()
            if ti.static(self.cfg.body_rotation):
                zr = constrained_omega(self.body_inertia(b), self.s.bodies.rotation_free[b],
                                       self.s.bodies.sms_residual_moment[b])
            self.s.bodies.sms_step[b] = z
            self.s.bodies.sms_step_moment[b] = zr
            out += z.dot(self.s.bodies.sms_residual[b]) + zr.dot(self.s.bodies.sms_residual_moment[b])
        return out

    @ti.func
    def body_added(self):
        """After the solve: the added mass's inertial force at each body's slaves, summed on the
        body (its kick takes it: RigidBodies.update), and the slaves taken as free DOFs for
        constraint_work (they are the body's, which books their added mass's work)."""
        for b in range(self.s.bodies.count[None]):
            force, moment = self.slave_sum(b, self.s.nodes.sms_product, self.s.nodes.sms_moment)
            self.s.bodies.sms_added_force[b] = force
            self.s.bodies.sms_added_moment[b] = moment
            for i in range(self.s.bodies.first_slave[b], self.s.bodies.first_slave[b] + self.s.bodies.slave_count[b]):
                c = self.s.bodies.slave_nodes[i]
                self.s.nodes.free_dofs[c] = ti.Vector([1.0, 1.0, 1.0])
                if ti.static(self.cfg.body_rotation):
                    self.s.nodes.free_rotations[c] = ti.Vector([1.0, 1.0, 1.0])

    # ------------------------------------------------------------------ the solve
    @ti.func
    def forces(self):
        """The right-hand side: each node's free DOFs, its out-of-balance force and moment on
        them, and its live elements' shares of its mass and rotary inertia; the first guess
        is the last step's accelerations on the free DOFs."""
        serial_loop(self.cfg.serial_node_loops)
        for c in range(self.s.nodes.count[None]):
            self.s.nodes.free_dofs[c] = zero3()
            self.s.nodes.free_rotations[c] = zero3()
            self.s.nodes.sms_drill_normal[c] = zero3()
            self.s.nodes.sms_force[c] = zero3()
            self.s.nodes.sms_torque[c] = zero3()
            self.s.nodes.sms_share[c] = ti.Vector([0.0, 0.0])
            if not self.nodes.is_idle(c):
                held = self.nodes.held(c)
                self.s.nodes.free_dofs[c] = ti.Vector([1.0 - (held & 1), 1.0 - ((held >> 1) & 1),
                                                       1.0 - ((held >> 2) & 1)], ti.f64)
                free = ti.Vector([1.0 - ((held >> 3) & 1), 1.0 - ((held >> 4) & 1), 1.0 - ((held >> 5) & 1)], ti.f64)
                self.s.nodes.free_rotations[c] = free
                normal, project = self.nodes.drill_normal(c)
                if project:
                    n = free * normal
                    if n.norm() > 1e-12:
                        self.s.nodes.sms_drill_normal[c] = n.normalized()
                r = self.nodes.residual_force(c)
                self.acc.total(self.s.step.residual_sq, r.norm_sqr())
                self.s.nodes.sms_force[c] = r
                self.s.nodes.sms_torque[c] = self.free_rotation(c, self.nodes.residual_torque(c))
                share = ti.Vector([0.0, 0.0])
                for i in range(self.s.elements.node_slot_start[c], self.s.elements.node_slot_start[c + 1]):
                    slot = self.s.elements.node_slots[i]
                    e, a = slot // 4, slot % 4
                    share += self.masses.alive(e) * ti.Vector([self.s.elements.corner_mass[e][a],
                                                                self.s.elements.corner_inertia[e][a]])
                self.s.nodes.sms_share[c] = share
            self.s.nodes.acceleration[c] = self.free_translation(c, self.s.nodes.acceleration[c])
            self.s.nodes.angular_acceleration[c] = self.free_rotation(c, self.s.nodes.angular_acceleration[c])
        if ti.static(self.coupled):
            self.body_forces()

    @ti.func
    def element_block_inverse(self, e, res: ti.template(), res_moment: ti.template()):
        """This element's block inverse of its shares of the node vector (res, res_moment), per
        corner in sms_corner_step, sms_corner_turn (module docstring, Solve; :meth:`inverse_at`
        gathers them).  With the shares f_a = (m_a / m_c) res_c and
        t_a = (J_a / J_c) res_moment_c: the rigid translation sum f / m_e; the spin Omega from
        (J_e + gamma P) Omega = tau + sum_a beta j_a P t_a / (J_a + beta j_a), tau = sum r_a x f_a,
        gamma = sum_a beta j_a J_a / (J_a + beta j_a) (the inverse kept by geometry); the deformation (f_a - m_a (fbar + J^-1 tau x r_a))
        / ((1 + beta) m_a); each rotation (P t_a + beta j_a P Omega) / (J_a + beta j_a) in the
        plane, t_a / J_a along the normal.  The results go back in the same shares."""
        c = self.s.elements.corners[e]
        m = self.s.elements.corner_mass[e]
        inertia = self.s.elements.corner_inertia[e]
        b = self.beta(e)
        n = self.s.elements.sms_normal[e]
        rho2 = self.s.elements.sms_radius_sq[e]
        f = ti.Matrix.zero(ti.f64, 4, 3)
        t = ti.Matrix.zero(ti.f64, 4, 3)
        mass = 0.0
        total = zero3()
        tau = zero3()
        for a in ti.static(range(4)):
            if c[a] >= 0:
                fa = m[a] / self.s.nodes.mass[c[a]] * res[c[a]]
                ta = inertia[a] / self.s.nodes.inertia[c[a]] * res_moment[c[a]]
                for d in ti.static(range(3)):
                    f[a, d] = fa[d]
                    t[a, d] = ta[d]
                mass += m[a]
                total += fa
                tau += self.s.elements.sms_arm[e, a].cross(fa)
        spin_rhs = tau
        for a in ti.static(range(4)):
            if c[a] >= 0:
                ja = b * m[a] * rho2
                ta = ti.Vector([t[a, 0], t[a, 1], t[a, 2]])
                spin_rhs += ja * self.masses.plane(e, ta) / (inertia[a] + ja)
        spin = self.s.elements.sms_spin_block[e] @ spin_rhs
        mean = total / mass
        rigid_spin = self.s.elements.sms_inverse_inertia[e] @ tau
        for a in ti.static(range(4)):
            if c[a] >= 0:
                r = self.s.elements.sms_arm[e, a]
                fa = ti.Vector([f[a, 0], f[a, 1], f[a, 2]])
                ta = ti.Vector([t[a, 0], t[a, 1], t[a, 2]])
                z = mean + spin.cross(r)
                if m[a] > 0.0:
                    z += (fa - m[a] * (mean + rigid_spin.cross(r))) / ((1.0 + b) * m[a])
                ja = b * m[a] * rho2
                normal_part = ta.dot(n) * n
                w = (ta - normal_part + ja * self.masses.plane(e, spin)) / (inertia[a] + ja) + normal_part / inertia[a]
                self.s.elements.sms_corner_step[e, a] = m[a] / self.s.nodes.mass[c[a]] * z
                self.s.elements.sms_corner_turn[e, a] = inertia[a] / self.s.nodes.inertia[c[a]] * w

    @ti.func
    def gathered(self, c):
        """The sums of node c's live elements' corner results (:meth:`element_block_inverse`), in
        ascending element order."""
        step, turn = zero3(), zero3()
        for i in range(self.s.elements.node_slot_start[c], self.s.elements.node_slot_start[c + 1]):
            slot = self.s.elements.node_slots[i]
            e, a = slot // 4, slot % 4
            if self.masses.alive(e) > 0.0:
                step += self.s.elements.sms_corner_step[e, a]
                turn += self.s.elements.sms_corner_turn[e, a]
        return step, turn

    @ti.func
    def inverse_at(self, c, res: ti.template(), res_moment: ti.template()):
        """(P^-1 [res, res_moment]) at node c: its live elements' corner results
        (:meth:`element_block_inverse`, in ascending element order) and its point masses' part,
        res / m_c in their share, on its free DOFs (0 at a node without mass)."""
        z, zr = zero3(), zero3()
        if self.s.nodes.mass[c] > 0.0:          # (a node without mass has no free DOF)
            step, turn = self.gathered(c)
            share = self.s.nodes.sms_share[c]
            mass, inertia = self.s.nodes.mass[c], self.s.nodes.inertia[c]
            z = self.free_translation(c, step + (mass - share[0]) / mass ** 2 * res[c])
            zr = self.free_rotation(c, turn + (inertia - share[1]) / inertia ** 2 * res_moment[c])
        return z, zr

    @ti.func
    def precondition(self):
        """sms_step = P^-1 residual; returns residual . P^-1 residual (serial; module
        docstring, Solve): the element blocks' inverses of their shares of the residual,
        summed in the same shares, plus the nodes' point masses' part."""
        for e in range(self.s.elements.count[None]):
            if self.masses.alive(e) > 0.0:
                self.element_block_inverse(e, self.s.nodes.sms_residual, self.s.nodes.sms_residual_moment)
        out = 0.0
        for c in range(self.s.nodes.count[None]):
            z, zr = self.inverse_at(c, self.s.nodes.sms_residual, self.s.nodes.sms_residual_moment)
            self.s.nodes.sms_step[c] = z
            self.s.nodes.sms_step_moment[c] = zr
            out += z.dot(self.s.nodes.sms_residual[c]) + zr.dot(self.s.nodes.sms_residual_moment[c])
        if ti.static(self.coupled):
            out += self.body_precondition()
        return out

    @ti.func
    def solve(self):
        """The preconditioned conjugate gradients of the module docstring, in one serial block;
        then the momentum correction.  Books the iteration counts."""
        for _ in range(1):          # one thread: the loops below are serial
            n = self.s.nodes.count[None]
            for c in range(n):
                self.s.nodes.sms_residual[c] = self.s.nodes.sms_force[c]
                self.s.nodes.sms_residual_moment[c] = self.s.nodes.sms_torque[c]
            if ti.static(self.coupled):
                self.body_copy(self.rows.sms_residual, self.rows.sms_force, 0.0, self.rows.sms_force)
                self.body_copy(self.rows.sms_residual_moment, self.rows.sms_torque, 0.0, self.rows.sms_torque)
            bz = self.precondition()
            self.product(self.s.nodes.acceleration, self.s.nodes.angular_acceleration,
                         self.rows.sms_acceleration, self.rows.sms_angular_acceleration)
            for c in range(n):
                self.s.nodes.sms_residual[c] = self.s.nodes.sms_force[c] - self.s.nodes.sms_product[c]
                self.s.nodes.sms_residual_moment[c] = self.s.nodes.sms_torque[c] - self.s.nodes.sms_moment[c]
            if ti.static(self.coupled):
                self.body_copy(self.rows.sms_residual, self.rows.sms_force, -1.0, self.rows.sms_product)
                self.body_copy(self.rows.sms_residual_moment, self.rows.sms_torque, -1.0, self.rows.sms_moment)
            rz = self.precondition()
            if rz > bz:             # the last accelerations are a worse guess than zero: start from 0
                for c in range(n):
                    self.s.nodes.acceleration[c] = zero3()
                    self.s.nodes.angular_acceleration[c] = zero3()
                    self.s.nodes.sms_residual[c] = self.s.nodes.sms_force[c]
                    self.s.nodes.sms_residual_moment[c] = self.s.nodes.sms_torque[c]
                if ti.static(self.coupled):
                    self.body_copy(self.rows.sms_acceleration, self.rows.sms_force, 0.0, self.rows.sms_force, 0.0)
                    self.body_copy(self.rows.sms_angular_acceleration, self.rows.sms_torque, 0.0, self.rows.sms_torque, 0.0)
                    self.body_copy(self.rows.sms_residual, self.rows.sms_force, 0.0, self.rows.sms_force)
                    self.body_copy(self.rows.sms_residual_moment, self.rows.sms_torque, 0.0, self.rows.sms_torque)
                rz = self.precondition()
            for c in range(n):
                self.s.nodes.sms_search[c] = self.s.nodes.sms_step[c]
                self.s.nodes.sms_search_moment[c] = self.s.nodes.sms_step_moment[c]
            if ti.static(self.coupled):
                self.body_copy(self.rows.sms_search, self.rows.sms_step, 0.0, self.rows.sms_step)
                self.body_copy(self.rows.sms_search_moment, self.rows.sms_step_moment, 0.0, self.rows.sms_step_moment)
            goal = self.s.step.sms_tolerance[None] ** 2 * bz
            iterations = 0
            limit = self.s.step.sms_max_iterations[None]
            while rz > goal and iterations < limit:
                self.product(self.s.nodes.sms_search, self.s.nodes.sms_search_moment,
                             self.rows.sms_search, self.rows.sms_search_moment)
                curvature = 0.0
                for c in range(n):
                    curvature += (self.s.nodes.sms_search[c].dot(self.s.nodes.sms_product[c])
                                  + self.s.nodes.sms_search_moment[c].dot(self.s.nodes.sms_moment[c]))
                if ti.static(self.coupled):
                    for b in range(self.s.bodies.count[None]):
                        curvature += (self.rows.sms_search[b].dot(self.rows.sms_product[b])
                                      + self.rows.sms_search_moment[b].dot(self.rows.sms_moment[b]))
                alpha = rz / curvature
                for c in range(n):
                    self.s.nodes.acceleration[c] += alpha * self.s.nodes.sms_search[c]
                    self.s.nodes.angular_acceleration[c] += alpha * self.s.nodes.sms_search_moment[c]
                    self.s.nodes.sms_residual[c] -= alpha * self.s.nodes.sms_product[c]
                    self.s.nodes.sms_residual_moment[c] -= alpha * self.s.nodes.sms_moment[c]
                if ti.static(self.coupled):
                    self.body_copy(self.rows.sms_acceleration, self.rows.sms_acceleration, alpha, self.rows.sms_search)
                    self.body_copy(self.rows.sms_angular_acceleration, self.rows.sms_angular_acceleration, alpha,
                                   self.rows.sms_search_moment)
                    self.body_copy(self.rows.sms_residual, self.rows.sms_residual, -alpha, self.rows.sms_product)
                    self.body_copy(self.rows.sms_residual_moment, self.rows.sms_residual_moment, -alpha, self.rows.sms_moment)
                rz_new = self.precondition()
                for c in range(n):
                    self.s.nodes.sms_search[c] = self.s.nodes.sms_step[c] + (rz_new / rz) * self.s.nodes.sms_search[c]
                    self.s.nodes.sms_search_moment[c] = (self.s.nodes.sms_step_moment[c]
                                                         + (rz_new / rz) * self.s.nodes.sms_search_moment[c])
                if ti.static(self.coupled):
                    self.body_copy(self.rows.sms_search, self.rows.sms_step, rz_new / rz, self.rows.sms_search)
                    self.body_copy(self.rows.sms_search_moment, self.rows.sms_step_moment, rz_new / rz,
                                   self.rows.sms_search_moment)
                rz = rz_new
                iterations += 1
            if rz > goal and self.s.step.status[None] == STATUS_OK:
                self.s.step.status[None] = STATUS_SMS_SOLVE
                self.s.step.status_index[None] = iterations
            # sum m a = sum f over the free translations (M_add's translational rows sum to zero)
            residual_sum = zero3()
            mass_sum = zero3()
            for c in range(n):
                residual_sum += self.s.nodes.sms_residual[c]
                mass_sum += self.s.nodes.mass[c] * self.s.nodes.free_dofs[c]
            if ti.static(self.coupled):     # the bodies' rows too: the shift moves them with the nodes
                for b in range(self.s.bodies.count[None]):
                    free = self.s.bodies.translation_free[b]
                    residual_sum += self.rows.sms_residual[b]
                    mass_sum += self.s.bodies.total_mass[b] * ti.Vector([free[0, 0], free[1, 1], free[2, 2]])
            shift = residual_sum / ti.max(mass_sum, 1e-300)
            for c in range(n):
                self.s.nodes.acceleration[c] += self.s.nodes.free_dofs[c] * shift
            if ti.static(self.coupled):
                for b in range(self.s.bodies.count[None]):
                    self.rows.sms_acceleration[b] += self.s.bodies.translation_free[b] @ shift
                self.spread(self.s.nodes.acceleration, self.s.nodes.angular_acceleration,
                            self.rows.sms_acceleration, self.rows.sms_angular_acceleration)
            self.s.step.sms_iterations[None] += iterations
            self.s.step.sms_solves[None] += 1
            self.s.step.sms_iterations_max[None] = ti.max(self.s.step.sms_iterations_max[None], iterations)

    @ti.func
    def apply_reciprocal(self):
        """[a, alpha] = A [f, mu] with the reciprocal mass matrix A = P^-1 (module docstring,
        Reciprocal), in parallel loops: each element's geometry (:meth:`element_geometry`) and
        block inverse of its shares of the force in one loop, gathered at the nodes.  What the
        elements hand to a rigid body's slaves,
        m_s z_s and J_s z^r_s (sms_product, sms_moment; zero elsewhere), goes to the body with
        its load: its rows M_tot^-1 (F + sum m_s z_s) and the moment's likewise
        (sms_added_force, sms_added_moment hold minus them for RigidBodies.update), so the
        elements' momentum reaches it within the step.  The added mass's inertial forces are not
        formed (a held DOF's reaction and a constraint's work take the lumped mass;
        :meth:`reciprocal_kinetic`)."""
        for e in range(self.s.elements.count[None]):
            if self.masses.alive(e) > 0.0:
                self.element_geometry(e)
                self.element_block_inverse(e, self.s.nodes.sms_force, self.s.nodes.sms_torque)
        serial_loop(self.cfg.serial_node_loops)
        for c in range(self.s.nodes.count[None]):
            z, zr, handed, handed_turn = zero3(), zero3(), zero3(), zero3()
            slave = False
            if ti.static(self.coupled):
                slave = self.s.nodes.body[c] >= 0
            if slave:               # no free DOF of its own: what the blocks hand it goes to its body
                step, turn = self.gathered(c)
                handed, handed_turn = self.s.nodes.mass[c] * step, self.s.nodes.inertia[c] * turn
            else:
                z, zr = self.inverse_at(c, self.s.nodes.sms_force, self.s.nodes.sms_torque)
            self.s.nodes.acceleration[c] = z
            self.s.nodes.angular_acceleration[c] = zr
            self.s.nodes.sms_product[c] = handed
            self.s.nodes.sms_moment[c] = handed_turn
        for _ in range(1):          # the bodies' rows (few; serial)
            if ti.static(self.coupled):
                for b in range(self.s.bodies.count[None]):
                    force, moment = self.slave_sum(b, self.s.nodes.sms_product, self.s.nodes.sms_moment)
                    self.s.bodies.sms_added_force[b] = -force
                    self.s.bodies.sms_added_moment[b] = -moment
                    self.rows.sms_residual[b] = self.rows.sms_force[b] + self.s.bodies.translation_free[b] @ force
                    self.rows.sms_residual_moment[b] = self.rows.sms_torque[b] + self.s.bodies.rotation_free[b] @ moment
                self.body_precondition()
                self.body_copy(self.rows.sms_acceleration, self.rows.sms_step, 0.0, self.rows.sms_step)
                self.body_copy(self.rows.sms_angular_acceleration, self.rows.sms_step_moment, 0.0,
                               self.rows.sms_step_moment)
            self.s.step.sms_solves[None] += 1
        if ti.static(self.coupled):
            self.spread(self.s.nodes.acceleration, self.s.nodes.angular_acceleration,
                        self.rows.sms_acceleration, self.rows.sms_angular_acceleration)

    @ti.func
    def reciprocal_kinetic(self):
        """After the nodes' update, each live element's share of the step's change of the added
        mass's kinetic energy under the reciprocal mass matrix (module docstring, Reciprocal):
        h v_mid . (f - m a) + h omega_mid . (mu - J alpha) at its free corners, in its shares of
        their masses, v_mid = (v_s + v_f) / 2 the step's mean velocity after the constraints (so
        a wall's velocity change costs the lumped kinetic energy it books, and no more); at a
        rigid body's slave, minus what it handed the body, h v_mid . m_s z_ea + h omega_mid .
        J_s z^r_ea (the body's kick books its work on the body)."""
        kick = impulse_time(self.s.step)
        for e in range(self.s.elements.count[None]):
            if self.masses.alive(e) > 0.0:
                c = self.s.elements.corners[e]
                m = self.s.elements.corner_mass[e]
                inertia = self.s.elements.corner_inertia[e]
                change = 0.0
                for a in ti.static(range(4)):
                    if c[a] >= 0:
                        v_mid = 0.5 * (self.s.nodes.sms_search[c[a]] + self.s.nodes.grid_velocity[c[a]])
                        w_mid = 0.5 * (self.s.nodes.sms_search_moment[c[a]] + self.s.nodes.omega[c[a]])
                        if not self.nodes.is_idle(c[a]):
                            share = self.s.nodes.sms_share[c[a]]
                            lin = self.free_translation(c[a], self.s.nodes.acceleration[c[a]])
                            turn = self.free_rotation(c[a], self.s.nodes.angular_acceleration[c[a]])
                            if share[0] > 0.0:
                                change += m[a] / share[0] * v_mid.dot(
                                    self.s.nodes.sms_force[c[a]] - self.s.nodes.mass[c[a]] * lin)
                            if share[1] > 0.0:
                                change += inertia[a] / share[1] * w_mid.dot(
                                    self.s.nodes.sms_torque[c[a]] - self.s.nodes.inertia[c[a]] * turn)
                        if ti.static(self.coupled):
                            if self.s.nodes.body[c[a]] >= 0:
                                change -= (self.s.nodes.mass[c[a]] * v_mid.dot(self.s.elements.sms_corner_step[e, a])
                                           + self.s.nodes.inertia[c[a]]
                                           * w_mid.dot(self.s.elements.sms_corner_turn[e, a]))
                self.s.elements.sms_excess[e] += kick * change
            self.acc.total(self.s.step.kinetic, self.s.elements.sms_excess[e])

    @ti.func
    def inertial_forces(self):
        """sms_product, sms_moment = M_add [a, alpha] at every node (held ones included, for
        their reactions and constraint_work): parallel loops after the solve."""
        self.rigid_fit(self.s.nodes.acceleration, self.s.nodes.angular_acceleration)
        for c in range(self.s.nodes.count[None]):
            force, moment = self.added_at(c)
            self.s.nodes.sms_product[c] = force
            self.s.nodes.sms_moment[c] = moment

    @ti.func
    def constraint_work(self):
        """What the added mass does where a constraint sets the velocity (a wall, a boundary or
        prescribed motion, a rigid body's slave), which no work term books.  With v_s, v_f the
        velocities before and after the step, v_mid their mean, Delta = v_f - (v_s + dt a) the
        constraints' change after the solve and P the free DOFs, the step changes 1/2 v M v by
        (v_f - v_s) . M v_mid = dt (P f) . v_mid + m Delta . v_mid
        + Delta . M_add v_mid + dt ((I - P) v_mid) . M_add a:
        the work terms book the first, NodeUpdate.finish the second (wall column); the last two
        go to the node's wall column here (parallel loops)."""
        for c in range(self.s.nodes.count[None]):
            self.s.nodes.sms_residual[c] = 0.5 * (self.s.nodes.sms_search[c] + self.s.nodes.grid_velocity[c])
            self.s.nodes.sms_residual_moment[c] = 0.5 * (self.s.nodes.sms_search_moment[c] + self.s.nodes.omega[c])
        self.rigid_fit(self.s.nodes.sms_residual, self.s.nodes.sms_residual_moment)
        for c in range(self.s.nodes.count[None]):
            mid, mid_turn = self.s.nodes.sms_residual[c], self.s.nodes.sms_residual_moment[c]
            jump = self.s.nodes.grid_velocity[c] - self.s.nodes.sms_step[c]
            turn = self.s.nodes.omega[c] - self.s.nodes.sms_step_moment[c]
            held, held_turn = mid - self.free_translation(c, mid), mid_turn - self.free_rotation(c, mid_turn)
            if jump.norm_sqr() + turn.norm_sqr() + held.norm_sqr() + held_turn.norm_sqr() > 0.0:
                force, moment = self.added_at(c)
                work = -(jump.dot(force) + turn.dot(moment)
                         + impulse_time(self.s.step) * (held.dot(self.s.nodes.sms_product[c])
                                                        + held_turn.dot(self.s.nodes.sms_moment[c])))
                self.s.nodes.energy[c][2] += work
                self.acc.total(self.s.step.wall_energy, work)

    @ti.func
    def explicit_fe(self):
        """``fem`` mode with selective mass scaling: v^(n+1/2) = v^(n-1/2) + dt a (dt/2 from
        rest) with (M + M_add) [a, alpha] = [f, mu] on the free DOFs; then each node as
        NodeUpdate.explicit_fe (its rotation from alpha, NodeUpdate.finish; a held node's
        reaction adds M_add a), and the added mass's kinetic energy."""
        self.prepare()
        self.advance()

    @ti.func
    def prepare(self):
        """The solve of explicit_fe (with rigid bodies it runs before RigidBodies.update, whose
        kick takes the bodies' solved accelerations: module docstring, Bodies)."""
        if ti.static(not self.reciprocal):
            self.geometry()
        self.forces()
        if ti.static(self.reciprocal):
            self.apply_reciprocal()
        else:
            self.solve()
            self.inertial_forces()
            if ti.static(self.coupled):
                self.body_added()
        self.step_change()

    @ti.func
    def step_change(self):
        """The balance term of a step that changes (module docstring, A step that changes):
        E_ms += (dt^(n+1/2) - dt^(n-1/2)) h / 4 sum_c (f_int,c . a_c + m_int,c . alpha_c), h the
        kick, booked on each live element in its corners' mass shares (zero at a constant step)."""
        change = self.s.step.dt[None] - self.s.step.dt_last[None]
        scale = 0.25 * change * impulse_time(self.s.step)
        for e in range(self.s.elements.count[None]):
            if change != 0.0 and self.masses.alive(e) > 0.0:
                c = self.s.elements.corners[e]
                m = self.s.elements.corner_mass[e]
                total = 0.0
                for a in ti.static(range(4)):
                    if c[a] >= 0:
                        share = self.s.nodes.sms_share[c[a]][0]
                        if share > 0.0:
                            total += m[a] / share * (
                                self.s.nodes.force_int[c[a]].dot(self.s.nodes.acceleration[c[a]])
                                + self.s.nodes.moment_int[c[a]].dot(self.s.nodes.angular_acceleration[c[a]]))
                work = scale * total
                self.s.elements.mass_energy[e][1] += work
                self.acc.total(self.s.step.mass_scaling_energy, work)

    @ti.func
    def advance(self):
        """The nodes' update of explicit_fe after the solve."""
        serial_loop(self.cfg.serial_node_loops)
        for c in range(self.s.nodes.count[None]):
            keep = self.s.step.velocity_keep[None]
            start, start_turn = keep * self.s.nodes.grid_velocity[c], keep * self.s.nodes.omega[c]
            kick = impulse_time(self.s.step)
            self.s.nodes.sms_search[c] = start                  # v_s = v^(n-1/2)
            self.s.nodes.sms_search_moment[c] = start_turn
            self.s.nodes.sms_step[c] = start + kick * self.s.nodes.acceleration[c]        # v_s + dt a (a = 0
            self.s.nodes.sms_step_moment[c] = start_turn + kick * self.s.nodes.angular_acceleration[c]   # if held)
            v = zero3()
            if not self.nodes.is_idle(c):
                v = self.s.nodes.sms_step[c]
            self.nodes.finish(c, v)
        if ti.static(self.reciprocal):
            self.reciprocal_kinetic()
        else:
            self.constraint_work()
            for e in range(self.s.elements.count[None]):
                self.acc.total(self.s.step.kinetic, self.beta(e) * self.node_kinetic(e))
