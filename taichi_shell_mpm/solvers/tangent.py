"""The shell's internal forces for a trial increment from the last converged state, and
their tangent stiffness by central differences, element by element (issue 19).

Why a trial increment.  The element is in rate form (stages/shell.py): one update turns
the corner displacements dt v and rotation increments dt omega of a step into a strain
increment on the mid-step geometry, updates the stress at each through-thickness point
(the plastic return included), the hourglass and drilling resultants, and gives the
resisting nodal forces at the end of the step.  So the internal force of an increment
(du, dtheta) is *one* element update with dt = 1, v = du, omega = dtheta, positions
x_n + du, from the converged state (stress, plastic strain, hourglass and drilling
resultants of the start of the increment) [choice]: a Newton iterate is a trial of that one
update, never an accumulation of them, so the equations solved are exactly those of a
(large) explicit step from the converged point, with the mid-step geometry of a large
increment (Features.finite_increment: stages/shell.increment_geometry; the explicit step's
x - dt v / 2 is the element shrunk by cos(alpha / 2) under a rotation alpha, which made
Newton 0.04-0.09 % stiffer at 20 increments, docs/newton.md).  The rotation increment enters
the element only as dtheta (the BT frame comes from the geometry, method.md 3.1); the nodal
orientation is composed with exp(dtheta) once the increment has converged
(:meth:`IncrementalForces.commit`).

How, without a second copy of the element.  The element pass of the explicit step is
reused as it is, on a *virtual* state (state.State of a virtual model): each element e
appears P = 1 + 2 x 24 times with 4 private corner nodes: slot 0 with the trial increment,
slot 1 + 2 j (+ 1) with degree of freedom j of its 24 (corner a = j // 6, component j % 6:
ux uy uz rx ry rz) moved by +h (-h).  One element pass (stages/shell.ShellElement, the
parallel launch's code: corner loads in per-element slots, no scatter; serial on a small
mesh, :func:`newton_is_serial`), in one kernel launch with the collection, then gives the forces
of the trial increment (slot 0) and the 24 x 24 element tangent
K_e[:, j] = (f(+h_j) - f(-h_j)) / (2 h_j): the derivative of exactly the discrete forces
the explicit step uses (hourglass, drilling spring, BWC, the plane-stress return, i.e. the
consistent tangent of the return map).  h = FD_STEP x the mean edge for translations and
FD_STEP radians for rotations.

Cost: 49 element updates per element and iteration (measured: docs/newton.md).  The
virtual state holds 4 x 49 nodes per element (about 0.1 MB per element).

Node-smoothed triangles (``[element].triangle = "ns"``, stages/ns_membrane.py) [choice].  Their
membrane strain is a mean over each node's triangles and their loads the transpose, so a
node's translation moves the forces of nodes up to three element edges away (its triangles'
rates -> the node means at their corners -> the smoothed strain and resultant of those
nodes' triangles -> the node means of the resultants at their corners -> the loads of those
nodes' triangles), and its rotation those up to two away (through the bending part of the
stress).  No element-sized copy sees that, so the virtual state is instead 1 + 2 q copies of
the *whole mesh* (:class:`Colouring`): copy 0 the trial, copies 1 + 2 i (+ 1) the trial with
+h (-h) on every DOF of DOF colour i at once.  Two nodes share a translation colour when
they are more than 6 edges apart (rotation: 4), so the forces each perturbed DOF changes do
not overlap and the node forces of one pair of copies give a column of K for every DOF of
the colour (the colouring of Curtis, Powell & Reid 1974 on the graph's power).  Still
central differences of exactly the discrete forces, in one element pass; q = 3 (C_t + C_r)
with C_t ~ 50, C_r ~ 26 node colours on a triangulated grid (hemisphere 8x8 to 32x32:
measured, docs/newton.md), so 457 mesh copies, ~9 times the element copies' 49.
"""

import dataclasses

import numpy as np
import scipy.sparse as sp
import taichi as ti

