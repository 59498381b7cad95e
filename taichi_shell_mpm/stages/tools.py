"""Rigid tools ([[tool]]; stage S1 with the self-contact, docs/scenes.md): planes, finite
rectangles, capped cylinders, spheres and triangulated surface meshes, fixed, moving with a
rigid body or moved by a velocity or displacement curve; penalty contact with Coulomb
friction, the force and energy of each tool.  Compiled only for the kinds a scene uses
(``Features.tool_kinds``, a ti.static loop); every size, pose and coefficient is run-time data
(state.tools).

Contact [choice: the self-contact's law, stages/contact.py, so both behave alike and the
step stays stable at any dt].  A node's mid-surface point x is in contact with a tool when
its signed distance d to the tool's surface (positive on the outer side) is below half the
node's thickness h/2 (the shell's face touches the surface).  The tool pushes it along the
outward normal n with
    f_n = max(0, k (h/2 - d) + c 2 sqrt(k m) (v_tool - v) . n),   k = alpha m / dt_stable^2,
(m: the node's mass, alpha the tool's ``stiffness``, c its ``damping`` fraction of critical;
dt_stable, not a step shortened to land on an output time), plus the regularised Coulomb
friction of stages/contact.coulomb_friction on the slip v - v_tool.  The forces act at
x^n (the start of the step) like every other load, so m (v^(n+1/2) - v^(n-1/2)) = dt f.

Geometry, in the tool's frame (q = F (x - c), tools.py): d and n of each kind, in its file
(tool_kinds/plane.py, rectangle.py, cylinder.py, sphere.py, mesh.py), dispatched with
``ti.static`` over the kinds the scene uses.

Step limit [issue 28 item 3: a mesh tool moving more than its reach per step went through
the shell].  As the self-contact's (stages/timestep.contact_step), the next step keeps every
node's approach to every tool within approach_step(alpha) h (h: the node's thickness; 0.2 h
at alpha = 0.1, 0.63 h at 1), so a node is caught at most that far past touching and its
spring stops it within dt v / sqrt(alpha) more, well inside the mesh's (and the rectangle's)
reach of one thickness behind the surface:
    dt <= (approach_step(alpha) h + max(|d| - h/2, 0)) / (-(v - v_tool) . n),
over the nodes approaching a tool (n: the outward normal at the nearest surface point, so the
closing speed is the rate of change of d; a node sliding along a tool does not pay), with d a
lower bound of the distance (the mesh: ``reach`` where its buckets list no facet), so a tool
still far away does not shorten the step.  Not covered [measured, issue 28]: a tool driven at
a prescribed speed that carries the shell along holds its nodes at the depth F / k =
F dt^2 / (alpha m) (F: the shell pulling them back), ~ CFL v dt / alpha at the element step,
beyond the reach once v dt exceeds ~alpha h / 3 (a free plate dragged at 3 thicknesses per
element step was lost once its nodes had stopped closing).  Shortening dt while they are held
does not cure it: k follows dt_stable, and stiffening a loaded spring created energy (both a
depth rule and the self-contact's Galilean spread while touching were tried; the sphere strike
of tests/test_tools.py then collapsed its step).  Evaluated at x^n with v^(n-1/2) in
:meth:`node_force`, applied from the next step on (stages/timestep.TimeStep.next_step); the
first step is the element rule's (a tool should start clear of the shell).

Energy (energy.py).  The work done against each tool's forces is booked at the node with its
time-centred velocity, -dt f . v_mid (the node's ``contact`` column), and at the tool's own
motion, dt F . V_tool (F = sum f, V_tool the tool's mean velocity over the step, or its body's
time-centred velocity): so E_tool = -dt sum f . (v_mid - V_tool), the energy stored in the
penalty springs plus what damping and friction dissipate.  A tool moved by a curve does the
work dt F . V_tool on the shell (booked as prescribed-motion work); a body's kinetic energy
changes by exactly -dt F . V_mid (its velocity update, stages/bodies.py), so a body-driven
tool closes the balance by itself.

Rigid bodies.  A tool moving with a body is part of it (:meth:`RigidTools.pose`, the one
place a body's pose is read): centre = x_b + R (origin - X_b), frame rows F0 R^T, its points'
velocity V + omega x (x - x_b) (:meth:`point_velocity`).  Its force pushes the body back
(stages/bodies.RigidBodies.update): -F_k at the tool's centre plus the moment -M_k
(state.tools.moment, about the centre), not booked as the body's external work; :meth:`end`
books dt (F . V_mid + omega_mid . ((c_k - x_b) x F + M_k)) as the tool's work, which is what the
body's kinetic energy loses (translation exactly, rotation to the body's own balance).  Nodes
of that body are not in contact with it.
"""
import taichi as ti

from ..model.tools import BODY, DISPLACEMENT, FIXED, TOOL_KINDS, VELOCITY
from ..tool_kinds import KINDS
from . import contact
from .accumulate import Accumulator
from .contact import coulomb_friction
from .timestep import DT_UNSET, approach_step, impulse_time


