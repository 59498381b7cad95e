"""Rigid bodies with added mass and rigid planar walls (stage S6; method.md 2.5c, 7.5).

A rigid body translates along one direction: its slave nodes are Lagrangian only
(skipped by P2G/G2P), the force their elements exert is summed, and
M_tot V' = F (M_tot = added mass + slave node masses).  A wall keeps every free node's
mid-surface at least half the shell thickness on the side its normal points to, by a
velocity correction after G2P (frictionless, perfectly inelastic); a moving wall's impulse
goes back to its rigid body, and the energy the walls take out (their impulses times the
time-centred velocities of nodes and bodies, energy.py) is booked as wall energy.  A fixed
wall is a support: the force of its correction over the step, m dv n / dt, is added to
the support reaction (with the clamped nodes' f_int - f_ext - f_con, stages/constraints.py),
so the crush force history sees a lobe that rests on the support plane.
"""
import taichi as ti

from .accumulate import Accumulator
from .timestep import impulse_time


@ti.data_oriented
class RigidBodies:
    def __init__(self, state, cfg, energy):
        self.s = state
        self.cfg = cfg
        self.energy = energy            # energy.EnergyLedger
        self.acc = Accumulator(cfg.serial)
        self.half_thickness = 0.5 * cfg.thickness
        # threads launch: wall impulses summed in node order instead of by atomics (serial
        # and gpu launches add them directly)
        self.impulses_in_node_order = cfg.launch == "threads" and any(w[2] >= 0 for w in cfg.walls)

    @ti.func
    def update(self):
        """V^{n+1/2} = V^{n-1/2} + dt F / M_tot with F = sum over slaves of (f_ext - f_int + f_con).dir."""
        for b, body in ti.static(enumerate(self.cfg.bodies)):
            d = ti.Vector(body[2], dt=ti.f64)
            force = 0.0
            for i in range(body[3], body[3] + body[4]):
                c = self.s.slave_nodes[i]
                f = self.s.load_factor[None] * self.s.load_force[c] - self.s.force_int[c]
                if ti.static(self.cfg.has_contact):
                    f += self.s.force_contact[c]
                force += f.dot(d)
            self.s.body_force[b] = force
            if ti.static(self.cfg.static):      # the body's own equilibrium (its slaves are not free nodes)
                self.s.residual_sq[None] += force * force
            self.s.body_velocity_start[b] = self.s.velocity_keep[None] * self.s.body_velocity[b]
            self.s.body_velocity[b] = self.s.velocity_keep[None] * self.s.body_velocity[b] + \
                impulse_time(self.s) * force / body[0]
            self.s.body_displacement[b] += self.s.dt[None] * self.s.body_velocity[b]

    @ti.func
    def slave_velocity(self, c):
        v = ti.Vector([0.0, 0.0, 0.0])
        for b, body in ti.static(enumerate(self.cfg.bodies)):
            if self.s.node_body[c] == b:
                v = self.s.body_velocity[b] * ti.Vector(body[2], dt=ti.f64)
        return v

    @ti.func
    def walls(self, c, v):
        """Correct the velocity of free node c so that it ends the step outside every wall."""
        out = v
        for w in ti.static(self.cfg.walls):
            n = ti.Vector(w[1], dt=ti.f64)
            p = ti.Vector(w[0], dt=ti.f64)
            wall_speed = 0.0
            if ti.static(w[2] >= 0):
                d = ti.Vector(self.cfg.bodies[w[2]][2], dt=ti.f64)
                p += self.s.body_displacement[w[2]] * d          # at t^{n+1}
                wall_speed = self.s.body_velocity[w[2]] * d.dot(n)
            dt = self.s.dt[None]
            gap = (self.s.position[c] + dt * out - p).dot(n) - self.half_thickness
            if gap < 0.0 and dt > 0.0:
                # no further approach than the wall moves, plus a bounded push-out of a node
                # already inside (at most 1% of the half thickness per step: an unbounded
                # "land exactly" correction kicked folded nodes behind the moving wall)
                push = ti.min((self.s.position[c] - p).dot(n) + dt * wall_speed - self.half_thickness, 0.0)   # at t^n
                target = wall_speed + ti.min(-push, 0.01 * self.half_thickness) / dt
                dv = ti.max(0.0, target - out.dot(n))
                out += dv * n
                m = self.s.corner_mass[c]
                if ti.static(w[2] >= 0):
                    impulse = -m * dv * n.dot(ti.Vector(self.cfg.bodies[w[2]][2], dt=ti.f64))
                    if ti.static(self.impulses_in_node_order):   # summed by apply_wall_impulses
                        self.s.node_wall_impulse[c, w[2]] += impulse
                    else:
                        self.acc.add(self.s.body_impulse, w[2], impulse)
                else:        # a fixed wall is a support: its force on the shell is reaction
                    self.acc.total(self.s.reaction, (m * dv / dt) * n)
        return out

    @ti.func
    def apply_wall_impulses(self):
        """A moving wall pushes its rigid body back (end of step).  The impulse J's energy,
        J V_mid with the body's time-centred velocity V_mid = (V^(n-1/2) + V^(n+1/2)) / 2, is
        taken out as wall energy (energy.py: the walls' work on the nodes is booked the same
        way, so a wall that only carries load books nothing)."""
        if ti.static(self.impulses_in_node_order):         # no atomics, the serial sum's bits
            ti.loop_config(serialize=True)
            for c in range(self.s.n_nodes):
                for b in ti.static(range(len(self.cfg.bodies))):
                    self.s.body_impulse[b] += self.s.node_wall_impulse[c, b]
                    self.s.node_wall_impulse[c, b] = 0.0
        for b, body in ti.static(enumerate(self.cfg.bodies)):
            impulse = self.s.body_impulse[b]
            self.s.body_velocity[b] += impulse / body[0]
            v_mid = 0.5 * (self.s.body_velocity_start[b] + self.s.body_velocity[b])
            self.energy.body(b, -impulse * v_mid)
            self.s.body_impulse[b] = 0.0

    @ti.func
    def kinetic_energy(self):
        """KE of the bodies, slave nodes and added mass together (1/2 M_tot V^2 with the
        velocity after the wall impulses; the node update leaves the slaves out)."""
        ke = 0.0
        for b, body in ti.static(enumerate(self.cfg.bodies)):
            ke += 0.5 * body[0] * self.s.body_velocity[b] ** 2
        return ke
