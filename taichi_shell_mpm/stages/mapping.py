"""The double mapping (stages S2 and S4; paper eq 1-3, 8-9, 15; method.md 2.1-2.2).

Element -> corner is done once (frozen CPDI2 weights give the corner masses, see
:func:`taichi_shell_mpm.assembly.cpdi2_weights`); here the corners map to the grid with
trilinear functions and back.  Transfer (compile-time): ``apic`` (affine corner
velocity C_c, conserves angular momentum; default), ``polypic``, ``pic``, or ``flip``
blended with PIC by ``flip_blend``.

``polypic`` (Fu et al. 2017, "A polynomial particle-in-cell method", ACM TOG 36(6)) with
every mode of the trilinear stencil: besides v_c and C_c a node carries its cell's
bilinear and trilinear velocity modes (d2v/dxdy, d2v/dydz, d2v/dzdx, d3v/dxdydz), so
that G2P keeps the whole trilinear field of the cell it read and P2G hands each grid node
back the velocity that field has there.  Grid -> nodes -> grid is then the identity for
nodes that stay in their cell, which APIC is only for affine grid fields: at one cell per
element (h = l) the part of a node-scale wave that is not affine over a cell is what
APIC's round trip dissipates (docs/grid.md).

Each free node finds its stencil's 8 grid nodes through the grid's hash
(stages/grid.py) only when its base cell changes; P2G, G2P and the clear address them
through the node's 8 stored slots.

P2G order [choice, measured in the note of issue 4]: on the CPU the free nodes are
binned every step by the grid plane of their stencil's base across the mesh's longest
axis (a counting sort), and scattered plane by plane, first the even planes, then the
odd ones.  Two planes of the same parity share no grid node, so the planes of a pass
run in parallel with plain adds (an f64 atomic add costs ~13 ns on the CPU against
~1 ns), and the sums do not depend on the number of threads.  On a GPU the nodes scatter
in one parallel loop with atomic adds.  P2G, G2P and the clear are bound by loads and
stores (the second core barely speeds them up here); balanced runs of consecutive planes
instead of alternating single planes gained nothing (note of issue 4).
"""

import taichi as ti

from ..state import MAX_SLAB_PLANES, NO_CELL, STATUS_LEFT_GRID, State
from .accumulate import Accumulator, serial_loop
from .constraints import NodeUpdate
from .grid import GridUpdate
from .timestep import impulse_time


