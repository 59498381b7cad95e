"""Prescribed motion (``[[motion]]``; stage S6, method.md 2.5): displacement, velocity or
acceleration of chosen DOFs of a node set, value x a curve f (curves.py), with the
reaction and the work of the constraint.

At the start of each step a short serial pass (:meth:`PrescribedMotion.begin`) turns each
motion's curve into what its DOFs need between the arguments s^n and s^(n+1) (the time; in
a static run the load factor, moved towards the level's by at most step.motion_ramp per
step, solvers/static.py, while the relaxation carries the rest of the shell after it):

* displacement, u = value f(s): a translation moves to X + u(s^(n+1)), v = (X + u - x^n) / dt,
  so its position is u to round-off however long the run; a rotation turns by
  value (f(s^(n+1)) - f(s^n)) (there is no rotation vector to aim at: the orientation is
  integrated, stages/constraints.NodeUpdate.rotate_orientation);
* velocity: v = value (F(s^(n+1)) - F(s^n)) / dt, F = int f: the exact mean of value f over
  the step [choice: the mid-step value f(t^(n+1/2)) is off by O(dt^2) at each corner of a
  table, every time, so positions would drift from value F(t)];
* acceleration: v^(n+1/2) = v^(n-1/2) + value (M^n - M^(n-1)), M^n = (G(s^(n+1)) - G(s^n)) / dt
  with G = int F, so that v^(n+1/2) = v_0 + value M^n (v_0: the [[initial]] velocity) and the
  position is X + v_0 t + value G(t) [choice: v + dt value f(t^n) lags half a step, an error
  of value f t dt / 2 in the position].

The free DOFs of a partly prescribed node move as the stage gives them (its grid velocity in
``mpm`` mode: the prescribed components' forces are left out of its P2G, as a support's
are); a node with all three translations held is Lagrangian only (is_prescribed).

Reaction and work.  The constraint force on a prescribed DOF is what takes the node's
momentum from the velocity the loads would give it to the prescribed one,
R = m (v_prescribed - v_free) / dt_k with v_free = v^(n-1/2) + dt_k (f_ext - f_int + f_con) / m
(dt_k: stages/timestep.impulse_time; J and the moments for rotations), i.e.
R = m (v^(n+1/2) - v^(n-1/2)) / dt_k - (f_ext - f_int + f_con): at rest (a converged static
level) the support reaction f_int - f_ext - f_con.  Its work dt_k R (v^(n-1/2) + v^(n+1/2)) / 2
is booked like every other force's (energy.py: time-centred), per node (the ``motion_work``
column) and per motion (:meth:`energy.EnergyLedger.motion`); the prescribed nodes' kinetic
energy then balances exactly.
"""
import taichi as ti

from .accumulate import Accumulator
from .loads import ExternalLoads
from .timestep import impulse_time

DISPLACEMENT, VELOCITY, ACCELERATION = 0, 1, 2      # scene.MOTION_KINDS


@ti.func
def held_bits(s: ti.template(), cfg: ti.template(), bits, motions):
    """The DOF bits (of a node or a rigid body) its motions hold this step: all of `bits`, or
    with time windows ([[motion]] start/end) those whose motion's window holds t^n
    (loads.motion_active, set by PrescribedMotion.begin) [choice: a window's edge inside a step
    takes effect at the next step; the steps do not land on it].  `motions`: the motion of each
    DOF."""
    m = bits
    if ti.static(cfg.motion_windows):
        for d in ti.static(range(6)):
            if (m >> d) & 1:
                if s.loads.motion_active[motions[d]] == 0:
                    m &= ~(1 << d)
    return m


