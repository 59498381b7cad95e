"""Node-level update after the velocity is known: essential BCs and prescribed motion
(stages/motion.py), position, rotations (stages S4 tail, S5, S6; method.md 2.3 and 2.5) and
the per-node energy terms (section 8).  The external loads come from
stages/loads.ExternalLoads.at_node.

Also the explicit-FE node update used in ``fem`` mode, where the grid is switched off and
the same BT forces are integrated directly at the nodes.
"""

import taichi as ti

from ..state import STATUS_NONFINITE, State
from .accumulate import Accumulator, serial_loop
from .rotation import quaternion_exp, quaternion_product
from .timestep import impulse_time

FIXED_TRANSLATION = 0b000111


@ti.func
def drop_fixed(vec, mask, first_bit: ti.template()):
    """Zero the components of `vec` whose DOF bit (first_bit + axis) is set in `mask`."""
    out = vec
    for d in ti.static(range(3)):
        if (mask >> (first_bit + d)) & 1:
            out[d] = 0.0
    return out


@ti.data_oriented
class NodeUpdate:
    def __init__(self, state: State, cfg, bodies, energy, loads, motion, joints=None):
        self.s = state
        self.cfg = cfg
        self.bodies = bodies            # stages/bodies.RigidBodies: the rigid system (its tools too)
        self.energy = energy            # energy.EnergyLedger
        self.loads = loads              # stages/loads.ExternalLoads
        self.motion = motion            # stages/motion.PrescribedMotion
        self.joints = joints            # stages/joints.Joints (None without [[tie]] / [[spotweld]])
        self.acc = Accumulator(cfg.serial)

    @ti.func
    def held(self, c):
        """DOF bits (ux .. rz) of node c that a [[boundary]] fixes or a [[motion]] prescribes."""
        mask = self.s.nodes.fix_mask[c]
        if ti.static(self.cfg.loads):
            mask |= self.motion.mask(c)
        return mask

    @ti.func
    def is_prescribed(self, c):
        """All translations fixed or prescribed, a rigid-body slave or a joint's slave: Lagrangian
        only, skipped by P2G/G2P (method.md 2.5a, 2.5c; stages/joints.py)."""
        out = (self.held(c) & FIXED_TRANSLATION) == FIXED_TRANSLATION or self.s.nodes.body[c] >= 0
        if ti.static(self.cfg.joints):
            out = out or self.joints.follows(c)
        return out

    @ti.func
    def mass_of(self, c):
        """The mass the node update integrates: the node's, plus its joint slaves' lumped shares
        (stages/joints.py)."""
        m = self.s.nodes.mass[c]
        if ti.static(self.cfg.joints):
            m += self.s.joints.node_mass[c]
        return m

    @ti.func
    def inertia_of(self, c):
        """The rotary inertia the node update integrates (as :meth:`mass_of`)."""
        j = self.s.nodes.inertia[c]
        if ti.static(self.cfg.joints):
            j += self.s.joints.node_inertia[c]
        return j

    @ti.func
    def is_idle(self, c):
        """Prescribed, or without mass (every element around it eroded, stages/masses.py):
        skipped by P2G/G2P and the explicit-FE update, it keeps a zero velocity."""
        out = self.is_prescribed(c)
        if ti.static(self.cfg.mass_update):
            out = out or self.mass_of(c) <= 0.0
        return out

    @ti.func
    def drill_normal(self, c):
        """Unit nodal normal and whether the drilling projection applies (not at kinks; never
        with the drilling spring of stages/drilling.py, which keeps the drilling rotation)."""
        n = ti.Vector([0.0, 0.0, 1.0])
        ok = False
        if ti.static(not self.cfg.drilling_spring):
            total = self.s.nodes.normal_sum[c]
            ok = total.norm() >= 0.5 * self.s.nodes.area_sum[c]
            n = total.normalized(1e-300)
        return n, ok

    @ti.func
    def contact_force(self, c):
        """f_con: the self-contact's and the rigid tools' force on node c this step."""
        f = ti.Vector([0.0, 0.0, 0.0])
        if ti.static(self.cfg.contact):
            f += self.s.contact.force[c]
        if ti.static(self.cfg.tools):
            f += self.s.tools.total_force[c]
        return f

    @ti.func
    def residual_force(self, c):
        """Out-of-balance nodal force f_ext - f_int (+ f_con) with fixed and prescribed components dropped."""
        force, _ = self.loads.at_node(c)
        r = force - self.s.nodes.force_int[c]
        if ti.static(self.cfg.contact or self.cfg.tools):
            r += self.contact_force(c)
        if ti.static(self.cfg.joints):       # the slaves' forces lumped on a master (stages/joints.py)
            r += self.s.joints.node_force[c]
        return drop_fixed(r, self.held(c), 0)

    @ti.func
    def residual_torque(self, c):
        """Out-of-balance nodal moment mu_ext - mu_int without its drilling part (method.md 2.3),
        fixed components dropped."""
        normal, project = self.drill_normal(c)
        _, moment = self.loads.at_node(c)
        return self.residual_torque_about(c, normal, project, moment)

    @ti.func
    def net_moment(self, c, moment):
        """mu_ext - mu_int at node c (`moment`: mu_ext), with its joint slaves' moments lumped on
        it (stages/joints.py)."""
        torque = moment - self.s.nodes.moment_int[c]
        if ti.static(self.cfg.joints):
            torque += self.s.joints.node_moment[c]
        return torque

    @ti.func
    def residual_torque_about(self, c, normal, project, moment):
        """residual_torque with the node's drilling normal and external moment already at hand."""
        torque = self.net_moment(c, moment)
        if project:
            torque -= torque.dot(normal) * normal
        return drop_fixed(torque, self.held(c), 3)

    @ti.func
    def velocity_gain(self, mass):
        """dv = gain * F: the central-difference dt/m, plus FIRE's mixing term in a static solve."""
        gain = impulse_time(self.s.step) / mass
        if ti.static(self.cfg.fire):
            gain += self.s.step.fire_mix[None] / mass
        return gain

    @ti.func
    def finish(self, c, v_grid):
        """Given the node's new grid velocity: apply BCs, prescribed motion and walls, move it,
        update omega (S5 with the drilling projection of method.md 2.3), book KE, the node's
        energy increments (energy.py: work with the time-centred velocity), residual and max
        speed, and (batched launch) zero the node sums of the element loads."""
        dt = self.s.step.dt[None]
        mask = self.s.nodes.fix_mask[c]
        force_ext, moment_ext = self.loads.at_node(c)
        keep = self.s.step.velocity_keep[None]
        v_start = keep * self.s.nodes.grid_velocity[c]          # v^(n-1/2) (0 after a relaxation reset)
        w_start = keep * self.s.nodes.omega[c]
        vg = drop_fixed(v_grid, mask, 0)
        rigid = self.s.nodes.body[c] >= 0
        follower, spins = False, False           # a joint's slave, its rotation tied (stages/joints.py)
        if ti.static(self.cfg.joints):
            follower, spins = self.joints.follows(c), self.joints.spins_with(c)
        placed = self.s.nodes.position[c]              # a rotating body's slave: its new place
        if ti.static(self.cfg.bodies):
            if rigid:
                vg, placed = self.bodies.slave_motion(c)
        moved = 0                                            # DOF bits prescribed by a motion
        if ti.static(self.cfg.loads):
            moved = self.motion.mask(c)
            vg = self.motion.prescribed(c, vg, v_start, 0)
        before_walls = vg
        if (mask & FIXED_TRANSLATION) == FIXED_TRANSLATION:
            # support reaction R = f_int - f_ext - f_con (method.md 2.5a)
            reaction = self.s.nodes.force_int[c] - force_ext
            if ti.static(self.cfg.contact or self.cfg.tools):
                reaction -= self.contact_force(c)
            if ti.static(self.cfg.selective_mass):     # the added mass's inertial force (stages/selective_mass.py)
                reaction += self.s.nodes.sms_product[c]
            if ti.static(self.cfg.joints):             # a fixed master carries its slaves' loads
                reaction -= self.s.joints.node_force[c]
            self.acc.total(self.s.step.reaction, reaction)
        elif ti.static(self.cfg.walls):
            if not rigid and not follower and (moved & FIXED_TRANSLATION) == 0:      # walls leave prescribed nodes alone
                vg = self.bodies.walls(c, vg)
        if not (vg.norm() <= self.s.step.runaway_speed[None]):       # also catches NaN
            self.s.step.status[None] = STATUS_NONFINITE
            self.s.step.status_index[None] = c
        self.s.nodes.grid_velocity[c] = vg
        if ti.static(self.cfg.method == "mpm"):
            # the carried velocity gets the same BC/wall correction, else P2G would feed the
            # removed velocity back to the grid every step
            self.s.nodes.velocity[c] += vg - v_grid
            if ti.static(self.cfg.motion_windows):
                if self.s.grid.on_grid[c] == 0:     # held off the grid: it carries the velocity it moves
                    self.s.nodes.velocity[c] = vg   # with, which it keeps when its motion releases it
        self.s.nodes.position[c] += dt * vg
        if ti.static(self.cfg.body_rotation):
            if rigid:
                self.s.nodes.position[c] = placed
        # rotations: J w' = mu_ext - mu_int, then remove the drilling component
        normal, project = self.drill_normal(c)
        torque = self.net_moment(c, moment_ext)
        w = w_start + self.velocity_gain(self.inertia_of(c)) * torque
        if ti.static(self.cfg.selective_mass):     # solved with the added mass (stages/selective_mass.py)
            w = w_start + impulse_time(self.s.step) * self.s.nodes.angular_acceleration[c]
        if project:
            w -= w.dot(normal) * normal
        w = drop_fixed(w, mask, 3)
        if rigid:               # a slave turns with its body (a ram's rotations are held)
            w = ti.Vector([0.0, 0.0, 0.0])
            if ti.static(self.cfg.body_rotation):
                w = self.bodies.slave_omega(c)
        if ti.static(self.cfg.loads):
            w = self.motion.prescribed(c, w, w_start, 3)
        if ti.static(self.cfg.mass_update):
            if self.inertia_of(c) <= 0.0:      # a node without mass (stages/masses.py)
                w = ti.Vector([0.0, 0.0, 0.0])
        if ti.static(self.cfg.joints):
            if spins:
                w = self.joints.spin(c)
        self.s.nodes.omega[c] = w
        self.rotate_orientation(c, dt * w)
        if ti.static(self.cfg.body_rotation):
            if rigid:           # composed with the body's rotation exactly (R(t = 0) = 1)
                self.s.nodes.rotation[c] = self.s.bodies.rotation[self.s.nodes.body[c]]
        if not rigid:        # a slave's rotation is held and its translation is the body's (stages/bodies.py)
            if not spins:
                self.acc.total(self.s.step.residual_sq,
                               self.residual_torque_about(c, normal, project, moment_ext).norm_sqr()
                               / (self.s.step.length_ref[None] ** 2))
            moving_v, moving_w = vg, w
            if ti.static(self.cfg.static and self.cfg.loads):      # a prescribed DOF's speed is no relaxation
                moving_v, moving_w = drop_fixed(vg, moved, 0), drop_fixed(w, moved, 3)
            mass, inertia = self.mass_of(c), self.inertia_of(c)
            if ti.static(self.cfg.joints):     # a joint's slave: its masters carry its (lumped) kinetic energy
                if follower:
                    mass = 0.0
                if spins:
                    inertia = 0.0
            self.acc.total(self.s.step.kinetic, 0.5 * (mass * moving_v.norm_sqr() + inertia * moving_w.norm_sqr()))
        v_mid, w_mid = 0.5 * (v_start + vg), 0.5 * (w_start + w)
        kick = impulse_time(self.s.step)              # the duration of the velocity update (dt/2 from rest)
        external = self.loads.work(c, v_mid, w_mid, kick)
        contact = 0.0
        force = force_ext - self.s.nodes.force_int[c]
        if ti.static(self.cfg.contact):
            contact = -kick * self.s.contact.force[c].dot(v_mid)
        if ti.static(self.cfg.body_rotation):
            if rigid:           # a rotating body books its slaves' load and self-contact work (stages/bodies.py)
                external, contact = 0.0, 0.0
        if ti.static(self.cfg.tools):
            contact += self.bodies.tool_work(c, v_mid, kick)
        if ti.static(self.cfg.contact or self.cfg.tools):
            force += self.contact_force(c)
        wall = -self.mass_of(c) * (vg - before_walls).dot(v_mid)     # minus the walls' impulse . v_mid
        motion = 0.0
        if ti.static(self.cfg.loads):
            motion = self.motion.book(c, force, torque, v_start, vg, w_start, w)
        self.energy.node(c, external, contact, wall, motion)
        self.acc.maximum(self.s.step.max_speed, ti.max(ti.abs(vg[0]), ti.abs(vg[1]), ti.abs(vg[2])))
        if ti.static(self.cfg.contact):
            for d in ti.static(range(3)):
                self.acc.maximum_at(self.s.contact.velocity_high, d, vg[d])
                self.acc.minimum_at(self.s.contact.velocity_low, d, vg[d])
        if ti.static(self.cfg.serial):          # parallel launches overwrite them (CornerLoads.gather)
            self.s.nodes.force_int[c] = ti.Vector([0.0, 0.0, 0.0])
            self.s.nodes.moment_int[c] = ti.Vector([0.0, 0.0, 0.0])
            if ti.static(self.cfg.nodal_normals):
                self.s.nodes.normal_sum[c] = ti.Vector([0.0, 0.0, 0.0])
                self.s.nodes.area_sum[c] = 0.0

    @ti.func
    def rotate_orientation(self, c, dtheta):
        """q <- normalize(q + 1/2 (0, dtheta) q): the orientation, for output only (BT needs no
        nodal frame).  With follower loads or prescribed motion it is physics (the loads turn
        with it; a prescribed rotation is checked against it), and the increment is the exact
        (cos(phi/2), sin(phi/2) dtheta / phi) q, phi = |dtheta| [choice: the first-order form
        turns by 2 atan(phi/2), 3e-4 rad short of a static level's 0.157 rad jump]."""
        turn = ti.Vector([1.0, 0.5 * dtheta[0], 0.5 * dtheta[1], 0.5 * dtheta[2]])
        if ti.static(self.cfg.loads):
            turn = quaternion_exp(dtheta)
        self.s.nodes.rotation[c] = quaternion_product(turn, self.s.nodes.rotation[c]).normalized()

    @ti.func
    def explicit_fe(self):
        """``fem`` mode: v~ += dt (f_ext - f_int)/m at the nodes (central difference)."""
        serial_loop(self.cfg.serial_node_loops)
        for c in range(self.s.nodes.count[None]):
            v = ti.Vector([0.0, 0.0, 0.0])
            if not self.is_idle(c):
                r = self.residual_force(c)
                self.acc.total(self.s.step.residual_sq, r.norm_sqr())
                v = self.s.step.velocity_keep[None] * self.s.nodes.grid_velocity[c] + self.velocity_gain(self.mass_of(c)) * r
            if ti.static(self.cfg.joints):
                if not self.joints.follows(c):          # a joint's slave: after its masters (stages/joints.py)
                    self.finish(c, v)
            else:
                self.finish(c, v)
