"""Tied contact and spot welds (scene/joints.py, set up by model/joints.py): kinematic
constraints of a slave node s on master nodes a, without Lagrange multipliers
(LS-DYNA's constraint-based tied contact and *CONSTRAINED_SPOTWELD).

Each joint j has a slave s, masters a with weights N_a (sum N_a = 1: a tie's segment shape
functions at the slave's projection (xi, eta); a weld's one master N1, N = 1), an offset r
(the slave's place relative to the interpolated point, x_s = sum N_a x_a + r) and whether
the slave's rotation is tied (a tie's `rotations`; always for a weld).

Before the masters' update (:meth:`Joints.distribute`), the slave's mass and loads go to the
masters with the shape functions (the transpose of the velocity map below):

    m_a += N_a m_s,    f_a += N_a f_s,    mu_a += N_a (r x f_s) [+ N_a mu_s tied],
    J_a += N_a (m_s |r|^2) [+ N_a J_s tied]

(f_s = f_ext - f_int + f_con of the slave, mu_s = mu_ext - mu_int).  The masters move with
these (fem: at the nodes; mpm: P2G carries m_a and f_a to the grid, so the slave's mass and
force meet the grid through its masters' stencils -- the slave itself is off the grid, like a
rigid body's slave -- and the grid's momentum is that of every node, sum m'_a v_a =
sum m_a v_a + m_s v_s).  After the masters' update (:meth:`Joints.follow`) the slave is
placed and given their motion:

    r^(n+1) = exp(dt omega_bar^) r^n,   omega_bar = sum N_a omega_a^(n+1/2),
    x_s^(n+1) = sum N_a x_a^(n+1) + r^(n+1),   v_s^(n+1/2) = sum N_a v_a + (r^(n+1) - r^n) / dt,
    omega_s^(n+1/2) = omega_bar (tied),

so a tie holds the slave at its offset from the segment, the offset turning with the
segment's (interpolated nodal) rotation, and a weld moves its pair as one rigid link.

Conservation.  With r = 0 the constraint is linear: v_s = sum N_a v_a at every half step,
and m'_a (v_a^+ - v_a^-) = dt f'_a gives the total momentum's change
sum_a m'_a dv_a = dt (sum f_a + f_s) exactly (the constraint forces cancel), and the angular
momentum's exactly too (sum N_a x_a = x_s).  The kinetic energy the integrator keeps is the
lumped one, 1/2 sum m'_a |v_a|^2 (+ 1/2 J'_a |omega_a|^2), with the slaves' own translational
(and tied rotational) kinetic energy left out: that is what energy.py books, so the loads'
work at the slave, f_s . v_s_mid = sum N_a f_s . v_a_mid, closes the balance to round-off
and the constraint does no work.  [choice] The physical kinetic energy differs by
1/2 sum m_s (sum N_a |v_a|^2 - |v_s|^2) >= 0 (the lumping, zero for a translating segment and
for a weld of coincident nodes); the exact alternative, the constraint's coupled mass
matrix m_s N N^T per slave, is a linear solve per step where slaves share masters.  With an
offset r != 0 the masters' rotary inertia takes the scalar m_s |r|^2 (the nodal inertias of
this code are scalars), so the angular momentum and the kinetic energy are kept to the
lumping of the link's inertia tensor, m_s (|r|^2 1 - r r^T) against m_s |r|^2 1, and the
linear momentum exactly.

Spot welds.  The weld's force on N2 is what made N2 do what it did:
f_c = m_2 (v_2^(n+1/2) - v_2^(n-1/2)) / dt - f_2 (for a pair of two masses, the mass-weighted
difference of their unconstrained accelerations, m1 m2 / (m1 + m2) (a_2 - a_1), plus the
link's rotation); split along the weld axis e (N1 -> N2, turned with the pair; coincident
nodes: N1's shell normal at t = 0): the normal force f_n = -f_c . e (> 0: tension, pulling
the pair apart) and the shear f_s = |f_c + f_n e|.  The weld fails at the end of the first
step where (max(f_n, 0) / SN)^n + (f_s / SS)^m >= 1 (LS-DYNA: only tension counts; coincident
nodes, where the axis has no sense: |f_n|), or at TF; from the next step on the two nodes are
free.  In a static solve the relaxation's inertia is fictitious: f_c = -f_2 (the equilibrium's
force; during a level's relaxation it may pass its converged value).  Its failure forces and time stay in the fields (summary.json).

A tie to a segment that erodes is released (the slave is free from the next step on).
"""
import taichi as ti

from ..state import State
from .rotation import rotate_vector
from .timestep import impulse_time

WELD = 1         # model/joints.WELD


