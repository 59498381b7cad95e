"""External loads of a step (stage S1; method.md 2.1) and the time curves they read
(curves.py; the tables of loading.py).

:meth:`ExternalLoads.at_node` is the one place the step reads a node's external force and
moment f_ext, mu_ext (the node update, P2G's residual, the rigid bodies, FIRE): the plain
dead loads times the load factor, and with ``Features.loads`` the loads that follow a
curve or turn with their node, the pressure and gravity.  Loads act at the start of the
step: their curves are read at t^n (the load factor lambda in a static run), so that
m (v^(n+1/2) - v^(n-1/2)) = dt f_ext^n and their work is booked time-centred like the
plain loads' (energy.py).

Follower loads turn with their node (:meth:`ExternalLoads.follow`): with its fibre, the
reference normal n0 turned by the node's orientation quaternion (nodes.rotation, updated by
stages/constraints.NodeUpdate.rotate_orientation), and in the plane normal to it with the
direction to a neighbouring node [choice, measured: the quaternion's rotation about the
normal is the integral of the drilling rate, which the Belytschko-Tsay element neither
resists nor defines; turned by the full quaternion, the follower end moment on the rolled
strip (Sze) drove the tip nodes' drilling rotations apart by 0.06 rad and the relaxation of
the third of 8 levels never converged; the geometric in-plane direction is what LS-DYNA's
follower loads use too (nodes defining the direction)].  The loads are scaled and turned
once at the start of the step, so every reader sees the same f_ext^n whatever the order
the nodes move in.  Pressure follows the current
geometry: each element's consistent nodal forces int N_a p n dA over the bilinear surface
through its corners at x^n (:func:`pressure_corner_forces`) [choice: exact for any quad,
warped or not; an equal quarter of p (d13 x d24) / 2 per corner is the same only for a
parallelogram, and the frozen CPDI2 weights are consistent only in the reference
configuration].  The corner forces are written per element slot and summed at each
loaded node in slot order [choice]: the same bits in every launch and on any number of
threads, without atomics (as stages/accumulate.CornerLoads does for the element loads).
An eroded element (stages/masses.py) carries no pressure from the step after its failure on:
its surface is gone, and its corner nodes may be left without mass.  Gravity acts on the
physical mass, which the mass rebuild of erosion keeps at what remains (stages/masses.py).
"""
import taichi as ti

from ..curves import SMOOTH_STEP
from .accumulate import Accumulator


@ti.func
def turned(q, v):
    """v turned by the unit quaternion q = (w, x, y, z)."""
    u = ti.Vector([q[1], q[2], q[3]])
    t = 2.0 * u.cross(v)
    return v + q[0] * t + u.cross(t)


@ti.func
def pressure_corner_forces(x, triangle):
    """Rows: the nodal forces of a unit pressure on the element with corners x (4x3) along the
    corner order's normal (loading.pressure_corner_forces is the numpy twin): for a quad the
    integrals of N_a (x_xi x x_eta) = c0 + xi c1 + eta c2 over the parent square,
    c0 + (xi_a c1 + eta_a c2) / 3; for a triangle a third of its vector area at each corner."""
    out = ti.Matrix.zero(ti.f64, 4, 3)
    x1, x2 = ti.Vector([x[0, 0], x[0, 1], x[0, 2]]), ti.Vector([x[1, 0], x[1, 1], x[1, 2]])
    x3, x4 = ti.Vector([x[2, 0], x[2, 1], x[2, 2]]), ti.Vector([x[3, 0], x[3, 1], x[3, 2]])
    if triangle:
        third = (x2 - x1).cross(x3 - x1) / 6.0
        for a, d in ti.static(ti.ndrange(3, 3)):
            out[a, d] = third[d]
    else:
        a1 = 0.25 * (-x1 + x2 + x3 - x4)
        a2 = 0.25 * (-x1 - x2 + x3 + x4)
        a3 = 0.25 * (x1 - x2 + x3 - x4)
        c0, c1, c2 = a1.cross(a2), a1.cross(a3), a3.cross(a2)
        for a in ti.static(range(4)):
            xi, eta = ti.static((-1.0, 1.0, 1.0, -1.0)[a], (-1.0, -1.0, 1.0, 1.0)[a])
            f = c0 + (xi * c1 + eta * c2) / 3.0
            for d in ti.static(range(3)):
                out[a, d] = f[d]
    return out


