"""The background grid (stage S3; paper eq 5-7; method.md 1, 2.4): where its nodes live, the
grid update v- = p/m and v+ = v- + dt f/m with the symmetry grid planes (normal parts of p
and f removed), and clearing.

Unbounded and sparse [choice, issue 20]: grid node (i, j, k) sits at (i, j, k) h for any
integers within the hash key's range (assembly.KEY_BITS); only the nodes of the shell nodes'
stencils exist.  A hash table (open addressing, linear probing) maps a grid node's key to a
slot of dense storage, whose size is a class of the free shell nodes' count
(state.grid_capacity), so the grid's memory follows the shell's area and no empty space
costs anything.  Each shell node keeps the base cell of its stencil and its 8 slots; the
hash is asked only when the base cell changes (a node crosses a cell every h / (v dt)
steps: every ~280 steps in the tube), found in parallel and looked up serially (Taichi has
no compare-and-swap to claim a table entry concurrently).  Slots of cells the shell has left
stay taken until the pool runs dry; then the table is emptied and every node's slots are
looked up again (a collection).  The pool holds twice the most the stencils can use
(8 per node), so collections are rare and memory stays constant however far the shell
travels.

Measured [docs/performance.md, "The grid: hashed, against Taichi's sparse SNodes"]: as
fast as the dense box it replaced (tube B/A 1.04 median, bit-for-bit the same results),
1.6-1.7x faster than the best sparse-SNode layout in the scene's box and 4.6-8.3x in a box
100x larger (their list generation and deactivate_all() scan the top pointer array, so
empty space costs time), and a sparse tree's shape enters the offline-cache key (a cold
compile per scene box), while the hash's storage comes in power-of-4 size classes and its
box is run-time data.

Multi-field grid ([method].fields = "multi", Bardenhagen et al. 2001; Homel & Herbold
2017): every grid node has MAX_FIELDS velocity fields, stored field-major (field f of slot
g at f * capacity + g).  In P2G each shell node takes, at each of its 8 grid nodes, the
first field opened by a node of its layer (:meth:`same_layer`: same part, reference
positions within FIELD_RADIUS_CELLS cells, nodal normals on one side), else opens a free
one; G2P and the clear read the same fields.  Layers closer than a cell thus keep their
own velocities; by default ([method].field_contact = "penalty") they interact only through
[contact] (the penalty forces enter P2G as nodal forces).  The per-node indices are scalar
fields (node_slots[c, q], anchor[g, f]): with vector fields indexed at run time, the
multi-field step segfaulted in its first batch on Taichi 1.7 (CPU), in debug mode too.

A grid node that more than MAX_FIELDS layers reach puts the extra ones into its last field,
where unrelated layers then move together.  It is counted (field_overflow: joins of a full
grid node; summary.json ``grid``) and the first step in which it happens is kept with the
number of grid nodes that overflowed then, so that the run warns of it once, at that
time (Simulation.check_fields, issue 28), on the console and in summary.json's warnings; the
record is part of the checkpoint, so a restarted run's summary is that of one run.

Grid contact condition (field_contact = "grid", compiled only then; :meth:`GridUpdate.contact`,
Bardenhagen et al. 2000, 2001): where a grid node has two or more fields with mass, a field
approaching the others' centre of mass loses the normal part of its velocity relative to it
(perfectly plastic) and its slip is slowed by Coulomb friction, mu times that normal change,
down to sticking; applied to v+ where G2P reads it.  P2G adds per field sum N m x and sum N m n
(n: the node's unit shell normal), 6 doubles per field.  Three choices, each measured on two
sheets at h = 2t (docs/contact.md, tests/test_grid.py):
* The normal is the pair's (Homel & Herbold 2017), n = normalize(n_a - n_rest), from the fields'
  shell normals each turned towards the other field's centroid, not from the mass gradients
  sum N m grad N: two sheets inside one cell have no grid node between them, and there each
  sheet's trilinear mass gradient points at the same grid node (its normal component does
  not depend on where in the cell the sheet is), so their difference carries no side.
* Contact only where the fields' centroids are closer than t_c along n (a separation test, as
  Nairn's MPM codes make): without it the condition acts as soon as two layers share a grid
  node, and two sheets (t = 0.02 or 0.125, h = 0.25) met at a gap of 0.249 (one cell) and
  stayed 0.241 apart; with it they meet at 0.1247 (t = 0.125) and 0.0193 (t = 0.02).
* A shell node whose velocity the condition changed carries no affine velocity (C = 0, PIC
  for that node and step; with PolyPIC no velocity modes either): the condition corrects a
  layer's field only at the grid nodes it shares with another, and APIC's C kept the velocity of the others (those on the far side of
  the sheet, those the other layer's nodes do not reach) for good, so that stacked sheets
  ended still approaching at 0.034 (upper -0.117, lower -0.083) instead of both at -0.1.
  Dropping only the gradient across the sheet, C (1 - n n^T), fixed the stacked sheets but not
  the shifted ones of tests/test_grid.py (closest upper node over the lower sheet 0.041 for
  t = 0.125, through it for t = 0.02; with C = 0: 0.116 and 0.017).
The kinetic energy it removes is booked as contact energy, the node's share of the impulse,
-m dv . v_mid, like a wall's (energy.py): the stacked sheets' balance closes to 1e-16.

The update is evaluated where G2P reads a node (:meth:`GridUpdate.velocities`) rather
than in a loop of its own over a list of touched nodes [choice, measured in the note of
issue 4]: it costs a division per read instead of a list, and lets P2G run in parallel
without atomics.

Without FLIP and outside statics (StepConfig.grid_force false) only v+ is read, so P2G
scatters the momentum and the force impulse into one field, p~_I = sum N (m (v + C dx) +
dt f), and v+ = p~/m [choice, measured in the note of issue 4]: 4 doubles per grid node
instead of 7, the same v+ up to rounding.
"""

