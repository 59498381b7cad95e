"""Scatter-adds that are atomic only when they have to be.

In the batched launch (one serial loop of many steps, see
:mod:`taichi_shell_mpm.solvers.stepper`) nothing runs concurrently, and Taichi's f64
atomics (a compare-and-swap loop on x86) were measured to cost more than half of the
step: hemisphere quarter 16x16 in mpm mode, 223 us/step with atomics.  The switch is
compile-time.  In parallel loops on the CPU, sums into 0-d fields (energies, norms) are
cheap -- Taichi gives each thread its own partial sum -- but scattered adds are not, so
the element loads go through :class:`CornerLoads`.
"""
import taichi as ti


@ti.func
def serial_loop(serial: ti.template()):
    """When `serial` (compile time), the loop that follows this call runs on the calling
    thread: a light node loop of a small mesh in the threads launch
    (config.Features.serial_node_loops; runtime.serial_node_loops says why)."""
    if ti.static(serial):
        ti.loop_config(serialize=True)


@ti.data_oriented
class Accumulator:
    def __init__(self, serial: bool):
        self.serial = serial

    @ti.func
    def add(self, field: ti.template(), index, value):
        if ti.static(self.serial):
            field[index] = field[index] + value
        else:
            field[index] += value

    @ti.func
    def total(self, field: ti.template(), value):
        """Add to a 0-d field (an energy or norm accumulated over nodes/elements)."""
        if ti.static(self.serial):
            field[None] = field[None] + value
        else:
            field[None] += value

    @ti.func
    def minimum(self, field: ti.template(), value):
        """field[None] = min(field[None], value)."""
        if ti.static(self.serial):
            field[None] = ti.min(field[None], value)
        else:
            ti.atomic_min(field[None], value)

    @ti.func
    def maximum_at(self, field: ti.template(), d: ti.template(), value):
        """field[None][d] = max(field[None][d], value) for a 0-d vector field."""
        if ti.static(self.serial):
            field[None][d] = ti.max(field[None][d], value)
        else:
            ti.atomic_max(field[None][d], value)

    @ti.func
    def minimum_at(self, field: ti.template(), d: ti.template(), value):
        """field[None][d] = min(field[None][d], value) for a 0-d vector field."""
        if ti.static(self.serial):
            field[None][d] = ti.min(field[None][d], value)
        else:
            ti.atomic_min(field[None][d], value)

    @ti.func
    def maximum(self, field: ti.template(), value):
        if ti.static(self.serial):
            field[None] = ti.max(field[None], value)
        else:
            ti.atomic_max(field[None], value)


@ti.data_oriented
class CornerLoads:
    """Element -> node loads of the shell stage: resisting force, moment, and (only for the
    drilling projection and the multi-field grid, ``normals``) the A e3 and A sums of the nodal
    normal (method.md 2.3).

    Batched (serial) launch: plain adds into the node fields, which the node update zeroes
    after use.  Parallel launches: each element writes its corners' loads to slots of its
    own, and :meth:`gather` sums them at each node in ascending element order -- the order
    of the serial adds, so both give the same bits, and no atomics are needed."""

    def __init__(self, state, cfg):
        self.s = state
        self.serial = cfg.serial
        self.serial_nodes = cfg.serial_node_loops     # the gather on one thread (serial_loop)
        self.normals = cfg.nodal_normals      # the drilling projection and the multi-field grid need them

    @ti.func
    def add(self, e, a, node, force, moment, normal, area):
        if ti.static(self.serial):
            self.s.nodes.force_int[node] = self.s.nodes.force_int[node] + force
            self.s.nodes.moment_int[node] = self.s.nodes.moment_int[node] + moment
            if ti.static(self.normals):
                self.s.nodes.normal_sum[node] = self.s.nodes.normal_sum[node] + normal
                self.s.nodes.area_sum[node] = self.s.nodes.area_sum[node] + area
        else:       # one slot layout (state.py); the normal sums stay 0 without the projection
            self.s.elements.corner_loads[e, a] = ti.Vector([force[0], force[1], force[2], moment[0], moment[1], moment[2],
                                                            normal[0], normal[1], normal[2], area])

    @ti.func
    def gather(self):
        """Parallel launches: the node sums of the slots written by :meth:`add` (one loop)."""
        if ti.static(not self.serial):
            serial_loop(self.serial_nodes)
            for c in range(self.s.nodes.count[None]):
                total = ti.Vector.zero(ti.f64, 10)
                for i in range(self.s.elements.node_slot_start[c], self.s.elements.node_slot_start[c + 1]):
                    slot = self.s.elements.node_slots[i]
                    total += self.s.elements.corner_loads[slot // 4, slot % 4]
                self.s.nodes.force_int[c] = ti.Vector([total[0], total[1], total[2]])
                self.s.nodes.moment_int[c] = ti.Vector([total[3], total[4], total[5]])
                if ti.static(self.normals):
                    self.s.nodes.normal_sum[c] = ti.Vector([total[6], total[7], total[8]])
                    self.s.nodes.area_sum[c] = total[9]