@ti.data_oriented
class Mapping:
    def __init__(self, state: State, cfg, nodes: NodeUpdate, grid: GridUpdate):
        self.s = state
        self.cfg = cfg
        self.nodes = nodes
        self.grid = grid
        self.grid_acc = Accumulator(not cfg.atomic_scatter)
        self.acc = Accumulator(cfg.serial)

    @ti.func
    def stencil(self, x):
        """Base grid node (integer coordinates), fractional position and validity (within the
        grid's bounds) for trilinear weights."""
        r = x * self.s.grid.inv_h[None]
        base = ti.floor(r, ti.i32)
        frac = r - base
        inside = True
        lo, hi = self.s.grid.bound_lo[None], self.s.grid.bound_hi[None]
        for d in ti.static(range(3)):
            if not (r[d] >= lo[d] and r[d] < hi[d] + 1):       # also catches a NaN position
                inside = False
        return base, frac, inside

    @ti.func
    def plane_of(self, c):
        """Node c's stencil base across the slab axis."""
        base = self.s.grid.node_base[c]
        axis = self.s.grid.slab_axis[None]
        plane = base[0]
        for d in ti.static(range(1, 3)):
            if axis == d:
                plane = base[d]
        return plane

    @ti.func
    def axis_weights(self, frac):
        """Linear weights along each axis: row 0 is 1 - r (the base node), row 1 is r."""
        return ti.Matrix.rows([1.0 - frac, frac])

    @ti.func
    def weight(self, w, i: ti.template(), j: ti.template(), k: ti.template()):
        """N_I = prod_d N^(r_d) and its gradient for the cell corner (i, j, k) in {0,1}^3, from
        the per-axis weights w (:meth:`axis_weights`); the corner is a compile-time constant."""
        n = w[i, 0] * w[j, 1] * w[k, 2]
        grad = self.s.grid.inv_h[None] * ti.Vector([(2 * i - 1) * w[j, 1] * w[k, 2], (2 * j - 1) * w[i, 0] * w[k, 2],
                                       (2 * k - 1) * w[i, 0] * w[j, 1]])
        return n, grad

    @ti.func
    def cell_powers(self):
        """(h^2, h^2, h^2, h^3): the mixed velocity modes' lengths (PolyPIC)."""
        h = self.s.grid.h[None]
        return ti.Vector([h * h, h * h, h * h, h * h * h])

    @ti.func
    def locate(self):
        """The stencil base of every free node (on_grid 0 for prescribed nodes and nodes without
        mass, NodeUpdate.is_idle; a node outside the grid's bounds stops the run), the span of the bases across the slab axis, and the
        grid slots of the nodes whose base changed (GridUpdate.assign_slots)."""
        self.s.grid.moved_count[None] = 0
        self.s.grid.slab_low[None] = 1 << 30
        self.s.grid.slab_high[None] = -(1 << 30)
        serial_loop(self.cfg.serial_node_loops)
        for c in range(self.s.nodes.count[None]):
            on = 0
            if not self.nodes.is_idle(c):
                base, _, inside = self.stencil(self.s.nodes.position[c])
                if inside:
                    on = 1
                    if (base != self.s.grid.node_base[c]).any():
                        self.s.grid.node_base[c] = base
                        self.s.grid.moved_nodes[ti.atomic_add(self.s.grid.moved_count[None], 1)] = c
                    plane = self.plane_of(c)
                    self.acc.minimum(self.s.grid.slab_low, plane)
                    self.acc.maximum(self.s.grid.slab_high, plane)
                else:
                    self.s.step.status[None] = STATUS_LEFT_GRID
                    self.s.step.status_index[None] = c
            self.s.grid.on_grid[c] = on
            if ti.static(self.cfg.motion_windows):
                if on == 0:     # held: on release it looks its grid slots up again and rejoins with its
                    self.s.grid.node_base[c] = ti.Vector([NO_CELL, NO_CELL, NO_CELL])   # own velocity only
                    if ti.static(self.cfg.affine_transfer):
                        self.s.nodes.affine[c] = ti.Matrix.zero(ti.f64, 3, 3)
                    if ti.static(self.cfg.velocity_modes):
                        self.s.nodes.velocity_modes[c] = ti.Matrix.zero(ti.f64, 3, 4)
        self.grid.assign_slots()

    @ti.func
    def bin_nodes(self):
        """Counting sort of the located nodes by plane, relative to the lowest one, modulo
        MAX_SLAB_PLANES (even: planes in two bins of one parity are never neighbours);
        serial, a few ns per node."""
        n_bins = ti.min(self.s.grid.slab_high[None] - self.s.grid.slab_low[None] + 1, MAX_SLAB_PLANES)
        ti.loop_config(serialize=True)
        for p in range(n_bins + 1):
            self.s.grid.slab_start[p] = 0
        ti.loop_config(serialize=True)
        for c in range(self.s.nodes.count[None]):
            if self.s.grid.on_grid[c] == 1:
                p = self.bin_of(c)
                self.s.grid.slab_start[p + 1] += 1
        ti.loop_config(serialize=True)
        for p in range(n_bins):
            self.s.grid.slab_fill[p] = self.s.grid.slab_start[p]
            self.s.grid.slab_start[p + 1] += self.s.grid.slab_start[p]
        ti.loop_config(serialize=True)
        for c in range(self.s.nodes.count[None]):
            if self.s.grid.on_grid[c] == 1:
                p = self.bin_of(c)
                self.s.grid.slab_nodes[self.s.grid.slab_fill[p]] = c
                self.s.grid.slab_fill[p] += 1

    @ti.func
    def bin_of(self, c):
        return (self.plane_of(c) - self.s.grid.slab_low[None]) % MAX_SLAB_PLANES

    @ti.func
    def scatter(self, c):
        """S2 for node c: m_I += N m_c, p_I += N m_c (v_c + C_c (X_I - x_c)), f_I += N (f_ext - f_int)_c
        (or p_I += N (m_c (v_c + C_c (X_I - x_c)) + dt f_c) without a grid force field).
        With APIC, v_c + C_c (X_I - x_c) = (v_c - h C_c r) + h C_c (i, j, k) for the cell
        corner (i, j, k) and fractional position r: one product per node, additions per corner.
        PolyPIC adds the mixed modes at the corner's offset from the node in cells, d = (i, j, k)
        - r: h^2 (d2v/dxdy d_x d_y + d2v/dydz d_y d_z + d2v/dzdx d_z d_x) + h^3 d3v/dxdydz d_x d_y d_z."""
        _base, frac, _inside = self.stencil(self.s.nodes.position[c])
        w = self.axis_weights(frac)
        mass = self.nodes.mass_of(c)          # with a joint's slaves lumped on it (stages/joints.py)
        keep = self.s.step.velocity_keep[None]
        force = self.nodes.residual_force(c)
        vel = keep * self.s.nodes.velocity[c]
        if ti.static(self.cfg.fire):
            vel += (self.s.step.fire_mix[None] / mass) * force    # FIRE mixing (solvers/stepper.py)
        affine_h = ti.Matrix.zero(ti.f64, 3, 3)
        if ti.static(self.cfg.affine_transfer):
            affine_h = (keep * self.s.grid.h[None]) * self.s.nodes.affine[c]
            vel -= affine_h @ frac
        modes_m = ti.Matrix.zero(ti.f64, 3, 4)
        powers = ti.Vector([0.0, 0.0, 0.0, 0.0])
        if ti.static(self.cfg.velocity_modes):
            modes_m = (keep * mass) * self.s.nodes.velocity_modes[c]
            powers = self.cell_powers()
        momentum = mass * vel
        if ti.static(not self.cfg.grid_force):
            momentum += impulse_time(self.s.step) * force      # p + dt f (stages/timestep.py)
        affine_m = mass * affine_h
        place, facing = ti.Vector([0.0, 0.0, 0.0]), ti.Vector([0.0, 0.0, 0.0])
        if ti.static(self.cfg.grid_contact):        # m x and m n of the grid contact condition (stages/grid.py)
            place, facing = mass * self.s.nodes.position[c], mass * self.s.nodes.normal_sum[c].normalized()
        if ti.static(self.cfg.multi_field and not self.cfg.atomic_scatter):
            self.grid.claim(c)
        for i, j, k in ti.static(ti.ndrange(2, 2, 2)):
            n, _ = self.weight(w, i, j, k)
            g = self.grid.address(self.grid.corner(c, i, j, k), self.grid.field_of(c, 4 * i + 2 * j + k))
            p = momentum
            if ti.static(self.cfg.affine_transfer):
                for d, on in ti.static(enumerate((i, j, k))):
                    if ti.static(on):
                        p += ti.Vector([affine_m[0, d], affine_m[1, d], affine_m[2, d]])
            if ti.static(self.cfg.velocity_modes):
                # the mixed terms at the corner's offset from the node, h d with d = (i, j, k) - frac
                d = ti.Vector([i, j, k], ti.f64) - frac
                p += modes_m @ (powers * ti.Vector([d[0] * d[1], d[1] * d[2], d[2] * d[0], d[0] * d[1] * d[2]]))
            self.grid_acc.add(self.s.grid.mass, g, n * mass)
            self.grid_acc.add(self.s.grid.momentum, g, n * p)
            if ti.static(self.cfg.grid_force):
                self.grid_acc.add(self.s.grid.force, g, n * force)
            if ti.static(self.cfg.grid_contact):
                self.grid_acc.add(self.s.grid.field_position, g, n * place)
                self.grid_acc.add(self.s.grid.field_normal, g, n * facing)

    @ti.func
    def particles_to_grid(self):
        """S2 over all free nodes (order: see the module docstring)."""
        self.locate()
        if ti.static(self.cfg.atomic_scatter):
            if ti.static(self.cfg.multi_field):
                self.grid.claim_rounds()
            for c in range(self.s.nodes.count[None]):
                if self.s.grid.on_grid[c] == 1:
                    self.scatter(c)
        else:
            self.bin_nodes()
            n_bins = ti.min(self.s.grid.slab_high[None] - self.s.grid.slab_low[None] + 1, MAX_SLAB_PLANES)
            for parity in ti.static(range(2)):
                for q in range((n_bins + 1 - parity) // 2):
                    p = 2 * q + parity
                    for i in range(self.s.grid.slab_start[p], self.s.grid.slab_start[p + 1]):
                        self.scatter(self.s.grid.slab_nodes[i])
        if ti.static(self.cfg.multi_field):
            self.grid.note_overflow()

    @ti.func
    def grid_to_particles(self):
        """S3 + S4: v~_c = sum N v+_I (moves the node), with the grid update evaluated at each
        node read (:meth:`GridUpdate.velocities`); carried v_c by the transfer rule; then
        the node-level BCs, position and rotation update (:meth:`NodeUpdate.finish`)."""
        for c in range(self.s.nodes.count[None]):
            v_grid = ti.Vector([0.0, 0.0, 0.0])
            if self.s.grid.on_grid[c] == 1:
                base, frac, _inside = self.stencil(self.s.nodes.position[c])
                w = self.axis_weights(frac)
                mass = self.nodes.mass_of(c)
                v_delta = ti.Vector([0.0, 0.0, 0.0])
                affine = ti.Matrix.zero(ti.f64, 3, 3)
                massive_grad = ti.Vector([0.0, 0.0, 0.0])
                modes = ti.Matrix.zero(ti.f64, 3, 4)
                massive_mixed = ti.Vector([0.0, 0.0, 0.0, 0.0])
                powers = ti.Vector([1.0, 1.0, 1.0, 1.0])
                if ti.static(self.cfg.velocity_modes):
                    powers = self.cell_powers()
                v_contact = ti.Vector([0.0, 0.0, 0.0])
                for i, j, k in ti.static(ti.ndrange(2, 2, 2)):
                    n, grad = self.weight(w, i, j, k)
                    slot, field = self.grid.corner(c, i, j, k), self.grid.field_of(c, 4 * i + 2 * j + k)
                    g = self.grid.address(slot, field)
                    v_minus, v_plus, f, inv_mass = self.grid.velocities(g, base + ti.Vector([i, j, k]))
                    if ti.static(self.cfg.grid_contact):
                        v_touch = self.grid.contact(slot, field, base + ti.Vector([i, j, k]), v_plus)
                        v_contact += n * (v_touch - v_plus)
                        v_plus = v_touch
                    massive = inv_mass > 0.0
                    v_grid += n * v_plus
                    if ti.static(self.cfg.static):
                        # grid residual sum_I |f_I|^2 (method.md 6.4), shared out by the node's
                        # mass share N m_c / m_I of each grid node
                        if massive:
                            self.acc.total(self.s.step.residual_sq, (n * mass * inv_mass) * f.norm_sqr())
                    if ti.static(self.cfg.transfer == "flip"):
                        v_delta += n * (v_plus - v_minus)
                    if ti.static(self.cfg.affine_transfer):
                        affine += v_plus.outer_product(grad)
                        if massive:
                            massive_grad += grad
                    if ti.static(self.cfg.velocity_modes):
                        # N_I's mixed derivatives at the node (d2/dxdy, d2/dydz, d2/dzdx, d3/dxdydz)
                        mixed = ti.Vector([(2 * i - 1) * (2 * j - 1) * w[k, 2], (2 * j - 1) * (2 * k - 1) * w[i, 0],
                                           (2 * k - 1) * (2 * i - 1) * w[j, 1],
                                           (2 * i - 1) * (2 * j - 1) * (2 * k - 1)]) / powers
                        modes += v_plus.outer_product(mixed)
                        if massive:
                            massive_mixed += mixed
                if ti.static(self.cfg.affine_transfer):
                    # C = sum over nodes with mass of (v+_I - v~_c) grad N_I^T [choice]: a
                    # massless node (weight 0, gradient not 0: a corner sitting on a grid
                    # plane) carries no velocity, so it must not pull C towards -v/h.
                    # Identical to sum v+_I grad N_I^T when all 8 nodes have mass.  The
                    # higher modes likewise (their weights, like the gradient's, sum to 0).
                    affine -= v_grid.outer_product(massive_grad)
                    if ti.static(self.cfg.velocity_modes):
                        modes -= v_grid.outer_product(massive_mixed)
                    if ti.static(self.cfg.grid_contact):
                        if v_contact.norm_sqr() > 0.0:
                            # a node the grid contact moved carries no affine velocity
                            # [choice, measured: stages/grid.py]
                            affine = ti.Matrix.zero(ti.f64, 3, 3)
                            modes = ti.Matrix.zero(ti.f64, 3, 4)
                carried = v_grid
                if ti.static(self.cfg.transfer == "flip"):
                    a = self.s.step.flip_blend[None]
                    carried = a * (self.s.step.velocity_keep[None] * self.s.nodes.velocity[c] + v_delta) + (1.0 - a) * v_grid
                if ti.static(self.cfg.affine_transfer):
                    self.s.nodes.affine[c] = affine
                if ti.static(self.cfg.velocity_modes):
                    self.s.nodes.velocity_modes[c] = modes
                self.s.nodes.velocity[c] = carried
                if ti.static(self.cfg.grid_contact):
                    # the grid contact's work, booked like a wall's: its impulse m dv . v_mid (energy.py)
                    v_mid = 0.5 * (self.s.step.velocity_keep[None] * self.s.nodes.grid_velocity[c] + v_grid)
                    self.nodes.energy.node(c, 0.0, -mass * v_contact.dot(v_mid), 0.0, 0.0)
            if ti.static(self.cfg.joints):
                if not self.nodes.joints.follows(c):     # a joint's slave: after its masters (stages/joints.py)
                    self.nodes.finish(c, v_grid)
            else:
                self.nodes.finish(c, v_grid)

    @ti.func
    def clear_grid(self):
        """Zero the grid nodes written this step (those around the located nodes)."""
        for c in range(self.s.nodes.count[None]):
            if self.s.grid.on_grid[c] == 1:
                self.grid.clear(c)
