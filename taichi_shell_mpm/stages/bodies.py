"""Rigid bodies with added mass and inertia, and rigid planar walls (stage S6; method.md 2.5c, 7.5).

A rigid body's slave nodes are Lagrangian only (skipped by P2G/G2P); the loads at them and
the forces their elements exert are summed into the body's force F and moment M (about its
centre x_c), and the body moves as one: a translation V, projected on its free translations
(P_t: the identity, the fixed axes dropped, or d d^T for a ram along `direction`), and
with Features.body_rotation a rotation R (a unit quaternion), the slaves placed at
x = x_c + R (X - X_c) and turned with the body.

Translation, the central difference: M_tot V^(n+1/2) = P_t (M_tot V^(n-1/2) + dt F^n),
x_c^(n+1) = x_c^n + dt V^(n+1/2).  A ram along `direction` is this with P_t = d d^T: for an
axis direction the same floating-point operations as the scalar update it replaces.

Rotation [choice]: kick, then a free-rigid-body drift -- the rotational twin of the
staggered translation.  Kick: L^(n+1/2) = L^(n-1/2) + dt M^n (the angular momentum about
the centre, space frame).  Drift over dt at constant L: the Simo-Wong energy-momentum
midpoint rule (Simo & Wong, IJNME 31, 1991) in the body frame, Pi_n = R_n^T L,
R_(n+1) = R_n exp(dt W^), Pi_(n+1) = exp(-dt W^) Pi_n, W = J^-1 (Pi_n + Pi_(n+1)) / 2
(J: the body-frame inertia), solved by fixed-point iteration to round-off.  Since
exp(-dt W^) leaves W unchanged, (Pi_(n+1) - Pi_n) . W = 0: the drift keeps the kinetic
energy 1/2 Pi . J^-1 Pi exactly and |Pi|, and L = R Pi exactly, for any step (a free body
tumbling about a non-principal axis: tests/test_bodies.py).  Other explicit choices, and
why not: omega = I(R_n)^-1 L with a forward exponential update (first order, its energy
drifts secularly); the splitting methods of Dullweber-Leimkuhler-McLachlan / Omelyan keep
L and |Pi| but the energy only to O(dt^2) in a bounded oscillation; the implicit midpoint
costs the same iteration as Simo-Wong.  The kick changes the kinetic energy by exactly
dt M . (omega^- + omega^+) / 2 with omega^+- = I(R_n)^-1 L^(n+-1/2), the work booked for an
applied moment (energy.py's time-centred work); a rotating body books the work of the loads
and contact forces at its slaves so too, with F . V_mid + M . omega_mid (at the nodes, with
their secant velocities, it missed the kinetic energy by dt omega |r| / 2 of the work: the
chord's centripetal part, 1.5e-6 of it for a flywheel spun up at dt = 0.013).  A body with some rotations fixed (global
axes): omega is confined to the free axes, solved from P_r I P_r omega = P_r L (the fixed
axes' rows are the constraint's moment), L = I omega, then R_(n+1) = exp(dt omega^) R_n
(exact for one free axis, about which I does not change; two free axes of three: first
order).  A slave's velocity over the step is its secant (x^(n+1) - x^n) / dt and its nodal
angular velocity the Cayley vector of the step's rotation, (2 / dt) tan(phi / 2) omega / |omega|
(phi = dt |omega|), so that on the shell element's mid-step geometry (stages/shell.py,
Hughes-Winget) the body's elements strain by round-off only [choice, measured: the body's
velocity field V + omega x r with omega itself gave them 0.5 % of its energy in 80 steps at
dt |omega| = 0.03; the secant with omega, 1e-9 -- either stopped a run at once, as the
balance guard's scale is what the shell absorbed].

Walls.  A wall keeps every free node's mid-surface at least half the shell thickness on the
side its normal points to, by a velocity correction after G2P (frictionless, perfectly
inelastic); a moving wall moves with its body (turning with it) and its impulse goes back
to the body (force and moment), and the energy the walls take out (their impulses times the
time-centred velocities of nodes and bodies, energy.py) is booked as wall energy.  A fixed
wall is a support: the force of its correction over the step, m dv n / dt, is added to the
support reaction (with the clamped nodes' f_int - f_ext - f_con, stages/constraints.py), so
the crush force history sees a lobe that rests on the support plane.

Other stages load a body through add_force (at t^n, before update) and add_impulse (during
the node update; applied at the end of the step); see /work/notes/bodies_api.md.

Time step (issue 28 item 7): a body limits the next step to its stable step on the elements it
carries (model/bodies.body_step, host, from its mass and inertia) and to MAX_TURN of rotation.
"""
import taichi as ti