@ti.data_oriented
class ExternalLoads:
    def __init__(self, state, cfg):
        self.s = state
        self.cfg = cfg                  # config.Features
        self.acc = Accumulator(cfg.serial)

    # ------------------------------------------------------------------ curves
    @ti.func
    def curve(self, k, arg, order: ti.template()):
        """f(arg) (order 0), F = int_0^arg f (1) or G = int_0^arg F (2) of curve k (curves.py)."""
        p = self.s.loads.curve_parameter[k]                  # start, end, scale
        f, integral, second = 0.0, 0.0, 0.0
        if self.s.loads.curve_kind[k] == SMOOTH_STEP:
            length = p[1] - p[0]
            x = ti.min(ti.max((arg - p[0]) / length, 0.0), 1.0)
            after = ti.max(arg - p[1], 0.0)
            f = x * x * x * (10.0 - 15.0 * x + 6.0 * x * x)
            integral = length * x ** 4 * (2.5 - 3.0 * x + x * x) + after
            second = length * length * x ** 5 * (0.5 - 0.5 * x + x * x / 7.0) + 0.5 * length * after + 0.5 * after * after
        else:
            lo = self.s.loads.curve_first[k]
            row = self.s.loads.curve_table[lo]
            if arg < row[0]:                      # the flat start
                tau = arg - row[0]
                f, integral, second = row[1], row[1] * tau, 0.5 * row[1] * tau * tau
            else:                                 # the last row with t_i <= arg (bisection)
                hi = lo + self.s.loads.curve_rows[k]
                while hi - lo > 1:
                    mid = (lo + hi) // 2
                    if self.s.loads.curve_table[mid][0] <= arg:
                        lo = mid
                    else:
                        hi = mid
                row = self.s.loads.curve_table[lo]
                tau = arg - row[0]
                f = row[1] + row[2] * tau
                integral = row[3] + row[1] * tau + 0.5 * row[2] * tau * tau
                second = row[4] + row[3] * tau + 0.5 * row[1] * tau * tau + row[2] * tau * tau * tau / 6.0
        origin = self.s.loads.curve_origin[k]
        value = f
        if ti.static(order == 1):
            value = integral - origin[0]
        if ti.static(order == 2):
            value = second - origin[1] - origin[0] * arg
        return p[2] * value

    @ti.func
    def curve_or_default(self, k, arg, order: ti.template()):
        """:meth:`curve`, or for k = -1 the default: f(s) = s in a static run (s = lambda), f = 1
        in a dynamic one (F = s, G = s^2 / 2)."""
        out = arg
        if k >= 0:
            out = self.curve(k, arg, order)
        elif ti.static(not self.cfg.static):
            out = 1.0
            if ti.static(order == 1):
                out = arg
            if ti.static(order == 2):
                out = 0.5 * arg * arg
        return out

    @ti.func
    def argument(self):
        """What the loads' curves read this step: t^n, or the load factor in a static run."""
        out = self.s.step.time[None]
        if ti.static(self.cfg.static):
            out = self.s.step.load_factor[None]
        return out

    @ti.func
    def scale(self, k):
        """This step's value of curve k, or the load factor for k = -1."""
        out = self.s.step.load_factor[None]
        if k >= 0:
            out = self.s.loads.curve_value[k]
        return out

    # ------------------------------------------------------------------ the pass at the start of a step
    @ti.func
    def follow(self, i, v):
        """Vector v of follower entry i turned with its node: R v, R = F F0^T with the
        reference frame F0 (rows e0, n0 x e0, n0: loading.follower_frames) and the current
        one F = [e, d x e, d], d = q n0 (the fibre; q the node's orientation) and e the unit
        direction to the entry's neighbour node projected onto the plane normal to d."""
        c, frame = self.s.loads.entry_node[i], self.s.loads.entry_frame[i]
        d = turned(self.s.nodes.rotation[c], ti.Vector([frame[2, 0], frame[2, 1], frame[2, 2]]))
        e = self.s.nodes.position[self.s.loads.entry_neighbor[i]] - self.s.nodes.position[c]
        e = (e - e.dot(d) * d).normalized()
        local = frame @ v
        return local[0] * e + local[1] * d.cross(e) + local[2] * d

    @ti.func
    def begin(self):
        """Every curve at this step's argument (a short serial loop), gravity, the curve and
        follower entries (scaled, turned), and the pressure forces of the current geometry
        (per element slot, then summed at each loaded node)."""
        arg = self.argument()
        ti.loop_config(serialize=True)
        for k in range(self.s.loads.curve_count[None]):
            self.s.loads.curve_value[k] = self.curve(k, arg, 0)
        if ti.static(self.cfg.loads):
            self.s.loads.gravity_now[None] = self.scale(self.s.loads.gravity_curve[None]) * self.s.loads.gravity[None]
            for i in range(self.s.loads.entry_count[None]):
                scale = self.scale(self.s.loads.entry_curve[i])
                f, m = scale * self.s.loads.entry_force[i], scale * self.s.loads.entry_moment[i]
                if self.s.loads.entry_neighbor[i] >= 0:
                    f, m = self.follow(i, f), self.follow(i, m)
                self.s.loads.entry_force_now[i] = f
                self.s.loads.entry_moment_now[i] = m
            for i in range(self.s.loads.pressure_count[None]):
                e = self.s.loads.pressure_element[i]
                corners = self.s.elements.corners[e]
                x = ti.Matrix.zero(ti.f64, 4, 3)
                for a in ti.static(range(4)):
                    c = ti.max(corners[a], corners[0])       # a triangle's 4th corner: -1
                    for d in ti.static(range(3)):
                        x[a, d] = self.s.nodes.position[c][d]
                p = self.s.loads.pressure_value[i] * self.scale(self.s.loads.pressure_curve[i])
                if ti.static(self.cfg.erosion):      # an eroded element carries no load (stages/masses.py)
                    if self.s.elements.eroded[e] != 0:
                        p = 0.0
                f = p * pressure_corner_forces(x, corners[3] < 0)
                for a in ti.static(range(4)):
                    self.s.loads.pressure_corner_force[i, a] = ti.Vector([f[a, 0], f[a, 1], f[a, 2]])
            for j in range(self.s.loads.pressure_node_count[None]):
                total = ti.Vector([0.0, 0.0, 0.0])
                for i in range(self.s.loads.pressure_node_start[j], self.s.loads.pressure_node_start[j + 1]):
                    slot = self.s.loads.pressure_node_slots[i]
                    total += self.s.loads.pressure_corner_force[slot // 4, slot % 4]
                self.s.nodes.pressure_force[self.s.loads.pressure_nodes[j]] = total

    # ------------------------------------------------------------------ per node
    @ti.func
    def beyond_plain(self, c):
        """Force and moment on node c of the loads beyond the plain ones (curve and follower
        entries, pressure, gravity) in this step (:meth:`begin`)."""
        force = self.s.nodes.pressure_force[c] + self.s.nodes.physical_mass[c] * self.s.loads.gravity_now[None]
        moment = ti.Vector([0.0, 0.0, 0.0])
        for i in range(self.s.nodes.load_start[c], self.s.nodes.load_start[c + 1]):
            force += self.s.loads.entry_force_now[i]
            moment += self.s.loads.entry_moment_now[i]
        return force, moment

    @ti.func
    def at_node(self, c):
        """f_ext and mu_ext of node c in this step (module docstring)."""
        lam = self.s.step.load_factor[None]
        force = lam * self.s.nodes.load_force[c]
        moment = lam * self.s.nodes.load_moment[c]
        if ti.static(self.cfg.loads):
            f, m = self.beyond_plain(c)
            force += f
            moment += m
        return force, moment

    @ti.func
    def work(self, c, v_mid, w_mid, kick):
        """Their work on node c over the step, time-centred (energy.py): kick f_ext . v_mid +
        mu_ext . w_mid (written in the plain loads' form of before issue 18, so that a run
        without the new loads books the same bits)."""
        out = kick * self.s.step.load_factor[None] * (self.s.nodes.load_force[c].dot(v_mid)
                                                    + self.s.nodes.load_moment[c].dot(w_mid))
        if ti.static(self.cfg.loads):
            f, m = self.beyond_plain(c)
            out += kick * (f.dot(v_mid) + m.dot(w_mid))
        return out