@ti.data_oriented
class PrescribedMotion:
    def __init__(self, state, cfg, loads: ExternalLoads, energy):
        self.s = state
        self.cfg = cfg
        self.loads = loads
        self.energy = energy            # energy.EnergyLedger
        self.acc = Accumulator(cfg.serial)

    @ti.func
    def begin(self):
        """Each motion's displacement level and rate of this step (module docstring); remember
        s^(n+1)."""
        start = self.s.step.curve_argument[None]
        dt = self.s.step.dt[None]
        end = self.s.step.time[None] + dt
        if ti.static(self.cfg.static):       # towards lambda by at most motion_ramp per step
            end = self.s.step.load_factor[None]
            if ti.abs(end - start) > self.s.step.motion_ramp[None]:
                end = start + ti.math.sign(end - start) * self.s.step.motion_ramp[None]
        ti.loop_config(serialize=True)
        for k in range(self.s.loads.motion_count[None]):
            curve = self.s.loads.motion_curve[k]
            kind = self.s.loads.motion_kind[k]
            if kind == DISPLACEMENT:
                level = self.loads.curve_or_default(curve, end, 0)
                self.s.loads.motion_level[k] = level
                self.s.loads.motion_rate[k] = (level - self.loads.curve_or_default(curve, start, 0)) / dt
            elif kind == VELOCITY:
                self.s.loads.motion_rate[k] = (self.loads.curve_or_default(curve, end, 1)
                                    - self.loads.curve_or_default(curve, start, 1)) / dt
            else:
                mean = (self.loads.curve_or_default(curve, end, 2) - self.loads.curve_or_default(curve, start, 2)) / dt
                self.s.loads.motion_rate[k] = mean - self.s.loads.motion_mean[k]
                self.s.loads.motion_mean[k] = mean
        self.s.step.curve_argument[None] = end
        if ti.static(self.cfg.motion_windows):     # held over this step when start <= t^n < end
            now = self.s.step.time[None]
            for k in range(self.s.loads.motion_count[None]):
                window = self.s.loads.motion_window[k]
                self.s.loads.motion_active[k] = 1 if window[0] <= now < window[1] else 0

    @ti.func
    def mask(self, c):
        """DOF bits of node c its motions hold this step (:func:`held_bits`)."""
        return held_bits(self.s, self.cfg, self.s.nodes.motion_mask[c], self.s.nodes.motion[c])

    @ti.func
    def prescribed(self, c, vec, start, first_bit: ti.template()):
        """`vec` (a velocity: first_bit 0; an angular velocity: 3) with the components node c's
        motions prescribe this step; `start`: the same at the start of the step."""
        out = vec
        mask = self.mask(c)
        for d in ti.static(range(3)):
            if (mask >> (first_bit + d)) & 1:
                k = self.s.nodes.motion[c][first_bit + d]
                value = self.s.loads.motion_value[k][first_bit + d]
                kind = self.s.loads.motion_kind[k]
                if kind == DISPLACEMENT:
                    if ti.static(first_bit == 0):
                        out[d] = (self.s.nodes.position_ref[c][d] + value * self.s.loads.motion_level[k]
                                  - self.s.nodes.position[c][d]) / self.s.step.dt[None]
                    else:
                        out[d] = value * self.s.loads.motion_rate[k]
                elif kind == VELOCITY:
                    out[d] = value * self.s.loads.motion_rate[k]
                else:
                    out[d] = start[d] + value * self.s.loads.motion_rate[k]
        return out

    @ti.func
    def book(self, c, force, torque, v_start, v, w_start, w):
        """Reaction and work of node c's prescribed DOFs (module docstring); `force`, `torque`:
        f_ext - f_int + f_con and mu_ext - mu_int at the node.  Returns the node's work."""
        mask = self.mask(c)
        work = 0.0
        if ti.static(self.cfg.motion_windows):     # a released DOF has no reaction
            for d in ti.static(range(6)):
                if (self.s.nodes.motion_mask[c] >> d) & 1 and not (mask >> d) & 1:
                    self.s.nodes.motion_reaction[c, d] = 0.0
        if mask != 0:
            kick, dt = impulse_time(self.s.step), self.s.step.dt[None]
            mass, inertia = self.s.nodes.mass[c], self.s.nodes.inertia[c]
            for d in ti.static(range(6)):
                if (mask >> d) & 1:
                    reaction, done, scale = 0.0, 0.0, 1.0
                    if ti.static(self.cfg.static):       # quasi-static: no inertia (the masses are fictitious)
                        if ti.static(d < 3):
                            reaction = -force[d]
                            done = dt * reaction * v[d]
                        else:
                            reaction = -torque[d - 3]
                            done = dt * reaction * w[d - 3]
                            scale = 1.0 / self.s.step.length_ref[None]
                    elif ti.static(d < 3):
                        reaction = mass * (v[d] - v_start[d]) / kick - force[d]
                        done = kick * reaction * 0.5 * (v_start[d] + v[d])
                    else:
                        reaction = inertia * (w[d - 3] - w_start[d - 3]) / kick - torque[d - 3]
                        done = kick * reaction * 0.5 * (w_start[d - 3] + w[d - 3])
                    self.s.nodes.motion_reaction[c, d] = reaction
                    self.energy.motion(c, d, done)
                    work += done
                    if ti.static(self.cfg.static):      # the residual's scale (solvers/static.py)
                        self.acc.total(self.s.step.constraint_sq, (scale * reaction) ** 2)
        return work