from ..state import ROTATION_CONSTRAINED, ROTATION_FREE, ROTATION_HELD, STATUS_BODY_ROTATION, STATUS_OK
from .accumulate import Accumulator
from .motion import ACCELERATION, DISPLACEMENT, held_bits
from .rotation import cayley_velocity, quaternion_exp, quaternion_matrix, quaternion_product, rotate_vector
from .timestep import MAX_TURN, impulse_time
from .tools import RigidTools

SIMO_WONG_ITERATIONS = 50      # fixed-point iterations at most (a few at dt |omega| << 1)
SIMO_WONG_TOLERANCE = 1e-15    # relative change of W that ends them


@ti.func
def constrained_omega(inertia, free, momentum):
    """omega on the free axes (projector `free`, diagonal 0/1) with free (I omega - L) = 0:
    (P I P + 1 - P) omega = P L."""
    eye = ti.Matrix.identity(ti.f64, 3)
    a = free @ inertia @ free + eye - free
    return a.inverse() @ (free @ momentum)


@ti.data_oriented
class RigidBodies:
    """The rigid system: bodies, walls and tools (stages/tools.py, built here).  The step
    talks to it through a narrow interface: :meth:`begin` (the tools' poses and forces at
    t^n), :meth:`update` (the bodies' velocities), the node-level :meth:`slave_motion`,
    :meth:`slave_omega`, :meth:`walls` and :meth:`tool_work`, and :meth:`end` (impulses back
    to the bodies, their kinetic energy, the tools' work).  Bodies and walls are run-time
    tables (state.bodies); Features.bodies / walls / body_rotation / tools decide whether
    their code is compiled."""

    def __init__(self, state, cfg, energy, loads):
        self.s = state
        self.cfg = cfg
        self.energy = energy            # energy.EnergyLedger
        self.loads = loads              # stages/loads.ExternalLoads
        # the rigid tools (None without): built here, as part of the one rigid system, since
        # those moving with a body take its pose and push it back (update)
        self.tools = RigidTools(state, cfg, loads, self) if cfg.tools else None
        self.acc = Accumulator(cfg.serial)
        # threads launch: wall impulses summed in node order instead of by atomics (serial
        # and gpu launches add them directly)
        self.impulses_in_node_order = cfg.launch == "threads" and cfg.moving_walls
        # selective mass scaling: the bodies' DOFs are in its solve (stages/selective_mass.py)
        self.coupled = cfg.bodies and cfg.selective_mass

    # ------------------------------------------------------------ the step's interface
    @ti.func
    def begin(self):
        """Before the velocity update: each tool's pose and velocity at t^n and its forces on
        the nodes (stages/tools.py)."""
        if ti.static(self.cfg.tools):
            self.tools.begin()
            self.tools.forces()

    @ti.func
    def end(self):
        """After the nodes' update: the walls' (and tools') impulses back to the bodies, the
        bodies' kinetic energy, then each tool's work at its own motion (once the bodies'
        velocities are final)."""
        if ti.static(self.cfg.bodies):
            self.apply_impulses()
            self.add_kinetic_energy()
        if ti.static(self.cfg.tools):
            self.tools.end()

    @ti.func
    def tool_work(self, c, v_mid, kick):
        """The work done against the tools' forces on node c over the step (its contact column)."""
        return self.tools.book_node(c, v_mid, kick)

    # ------------------------------------------------------------ pose (bodies_api.md)
    @ti.func
    def center(self, b):
        return self.s.bodies.center0[b] + self.s.bodies.displacement[b]

    @ti.func
    def rotation_matrix(self, b):
        return quaternion_matrix(self.s.bodies.rotation[b])

    @ti.func
    def place(self, b, x_ref):
        """Where the point of the body at x_ref in the reference configuration is now."""
        return self.center(b) + self.rotation_matrix(b) @ (x_ref - self.s.bodies.center0[b])

    @ti.func
    def point_velocity(self, b, x):
        return self.s.bodies.velocity[b] + self.s.bodies.omega[b].cross(x - self.center(b))

    @ti.func
    def add_force(self, b, force, x):
        """A force at the point x at t^n, from a stage that runs before update()."""
        self.acc.add(self.s.bodies.applied_force, b, force)
        if ti.static(self.cfg.body_rotation):
            self.acc.add(self.s.bodies.applied_moment, b, (x - self.center(b)).cross(force))

    @ti.func
    def add_impulse(self, b, impulse, x):
        """An impulse at the point x during the node update, applied at the end of the step."""
        self.acc.add(self.s.bodies.impulse, b, impulse)
        if ti.static(self.cfg.body_rotation):
            self.acc.add(self.s.bodies.angular_impulse, b, (x - self.center(b)).cross(impulse))

    # ------------------------------------------------------------ the step
    @ti.func
    def loads_on(self, b, x_c):
        """Body b's load at t^n, read only (:meth:`update`; the selective mass scaling's solve,
        stages/selective_mass.py, takes it as the body's right-hand side): the force F (the added
        mass's weight, the slaves' f_ext - f_int + f_con, the tools moving with it, the applied
        force), its moment about x_c without the applied moment, the added mass's weight, and
        (rotating body) the slaves' loads and contact forces with their moments apart."""
        force = ti.Vector([0.0, 0.0, 0.0])
        moment = ti.Vector([0.0, 0.0, 0.0])
        weight = ti.Vector([0.0, 0.0, 0.0])
        if ti.static(self.cfg.loads):
            weight = self.s.bodies.added_mass[b] * self.s.loads.gravity_now[None]
            force = weight
        # a rotating body's loads and contact forces at its slaves, apart (their work is booked here)
        slave_loads = ti.Vector([0.0, 0.0, 0.0])
        slave_load_moment = ti.Vector([0.0, 0.0, 0.0])
        contact = ti.Vector([0.0, 0.0, 0.0])
        contact_moment = ti.Vector([0.0, 0.0, 0.0])
        for i in range(self.s.bodies.first_slave[b], self.s.bodies.first_slave[b] + self.s.bodies.slave_count[b]):
            c = self.s.bodies.slave_nodes[i]
            external, external_moment = self.loads.at_node(c)
            f = external - self.s.nodes.force_int[c]
            if ti.static(self.cfg.contact):
                f += self.s.contact.force[c]
            if ti.static(self.cfg.tools):
                f += self.s.tools.total_force[c]
            force += f
            if ti.static(self.cfg.body_rotation):
                r = self.s.nodes.position[c] - x_c
                moment += r.cross(f) + external_moment - self.s.nodes.moment_int[c]
                slave_loads += external
                slave_load_moment += r.cross(external) + external_moment
                if ti.static(self.cfg.contact):
                    contact += self.s.contact.force[c]
                    contact_moment += r.cross(self.s.contact.force[c])
        if ti.static(self.cfg.tools):        # the tools moving with it are pushed back
            reaction, reaction_moment = self.tools.on_body(b, x_c)
            force += reaction
            if ti.static(self.cfg.body_rotation):
                moment += reaction_moment
        force += self.s.bodies.applied_force[b]
        return force, moment, weight, slave_loads, slave_load_moment, contact, contact_moment

    @ti.func
    def update(self):
        """F (and M) from the slaves' f_ext - f_int + f_con (and their moments), the added
        mass's weight and the applied loads; then the kick and drift of the module docstring.
        Under selective mass scaling (``coupled``) the kick takes the body's acceleration from
        the solve that holds its DOFs (stages/selective_mass.py, Bodies): M_tot A on its free
        translations, F less the added mass's inertial force at its slaves on the others (a
        prescribed DOF's reaction), and M less that force's moment for the rotation."""
        ti.loop_config(serialize=True)
        for b in range(self.s.bodies.count[None]):
            x_c = self.center(b)
            if ti.static(self.cfg.body_rotation):
                self.s.bodies.center_start[b] = x_c
            force, moment, weight, slave_loads, slave_load_moment, contact, contact_moment = self.loads_on(b, x_c)
            applied = self.s.bodies.applied_force[b]
            self.s.bodies.applied_force[b] = ti.Vector([0.0, 0.0, 0.0])
            self.s.bodies.force[b] = force
            free = self.s.bodies.translation_free[b]
            if ti.static(self.cfg.static):      # the body's own equilibrium (its slaves are not free nodes)
                self.s.step.residual_sq[None] += (free @ force).norm_sqr()
            kick = impulse_time(self.s.step)
            keep = self.s.step.velocity_keep[None]
            self.s.bodies.velocity_start[b] = keep * self.s.bodies.velocity[b]
            if ti.static(self.coupled):
                force = (self.s.bodies.total_mass[b] * self.s.bodies.sms_acceleration[b]
                         + (ti.Matrix.identity(ti.f64, 3) - free) @ (force - self.s.bodies.sms_added_force[b]))
                moment -= self.s.bodies.sms_added_moment[b]
            self.s.bodies.velocity[b] = free @ (keep * self.s.bodies.velocity[b]
                                                + kick * force / self.s.bodies.total_mass[b])
            if ti.static(self.cfg.loads):
                if self.s.bodies.motion_mask[b] & 0b111:
                    self.prescribe_translation(b, force)
            self.s.bodies.displacement[b] += self.s.step.dt[None] * self.s.bodies.velocity[b]
            # the added mass's weight and the applied force work on the body (the slaves' loads: per
            # node, or here with a rotating body)
            self.energy.body_external(b, (kick * (weight + applied) * 0.5).dot(self.s.bodies.velocity_start[b]
                                                                             + self.s.bodies.velocity[b]))
            if ti.static(self.cfg.body_rotation):
                omega_mid = self.turn(b, moment)
                self.s.bodies.omega_mid[b] = omega_mid
                v_mid = 0.5 * (self.s.bodies.velocity_start[b] + self.s.bodies.velocity[b])
                self.energy.body_external(b, kick * (slave_loads.dot(v_mid) + slave_load_moment.dot(omega_mid)))
                if ti.static(self.cfg.contact):
                    self.energy.body_contact(b, -kick * (contact.dot(v_mid) + contact_moment.dot(omega_mid)))

    @ti.func
    def prescribed_rate(self, b, d: ti.template(), start):
        """What the [[motion]] of DOF d of body b sets its velocity (d < 3) or angular velocity
        component to over the step (stages/motion.py's rates; a translation's displacement is
        aimed at X_c + value f(s^(n+1)), a rotation's turned by its increment)."""
        k = self.s.bodies.motion[b][d]
        value = self.s.loads.motion_value[k][d]
        kind = self.s.loads.motion_kind[k]
        out = value * self.s.loads.motion_rate[k]
        if kind == DISPLACEMENT:
            if ti.static(d < 3):
                out = (self.s.bodies.center0[b][d] + value * self.s.loads.motion_level[k]
                       - self.center(b)[d]) / self.s.step.dt[None]
        elif kind == ACCELERATION:
            out += start
        return out

    @ti.func
    def held(self, b):
        """DOF bits of body b its motions hold this step (stages/motion.held_bits: with time
        windows, translations only)."""
        return held_bits(self.s, self.cfg, self.s.bodies.motion_mask[b], self.s.bodies.motion[b])

    @ti.func
    def prescribe_translation(self, b, force):
        """The prescribed components of V, the reaction R = M (V - V_start) / dt_k - F of each
        and its time-centred work (stages/motion.py's), per body and DOF; a DOF released by its
        motion's time window moves freely and has no reaction."""
        mask = self.held(b)
        kick = impulse_time(self.s.step)
        start = self.s.bodies.velocity_start[b]
        for d in ti.static(range(3)):
            if ti.static(self.cfg.motion_windows):
                if not (mask >> d) & 1:
                    self.s.bodies.motion_reaction[b][d] = 0.0
            if (mask >> d) & 1:
                v = self.prescribed_rate(b, d, start[d])
                self.s.bodies.velocity[b][d] = v
                reaction = self.s.bodies.total_mass[b] * (v - start[d]) / kick - force[d]
                self.s.bodies.motion_reaction[b][d] = reaction
                self.energy.body_motion(b, d, kick * reaction * 0.5 * (start[d] + v))

    @ti.func
    def turn(self, b, moment):
        """The rotational kick and drift (module docstring); books the applied moment's work and
        returns the kick's time-centred angular velocity (omega^- + omega^+) / 2."""
        applied = self.s.bodies.applied_moment[b]
        self.s.bodies.applied_moment[b] = ti.Vector([0.0, 0.0, 0.0])
        moment += applied
        self.s.bodies.moment[b] = moment
        mode = self.s.bodies.rotation_mode[b]
        free = self.s.bodies.rotation_free[b]
        if ti.static(self.cfg.static):
            self.s.step.residual_sq[None] += (free @ moment).norm_sqr() / (self.s.step.length_ref[None] ** 2)
        dt = self.s.step.dt[None]
        keep = self.s.step.velocity_keep[None]
        self.s.bodies.omega_start[b] = keep * self.s.bodies.omega[b]
        q = self.s.bodies.rotation[b]
        r = quaternion_matrix(q)
        j = self.s.bodies.inertia[b]
        inertia = r @ j @ r.transpose()
        before = keep * self.s.bodies.angular_momentum[b]
        after = before + impulse_time(self.s.step) * moment
        omega = ti.Vector([0.0, 0.0, 0.0])           # the step's angular velocity, space frame
        omega_before = ti.Vector([0.0, 0.0, 0.0])    # I(R_n)^-1 L before and after the kick
        omega_after = ti.Vector([0.0, 0.0, 0.0])
        if mode == ROTATION_HELD:             # held, or turned by a [[motion]]
            after = ti.Vector([0.0, 0.0, 0.0])
            if ti.static(self.cfg.loads):
                mask = self.s.bodies.motion_mask[b]
                if mask >> 3:
                    start = self.s.bodies.omega_start[b]
                    for d in ti.static(range(3)):
                        if (mask >> (3 + d)) & 1:
                            omega[d] = self.prescribed_rate(b, 3 + d, start[d])
                    after = inertia @ omega
                    kick = impulse_time(self.s.step)
                    reaction = (after - before) / kick - moment        # the moment the motion exerts
                    for d in ti.static(range(3)):
                        if (mask >> (3 + d)) & 1:
                            self.s.bodies.motion_reaction[b][3 + d] = reaction[d]
                            self.energy.body_motion(b, 3 + d, kick * reaction[d] * 0.5 * (start[d] + omega[d]))
                    omega_before, omega_after = start, omega
                    q = quaternion_product(quaternion_exp(dt * omega), q)
        elif mode == ROTATION_CONSTRAINED:
            omega_before = constrained_omega(inertia, free, before)
            omega = constrained_omega(inertia, free, after)
            omega_after = omega
            after = inertia @ omega
            q = quaternion_product(quaternion_exp(dt * omega), q)
        elif mode == ROTATION_FREE:
            inverse = inertia.inverse()
            omega_before, omega_after = inverse @ before, inverse @ after
            j_inv = j.inverse()
            pi = r.transpose() @ after
            w = j_inv @ pi
            converged = False
            for _ in range(SIMO_WONG_ITERATIONS):
                w_new = j_inv @ (0.5 * (pi + rotate_vector(-dt * w, pi)))
                change = (w_new - w).norm()
                w = w_new
                if change <= SIMO_WONG_TOLERANCE * w.norm():
                    converged = True
                    break
            if not converged and self.s.step.status[None] == STATUS_OK:    # MAX_TURN should prevent it
                self.s.step.status[None] = STATUS_BODY_ROTATION
                self.s.step.status_index[None] = b
            omega = r @ w
            q = quaternion_product(q, quaternion_exp(dt * w))
        self.s.bodies.kinetic_rotation[b] = 0.5 * after.dot(omega_after)
        omega_mid = 0.5 * (omega_before + omega_after)
        self.energy.body_external(b, impulse_time(self.s.step) * applied.dot(omega_mid))
        self.s.bodies.angular_momentum[b] = after
        self.s.bodies.omega[b] = omega
        self.s.bodies.rotation[b] = q.normalized()
        return omega_mid

    @ti.func
    def slave_motion(self, c):
        """Rigid slave c's velocity over the step and its position at t^(n+1) (after update)."""
        b = self.s.nodes.body[c]
        v = self.s.bodies.velocity[b]
        x = self.s.nodes.position[c]
        if ti.static(self.cfg.body_rotation):
            dt = self.s.step.dt[None]
            placed = self.place(b, self.s.nodes.position_ref[c])
            if dt > 0.0:
                v = (placed - x) / dt
            x = placed
        else:
            x += self.s.step.dt[None] * v
        return v, x

    @ti.func
    def slave_omega(self, c):
        """Rigid slave c's nodal angular velocity over the step: the Cayley vector of the
        body's step rotation (module docstring)."""
        return cayley_velocity(self.s.bodies.omega[self.s.nodes.body[c]], self.s.step.dt[None])

    @ti.func
    def walls(self, c, v):
        """Correct the velocity of free node c so that it ends the step outside every wall
        (its mid-surface at least half the thickness of its thickest element away)."""
        out = v
        half = 0.5 * self.s.nodes.thickness[c]
        dt = self.s.step.dt[None]
        for k in range(self.s.bodies.wall_count[None]):
            n = self.s.bodies.wall_normal[k]
            p = self.s.bodies.wall_point[k]
            b = self.s.bodies.wall_body[k]
            wall_speed = 0.0
            if b >= 0:                                          # at t^{n+1}
                if ti.static(self.cfg.body_rotation):
                    n = self.rotation_matrix(b) @ n
                    p = self.place(b, p)
                    wall_speed = self.point_velocity(b, self.s.nodes.position[c] + dt * out).dot(n)
                else:
                    p += self.s.bodies.displacement[b]
                    wall_speed = self.s.bodies.velocity[b].dot(n)
            gap = (self.s.nodes.position[c] + dt * out - p).dot(n) - half
            if gap < 0.0 and dt > 0.0:
                # no further approach than the wall moves, plus a bounded push-out of a node
                # already inside (at most 1% of the half thickness per step: an unbounded
                # "land exactly" correction kicked folded nodes behind the moving wall)
                push = ti.min((self.s.nodes.position[c] - p).dot(n) + dt * wall_speed - half, 0.0)   # at t^n
                target = wall_speed + ti.min(-push, 0.01 * half) / dt
                dv = ti.max(0.0, target - out.dot(n))
                out += dv * n
                m = self.s.nodes.mass[c]
                if ti.static(self.cfg.joints):          # a master with its joint slaves' mass (stages/joints.py)
                    m += self.s.joints.node_mass[c]
                if b >= 0:
                    if ti.static(self.cfg.moving_walls):
                        impulse = -m * dv * n
                        if ti.static(self.impulses_in_node_order):   # summed by apply_impulses
                            self.s.bodies.node_wall_impulse[c, k] += impulse
                            if ti.static(self.cfg.body_rotation):
                                self.s.bodies.node_wall_moment[c, k] += (
                                    self.s.nodes.position[c] + dt * out - self.center(b)).cross(impulse)
                        else:
                            self.add_impulse(b, impulse, self.s.nodes.position[c] + dt * out)
                else:        # a fixed wall is a support: its force on the shell is reaction
                    self.acc.total(self.s.step.reaction, (m * dv / dt) * n)
        return out

    @ti.func
    def apply_impulses(self):
        """The walls (tools) push their rigid bodies back (end of step).  The impulse J's
        energy, J . V_mid with the body's time-centred velocity V_mid = (V^(n-1/2) + V^(n+1/2)) / 2,
        and an angular impulse H's, H . (omega^- + omega^+) / 2 (omega = I^-1 L before and
        after it), are taken out as wall energy (energy.py: the walls' work on the nodes is
        booked the same way, so a wall that only carries load books nothing)."""
        if ti.static(self.impulses_in_node_order):         # no atomics, the serial sum's bits
            ti.loop_config(serialize=True)
            for c in range(self.s.nodes.count[None]):
                for k in range(self.s.bodies.wall_count[None]):
                    b = self.s.bodies.wall_body[k]
                    if b >= 0:
                        self.s.bodies.impulse[b] += self.s.bodies.node_wall_impulse[c, k]
                        self.s.bodies.node_wall_impulse[c, k] = ti.Vector([0.0, 0.0, 0.0])
                        if ti.static(self.cfg.body_rotation):
                            self.s.bodies.angular_impulse[b] += self.s.bodies.node_wall_moment[c, k]
                            self.s.bodies.node_wall_moment[c, k] = ti.Vector([0.0, 0.0, 0.0])
        ti.loop_config(serialize=True)
        for b in range(self.s.bodies.count[None]):
            impulse = self.s.bodies.impulse[b]
            change = self.s.bodies.translation_free[b] @ (impulse / self.s.bodies.total_mass[b])
            if ti.static(self.cfg.loads):     # a prescribed DOF keeps its velocity: its motion takes the impulse
                mask = self.held(b)
                v_mid = 0.5 * (self.s.bodies.velocity_start[b] + self.s.bodies.velocity[b])
                kick = impulse_time(self.s.step)
                for d in ti.static(range(3)):
                    if (mask >> d) & 1:
                        change[d] = 0.0
                        self.s.bodies.motion_reaction[b][d] -= impulse[d] / kick
                        self.energy.body_motion(b, d, -impulse[d] * v_mid[d])
            self.s.bodies.velocity[b] += change
            v_mid = 0.5 * (self.s.bodies.velocity_start[b] + self.s.bodies.velocity[b])
            self.energy.body(b, -impulse.dot(v_mid))
            self.s.bodies.impulse[b] = ti.Vector([0.0, 0.0, 0.0])
            if ti.static(self.cfg.body_rotation):
                h = self.s.bodies.angular_impulse[b]
                mode = self.s.bodies.rotation_mode[b]
                if mode != ROTATION_HELD:
                    r = self.rotation_matrix(b)
                    inertia = r @ self.s.bodies.inertia[b] @ r.transpose()
                    free = self.s.bodies.rotation_free[b]
                    before = self.s.bodies.angular_momentum[b]
                    w_before = constrained_omega(inertia, free, before)
                    w_after = constrained_omega(inertia, free, before + h)
                    after = inertia @ w_after
                    self.energy.body(b, -h.dot(0.5 * (w_before + w_after)))
                    self.s.bodies.angular_momentum[b] = after
                    self.s.bodies.kinetic_rotation[b] = 0.5 * after.dot(w_after)
                elif ti.static(self.cfg.loads):   # turned by a [[motion]]: it takes the angular impulse
                    mask = self.s.bodies.motion_mask[b]
                    if mask >> 3:
                        w_mid = 0.5 * (self.s.bodies.omega_start[b] + self.s.bodies.omega[b])
                        kick = impulse_time(self.s.step)
                        for d in ti.static(range(3)):
                            if (mask >> (3 + d)) & 1:
                                self.s.bodies.motion_reaction[b][3 + d] -= h[d] / kick
                                self.energy.body_motion(b, 3 + d, -h[d] * w_mid[d])
                        self.energy.body(b, -h.dot(w_mid))
                self.s.bodies.angular_impulse[b] = ti.Vector([0.0, 0.0, 0.0])
            self.s.step.dt_next[None] = ti.min(self.s.step.dt_next[None], self.step_limit(b))

    @ti.func
    def step_limit(self, b):
        """The next step body b allows: its stable step on its elements (model/bodies.body_step) and,
        turning, MAX_TURN / (|L| / J_min) free or MAX_TURN / |omega| (module constants)."""
        limit = self.s.bodies.stable_step[b]
        if ti.static(self.cfg.body_rotation):
            rate = self.s.bodies.omega[b].norm()
            if self.s.bodies.rotation_mode[b] == ROTATION_FREE:
                rate = ti.max(rate, self.s.bodies.angular_momentum[b].norm() / self.s.bodies.inertia_min[b])
            if rate > 0.0:
                limit = ti.min(limit, MAX_TURN / rate)
        return limit

    @ti.func
    def add_kinetic_energy(self):
        """Add the bodies' KE (slave nodes and added mass together: 1/2 M_tot |V|^2 with the
        velocity after the wall impulses, + 1/2 L . I^-1 L; the node update leaves the slaves
        out) to the step's."""
        ti.loop_config(serialize=True)
        for b in range(self.s.bodies.count[None]):
            self.s.step.kinetic[None] += 0.5 * self.s.bodies.total_mass[b] * self.s.bodies.velocity[b].norm_sqr()
            if ti.static(self.cfg.body_rotation):
                self.s.step.kinetic[None] += self.s.bodies.kinetic_rotation[b]