from ..energy import ELEMENT_PARTS, EnergyLedger
from ..runtime import THREADS_MIN_ELEMENTS, cpu_threads
from ..stages.rotation import quaternion_exp, quaternion_product
from ..stages.shell import ShellElement
from ..state import STATUS_OK, State

DOFS_PER_ELEMENT = 24
SLOTS = 1 + 2 * DOFS_PER_ELEMENT          # the trial increment, then +h / -h of each element DOF
FD_STEP = 1e-6     # central-difference step: relative to the mean edge (translations), radians (rotations)
STAGGER = ELEMENT_PARTS.index("stagger")     # the element pass books dt/2 P_e there (energy.py): dt = 1 is no time step
MAX_VIRTUAL_ELEMENTS = 1 << 22            # ~85 000 shell elements (about 8 GB): a clear error beyond


def virtual_model(model, copies: int, whole_mesh: bool = False):
    """`model` with each element repeated `copies` times, copy-major (virtual element
    s * m + e): each copy on 4 private nodes (virtual node 4 v + a), or with `whole_mesh` the
    mesh's own connectivity in each copy (virtual node s * n + c: the node-smoothed
    triangles' tangent, module docstring); nothing is loaded, fixed or inertial there (the
    virtual state only runs the element pass).  Each per-element array is repeated along its
    first axis, whatever its rank (the (m, 2) material axis included: tiling along the last
    axis gave an (m, 2 copies) array whose rows were read as the wrong elements' axes)."""
    m = len(model.elements)
    count = m * copies
    el = model.element

    def repeat(a):
        return np.tile(a, (copies,) + (1,) * (np.ndim(a) - 1))
    tile = {f.name: repeat(getattr(el, f.name)) for f in dataclasses.fields(el)}
    if whole_mesh:
        n = len(model.points) * copies
        offset = (len(model.points) * np.arange(copies))[:, None, None]
        corners = np.where(model.elements[None] >= 0, model.elements[None] + offset, -1).reshape(count, 4)
    else:
        n = 4 * count
        corners = np.arange(n).reshape(count, 4)
        corners[np.tile(model.elements[:, 3] < 0, copies), 3] = -1        # a triangle stays one
    ones = np.ones(n)
    return dataclasses.replace(
        model, points=np.zeros((n, 3)), elements=corners.astype(np.int32), element=type(el)(**tile),
        area0=repeat(model.area0), corner_weight=repeat(model.corner_weight),
        corner_mass=repeat(model.corner_mass), corner_inertia=repeat(model.corner_inertia),
        node_mass=ones, node_inertia=ones, node_area=ones, node_thickness=ones,
        fix_mask=np.zeros(n, np.int32), load_force=np.zeros((n, 3)), load_moment=np.zeros((n, 3)),
        velocity0=np.zeros((n, 3)), omega0=np.zeros((n, 3)), grid=None, probes=(), rigid_bodies=(), walls=(),
        node_body=np.full(n, -1, np.int32), neighbor_start=None, neighbor_nodes=None)


def smoothed_tangent(model, triangle: str) -> bool:
    """Whether the tangent needs the whole-mesh copies: node-smoothed triangles in the mesh."""
    return triangle == "ns" and bool((model.elements[:, 3] < 0).any())


def newton_is_serial(virtual_elements: int) -> bool:
    """Whether Newton's kernels run serially on the CPU: a virtual mesh (:func:`virtual_count`)
    below runtime.THREADS_MIN_ELEMENTS, or one core.  The CLI then starts Taichi
    with one thread [measured, docs/newton.md]: a thread-pool dispatch per parallel loop costs
    more than the work of a few hundred element updates, and on a busy machine each one waits
    for a worker to be scheduled (a 10x1 cantilever's tangent: 0.27 ms median, 0.29 ms mean
    on one thread; 0.40-0.56 ms median, 1.4-2.6 ms mean through the pool, even with its loops
    serial)."""
    return cpu_threads() < 2 or virtual_elements < THREADS_MIN_ELEMENTS