@ti.data_oriented
class Joints:
    def __init__(self, state: State, cfg, loads):
        self.s = state
        self.cfg = cfg
        self.loads = loads              # stages/loads.ExternalLoads
        self.nodes = None               # stages/constraints.NodeUpdate (the Stepper sets it)

    # ------------------------------------------------------------ node-level queries
    @ti.func
    def follows(self, c):
        """Node c is an active joint's slave (moved by :meth:`follow`, off the grid)."""
        j = self.s.joints.node_joint[c]
        out = False
        if j >= 0:
            out = self.s.joints.active[j] == 1
        return out

    @ti.func
    def spins_with(self, c):
        """Node c is an active joint's slave whose rotation is tied."""
        out = False
        if self.follows(c):
            out = self.s.joints.rotations[self.s.joints.node_joint[c]] == 1
        return out

    @ti.func
    def spin(self, c):
        """sum N_a omega_a over the masters of the joint node c follows."""
        j = self.s.joints.node_joint[c]
        out = ti.Vector([0.0, 0.0, 0.0])
        for k in ti.static(range(4)):
            a = self.s.joints.masters[j][k]
            if a >= 0:
                out += self.s.joints.weights[j][k] * self.s.nodes.omega[a]
        return out

    # ------------------------------------------------------------ the step
    @ti.func
    def distribute(self):
        """Before the velocity update: each active slave's mass, rotary inertia, force and
        moment lumped on its masters (module docstring).  Serial: a few entries per joint, in
        joint order (the same sums on any number of threads)."""
        ti.loop_config(serialize=True)
        for j in range(self.s.joints.count[None]):
            for k in ti.static(range(4)):
                a = self.s.joints.masters[j][k]
                if a >= 0:
                    self.s.joints.node_mass[a] = 0.0
                    self.s.joints.node_inertia[a] = 0.0
                    self.s.joints.node_force[a] = ti.Vector([0.0, 0.0, 0.0])
                    self.s.joints.node_moment[a] = ti.Vector([0.0, 0.0, 0.0])
        ti.loop_config(serialize=True)
        for j in range(self.s.joints.count[None]):
            if ti.static(self.cfg.erosion):
                e = self.s.joints.element[j]
                if e >= 0:
                    if self.s.elements.eroded[e] != 0:
                        self.s.joints.active[j] = 0
            if self.s.joints.active[j] == 1:
                s = self.s.joints.slave[j]
                external, moment_ext = self.loads.at_node(s)
                f = external - self.s.nodes.force_int[s] + self.nodes.contact_force(s)
                self.s.joints.slave_force[j] = f
                m_s = self.s.nodes.mass[s]
                r = self.s.joints.offset[j]
                moment = r.cross(f)
                inertia = m_s * r.norm_sqr()
                if self.s.joints.rotations[j] == 1:
                    moment += moment_ext - self.s.nodes.moment_int[s]
                    inertia += self.s.nodes.inertia[s]
                for k in ti.static(range(4)):
                    a = self.s.joints.masters[j][k]
                    if a >= 0:
                        w = self.s.joints.weights[j][k]
                        self.s.joints.node_mass[a] += w * m_s
                        self.s.joints.node_inertia[a] += w * inertia
                        self.s.joints.node_force[a] += w * f
                        self.s.joints.node_moment[a] += w * moment

    @ti.func
    def follow(self):
        """After the masters' update: place each active slave, give it its masters' motion and
        finish its node update (NodeUpdate.finish: its loads' work, its own rotation when free);
        a weld's force and failure (module docstring)."""
        dt = self.s.step.dt[None]
        keep = self.s.step.velocity_keep[None]
        ti.loop_config(serialize=True)
        for j in range(self.s.joints.count[None]):
            if self.s.joints.active[j] == 1:
                s = self.s.joints.slave[j]
                spin = ti.Vector([0.0, 0.0, 0.0])
                place = ti.Vector([0.0, 0.0, 0.0])
                v_masters = ti.Vector([0.0, 0.0, 0.0])
                carried = ti.Vector([0.0, 0.0, 0.0])
                for k in ti.static(range(4)):
                    a = self.s.joints.masters[j][k]
                    if a >= 0:
                        w = self.s.joints.weights[j][k]
                        spin += w * self.s.nodes.omega[a]
                        place += w * self.s.nodes.position[a]
                        v_masters += w * self.s.nodes.grid_velocity[a]
                        if ti.static(self.cfg.method == "mpm"):
                            carried += w * self.s.nodes.velocity[a]
                r = rotate_vector(dt * spin, self.s.joints.offset[j])
                place += r
                v_start = keep * self.s.nodes.grid_velocity[s]
                # the secant sum N_a v_a + (r^(n+1) - r^n) / dt [choice]: the secant of the
                # positions, (x^(n+1) - x^n) / dt, is the same but cancels digits at small
                # speeds (1e-6 m/s on 1 m: 3e-7 of the speed lost, the balance with it)
                v = v_masters
                if dt > 0.0:
                    v += (r - self.s.joints.offset[j]) / dt
                if ti.static(self.cfg.method == "mpm"):      # the masters' carried velocity, for its release
                    self.s.nodes.velocity[s] = carried + v - v_masters
                self.nodes.finish(s, v)
                self.s.nodes.position[s] = place
                self.s.joints.offset[j] = r
                axis = rotate_vector(dt * spin, self.s.joints.axis[j])
                self.s.joints.axis[j] = axis
                if self.s.joints.kind[j] == WELD:
                    self.weld(j, s, v, v_start, axis)

    @ti.func
    def weld(self, j, s, v, v_start, axis):
        """Weld j's force this step and its failure test (module docstring)."""
        kick = impulse_time(self.s.step)
        force = -self.s.joints.slave_force[j]
        if ti.static(not self.cfg.static):      # a static solve's (relaxation's) inertia is fictitious
            if kick > 0.0:
                force += self.s.nodes.mass[s] * (v - v_start) / kick
        normal = -force.dot(axis)
        shear = (force + normal * axis).norm()
        self.s.joints.force_normal[j] = normal
        self.s.joints.force_shear[j] = shear
        self.s.joints.peak_normal[j] = ti.max(self.s.joints.peak_normal[j], normal)
        self.s.joints.peak_shear[j] = ti.max(self.s.joints.peak_shear[j], shear)
        limit = self.s.joints.strength[j]
        tension = ti.max(normal, 0.0)
        if limit[5] > 0.0:          # coincident nodes: the axis has no sense
            tension = ti.abs(normal)
        ratio = ti.pow(tension / limit[0], limit[2]) + ti.pow(shear / limit[1], limit[3])
        end = self.s.step.time[None] + self.s.step.dt[None]
        if ratio >= 1.0 or end >= limit[4]:
            self.s.joints.active[j] = 0
            self.s.joints.failure_time[j] = end