import taichi as ti

from ..model.assembly import KEY_BITS
from ..state import MAX_FIELDS, State
from .timestep import impulse_time

HASH_PRIMES = (73856093, 19349663, 83492791)


@ti.data_oriented
class GridUpdate:
    """The grid's geometry (h, bounds, symmetry planes), hash table and mass floor are
    run-time data (state.grid, state.step.mass_floor)."""

    def __init__(self, state: State, cfg):
        self.s = state
        self.cfg = cfg

    # ------------------------------------------------------------------ where grid nodes live
    @ti.func
    def key(self, idx):
        """The hash key of grid node idx (integer coordinates) plus 1 (0 marks an empty entry)."""
        off = 1 << (KEY_BITS - 1)
        return (((ti.cast(idx[0] + off, ti.i64) << (2 * KEY_BITS)) | (ti.cast(idx[1] + off, ti.i64) << KEY_BITS)
                 | ti.cast(idx[2] + off, ti.i64)) + 1)

    @ti.func
    def slot_of(self, idx):
        """The storage slot of grid node idx, handed out from the pool when the node is new;
        -1 when the pool is dry (the caller collects).  Serial callers only."""
        k = self.key(idx)
        mask = (1 << self.s.grid.table_bits[None]) - 1
        # the spatial hash of Teschner et al. (2003): coordinates below 2^21 times primes below
        # 2^27 never overflow an i64 (an overflow is undefined behaviour in LLVM)
        off = 1 << (KEY_BITS - 1)
        h = ((ti.cast(idx[0] + off, ti.i64) * HASH_PRIMES[0]) ^ (ti.cast(idx[1] + off, ti.i64) * HASH_PRIMES[1])
             ^ (ti.cast(idx[2] + off, ti.i64) * HASH_PRIMES[2]))
        e = ti.cast(h & mask, ti.i32)
        slot = -2
        while slot == -2:
            stored = self.s.grid.table_key[e]
            if stored == k:
                slot = self.s.grid.table_slot[e]
            elif stored == 0:
                slot = -1
                if self.s.grid.slot_count[None] < self.s.grid.slot_capacity[None]:
                    slot = self.s.grid.slot_count[None]
                    self.s.grid.slot_count[None] = slot + 1
                    self.s.grid.table_key[e] = k
                    self.s.grid.table_slot[e] = slot
            else:
                e = (e + 1) & mask
        return slot

    @ti.func
    def look_up(self, c):
        """Find node c's 8 slots for the base cell in node_base; False when the pool ran dry.
        (Loops, not unrolled: each copy of a loop body is compile time.)"""
        base = self.s.grid.node_base[c]
        ok = True
        for q in range(8):
            slot = self.slot_of(base + ti.Vector([q >> 2, (q >> 1) & 1, q & 1]))
            self.s.grid.node_slots[c, q] = slot
            if slot < 0:
                ok = False
        return ok

    @ti.func
    def assign_slots(self):
        """Serially, the slots of the nodes whose base cell changed this step (moved_nodes);
        when the pool runs dry, a collection: empty the table and look every node up again."""
        dry = 0
        ti.loop_config(serialize=True)
        for i in range(self.s.grid.moved_count[None]):
            if dry == 0:
                if not self.look_up(self.s.grid.moved_nodes[i]):
                    dry = 1
        if dry == 1:
            self.s.grid.collections[None] += 1
            for e in range(self.s.grid.table_key.shape[0]):
                self.s.grid.table_key[e] = 0
            self.s.grid.slot_count[None] = 0
            ti.loop_config(serialize=True)
            for c in range(self.s.nodes.count[None]):
                if self.s.grid.on_grid[c] == 1:
                    self.look_up(c)

    @ti.func
    def corner(self, c, i: ti.template(), j: ti.template(), k: ti.template()):
        """The slot of corner (i, j, k) in {0,1}^3 of node c's stencil."""
        return self.s.grid.node_slots[c, 4 * i + 2 * j + k]

    # ------------------------------------------------------------------ the fields of a grid node
    @ti.func
    def address(self, g, f):
        """Storage index of field f of the grid node in slot g: field-major, so a grid node
        that only one layer reaches uses the first block, as a single-field grid would."""
        out = g
        if ti.static(self.cfg.multi_field):
            out = f * self.s.grid.slot_capacity[None] + g
        return out

    @ti.func
    def same_layer(self, c, a):
        """Whether shell nodes c and a are one layer where they reach a grid node: the same
        part, reference positions within FIELD_RADIUS_CELLS cells, normals on one side."""
        d = self.s.nodes.position_ref[c] - self.s.nodes.position_ref[a]
        near = d.norm_sqr() < self.s.grid.field_radius_sq[None]
        facing = self.s.nodes.normal_sum[c].dot(self.s.nodes.normal_sum[a]) > 0.0
        return near and facing and self.s.nodes.part[c] == self.s.nodes.part[a]

    @ti.func
    def claim(self, c):
        """The fields of node c at its 8 grid nodes (2 bits each, node_fields), where no other
        thread writes those grid nodes (CPU launches): at each, the first field opened by a
        node of c's layer, else the first free one (c opens it), else the last (a full grid
        node: field_overflow)."""
        fields = 0
        for q in range(8):
            g = self.s.grid.node_slots[c, q]
            f = -1
            for s in ti.static(range(MAX_FIELDS)):
                if f < 0:
                    a = self.s.grid.anchor[g, s] - 1
                    if a < 0:
                        self.s.grid.anchor[g, s] = c + 1
                        f = s
                    elif self.same_layer(c, a):
                        f = s
            if f < 0:
                f = MAX_FIELDS - 1
                self.overflow(g)
            fields |= f << (2 * q)
        self.s.grid.node_fields[c] = fields

    @ti.func
    def claim_rounds(self):
        """The fields of every node's corners with atomics (GPU): in round s the highest
        undecided node at a grid node opens field s there, and the undecided nodes of its
        layer join it; the last round puts the rest in the last field (field_overflow).
        Decided corners are flagged in bits 16-23 of node_fields."""
        for c in range(self.s.nodes.count[None]):
            self.s.grid.node_fields[c] = 0
        for s in ti.static(range(MAX_FIELDS)):
            for c in range(self.s.nodes.count[None]):
                if self.s.grid.on_grid[c] == 1:
                    for q in range(8):
                        if (self.s.grid.node_fields[c] >> (16 + q)) & 1 == 0:
                            ti.atomic_max(self.s.grid.anchor[self.s.grid.node_slots[c, q], s], c + 1)
            for c in range(self.s.nodes.count[None]):
                if self.s.grid.on_grid[c] == 1:
                    bits = self.s.grid.node_fields[c]
                    for q in range(8):
                        if (bits >> (16 + q)) & 1 == 0:
                            a = self.s.grid.anchor[self.s.grid.node_slots[c, q], s] - 1
                            if a == c or self.same_layer(c, a):
                                bits |= (s << (2 * q)) | (1 << (16 + q))
                            elif ti.static(s == MAX_FIELDS - 1):
                                bits |= (s << (2 * q)) | (1 << (16 + q))
                                self.overflow(self.s.grid.node_slots[c, q])
                    self.s.grid.node_fields[c] = bits

    @ti.func
    def overflow(self, g):
        """A shell node joins the last field of the full grid node in slot g (a layer more
        than MAX_FIELDS there): count the join, and the grid node once per step."""
        ti.atomic_add(self.s.grid.field_overflow[None], 1)
        if ti.atomic_or(self.s.grid.overflowed[g], 1) == 0:
            ti.atomic_add(self.s.grid.overflow_nodes[None], 1)

    @ti.func
    def note_overflow(self):
        """After the claim: remember the first step in which grid nodes overflowed, its time
        and how many (the host warns of it once: Simulation.check_fields); zero the count."""
        if self.s.grid.overflow_nodes[None] > 0 and self.s.grid.first_overflow_step[None] < 0:
            self.s.grid.first_overflow_step[None] = self.s.step.step[None] + 1     # the step being taken
            self.s.grid.first_overflow_time[None] = self.s.step.time[None]
            self.s.grid.first_overflow_nodes[None] = self.s.grid.overflow_nodes[None]
        self.s.grid.overflow_nodes[None] = 0

    @ti.func
    def field_of(self, c, q: ti.template()):
        """The field of node c at its corner q (4 i + 2 j + k), as P2G chose it."""
        f = 0
        if ti.static(self.cfg.multi_field):
            f = (self.s.grid.node_fields[c] >> (2 * q)) & (MAX_FIELDS - 1)
        return f

    # ------------------------------------------------------------------ the grid update
    @ti.func
    def velocities(self, g, idx):
        """(v-, v+, f, 1/m or 0 when massless) of the grid node in slot g at integer
        coordinates idx (method.md 2.4).  Without a grid force field (see the module
        docstring) v- is v+ and f is zero."""
        m = self.s.grid.mass[g]
        p = self.s.grid.momentum[g]
        f = ti.Vector([0.0, 0.0, 0.0])
        if ti.static(self.cfg.grid_force):
            f = self.s.grid.force[g]
        if ti.static(self.cfg.grid_planes):
            for q in range(self.s.grid.planes[None]):
                for axis in ti.static(range(3)):
                    if self.s.grid.plane_axis[q] == axis and idx[axis] == self.s.grid.plane_index[q]:
                        p[axis] = 0.0
                        f[axis] = 0.0
        v_minus = ti.Vector([0.0, 0.0, 0.0])
        v_plus = ti.Vector([0.0, 0.0, 0.0])
        inv_mass = 0.0
        if m > self.s.step.mass_floor[None]:
            inv_mass = 1.0 / m
            v_minus = inv_mass * p
            v_plus = v_minus
            if ti.static(self.cfg.grid_force):
                v_plus += (impulse_time(self.s.step) * inv_mass) * f
        return v_minus, v_plus, f, inv_mass

    @ti.func
    def contact(self, slot, f, idx, v_plus):
        """Field f's v+ at the grid node in slot `slot` after the grid contact condition
        (Bardenhagen et al. 2000, 2001; module docstring).  With the centre-of-mass velocity
        v_cm = sum m_b v+_b / sum m_b over the fields with mass and the pair's normal n (from a
        to the rest), field a approaching, dv = v_a - v_cm, (dv . n) > 0, within t_c (the
        centroids' distance along n below field_gap) gets
            v_a' = v_a - (dv . n) n - min(1, mu (dv . n) / |dv_t|) dv_t,   dv_t = dv - (dv . n) n:
        the approach removed (perfectly plastic), the slip slowed by Coulomb friction, or the
        common v_cm where friction sticks.  Between two fields the impulses are equal and
        opposite (n_b = -n_a), so the node's momentum is kept."""
        m_tot = 0.0
        p_tot = ti.Vector([0.0, 0.0, 0.0])
        x_tot = ti.Vector([0.0, 0.0, 0.0])
        count = 0
        for b in ti.static(range(MAX_FIELDS)):
            g = self.address(slot, b)
            _v_minus, v_b, _f, inv_b = self.velocities(g, idx)
            if inv_b > 0.0:
                m_b = self.s.grid.mass[g]
                m_tot += m_b
                p_tot += m_b * v_b
                x_tot += self.s.grid.field_position[g]
                count += 1
        out = v_plus
        g_a = self.address(slot, f)
        m_a = self.s.grid.mass[g_a]
        if count > 1 and m_a > self.s.step.mass_floor[None]:
            x_a = self.s.grid.field_position[g_a] / m_a
            x_rest = (x_tot - self.s.grid.field_position[g_a]) / (m_tot - m_a)
            # the pair's normal: each field's shell normal turned towards the other side,
            # n = normalize(n_a - n_rest) (Homel & Herbold 2017: one normal for the pair)
            n_a = self.s.grid.field_normal[g_a]
            if n_a.dot(x_rest - x_a) < 0.0:
                n_a = -n_a
            n_rest = ti.Vector([0.0, 0.0, 0.0])
            for b in ti.static(range(MAX_FIELDS)):
                g = self.address(slot, b)
                m_b = self.s.grid.mass[g]
                if b != f and m_b > self.s.step.mass_floor[None]:
                    n_b = self.s.grid.field_normal[g]
                    if n_b.dot(x_a - self.s.grid.field_position[g] / m_b) < 0.0:
                        n_b = -n_b
                    n_rest += n_b
            n = n_a.normalized(1e-300) - n_rest.normalized(1e-300)
            if n.norm_sqr() > 0.0:
                n = n.normalized()
                dv = v_plus - p_tot / m_tot
                approach = dv.dot(n)
                if approach > 0.0 and (x_rest - x_a).dot(n) < self.s.grid.field_gap[None]:
                    slip = dv - approach * n
                    slip_speed = slip.norm()
                    stick = 1.0
                    if self.s.grid.field_friction[None] * approach < slip_speed:
                        stick = self.s.grid.field_friction[None] * approach / slip_speed
                    out = v_plus - approach * n - stick * slip
        return out

    @ti.func
    def clear(self, c):
        """Zero the 8 grid nodes of node c's stencil (the fields it used, and the openers)."""
        for i, j, k in ti.static(ti.ndrange(2, 2, 2)):
            slot = self.corner(c, i, j, k)
            g = self.address(slot, self.field_of(c, 4 * i + 2 * j + k))
            if ti.static(self.cfg.multi_field):
                for s in ti.static(range(MAX_FIELDS)):
                    self.s.grid.anchor[slot, s] = 0
                self.s.grid.overflowed[slot] = 0
            self.s.grid.mass[g] = 0.0
            self.s.grid.momentum[g] = ti.Vector([0.0, 0.0, 0.0])
            if ti.static(self.cfg.grid_force):
                self.s.grid.force[g] = ti.Vector([0.0, 0.0, 0.0])
            if ti.static(self.cfg.grid_contact):
                self.s.grid.field_position[g] = ti.Vector([0.0, 0.0, 0.0])
                self.s.grid.field_normal[g] = ti.Vector([0.0, 0.0, 0.0])