@ti.data_oriented
class RigidTools:
    def __init__(self, state, cfg, loads, bodies):
        self.s = state
        self.bodies = bodies            # stages/bodies.RigidBodies (pose of the tools moving with a body)
        self.g = state.tools
        self.cfg = cfg
        self.loads = loads              # stages/loads.ExternalLoads (curves)
        self.acc = Accumulator(cfg.serial)
        self.scatter_acc = Accumulator(not cfg.atomic_scatter)
        self.shapes = tuple(KINDS[name].kernel(state.tools, contact) for name in cfg.tool_kinds)
        self.kind_index = tuple(TOOL_KINDS.index(name) for name in cfg.tool_kinds)

    # ------------------------------------------------------------------ pose
    @ti.func
    def pose(self, k):
        """Tool k's centre and frame at t^n and the mean velocity of its points over the step
        (for a body: its centre's V^(n-1/2); the points' in :meth:`point_velocity`).  A tool
        moving with body b is part of it: centre = x_b + R (origin - X_b) (bodies.place), frame
        rows F0 R^T (a local direction F q in space is R F0^T q)."""
        centre = self.g.origin[k]
        frame = self.g.frame[k]
        velocity = ti.Vector([0.0, 0.0, 0.0])
        motion = self.g.motion[k]
        if ti.static(self.cfg.bodies):
            if motion == BODY:
                b = self.g.body[k]
                centre = self.bodies.place(b, centre)
                velocity = self.s.bodies.velocity[b]
                if ti.static(self.cfg.body_rotation):
                    frame = frame @ self.bodies.rotation_matrix(b).transpose()
        if ti.static(self.cfg.loads):
            if motion == VELOCITY or motion == DISPLACEMENT:
                start = self.s.step.time[None]
                end = start + self.s.step.dt[None]
                level0, level1 = 0.0, 0.0
                if motion == VELOCITY:
                    level0 = self.loads.curve_or_default(self.g.curve[k], start, 1)
                    level1 = self.loads.curve_or_default(self.g.curve[k], end, 1)
                else:
                    level0 = self.loads.curve_or_default(self.g.curve[k], start, 0)
                    level1 = self.loads.curve_or_default(self.g.curve[k], end, 0)
                centre += level0 * self.g.value[k]
                velocity = (level1 - level0) / self.s.step.dt[None] * self.g.value[k]
        return centre, frame, velocity

    @ti.func
    def point_velocity(self, k, x):
        """Velocity of tool k's point at x: a translating tool's is the same everywhere, a
        body's tool's V + omega x (x - x_b) (bodies.point_velocity, at t^(n-1/2))."""
        velocity = self.g.velocity[k]
        if ti.static(self.cfg.body_rotation):
            if self.g.motion[k] == BODY:
                velocity = self.bodies.point_velocity(self.g.body[k], x)
        return velocity

    # ------------------------------------------------------------------ geometry (tool frame)
    @ti.func
    def distance(self, k, q):
        """Signed distance, outward normal (tool frame) and whether tool k can touch q: its
        kind's (tool_kinds/<kind>.py), dispatched over the kinds the scene uses."""
        d, n, hit = 0.0, ti.Vector([0.0, 0.0, 1.0]), False
        kind = self.g.kind[k]
        for i, shape in ti.static(enumerate(self.shapes)):
            if kind == ti.static(self.kind_index[i]):
                d, n, hit = shape.distance(k, q)
        return d, n, hit

    # ------------------------------------------------------------------ the stage
    @ti.func
    def begin(self):
        """Each tool's pose and velocity at t^n; this step's force sums cleared (serial)."""
        self.g.step_limit[None] = DT_UNSET
        ti.loop_config(serialize=True)
        for k in range(self.g.count[None]):
            centre, frame, velocity = self.pose(k)
            self.g.centre[k], self.g.axes[k], self.g.velocity[k] = centre, frame, velocity
            self.g.force[k] = ti.Vector([0.0, 0.0, 0.0])
            self.g.moment[k] = ti.Vector([0.0, 0.0, 0.0])
            self.g.contacts[k] = 0

    @ti.func
    def node_force(self, k, c):
        """Force of tool k on node c at x^n (module docstring), and the longest next step
        that keeps the node's approach to the tool within the penalty's reach (Step limit)."""
        x = self.s.nodes.position[c]
        frame = self.g.axes[k]
        d, n_local, hit = self.distance(k, frame @ (x - self.g.centre[k]))
        n = frame.transpose() @ n_local
        coefficients = self.g.coefficients[k]            # alpha, damping, mu
        v_rel = self.s.nodes.grid_velocity[c] - self.point_velocity(k, x)
        half = 0.5 * self.s.nodes.thickness[c]
        force = ti.Vector([0.0, 0.0, 0.0])
        gap = half - d
        if hit and gap > 0.0 and self.s.step.dt[None] > 0.0:
            m = self.s.nodes.mass[c]
            stiffness = coefficients[0] * m / (self.s.step.dt_stable[None] ** 2)
            f_n = ti.max(0.0, stiffness * gap - coefficients[1] * 2.0 * ti.sqrt(stiffness * m) * v_rel.dot(n))
            force = f_n * n + coulomb_friction(coefficients[2], f_n, v_rel, n, self.g.slip_speed[None], m,
                                               impulse_time(self.s.step))
        clearance = ti.max(d - half, 0.0)                # how far the node is from touching
        if not hit:
            clearance = ti.max(ti.abs(d) - half, 0.0)
        closing = -v_rel.dot(n)
        limit = DT_UNSET
        if closing > 0.0:
            limit = (approach_step(coefficients[0]) * 2.0 * half + clearance) / closing
        return force, limit

    @ti.func
    def forces(self):
        """Every node's force from every tool (parallel over nodes), then each tool's sums in
        node order (serial on the CPU: the same bits on any number of threads, so a body
        pushed by its tool moves the same)."""
        for c in range(self.s.nodes.count[None]):
            total = ti.Vector([0.0, 0.0, 0.0])
            own = -2
            if ti.static(self.cfg.bodies):
                own = self.s.nodes.body[c]
            limit = DT_UNSET
            for k in range(self.g.count[None]):
                f = ti.Vector([0.0, 0.0, 0.0])
                if not (self.g.motion[k] == BODY and self.g.body[k] == own):
                    f, pair_limit = self.node_force(k, c)
                    limit = ti.min(limit, pair_limit)
                self.g.node_force[c, k] = f
                total += f
            self.g.total_force[c] = total
            if limit < DT_UNSET and self.s.nodes.mass[c] > 0.0:     # not a node of eroded elements only
                self.acc.minimum(self.g.step_limit, limit)
        if ti.static(not self.cfg.atomic_scatter):
            ti.loop_config(serialize=True)
        for c in range(self.s.nodes.count[None]):
            for k in range(self.g.count[None]):
                f = self.g.node_force[c, k]
                if f.norm_sqr() > 0.0:
                    self.scatter_acc.add(self.g.force, k, f)
                    self.scatter_acc.add(self.g.moment, k, (self.s.nodes.position[c] - self.g.centre[k]).cross(f))
                    self.scatter_acc.add(self.g.contacts, k, 1)

    @ti.func
    def on_body(self, b, x_b):
        """The force the tools moving with body b take from the shell (its reaction, -F_k at
        each tool's centre c_k) and its moment about the body's centre x_b,
        -(c_k - x_b) x F_k - M_k (M_k: tools.moment, about c_k).  Not booked as external work
        on the body: :meth:`end` books the same work as the tool's (once)."""
        out = ti.Vector([0.0, 0.0, 0.0])
        moment = ti.Vector([0.0, 0.0, 0.0])
        for k in range(self.g.count[None]):
            if self.g.motion[k] == BODY and self.g.body[k] == b:
                out -= self.g.force[k]
                moment -= (self.g.centre[k] - x_b).cross(self.g.force[k]) + self.g.moment[k]
        return out, moment

    @ti.func
    def book_node(self, c, v_mid, kick):
        """The work done against the tools' forces on node c over the step, -dt f . v_mid,
        per tool and in all (returned: the node's contact column)."""
        total = 0.0
        for k in range(self.g.count[None]):
            work = -kick * self.g.node_force[c, k].dot(v_mid)
            if work != 0.0:
                self.acc.add(self.g.energy, k, work)
                total += work
        return total

    @ti.func
    def end(self):
        """Book each tool's work at its own motion, dt F . V_tool (module docstring; after the
        bodies' velocities are final), and a fixed tool's force as support reaction (serial)."""
        kick = impulse_time(self.s.step)
        ti.loop_config(serialize=True)
        for k in range(self.g.count[None]):
            velocity = self.g.velocity[k]
            if ti.static(self.cfg.bodies):
                if self.g.motion[k] == BODY:
                    b = self.g.body[k]
                    velocity = 0.5 * (self.s.bodies.velocity_start[b] + self.s.bodies.velocity[b])
            work = kick * self.g.force[k].dot(velocity)
            if ti.static(self.cfg.body_rotation):     # sum f . omega_mid x (x - x_b^n)
                if self.g.motion[k] == BODY:
                    b = self.g.body[k]
                    # the kick's time-centred omega and x_b^n, with which the moment about x_b^n
                    # (on_body) changed the body's KE (RigidBodies.update; the drift's omega and an
                    # x_b^n rebuilt from the velocity after the wall impulses missed it)
                    omega_mid = self.s.bodies.omega_mid[b]
                    x_b = self.s.bodies.center_start[b]
                    work += kick * omega_mid.dot((self.g.centre[k] - x_b).cross(self.g.force[k]) + self.g.moment[k])
            self.g.work[k] += work
            self.g.energy[k] += work
            self.s.step.contact_energy[None] += work
            if self.g.motion[k] == VELOCITY or self.g.motion[k] == DISPLACEMENT:
                self.s.step.motion_work[None] += work
            if self.g.motion[k] == FIXED:
                self.s.step.reaction[None] += self.g.force[k]