def virtual_count(model, triangle: str) -> int:
    """The virtual state's element count: SLOTS copies of each element, or with node-smoothed
    triangles the whole mesh's copies (:class:`Colouring`)."""
    copies = Colouring(model.elements, len(model.points)).copies if smoothed_tangent(model, triangle) else SLOTS
    return len(model.elements) * copies


def reach(elements: np.ndarray, n: int, edges: int) -> sp.csr_matrix:
    """Which nodes are at most `edges` element edges (sharing an element) from each node: the
    pattern of (A + I)^edges, A the node adjacency."""
    pairs = np.stack(np.broadcast_arrays(elements[:, :, None], elements[:, None, :]), axis=-1).reshape(-1, 2)
    pairs = pairs[(pairs >= 0).all(axis=1)]
    step = sp.csr_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    out = sp.identity(n, format="csr")
    for _ in range(edges):
        out = out @ step
        out.data[:] = 1.0
    return out


def greedy_colours(conflicts: sp.csr_matrix) -> np.ndarray:
    """Each node the smallest colour none of its conflicting nodes (the row's pattern) holds,
    nodes in order."""
    colour = np.full(conflicts.shape[0], -1, np.int64)
    for i in range(len(colour)):
        taken = colour[conflicts.indices[conflicts.indptr[i]:conflicts.indptr[i + 1]]]
        free = np.ones(len(taken) + 1, bool)
        free[taken[(taken >= 0) & (taken <= len(taken))]] = False
        colour[i] = int(np.argmax(free))
    return colour


class Colouring:
    """The DOF colours of the whole-mesh copies (module docstring, "Node-smoothed triangles").

    A node's translation changes the forces of the nodes at most SUPPORT[0] = 3 edges away, its
    rotation those at most SUPPORT[1] = 2 away; two nodes take one colour of a kind only when
    more than twice that apart, so every node sees at most one perturbed node of each colour:
    ``owner[kind][i, k]`` (-1: none).  DOF colour j: j < 3 C_t translation component j % 3 of
    node colour j // 3, then rotations alike; copy 1 + 2 j (+h) and 2 + 2 j (-h)."""

    SUPPORT = (3, 2)

    def __init__(self, elements: np.ndarray, n: int):
        self.colour = np.zeros((n, 2), np.int32)
        self.owner = []
        for kind, edges in enumerate(self.SUPPORT):
            colour = greedy_colours(reach(elements, n, 2 * edges))
            near = reach(elements, n, edges).tocoo()
            owner = np.full((n, int(colour.max()) + 1), -1, np.int64)
            owner[near.row, colour[near.col]] = near.col
            self.colour[:, kind] = colour
            self.owner.append(owner)
        self.counts = (self.owner[0].shape[1], self.owner[1].shape[1])
        self.dofs = 3 * sum(self.counts)
        self.copies = 1 + 2 * self.dofs

    def entries(self, n: int):
        """The tangent's entries: for each DOF colour j and node i that sees one of its DOFs, the
        rows 6 i + (0..5) and the column of that DOF; with the index of (j, i, row component)
        in the (dofs, n, 6) array of the copies' force differences."""
        rows, cols, index = [], [], []
        for j in range(self.dofs):
            kind = int(j >= 3 * self.counts[0])
            node_colour, component = divmod(j - 3 * self.counts[0] * kind, 3)
            owner = self.owner[kind][:, node_colour]
            seen = np.nonzero(owner >= 0)[0]
            row = (6 * seen[:, None] + np.arange(6)).ravel()
            rows.append(row)
            cols.append(np.repeat(6 * owner[seen] + 3 * kind + component, 6))
            index.append(6 * n * j + row)
        return np.concatenate(rows), np.concatenate(cols), np.concatenate(index)


