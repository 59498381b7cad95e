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
    """Bodies and walls are run-time tables (state.bodies); Features.bodies / walls decide
    whether their code is compiled."""

    def __init__(self, state, cfg, energy, loads):
        self.s = state
        self.cfg = cfg
        self.energy = energy            # energy.EnergyLedger
        self.loads = loads              # stages/loads.ExternalLoads
        self.acc = Accumulator(cfg.serial)
        # threads launch: wall impulses summed in node order instead of by atomics (serial
        # and gpu launches add them directly)
        self.impulses_in_node_order = cfg.launch == "threads" and cfg.moving_walls

    @ti.func
    def update(self):
        """V^{n+1/2} = V^{n-1/2} + dt F / M_tot with F = sum over slaves of (f_ext - f_int + f_con).dir
        (+ the added mass's weight under gravity)."""
        for b in range(self.s.bodies.count[None]):
            d = self.s.bodies.direction[b]
            force = 0.0
            if ti.static(self.cfg.loads):
                force = self.s.bodies.added_mass[b] * self.s.loads.gravity_now[None].dot(d)      # its weight
            for i in range(self.s.bodies.first_slave[b], self.s.bodies.first_slave[b] + self.s.bodies.slave_count[b]):
                c = self.s.bodies.slave_nodes[i]
                external, _ = self.loads.at_node(c)
                f = external - self.s.nodes.force_int[c]
                if ti.static(self.cfg.contact):
                    f += self.s.contact.force[c]
                force += f.dot(d)
            self.s.bodies.force[b] = force
            if ti.static(self.cfg.static):      # the body's own equilibrium (its slaves are not free nodes)
                self.s.step.residual_sq[None] += force * force
            self.s.bodies.velocity_start[b] = self.s.step.velocity_keep[None] * self.s.bodies.velocity[b]
            self.s.bodies.velocity[b] = self.s.step.velocity_keep[None] * self.s.bodies.velocity[b] + impulse_time(self.s.step) * force / self.s.bodies.total_mass[b]
            self.s.bodies.displacement[b] += self.s.step.dt[None] * self.s.bodies.velocity[b]
            if ti.static(self.cfg.loads):      # the added mass's weight works on the body (the slaves' loads: per node)
                weight = self.s.bodies.added_mass[b] * self.s.loads.gravity_now[None].dot(d)
                self.energy.body_external(b, impulse_time(self.s.step) * weight * 0.5
                                          * (self.s.bodies.velocity_start[b] + self.s.bodies.velocity[b]))

    @ti.func
    def slave_velocity(self, c):
        b = self.s.nodes.body[c]
        return self.s.bodies.velocity[b] * self.s.bodies.direction[b]

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
            if b >= 0:
                d = self.s.bodies.direction[b]
                p += self.s.bodies.displacement[b] * d          # at t^{n+1}
                wall_speed = self.s.bodies.velocity[b] * d.dot(n)
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
                if b >= 0:
                    if ti.static(self.cfg.moving_walls):
                        impulse = -m * dv * n.dot(self.s.bodies.direction[b])
                        if ti.static(self.impulses_in_node_order):   # summed by apply_wall_impulses
                            self.s.bodies.node_wall_impulse[c, b] += impulse
                        else:
                            self.acc.add(self.s.bodies.impulse, b, impulse)
                else:        # a fixed wall is a support: its force on the shell is reaction
                    self.acc.total(self.s.step.reaction, (m * dv / dt) * n)
        return out

    @ti.func
    def apply_wall_impulses(self):
        """A moving wall pushes its rigid body back (end of step).  The impulse J's energy,
        J V_mid with the body's time-centred velocity V_mid = (V^(n-1/2) + V^(n+1/2)) / 2, is
        taken out as wall energy (energy.py: the walls' work on the nodes is booked the same
        way, so a wall that only carries load books nothing)."""
        if ti.static(self.impulses_in_node_order):         # no atomics, the serial sum's bits
            ti.loop_config(serialize=True)
            for c in range(self.s.nodes.count[None]):
                for b in range(self.s.bodies.count[None]):
                    self.s.bodies.impulse[b] += self.s.bodies.node_wall_impulse[c, b]
                    self.s.bodies.node_wall_impulse[c, b] = 0.0
        ti.loop_config(serialize=True)
        for b in range(self.s.bodies.count[None]):
            impulse = self.s.bodies.impulse[b]
            self.s.bodies.velocity[b] += impulse / self.s.bodies.total_mass[b]
            v_mid = 0.5 * (self.s.bodies.velocity_start[b] + self.s.bodies.velocity[b])
            self.energy.body(b, -impulse * v_mid)
            self.s.bodies.impulse[b] = 0.0

    @ti.func
    def add_kinetic_energy(self):
        """Add the bodies' KE (slave nodes and added mass together: 1/2 M_tot V^2 with the
        velocity after the wall impulses; the node update leaves the slaves out) to the step's."""
        for b in range(self.s.bodies.count[None]):
            self.s.step.kinetic[None] += 0.5 * self.s.bodies.total_mass[b] * self.s.bodies.velocity[b] ** 2
