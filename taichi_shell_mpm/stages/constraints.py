"""Node-level update after the velocity is known: essential BCs, position, rotations
(stages S4 tail, S5, S6; method.md 2.3 and 2.5) and the per-node energy terms (section 8).

Also the explicit-FE node update used in ``fem`` mode, where the grid is switched off and
the same BT forces are integrated directly at the nodes.
"""

import taichi as ti

from ..state import STATUS_NONFINITE, State
from .accumulate import Accumulator
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
    def __init__(self, state: State, cfg, bodies, energy):
        self.s = state
        self.cfg = cfg
        self.bodies = bodies
        self.energy = energy            # energy.EnergyLedger
        self.acc = Accumulator(cfg.serial)

    @ti.func
    def is_prescribed(self, c):
        """Fully prescribed translation or rigid-body slave: Lagrangian only, skipped by P2G/G2P
        (method.md 2.5a, 2.5c)."""
        return (self.s.nodes.fix_mask[c] & FIXED_TRANSLATION) == FIXED_TRANSLATION or self.s.nodes.body[c] >= 0

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
    def residual_force(self, c):
        """Out-of-balance nodal force f_ext - f_int with fixed components dropped."""
        r = self.s.step.load_factor[None] * self.s.nodes.load_force[c] - self.s.nodes.force_int[c]
        if ti.static(self.cfg.contact):
            r += self.s.contact.force[c]
        return drop_fixed(r, self.s.nodes.fix_mask[c], 0)

    @ti.func
    def residual_torque(self, c):
        """Out-of-balance nodal moment mu_ext - mu_int without its drilling part (method.md 2.3),
        fixed components dropped."""
        normal, project = self.drill_normal(c)
        return self.residual_torque_about(c, normal, project)

    @ti.func
    def residual_torque_about(self, c, normal, project):
        """residual_torque with the node's drilling normal already at hand (finish has it)."""
        torque = self.s.step.load_factor[None] * self.s.nodes.load_moment[c] - self.s.nodes.moment_int[c]
        if project:
            torque -= torque.dot(normal) * normal
        return drop_fixed(torque, self.s.nodes.fix_mask[c], 3)

    @ti.func
    def velocity_gain(self, mass):
        """dv = gain * F: the central-difference dt/m, plus FIRE's mixing term in a static solve."""
        gain = impulse_time(self.s.step) / mass
        if ti.static(self.cfg.fire):
            gain += self.s.step.fire_mix[None] / mass
        return gain

    @ti.func
    def finish(self, c, v_grid):
        """Given the node's new grid velocity: apply BCs and walls, move it, update omega
        (S5 with the drilling projection of method.md 2.3), book KE, the node's energy
        increments (energy.py: work with the time-centred velocity), residual and max speed,
        and (batched launch) zero the node sums of the element loads."""
        dt = self.s.step.dt[None]
        mask = self.s.nodes.fix_mask[c]
        lam = self.s.step.load_factor[None]
        keep = self.s.step.velocity_keep[None]
        v_start = keep * self.s.nodes.grid_velocity[c]          # v^(n-1/2) (0 after a relaxation reset)
        w_start = keep * self.s.nodes.omega[c]
        vg = drop_fixed(v_grid, mask, 0)
        rigid = self.s.nodes.body[c] >= 0
        if ti.static(self.cfg.bodies):
            if rigid:
                vg = self.bodies.slave_velocity(c)
        before_walls = vg
        if (mask & FIXED_TRANSLATION) == FIXED_TRANSLATION:
            # support reaction R = f_int - f_ext - f_con (method.md 2.5a)
            reaction = self.s.nodes.force_int[c] - lam * self.s.nodes.load_force[c]
            if ti.static(self.cfg.contact):
                reaction -= self.s.contact.force[c]
            self.acc.total(self.s.step.reaction, reaction)
        elif ti.static(self.cfg.walls):
            if not rigid:
                vg = self.bodies.walls(c, vg)
        if not (vg.norm() <= self.s.step.runaway_speed[None]):       # also catches NaN
            self.s.step.status[None] = STATUS_NONFINITE
            self.s.step.status_index[None] = c
        self.s.nodes.grid_velocity[c] = vg
        if ti.static(self.cfg.method == "mpm"):
            # the carried velocity gets the same BC/wall correction, else P2G would feed the
            # removed velocity back to the grid every step
            self.s.nodes.velocity[c] += vg - v_grid
        self.s.nodes.position[c] += dt * vg
        # rotations: J w' = mu_ext - mu_int, then remove the drilling component
        normal, project = self.drill_normal(c)
        torque = lam * self.s.nodes.load_moment[c] - self.s.nodes.moment_int[c]
        w = w_start + self.velocity_gain(self.s.nodes.inertia[c]) * torque
        if project:
            w -= w.dot(normal) * normal
        w = drop_fixed(w, mask, 3)
        if rigid:
            w = ti.Vector([0.0, 0.0, 0.0])
        self.s.nodes.omega[c] = w
        self.rotate_orientation(c, dt * w)
        if not rigid:        # a slave's rotation is held and its translation is the body's (stages/bodies.py)
            self.acc.total(self.s.step.residual_sq,
                           self.residual_torque_about(c, normal, project).norm_sqr() / (self.s.step.length_ref[None] ** 2))
            self.acc.total(self.s.step.kinetic, 0.5 * (self.s.nodes.mass[c] * vg.norm_sqr()
                                                  + self.s.nodes.inertia[c] * w.norm_sqr()))
        v_mid, w_mid = 0.5 * (v_start + vg), 0.5 * (w_start + w)
        kick = impulse_time(self.s.step)              # the duration of the velocity update (dt/2 from rest)
        external = kick * lam * (self.s.nodes.load_force[c].dot(v_mid) + self.s.nodes.load_moment[c].dot(w_mid))
        contact = 0.0
        if ti.static(self.cfg.contact):
            contact = -kick * self.s.contact.force[c].dot(v_mid)
        wall = -self.s.nodes.mass[c] * (vg - before_walls).dot(v_mid)     # minus the walls' impulse . v_mid
        self.energy.node(c, external, contact, wall)
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
        """q <- normalize(q + 1/2 (0, dtheta) q): orientation for output only (BT needs no nodal frame)."""
        q = self.s.nodes.rotation[c]
        p = 0.5 * dtheta
        r = ti.Vector([
            q[0] - p[0] * q[1] - p[1] * q[2] - p[2] * q[3],
            q[1] + p[0] * q[0] + p[1] * q[3] - p[2] * q[2],
            q[2] - p[0] * q[3] + p[1] * q[0] + p[2] * q[1],
            q[3] + p[0] * q[2] - p[1] * q[1] + p[2] * q[0]])
        self.s.nodes.rotation[c] = r.normalized()

    @ti.func
    def explicit_fe(self):
        """``fem`` mode: v~ += dt (f_ext - f_int)/m at the nodes (central difference)."""
        for c in range(self.s.nodes.count[None]):
            v = ti.Vector([0.0, 0.0, 0.0])
            if not self.is_prescribed(c):
                r = self.residual_force(c)
                self.acc.total(self.s.step.residual_sq, r.norm_sqr())
                v = self.s.step.velocity_keep[None] * self.s.nodes.grid_velocity[c] + self.velocity_gain(self.s.nodes.mass[c]) * r
            self.finish(c, v)