@ti.data_oriented
class IncrementalForces:
    """Internal forces and tangent of trial increments of `sim`'s shell (module docstring).
    ``evaluate`` fills numpy arrays (``internal`` and the tangent's ``values`` at ``entries``);
    ``commit`` makes an increment the new converged state of ``sim.state``."""

    def __init__(self, sim):
        self.sim = sim
        self.main = sim.state
        model = sim.model
        self.m, self.n = len(model.elements), len(model.points)
        self.smoothed = smoothed_tangent(model, sim.scene.element.triangle)
        self.colouring = Colouring(model.elements, self.n) if self.smoothed else None
        self.copies = self.colouring.copies if self.smoothed else SLOTS
        if self.m * self.copies > MAX_VIRTUAL_ELEMENTS:
            raise ValueError(f"{self.m} elements: the Newton tangent holds {self.copies} copies of each, more than "
                             f"{MAX_VIRTUAL_ELEMENTS} in all")
        launch = "threads" if sim.arch == "cpu" else "gpu"
        self.serial = sim.arch == "cpu" and newton_is_serial(self.m * self.copies)
        self.cfg = dataclasses.replace(sim.cfg, method="fem", launch=launch, grid_rule=False, grid_planes=False,
                                       bodies=False, walls=False, moving_walls=False, contact=False, friction=False,
                                       finite_increment=True)
        vmodel = virtual_model(model, self.copies, whole_mesh=self.smoothed)
        self.v = State(vmodel, self.cfg)
        self.v.load(vmodel)
        self.v.step.dt[None] = 1.0                  # v = du, omega = dtheta: one update of dt = 1
        self.shell = ShellElement(self.v, self.cfg, EnergyLedger(self.v, self.cfg, self.cfg.plastic))
        self.plastic = self.cfg.plastic
        self.drilling = self.cfg.drilling_spring
        self.internal = np.zeros((self.n, 6))
        if self.smoothed:
            self.node_colour = ti.field(ti.i32, shape=(self.n, 2))
            self.node_colour.from_numpy(self.colouring.colour)
            self.translation_colours = ti.field(ti.i32, shape=())
            self.translation_colours[None] = self.colouring.counts[0]
            self.columns = np.zeros((self.copies - 1, self.n, 6))     # the perturbed copies' node forces
            rows, cols, self.index = self.colouring.entries(self.n)
            steps = np.where(np.arange(self.colouring.dofs) < 3 * self.colouring.counts[0],
                             FD_STEP * model.mean_edge, FD_STEP)
            self.step_of_entry = steps[self.index // (6 * self.n)]
        else:
            self.columns = np.zeros((self.m, DOFS_PER_ELEMENT, DOFS_PER_ELEMENT))   # the element tangents
            corners = model.elements
            dof = np.where(corners[:, :, None] >= 0, 6 * corners[:, :, None] + np.arange(6), -1).reshape(
                -1, DOFS_PER_ELEMENT)
            rows = np.broadcast_to(dof[:, :, None], self.columns.shape).ravel()
            cols = np.broadcast_to(dof[:, None, :], self.columns.shape).ravel()
        self.entries = (rows, cols)         # global DOF 6 node + component; -1: no corner

    def values(self) -> np.ndarray:
        """The tangent's values at ``entries`` after an ``evaluate`` with the tangent: the element
        blocks, or the coloured columns (K[i, p] = (f_i(+h) - f_i(-h)) / 2 h of the copies' pair)."""
        if not self.smoothed:
            return self.columns.ravel()
        plus, minus = self.columns[0::2].ravel(), self.columns[1::2].ravel()
        return (plus[self.index] - minus[self.index]) / (2.0 * self.step_of_entry)

    # ------------------------------------------------------------------ kernels
    @ti.func
    def step(self, k: ti.template()):
        """The central-difference step of component k (run-time: the mean edge is data)."""
        h = FD_STEP
        if ti.static(k < 3):
            h *= self.v.step.length_ref[None]
        return h

    @ti.func
    def copy_element(self, to: ti.template(), te, source: ti.template(), se):
        """Element se's stress, plastic strain and resultants in state `source` to element te of
        state `to` (the converged state into a virtual copy, or a converged trial back)."""
        for k in ti.static(range(self.cfg.points)):
            to.points.stress[te, k] = source.points.stress[se, k]
            if ti.static(self.plastic):
                to.points.plastic_strain[te, k] = source.points.plastic_strain[se, k]
        to.elements.hourglass_resultant[te] = source.elements.hourglass_resultant[se]
        if ti.static(self.drilling):
            to.elements.drilling_moment[te] = source.elements.drilling_moment[se]

    @ti.func
    def converged_element(self, ve, e):
        """Virtual element ve starts from element e's converged state and energies."""
        self.copy_element(self.v, ve, self.main, e)
        self.v.elements.energy[ve] = self.main.elements.energy[e]

    @ti.func
    def trial_node(self, node, c, d, origin):
        """Virtual node `node` at real node c moved by the increment d (6): x_n - origin + du,
        v = du, omega = dtheta."""
        du = ti.Vector([d[0], d[1], d[2]])
        self.v.nodes.position[node] = (self.main.nodes.position[c] - origin) + du
        self.v.nodes.grid_velocity[node] = du
        self.v.nodes.omega[node] = ti.Vector([d[3], d[4], d[5]])

    @ti.func
    def load_slot(self, ve, increment: ti.template()):
        """Virtual element ve for the trial increment d (+- h on its DOF): corners at x_n + d
        (about the element's first corner: round-off of its size, not of |x|), v = d
        (translations), omega = d (rotations); its stress, plastic strain, resultants and
        energies those of the converged element."""
        m = self.main.elements.count[None]
        slot, e = ve // m, ve % m
        j = (slot - 1) // 2
        sign = 1.0 - 2.0 * ((slot - 1) % 2)
        c = self.main.elements.corners[e]
        origin = self.main.nodes.position[c[0]]
        for a in ti.static(range(4)):
            if c[a] >= 0:
                d = ti.Vector.zero(ti.f64, 6)
                for k in ti.static(range(6)):
                    d[k] = increment[c[a], k]
                    if slot > 0 and j == 6 * a + k:
                        d[k] += sign * self.step(k)
                self.trial_node(4 * ve + a, c[a], d, origin)
        self.converged_element(ve, e)

    @ti.func
    def load_copy_node(self, vn, increment: ti.template()):
        """Virtual node vn of the mesh copies (copy s = vn // n of node c = vn % n): the trial
        increment, with +-h on DOF colour j = (s - 1) // 2's component where c holds that
        colour (:class:`Colouring`); about the mesh's first node."""
        n = self.main.nodes.count[None]
        copy, c = vn // n, vn % n
        j = (copy - 1) // 2
        sign = 1.0 - 2.0 * ((copy - 1) % 2)
        rotation = 0
        if j >= 3 * self.translation_colours[None]:
            rotation = 1
        colour = (j - 3 * self.translation_colours[None] * rotation) // 3
        component = 3 * rotation + (j - 3 * self.translation_colours[None] * rotation) % 3
        d = ti.Vector.zero(ti.f64, 6)
        for k in ti.static(range(6)):
            d[k] = increment[c, k]
            if copy > 0 and component == k and self.node_colour[c, rotation] == colour:
                d[k] += sign * self.step(k)
        self.trial_node(vn, c, d, self.main.nodes.position[0])

    @ti.kernel
    def _evaluate(self, increment: ti.types.ndarray(), internal: ti.types.ndarray(), columns: ti.types.ndarray(),
                  tangent: ti.i32) -> ti.i32:
        """One element pass over copy 0 (with `tangent` all copies) of the trial increment (n, 6);
        its nodal internal forces into `internal` (n, 6) and, with `tangent`, the element
        tangents (m, 24, 24) or the perturbed mesh copies' node forces (copies - 1, n, 6) into
        `columns`.  One launch, serial on a small mesh (``serial``).  `tangent` is run-time data:
        one kernel for both (its front end costs ~4 s, docs/newton.md).  Returns the first
        failing virtual element (status), or -1."""
        m = self.main.elements.count[None]
        count = m
        if tangent:
            count = m * ti.static(self.copies)
        self.v.elements.count[None] = count
        if ti.static(self.smoothed):
            self.v.nodes.count[None] = (count // m) * self.main.nodes.count[None]
        else:
            self.v.nodes.count[None] = 4 * count
        self.v.step.status[None] = STATUS_OK
        if ti.static(self.serial):
            for _ in range(1):
                self._trial(increment, internal, columns, tangent, m, count)
        else:
            self._trial(increment, internal, columns, tangent, m, count)
        failed = -1
        if self.v.step.status[None] != STATUS_OK:
            failed = self.v.step.status_index[None]
        return failed

    @ti.func
    def _trial(self, increment: ti.template(), internal: ti.template(), columns: ti.template(), tangent, m, count):
        if ti.static(self.smoothed):
            for vn in range(self.v.nodes.count[None]):
                self.load_copy_node(vn, increment)
            for ve in range(count):
                self.converged_element(ve, ve % m)
        else:
            for ve in range(count):
                self.load_slot(ve, increment)
        self.shell.element_pass()
        if ti.static(self.smoothed):        # the copies' node sums (the element pass's gather)
            n = self.main.nodes.count[None]
            for vn, k in ti.ndrange(self.v.nodes.count[None], 6):
                load = self.v.nodes.force_int[vn][k % 3]
                if k >= 3:
                    load = self.v.nodes.moment_int[vn][k % 3]
                if vn < n:
                    internal[vn, k] = load
                else:
                    columns[vn // n - 1, vn % n, k] = load
        else:
            for c, k in ti.ndrange(self.main.nodes.count[None], 6):
                internal[c, k] = 0.0
            for _ in range(1):                        # serial: the corner loads summed at the nodes
                for e in range(m):
                    c = self.main.elements.corners[e]
                    for a in ti.static(range(4)):
                        if c[a] >= 0:
                            load = self.v.elements.corner_loads[e, a]
                            for k in ti.static(range(6)):
                                internal[c[a], k] += load[k]
            for e, j in ti.ndrange(m * tangent, DOFS_PER_ELEMENT):     # parallel: the bound, not an if
                h = FD_STEP
                if j % 6 < 3:
                    h *= self.v.step.length_ref[None]
                for a in ti.static(range(4)):
                    plus = self.v.elements.corner_loads[(1 + 2 * j) * m + e, a]
                    minus = self.v.elements.corner_loads[(2 + 2 * j) * m + e, a]
                    for k in ti.static(range(6)):
                        columns[e, 6 * a + k, j] = (plus[k] - minus[k]) / (2.0 * h)

    @ti.kernel
    def _commit(self, increment: ti.types.ndarray(), internal: ti.types.ndarray(), lam_old: ti.f64, lam: ti.f64,
                iterations: ti.i32):
        """Slot 0's element state becomes the converged one; nodes move by du, their
        orientation turns by exp(dtheta), velocities are zero (a static equilibrium).  The
        step's bookkeeping in the same launch: each node's external work of the dead loads
        (trapezoidal, (lam_old + lam) / 2 F . du), the energy totals, the reaction of the
        fully fixed nodes (their internal force less the load, from `internal`, the converged
        iterate's), the load factor and the step counter (+ iterations)."""
        if ti.static(self.serial):
            for _ in range(1):
                self._commit_state(increment, lam_old, lam)
        else:
            self._commit_state(increment, lam_old, lam)
        self._totals(internal, lam, iterations)

    @ti.func
    def _commit_state(self, increment: ti.template(), lam_old, lam):
        m = self.main.elements.count[None]
        for e in range(m):
            self.copy_element(self.main, e, self.v, e)
            energy = self.v.elements.energy[e]
            energy[STAGGER] = self.main.elements.energy[e][STAGGER]     # no kinetic energy: no stagger term
            self.main.elements.energy[e] = energy
        for c in range(self.main.nodes.count[None]):
            du = ti.Vector([increment[c, 0], increment[c, 1], increment[c, 2]])
            theta = ti.Vector([increment[c, 3], increment[c, 4], increment[c, 5]])
            dead_load_work = self.main.nodes.load_force[c].dot(du) + self.main.nodes.load_moment[c].dot(theta)
            self.main.nodes.energy[c][0] += 0.5 * (lam_old + lam) * dead_load_work
            self.main.nodes.position[c] += du
            self.main.nodes.grid_velocity[c] = ti.Vector([0.0, 0.0, 0.0])
            self.main.nodes.velocity[c] = ti.Vector([0.0, 0.0, 0.0])
            self.main.nodes.omega[c] = ti.Vector([0.0, 0.0, 0.0])
            self.main.nodes.rotation[c] = quaternion_product(quaternion_exp(theta),
                                                             self.main.nodes.rotation[c]).normalized()

    @ti.func
    def _totals(self, internal: ti.template(), lam, iterations):
        m = self.main.elements.count[None]
        for _ in range(1):                        # serial: fixed summation order
            total = ti.Vector.zero(ti.f64, 5)
            for e in range(m):
                total += self.main.elements.energy[e]
            self.main.step.internal_energy[None] = total[0]
            self.main.step.plastic_work[None] = total[1]
            self.main.step.hourglass_energy[None] = total[2]
            self.main.step.drilling_energy[None] = total[3]
            work = 0.0
            reaction = ti.Vector([0.0, 0.0, 0.0])
            for c in range(self.main.nodes.count[None]):
                work += self.main.nodes.energy[c][0]
                if self.main.nodes.fix_mask[c] & 0b111 == 0b111:
                    force = ti.Vector([internal[c, 0], internal[c, 1], internal[c, 2]])
                    reaction += force - lam * self.main.nodes.load_force[c]
            self.main.step.external_work[None] = work
            self.main.step.reaction[None] = reaction
            self.main.step.load_factor[None] = lam
            self.main.step.step[None] += iterations

    # ------------------------------------------------------------------ host
    def compile(self) -> None:
        """Compile (or load) the kernels: a zero increment, with and without the tangent, and
        its commit (which changes nothing: slot 0 holds the converged state)."""
        zero = np.zeros((self.n, 6))
        self.evaluate(zero, tangent=True)
        self.evaluate(zero, tangent=False)
        self._commit(zero, self.internal, 0.0, 0.0, 0)
        ti.sync()

    def evaluate(self, increment: np.ndarray, tangent: bool) -> int:
        """Internal forces (self.internal, (n, 6): force, moment) of the trial increment
        (n, 6) and, with `tangent`, the tangent (:meth:`values`).  Returns the virtual element
        whose update failed (inverted, return map) in the trial copy, or -1."""
        increment = np.ascontiguousarray(increment, dtype=np.float64)
        failed = int(self._evaluate(increment, self.internal, self.columns, int(tangent)))
        if failed >= self.m:                 # a perturbed copy failed: check the trial itself
            failed = int(self._evaluate(increment, self.internal, self.columns, 0))
        return failed

    def commit(self, increment: np.ndarray, internal: np.ndarray | None = None, lam_old: float = 0.0,
               lam: float = 0.0, iterations: int = 0) -> None:
        """Make `increment` the converged state (:meth:`_commit`); `internal`: the converged
        iterate's internal forces (the reaction), `lam_old`, `lam`: the load factors at the
        start and end of the increment (the external work)."""
        self._commit(np.ascontiguousarray(increment, dtype=np.float64),
                     self.internal if internal is None else np.ascontiguousarray(internal), lam_old, lam, iterations)
