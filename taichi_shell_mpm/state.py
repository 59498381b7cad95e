"""The one owner of Taichi fields, grouped by role (as Genesis's MPM solver groups its state;
the module is long, ~900 lines, because every field of every feature is declared here and
nowhere else, [choice] of the project's layout: one place to read what the step holds):

=============  ============================================================================
``nodes``      shell nodes (= particle-domain corners, method.md 1): kinematics, mass,
               loads, constraints, energy accumulators
``elements``   element topology and state: corners, hourglass and drilling resultants,
               energy accumulators, the parallel launches' corner-load slots
``sections``   per-element section and material data (thickness, shear factor, hourglass
               and drilling factors, wave speed, section id, material axis) and the tables
               they index (through-thickness points per section with each point's material
               and ply angle, parameters per material, the tabulated hardening curves)
``points``     through-thickness point state: stress, equivalent plastic strain, filtered
               strain rate
``grid``       the background grid (mpm) and its geometry
``contact``    self-contact: forces, candidate lists, side memory, spatial hash
``bodies``     rigid bodies and walls
``loads``      time curves, curve and follower loads, pressure, gravity, prescribed motions
``step``       the scalars of the step: dt, time, load factor, relaxation, energies, status,
               and the run-time parameters of the step (safety factor, reference length ...)
=============  ============================================================================

Compiled once per feature set and size class [choice, issue 17; shared/design/compile_once.md]:
every group is an SNode tree of its own (FieldsBuilder).  A per-entity field is dense over a
*capacity*, the model's count rounded up to a power of 4 (at least CAPACITY_MIN; the grid's
at least GRID_CAPACITY_MIN), and kernels
loop to the run-time counts (``nodes.count``, ``elements.count``); every value is run-time
data.  So a model of another size in the same class, or with other values, loads every
kernel from Taichi's offline cache; a size in another class compiles once more.  Measured
(compile_probe-style, 2-core CPU): a kernel over a field of fixed shape is a cache hit for
any count; an unrelated field of another size in another tree does not force a recompile.

What was tried first, and why not: pointer SNodes (a fixed virtual capacity, memory only
for the blocks touched, one class for every size) ran a gather-heavy element loop as fast as
dense (5.1-5.3 ns per element against 5.3-5.7), but the step crashed at random
(segmentation faults in 3 of 4 identical runs of the cantilever with the offline cache off;
none with dense fields); a dense field of fixed large capacity is zeroed and resident
(2^26 vectors: 1.5 GB), so the capacity follows the model.

Taichi keys a cached kernel by the SNodes it touches, each by its own structure and id but
not by its place in the tree: when the set of fields varied with the features, a kernel
cached by an fem run was loaded by an mpm run for another field at the same SNode id and
wrote the wrong memory (a segmentation fault).  So every run creates every field, in the
same order (a field the features do not use has the minimal size), and the cache folder is
per build of the package (runtime.kernel_cache_dir).  The points' count and the grid's
layout, which depend on the features, come last.

Host access goes through :meth:`State.read` / :meth:`State.write` (the first ``count``
entries; ``field.to_numpy()`` would return the whole virtual capacity).

Sign convention (method.md 0): ``nodes.force_int``/``nodes.moment_int`` are *resisting*
nodal forces; m a = f_ext - f_int through the grid.
"""
import contextlib
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
import taichi as ti

from .model.assembly import added_mass_geometry
from .model.bodies import node_point_masses
from .model.contact_pairs import DIRECTIONS, LAW_COLUMNS
from .scene.contact_pair import MAX_CONTACT_PAIRS
from .curves import COLUMNS as CURVE_COLUMNS
from .model.materials import FAILURE_COLUMNS, row_width
from .scene import MAX_BODIES, MAX_CURVES, MAX_MOTIONS
from .model.tools import MAX_TOOLS

(STATUS_OK, STATUS_CONVERGED, STATUS_INVERTED, STATUS_LEFT_GRID, STATUS_NONFINITE, STATUS_DT_COLLAPSE,
 STATUS_CONTACT_FULL, STATUS_ENERGY, STATUS_RETURN_FAILED, STATUS_MASS_ADDED, STATUS_BODY_ROTATION,
 STATUS_SMS_SOLVE) = range(12)
ROTATION_HELD, ROTATION_CONSTRAINED, ROTATION_FREE = range(3)    # bodies.rotation_mode (stages/bodies.py)
CANDIDATES_PER_NODE = 64     # capacity of the contact candidate lists, on average per node

CAPACITY_MIN = 16384         # the smallest size class of a per-entity field (4^7)
GRID_CAPACITY_MIN = 1 << 16  # the smallest size class of the grid's slots (4^8: 2-3.5 MB)
GRID_SLOTS_PER_NODE = 16     # grid slots per free shell node: twice the most its stencils can hold
NO_CELL = -(1 << 30)         # node_base of a node whose grid slots are not looked up yet
MAX_FIELDS = 4               # velocity fields per grid node of the multi-field grid (stages/grid.py)
FIELD_RADIUS_CELLS = 4.0     # shell nodes this many cells apart in the reference state are other layers
MAX_MATERIALS = 64
MAX_SECTIONS = 64
MAX_WALLS = 16
MAX_SLAB_PLANES = 1 << 16


def grid_capacity(nodes: int) -> int:
    """The size class of the grid's slot pool for `nodes` grid nodes: a power of 4, at least
    GRID_CAPACITY_MIN.  The shell's stencils hold at most 8 grid nodes per free shell node,
    so GRID_SLOTS_PER_NODE = 16 per node leaves half the pool for the slots of cells the
    shell has left, until a collection (stages/grid.py) hands them out again."""
    out = GRID_CAPACITY_MIN
    while out < nodes:
        out *= 4
    return out


def capacity(size: int) -> int:
    """The size class of a per-entity field of `size` entries: a power of 4, >= CAPACITY_MIN."""
    out = CAPACITY_MIN
    while out < size:
        out *= 4
    return out


def _on_cpu() -> bool:
    """Whether Taichi runs on the CPU (compile time)."""
    return ti.lang.impl.current_cfg().arch in (ti.x64, ti.arm64)


@ti.func
def _host_loop():
    """On the CPU, the loop that follows runs on the calling thread: a copy of a field to or
    from the host [choice, measured in docs/performance.md "Thread-pool dispatch": a parallel
    loop costs ~55-75 us of dispatch, a serial copy of the tube's 2 928 node vectors ~3 us].
    On a GPU it stays parallel."""
    if ti.static(_on_cpu()):
        ti.loop_config(serialize=True)


@ti.kernel
def _read_field(f: ti.template(), out: ti.types.ndarray(), n: ti.i32):
    """The first n entries of `f` into the flat `out`, row-major, components last."""
    _host_loop()
    for I in ti.grouped(ti.ndrange(n, *ti.static(f.shape[1:]))):
        _put(out, _row(I, f.shape) * ti.static(_width(f)), f[I], f)


@ti.kernel
def _write_field(f: ti.template(), src: ti.types.ndarray(), n: ti.i32):
    """The inverse of :func:`_read_field`."""
    _host_loop()
    for I in ti.grouped(ti.ndrange(n, *ti.static(f.shape[1:]))):
        f[I] = _entry(src, _row(I, f.shape) * ti.static(_width(f)), f)


BATCH_FIELDS = 32     # fields per kernel of State.arrays / restore (Taichi warns above 32 unrolled loops)
# Fields the host reads together, each set in one launch whichever of them is asked for: the
# rigid bodies' fields of the record and the run's checks (energies, force.csv, summary), which
# took a launch (~0.1 ms) each [measured in docs/performance.md, "The record's body reads"]
SNAPSHOTS = {"bodies": ("velocity", "kinetic_rotation", "omega", "wall_energy", "external_work", "motion_work",
                        "contact_energy", "center0", "displacement", "rotation", "angular_momentum", "force",
                        "moment")}


def _width(f) -> int:
    """Numbers per entry of `f`: n m of a matrix field, n of a vector field, 1 of a scalar one."""
    return f.n * f.m if isinstance(f, ti.MatrixField) else 1


@ti.func
def _row(I, shape: ti.template()):
    """The row-major index of the grouped index I in (any, *shape[1:])."""
    k = I[0]
    for d in ti.static(range(1, len(shape))):
        k = k * shape[d] + I[d]
    return k


@ti.kernel
def _read_fields(fields: ti.template(), out: ti.types.ndarray(), offsets: ti.types.ndarray(),
                 sizes: ti.types.ndarray()):
    """Every field of `fields` (one dtype) into the flat `out`: field q's first sizes[q]
    entries (0-d: its value) from offsets[q], row-major, components last.  One kernel for a
    checkpoint's fields of a dtype instead of one per field [issue 32]: each kernel is built
    and loaded again in every run (~7 ms each, 221 fields for the CI crash set of
    tests/test_matrix.py: a checkpoint's first save 1.5 s, its restore 1.35 s)."""
    for q in ti.static(range(len(fields))):
        f = ti.static(fields[q])
        if ti.static(len(f.shape) == 0):
            _put(out, offsets[q], f[None], f)
        else:
            _host_loop()
            for I in ti.grouped(ti.ndrange(sizes[q], *ti.static(f.shape[1:]))):
                _put(out, offsets[q] + _row(I, f.shape) * ti.static(_width(f)), f[I], f)


@ti.kernel
def _zero_fields(fields: ti.template()):
    """Every entry of every field of `fields` set to zero, the state of a field Taichi has just
    allocated (State.clear)."""
    for q in ti.static(range(len(fields))):
        f = ti.static(fields[q])
        if ti.static(len(f.shape) == 0):
            f[None] = _zero(f)
        else:
            for I in ti.grouped(f):
                f[I] = _zero(f)


# One entry of a field and its components on the host, row-major (the one place that knows a
# scalar, vector or matrix field's entry): the host's copies of every field go through these.
@ti.func
def _put(flat: ti.template(), base, v, f: ti.template()):
    """The components of the entry v of `f` into `flat` from `base`."""
    if ti.static(not isinstance(f, ti.MatrixField)):
        flat[base] = v
    elif ti.static(f.m == 1):
        for j in ti.static(range(f.n)):
            flat[base + j] = v[j]
    else:
        for j, k in ti.static(ti.ndrange(f.n, f.m)):
            flat[base + j * f.m + k] = v[j, k]


@ti.func
def _entry(flat: ti.template(), base, f: ti.template()):
    """The entry of `f` whose components lie in `flat` from `base` (the inverse of :func:`_put`)."""
    if ti.static(not isinstance(f, ti.MatrixField)):
        return flat[base]
    elif ti.static(f.m == 1):
        return ti.Vector([flat[base + j] for j in ti.static(range(f.n))])
    else:
        return ti.Matrix([[flat[base + j * f.m + k] for k in ti.static(range(f.m))] for j in ti.static(range(f.n))])


@ti.func
def _zero(f: ti.template()):
    """A zero entry of `f`."""
    if ti.static(not isinstance(f, ti.MatrixField)):
        return ti.cast(0, f.dtype)
    elif ti.static(f.m == 1):
        return ti.Vector.zero(f.dtype, f.n)
    else:
        return ti.Matrix.zero(f.dtype, f.n, f.m)


@ti.kernel
def _write_fields(fields: ti.template(), src: ti.types.ndarray(), offsets: ti.types.ndarray(),
                  sizes: ti.types.ndarray()):
    """The inverse of :func:`_read_fields`: field q's first sizes[q] entries (0-d: its value)
    from the flat `src` at offsets[q]."""
    for q in ti.static(range(len(fields))):
        f = ti.static(fields[q])
        if ti.static(len(f.shape) == 0):
            f[None] = _entry(src, offsets[q], f)
        else:
            _host_loop()
            for I in ti.grouped(ti.ndrange(sizes[q], *ti.static(f.shape[1:]))):
                f[I] = _entry(src, offsets[q] + _row(I, f.shape) * ti.static(_width(f)), f)


def _entry_shape(field, size: int | None) -> tuple:
    """The numpy shape of `size` entries of `field` (0-d: its value's), as State.read gives."""
    tail = (field.n,) if isinstance(field, ti.MatrixField) and field.m == 1 else \
        (field.n, field.m) if isinstance(field, ti.MatrixField) else ()
    return tail if len(field.shape) == 0 else (size, *field.shape[1:], *tail)


@dataclass(frozen=True)
class FieldKind:
    """What a field holds per entry: ``shape`` () a scalar, (n,) a vector, (n, m) a matrix."""
    shape: tuple
    dtype: object

    def make(self):
        """The Taichi field, not yet placed."""
        if not self.shape:
            return ti.field(self.dtype)
        if len(self.shape) == 1:
            return ti.Vector.field(self.shape[0], self.dtype)
        return ti.Matrix.field(*self.shape, self.dtype)


def scalar(dtype) -> FieldKind:
    return FieldKind((), dtype)


def vector(n: int, dtype) -> FieldKind:
    return FieldKind((n,), dtype)


def matrix(n: int, m: int, dtype) -> FieldKind:
    return FieldKind((n, m), dtype)


class Group(SimpleNamespace):
    """The fields of one role (module docstring), in an SNode tree of their own; each entry
    remembers how many of its entries the model uses.  ``allocate`` False: only the layout is
    recorded, no Taichi field is made (program.py compares layouts)."""

    def __init__(self, role: str, allocate: bool = True):
        super().__init__()
        self._role = role
        self._allocate = allocate
        self._builder = ti.FieldsBuilder() if allocate else None
        self._entries: dict[str, tuple] = {}       # name -> (field, host size, persistent)
        self._placed: list = []                    # every used field, in order (State.clear)
        self._layout: list[tuple] = []             # how each was placed (State.layout)

    def entity(self, name: str, kind: FieldKind, size: int, tail: tuple = (), persistent: bool = True,
               used: bool = True, host: bool = True):
        """Place a field of `kind` with one entry per entity (+ a fixed `tail` shape) over
        capacity(size); `size` entries are used.  A field the features do not use is placed all
        the same, at the smallest class (``used`` False), so that every run builds the same
        trees; only used fields with ``host`` are read, written and checkpointed by the host."""
        shape = (capacity(size if used else 0), *tail)
        axes = ti.i if not tail else (ti.ij if len(tail) == 1 else ti.ijk)
        self._place(name, kind, lambda f: self._builder.dense(axes, shape).place(f))
        self._record(name, kind, shape, size, used, host, persistent)

    def table(self, name: str, kind: FieldKind, shape: tuple, size: int | None = None, persistent: bool = True,
              used: bool = True):
        """Place a small dense table of fixed `shape` (0-d when shape is ()); ``used`` False:
        not read, written or checkpointed by the host."""
        self._place(name, kind, lambda f: (self._builder.dense(ti.i if len(shape) == 1 else ti.ij, shape).place(f)
                                           if shape else self._builder.place(f)))
        self._record(name, kind, shape, shape[0] if shape and size is None else size, used, True, persistent)

    def together(self, count: int, **kinds: FieldKind) -> None:
        """Place fields of `kinds` side by side over `count` entries (an array of structures),
        never read or written by the host."""
        fields = {name: kind.make() if self._allocate else None for name, kind in kinds.items()}
        if self._allocate:
            self._builder.dense(ti.i, count).place(*fields.values())
        for name, kind in kinds.items():
            setattr(self, name, fields[name])
            self._record(name, kind, (count,), count, True, False, False)

    def _place(self, name: str, kind: FieldKind, place) -> None:
        """The field of `kind` made and placed by `place`, as attribute `name` (None when
        only the layout is planned)."""
        field = None
        if self._allocate:
            field = kind.make()
            place(field)
        setattr(self, name, field)

    def _record(self, name: str, kind: FieldKind, shape: tuple, size, used: bool, host: bool,
                persistent: bool) -> None:
        field = getattr(self, name)
        if used:        # (a field the features do not use is never written: it stays zero)
            self._placed.append(field)
            if host:
                self._entries[name] = (field, size, persistent)
        self._layout.append((name, str(kind.dtype), kind.shape, tuple(shape), size, used, host, persistent))

    def finalize(self) -> None:
        self._tree = self._builder.finalize()

    def fields(self, persistent_only: bool = True) -> dict:
        return {n: (f, s) for n, (f, s, p) in self._entries.items() if p or not persistent_only}


@ti.data_oriented
class State:
    """All fields of a run, grouped by role (module docstring).  Sizes are data (the count
    fields), not kernel constants; ``features`` (config.Features) decides which fields exist."""

    def __init__(self, model, features, allocate: bool = True):
        n, m = len(model.points), len(model.elements)
        f64, i32, vec3 = ti.f64, ti.i32, 3
        fx = features
        self.n_nodes, self.n_elements = n, m
        self.features = fx
        self._cache: dict | None = None           # read(): see reads_cached
        self._pending: list | None = None         # load(): the arrays it writes at its end
        self._pending_rows: dict | None = None    # load(): the entries set one by one, per field
        self._snapshot_of: dict | None = None     # read(): id(field) -> (SNAPSHOTS key, host size)
        self._snapshot_plans: dict = {}           # read(): each SNAPSHOTS set's batches (keyed by id(field))
        nk = fx.points

        # --- shell nodes (= particle-domain corners), method.md 1
        g = self.nodes = Group("nodes", allocate)
        g.table("count", scalar(i32), ())
        for name, size in (("position", vec3), ("position_ref", vec3), ("velocity", vec3), ("grid_velocity", vec3),
                           ("omega", vec3), ("rotation", 4), ("force_int", vec3), ("moment_int", vec3),
                           ("load_force", vec3), ("load_moment", vec3)):
            g.entity(name, vector(size, f64), n)
        # position_ref: X_c; velocity: carried v_c (FLIP memory / APIC velocity); grid_velocity:
        # v~_c, the velocity that moved the node; rotation: accumulated orientation quaternion
        # (output only); force_int/moment_int: resisting internal loads; load_*: at load factor 1
        g.entity("mass", scalar(f64), n)
        g.entity("inertia", scalar(f64), n)          # scalar rotary inertia J_c
        g.entity("thickness", scalar(f64), n)        # the thickest adjacent element's
        g.entity("fix_mask", scalar(i32), n)         # bits ux uy uz rx ry rz
        g.entity("body", scalar(i32), n)             # rigid body of the node, -1 = none
        g.entity("energy", vector(4, f64), n)  # external work, contact, wall, motion (energy.py)
        g.entity("affine", matrix(3, 3, f64), n,   # C_c (method.md 2.2)
                 used=fx.affine_transfer)
        # PolyPIC's higher velocity modes (stages/mapping.py): columns d2v/dxdy, d2v/dydz,
        # d2v/dzdx, d3v/dxdydz
        g.entity("velocity_modes", matrix(3, 4, f64), n, used=fx.velocity_modes)
        # sum_e A_e e3 and sum_e A_e: the nodal normal of the drilling projection (method.md 2.3)
        # and of the multi-field grid's layer test (stages/grid.py)
        g.entity("normal_sum", vector(3, f64), n, used=fx.nodal_normals)
        g.entity("area_sum", scalar(f64), n, used=fx.nodal_normals)
        g.entity("part", scalar(i32), n, used=fx.multi_field)      # the lowest part of its elements
        # prescribed motion (stages/motion.py): DOF bits ux .. rz a [[motion]] prescribes, and the
        # motion of each DOF (-1: none)
        g.entity("motion_mask", scalar(i32), n, used=fx.loads)
        g.entity("motion", vector(6, i32), n, used=fx.loads)
        # the reaction on each prescribed DOF (this step's) and its work since the start; summed
        # per motion on the host, in node order (simulation.motion_values)
        g.entity("motion_reaction", scalar(f64), n, (6,), used=fx.loads)
        g.entity("motion_work", scalar(f64), n, (6,), used=fx.loads)
        # loads beyond the plain ones (stages/loads.py): physical mass (gravity), this step's
        # pressure force, CSR node -> curve/follower load entries
        g.entity("physical_mass", scalar(f64), n, used=fx.loads)
        # the [[point_mass]] mass and rotary inertia at each node: the per-step mass rebuild of
        # erosion and mass scaling adds them to the elements' shares (stages/masses.py)
        g.entity("point_mass", scalar(f64), n, used=fx.mass_update)
        g.entity("point_inertia", scalar(f64), n, used=fx.mass_update)
        g.entity("pressure_force", vector(3, f64), n, persistent=False, used=fx.loads, host=False)
        # selective mass scaling (stages/selective_mass.py): the solved accelerations (the next
        # step's first guess, so checkpointed), and the solve's scratch: the free translations
        # (1/0 per axis) and rotations, the drilling normal the rotations are kept normal to,
        # the right-hand side (force, torque), residual, preconditioned residual, search
        # direction and M times it (translation, rotation), and the node's shares of its live
        # elements' masses and rotary inertias
        g.entity("acceleration", vector(3, f64), n, used=fx.selective_mass)
        g.entity("angular_acceleration", vector(3, f64), n, used=fx.selective_mass)
        for name in ("free_dofs", "free_rotations", "sms_drill_normal", "sms_force", "sms_torque", "sms_residual",
                     "sms_residual_moment", "sms_step", "sms_step_moment", "sms_search", "sms_search_moment",
                     "sms_product", "sms_moment"):
            g.entity(name, vector(3, f64), n, persistent=False, used=fx.selective_mass, host=False)
        g.entity("sms_share", vector(2, f64), n, persistent=False, used=fx.selective_mass, host=False)
        g.entity("load_start", scalar(i32), n + 1, used=fx.loads)
        # the node-smoothed triangle (stages/ns_membrane.py): the node's weighted mean tensor
        g.entity("ns_mean", matrix(3, 3, f64), n, persistent=False, used=fx.triangle_ns, host=False)
        g.entity("ns_share", scalar(f64), n, persistent=False, used=fx.triangle_ns, host=False)   # 0: next to a quad

        # --- elements (= material points): topology and element-level state
        g = self.elements = Group("elements", allocate)
        g.table("count", scalar(i32), ())
        g.entity("corners", vector(4, i32), m)    # corner 3 = -1: triangle
        g.entity("hourglass_resultant", vector(5, f64), m)  # (QMx, QMy, QW, QBx, QBy), local
        # corner moments M_a of the drilling spring about e3 (stages/drilling.py)
        g.entity("drilling_moment", vector(4, f64), m, used=fx.drilling_spring)
        # internal, plastic work, hourglass, drilling; stagger (this step's, energy.py)
        g.entity("energy", vector(5, f64), m)
        # element loads gathered at the nodes (parallel launches, stages/accumulate.py): each
        # element writes its corners' (force, moment, A e3, A) to its own slots (the normal sums
        # only for the drilling projection); CSR node -> 4 e + a, e ascending
        gathered = fx.launch != "batched"
        g.entity("corner_loads", vector(10, f64), m, (4,), persistent=False,
                 used=gathered)
        g.entity("node_slot_start", scalar(i32), n + 1, used=gathered or fx.mass_update or fx.triangle_ns)
        g.entity("node_slots", scalar(i32), 4 * m, used=gathered or fx.mass_update or fx.triangle_ns)
        # the node-smoothed triangle (stages/ns_membrane.py): this step's w_e X_e and w_e = A/3
        g.entity("ns_tensor", matrix(3, 3, f64), m, persistent=False, used=fx.triangle_ns, host=False)
        g.entity("ns_weight", scalar(f64), m, persistent=False, used=fx.triangle_ns, host=False)
        # and for its loads the end-of-step normal and A grad N_a (rows a)
        g.entity("ns_gradient", matrix(3, 3, f64), m, persistent=False, used=fx.triangle_ns, host=False)
        g.entity("ns_normal", vector(3, f64), m, persistent=False, used=fx.triangle_ns, host=False)
        # erosion and selective mass scaling (issue 18; stages/masses.py): failed (1) or not;
        # density factor f_e >= 1; the element's physical shares of its corners' masses and
        # rotary inertias; kinetic energy its erosion took out of the nodes, and that its
        # added mass was given (energy.py)
        g.entity("eroded", scalar(i32), m, used=fx.erosion)
        g.entity("mass_factor", scalar(f64), m, used=fx.mass_scaling)
        g.entity("corner_mass", vector(4, f64), m, used=fx.mass_update)
        g.entity("corner_inertia", vector(4, f64), m, used=fx.mass_update)
        g.entity("mass_energy", vector(2, f64), m, used=fx.mass_update)
        # selective mass scaling (stages/selective_mass.py): the geometry of the step's added
        # mass (corner arms about the mass centre, inverse inertia J^-1, unit normal, rho^2),
        # kept from the start of the step
        g.entity("sms_arm", vector(3, f64), m, (4,), used=fx.selective_mass)
        g.entity("sms_inverse_inertia", matrix(3, 3, f64), m, used=fx.selective_mass)
        g.entity("sms_normal", vector(3, f64), m, used=fx.selective_mass)
        g.entity("sms_radius_sq", scalar(f64), m, used=fx.selective_mass)
        g.entity("sms_spin_block", matrix(3, 3, f64), m, persistent=False, used=fx.selective_mass,
                 host=False)      # (J_e + gamma P)^-1 of the preconditioner, with this step's beta
        # the solve's scratch, per corner (translation, rotation), gathered at the nodes: each
        # element's share of M_add or its block inverse of its shares of the vector in hand; and
        # with the reciprocal mass matrix the kinetic energy its added mass carries, a running
        # sum (stages/selective_mass.py)
        for name in ("sms_corner_step", "sms_corner_turn"):
            g.entity(name, vector(3, f64), m, (4,), persistent=False, used=fx.selective_mass, host=False)
        g.entity("sms_excess", scalar(f64), m, used=fx.reciprocal_mass)

        # --- section and material data of each element, and the tables they index
        g = self.sections = Group("sections", allocate)
        for name in ("thickness", "shear_factor", "wave_speed", "rotational_frequency",
                     "hourglass_membrane", "hourglass_bending", "hourglass_transverse", "drilling_factor"):
            g.entity(name, scalar(f64), m)
        # wave_speed: plane-stress c_e of its stiffest material; rotational_frequency:
        # sqrt(12 kappa G / rho) / t with physical rotary inertia, else 0 (stages/timestep.py);
        # hourglass_*: r E t / 8, r E t^3 / 192, r kappa G t^3 / 12 (stages/hourglass.py);
        # drilling_factor: alpha E t^3 / 48 (stages/drilling.py)
        g.entity("section", scalar(i32), m)
        g.entity("shear_wave_speed", scalar(f64), m, used=fx.reciprocal_mass)   # sqrt(G_max / rho)
        for name in ("opt_modulus", "opt_poisson", "opt_floor"):       # the OPT triangle (stages/opt_membrane.py)
            g.entity(name, scalar(f64), m, used=fx.triangle_opt)
        # cos, sin of the angle from e1 to the section's material axis (docs/laminates.md)
        g.entity("material_axis", vector(2, f64), m, used=fx.oriented)
        g.table("point_count", scalar(i32), (MAX_SECTIONS,))                 # points of each section's rule
        g.table("zeta", scalar(f64), (MAX_SECTIONS, nk))                      # point positions, -1..1
        g.table("weight", scalar(f64), (MAX_SECTIONS, nk))                    # and weights (sum 2)
        g.table("point_material", scalar(i32), (MAX_SECTIONS, nk))            # material of each point
        g.table("ply_axis", vector(2, f64), (MAX_SECTIONS, nk),       # cos, sin of its ply angle
                used=fx.oriented)
        g.table("material_kind", scalar(i32), (MAX_MATERIALS,))              # index into Features.materials
        g.table("material", scalar(f64), (MAX_MATERIALS, row_width(fx.materials)))   # parameters (model/materials.py)
        g.table("failure", vector(len(FAILURE_COLUMNS), f64), (MAX_MATERIALS,),   # erosion (failure_row)
                used=fx.erosion)
        # tabulated hardening curves, all materials' one after the other (a row holds its first
        # point and count): plastic strain and yield stress of each point
        curve_points = len(model.materials.curve_strain)
        tabulated = "tabulated" in fx.hardening
        g.entity("curve_strain", scalar(f64), curve_points, used=tabulated)
        g.entity("curve_stress", scalar(f64), curve_points, used=tabulated)

        # --- the scalars of the step and its run-time parameters
        g = self.step = Group("step", allocate)
        for name, dtype in (("dt", f64), ("dt_next", f64), ("dt_first", f64), ("dt_last", f64),
                            ("dt_stable", f64), ("time", f64),
                            ("step", ti.i64), ("load_factor", f64), ("restart_factor", f64),
                            ("velocity_keep", f64), ("fire_mix", f64), ("fire_alpha", f64), ("fire_uphill", i32),
                            ("fire_power", f64), ("fire_speed_sq", f64), ("fire_force_sq", f64),
                            ("residual_target_sq", f64), ("time_limit", f64), ("kinetic", f64),
                            ("kinetic_prev", f64), ("kinetic_initial", f64), ("energy_limit", f64),
                            ("internal_energy", f64), ("hourglass_energy", f64), ("drilling_energy", f64),
                            ("plastic_work", f64), ("external_work", f64), ("damped_energy", f64),
                            ("stagger_energy", f64), ("contact_energy", f64), ("wall_energy", f64),
                            ("residual_sq", f64), ("max_speed", f64), ("status", i32), ("status_index", i32),
                            ("dt_safety", f64), ("length_ref", f64), ("mass_floor", f64), ("runaway_speed", f64),
                            ("flip_blend", f64), ("dilatational_speed", f64), ("curve_argument", f64),
                            ("motion_work", f64), ("constraint_sq", f64), ("tolerance_sq", f64),
                            ("motion_ramp", f64), ("eroded_kinetic", f64), ("mass_scaling_energy", f64),
                            ("added_mass", f64), ("added_mass_cap", f64), ("target_dt", f64),
                            ("sms_tolerance", f64), ("sms_max_iterations", i32), ("sms_iterations", ti.i64),
                            ("sms_iterations_max", i32), ("sms_solves", ti.i64), ("ns_blend", f64)):
            g.table(name, scalar(dtype), ())
        # compiled in, not a field: the kick is the average of dt_last and dt under selective
        # mass scaling (stages/timestep.impulse_time)
        g.averaged_kick = fx.selective_mass
        # dt_last: the last step's dt;
        # restart_factor: 0.5 on a central-difference restart from rest, else 1; velocity_keep:
        # 0 right after a kinetic-damping reset, else 1; fire_*: FIRE state and scratch
        # (solvers/stepper.py); time_limit: advance() stops there exactly; kinetic...:
        # the 0-d running totals of energy.py; dt_safety, length_ref (the rotational residual's
        # L_ref), mass_floor (grid nodes below it are massless), runaway_speed, flip_blend, ns_blend:
        # the step's run-time parameters; curve_argument: the curves' argument at the end of the
        # last step (time, or the load factor in a static run; stages/motion.py); motion_work: the
        # running total of energy.py; constraint_sq, tolerance_sq: a static run's prescribed-DOF
        # forces (their norm^2) and tolerance^2, the residual's scale under displacement control;
        # eroded_kinetic, mass_scaling_energy: running totals (energy.py); added_mass: by selective
        # mass scaling since the start, added_mass_cap: its limit (0: none), target_dt: its step
        # (stages/masses.py); sms_*: selective mass scaling's solve: its tolerance and
        # iteration limit, the iterations and solves since the start, the most in one solve
        # (stages/selective_mass.py)
        g.table("reaction", vector(3, f64), ())           # force the supports exert on the shell
        g.table("reaction_impulse", vector(3, f64), ())   # its time integral since the start

        # --- rigid bodies and walls (method.md 2.5c, 7.5)
        g = self.bodies = Group("bodies", allocate)
        nb, nw = len(model.rigid_bodies), len(model.walls)
        g.table("count", scalar(i32), ())
        g.table("wall_count", scalar(i32), ())
        for name in ("wall_energy", "total_mass", "added_mass", "external_work", "kinetic_rotation", "contact_energy",
                     "stable_step", "inertia_min"):
            g.table(name, scalar(f64), (MAX_BODIES,), nb)
        for name in ("velocity", "velocity_start", "displacement", "force", "impulse", "center0", "omega",
                     "omega_start", "angular_momentum", "moment", "applied_force", "applied_moment",
                     "angular_impulse", "omega_mid", "center_start"):
            g.table(name, vector(3, f64), (MAX_BODIES,), nb)
        for name in ("inertia", "translation_free", "rotation_free"):
            g.table(name, matrix(3, 3, f64), (MAX_BODIES,), nb)
        g.table("rotation", vector(4, f64), (MAX_BODIES,), nb)
        # a [[motion]] of the body: its DOF bits and the motion of each DOF (-1: none), the
        # reaction of each prescribed DOF this step and its work so far (stages/bodies.py)
        g.table("motion_mask", scalar(i32), (MAX_BODIES,), nb)
        g.table("motion", vector(6, i32), (MAX_BODIES,), nb)
        g.table("motion_reaction", vector(6, f64), (MAX_BODIES,), nb)
        g.table("motion_work", vector(6, f64), (MAX_BODIES,), nb)
        g.table("rotation_mode", scalar(i32), (MAX_BODIES,), nb)
        # (stages/bodies.py) velocity: the centre's V^(n+1/2); velocity_start: V^(n-1/2) of the
        # step; displacement: x_c - center0 (the reference centre X_c); rotation: unit
        # quaternion (w, x, y, z) body -> space; omega: the space-frame angular velocity of the
        # step's rotation, omega_start the last step's; angular_momentum: L^(n+1/2) about the
        # centre, space frame; inertia: J about the centre in the body frame (= global axes at
        # t = 0); translation_free, rotation_free: projectors on the free DOFs; rotation_mode:
        # ROTATION_HELD / _CONSTRAINED / _FREE; kinetic_rotation: 1/2 L . I^-1 L;
        # force, moment: on the body this step (moment about the centre); applied_force,
        # applied_moment: added by other stages before the body update (consumed there);
        # impulse, angular_impulse: of walls (tools) this step, applied at its end;
        # wall_energy: work of the walls moving with it, on it; external_work: of gravity on
        # its added mass and of the applied loads; stable_step: the step its mass and inertia allow
        # (model/bodies.body_step); inertia_min: the smallest principal J about its free axes (the
        # step's turn limit); omega_mid, center_start: the kick's (omega^- + omega^+) / 2 and x_c^n of
        # this step (the tools moving with it book their work with them)
        # selective mass scaling with bodies (stages/selective_mass.py, Bodies): each body's
        # solved acceleration and angular acceleration (the next step's first guess, so
        # checkpointed), its rows of the solve (right-hand side, residual, preconditioned
        # residual, search direction, M times it: translation, rotation) and the added mass's
        # inertial force at its slaves and its moment, which its kick takes
        coupled = fx.selective_mass and fx.bodies
        g.table("sms_acceleration", vector(3, f64), (MAX_BODIES,), nb, used=coupled)
        g.table("sms_angular_acceleration", vector(3, f64), (MAX_BODIES,), nb, used=coupled)
        for name in ("sms_force", "sms_torque", "sms_residual", "sms_residual_moment", "sms_step", "sms_step_moment",
                     "sms_search", "sms_search_moment", "sms_product", "sms_moment", "sms_added_force",
                     "sms_added_moment"):
            g.table(name, vector(3, f64), (MAX_BODIES,), nb, persistent=False, used=coupled)
        g.table("direction", vector(3, f64), (MAX_BODIES,), nb)
        g.table("first_slave", scalar(i32), (MAX_BODIES,), nb)
        g.table("slave_count", scalar(i32), (MAX_BODIES,), nb)
        g.entity("slave_nodes", scalar(i32), sum(len(b.nodes) for b in model.rigid_bodies))
        g.table("wall_point", vector(3, f64), (MAX_WALLS,), nw)
        g.table("wall_normal", vector(3, f64), (MAX_WALLS,), nw)
        g.table("wall_body", scalar(i32), (MAX_WALLS,), nw)          # -1: fixed
        # each node's impulse on each moving wall's body, summed in node order (threads, stages/bodies.py)
        g.entity("node_wall_impulse", vector(3, f64), n, (MAX_WALLS,),
                 used=fx.launch == "threads" and fx.moving_walls)
        g.entity("node_wall_moment", vector(3, f64), n, (MAX_WALLS,),
                 used=fx.launch == "threads" and fx.moving_walls and fx.body_rotation)

        # --- time curves, loads beyond the plain nodal ones, prescribed motion (stages/loads.py,
        # stages/motion.py; loading.py)
        g = self.loads = Group("loads", allocate)
        ld = model.loading
        on = fx.loads
        g.table("curve_count", scalar(i32), ())
        for name, dtype in (("curve_kind", i32), ("curve_first", i32), ("curve_rows", i32)):
            g.table(name, scalar(dtype), (MAX_CURVES,), len(ld.curves.kind), used=on)
        g.table("curve_parameter", vector(3, f64), (MAX_CURVES,), len(ld.curves.kind), used=on)  # start, end, scale
        g.table("curve_origin", vector(2, f64), (MAX_CURVES,), len(ld.curves.kind), used=on)     # I(0), J(0)
        g.table("curve_value", scalar(f64), (MAX_CURVES,), len(ld.curves.kind), persistent=False,
                used=on)                                           # this step's f at the loads' argument
        g.entity("curve_table", vector(CURVE_COLUMNS, f64), len(ld.curves.rows), used=on)   # curves.py rows
        ne = len(ld.entry_curve)
        g.table("entry_count", scalar(i32), ())
        for name, dtype in (("entry_node", i32), ("entry_curve", i32), ("entry_neighbor", i32)):
            g.entity(name, scalar(dtype), ne, used=on)
        g.entity("entry_frame", matrix(3, 3, f64), ne, used=on)     # a follower's reference frame (rows)
        g.entity("entry_force", vector(3, f64), ne, used=on)        # at load factor 1, reference axes
        g.entity("entry_moment", vector(3, f64), ne, used=on)
        # this step's: scaled by the curve and turned (followers) at the start of the step
        g.entity("entry_force_now", vector(3, f64), ne, persistent=False, used=on, host=False)
        g.entity("entry_moment_now", vector(3, f64), ne, persistent=False, used=on, host=False)
        npr = len(ld.pressure_element)
        g.table("pressure_count", scalar(i32), ())
        g.table("pressure_node_count", scalar(i32), ())
        g.entity("pressure_element", scalar(i32), npr, used=on)
        g.entity("pressure_value", scalar(f64), npr, used=on)
        g.entity("pressure_curve", scalar(i32), npr, used=on)
        g.entity("pressure_corner_force", vector(3, f64), npr, (4,), persistent=False, used=on, host=False)
        g.entity("pressure_nodes", scalar(i32), len(ld.pressure_nodes), used=on)
        g.entity("pressure_node_start", scalar(i32), len(ld.pressure_nodes) + 1, used=on)
        g.entity("pressure_node_slots", scalar(i32), len(ld.pressure_node_slots), used=on)
        g.table("gravity", vector(3, f64), (), used=on)          # g
        g.table("gravity_curve", scalar(i32), (), used=on)
        g.table("gravity_now", vector(3, f64), (), persistent=False, used=on)   # this step's
        nm = len(ld.motions)
        g.table("motion_count", scalar(i32), ())
        for name, dtype in (("motion_kind", i32), ("motion_curve", i32)):
            g.table(name, scalar(dtype), (MAX_MOTIONS,), nm, used=on)
        g.table("motion_value", vector(6, f64), (MAX_MOTIONS,), nm, used=on)   # per DOF ux .. rz
        windows = fx.motion_windows
        g.table("motion_window", vector(2, f64), (MAX_MOTIONS,), nm, used=windows)  # start, end
        g.table("motion_active", scalar(i32), (MAX_MOTIONS,), nm, persistent=False, used=windows)  # this step
        # this step's displacement level f(s^(n+1)) and rate (stages/motion.py); the acceleration
        # curves' mean velocity of the last step
        g.table("motion_level", scalar(f64), (MAX_MOTIONS,), nm, persistent=False, used=on)
        g.table("motion_rate", scalar(f64), (MAX_MOTIONS,), nm, persistent=False, used=on)
        g.table("motion_mean", scalar(f64), (MAX_MOTIONS,), nm, used=on)

        # --- rigid tools ([[tool]]; tools.py, stages/tools.py)
        g = self.tools = Group("tools", allocate)
        tt = model.tools
        on = fx.tools
        nt = len(tt.names) if tt is not None else 0
        g.table("count", scalar(i32), (), persistent=False)
        g.table("slip_speed", scalar(f64), (), persistent=False, used=on)   # v_eps of the friction law
        g.table("reach", scalar(f64), (), persistent=False, used=on)        # how far behind a mesh nodes are caught
        g.table("step_limit", scalar(f64), (), persistent=False, used=on)   # this step's dt bound (stages/tools.py)
        for name, dtype in (("kind", i32), ("motion", i32), ("body", i32), ("curve", i32)):
            g.table(name, scalar(dtype), (MAX_TOOLS,), nt, persistent=False, used=on)
        for name in ("origin", "size", "value", "coefficients"):
            g.table(name, vector(3, f64), (MAX_TOOLS,), nt, persistent=False, used=on)
        g.table("frame", matrix(3, 3, f64), (MAX_TOOLS,), nt, persistent=False, used=on)
        # this step's pose at t^n (centre, frame rows) and velocity of the tool's points (its
        # mean over the step for a prescribed motion; V^(n-1/2) of its body)
        g.table("centre", vector(3, f64), (MAX_TOOLS,), nt, persistent=False, used=on)
        g.table("axes", matrix(3, 3, f64), (MAX_TOOLS,), nt, persistent=False, used=on)
        g.table("velocity", vector(3, f64), (MAX_TOOLS,), nt, persistent=False, used=on)
        # force and moment (about the centre) the tool exerts on the shell this step; nodes touching
        g.table("force", vector(3, f64), (MAX_TOOLS,), nt, used=on)
        g.table("moment", vector(3, f64), (MAX_TOOLS,), nt, used=on)
        g.table("contacts", scalar(i32), (MAX_TOOLS,), nt, used=on)
        # energy: the contact energy booked so far (energy.py); work: the part of it booked at
        # the tool's own motion, kick F . V_tool (the work its driver or body put in)
        g.table("energy", scalar(f64), (MAX_TOOLS,), nt, used=on)
        g.table("work", scalar(f64), (MAX_TOOLS,), nt, used=on)
        # each node's force from each tool, and their sum (this step's)
        g.entity("node_force", vector(3, f64), n, (MAX_TOOLS,), persistent=False, used=on, host=False)
        g.entity("total_force", vector(3, f64), n, persistent=False, used=on, host=False)
        # surface meshes (model/tools.ToolTable): triangles in the tool's frame, their normals, buckets
        meshes = "mesh" in fx.tool_kinds
        ntri = len(tt.triangles) if meshes else 0
        g.table("tri_first", scalar(i32), (MAX_TOOLS,), nt, persistent=False, used=meshes)
        g.table("bucket_first", scalar(i32), (MAX_TOOLS,), nt, persistent=False, used=meshes)
        g.table("grid_lo", vector(3, f64), (MAX_TOOLS,), nt, persistent=False, used=meshes)
        g.table("grid_h", scalar(f64), (MAX_TOOLS,), nt, persistent=False, used=meshes)
        g.table("grid_dims", vector(3, i32), (MAX_TOOLS,), nt, persistent=False, used=meshes)
        g.entity("triangles", matrix(3, 3, f64), ntri, persistent=False, used=meshes)
        g.entity("tri_normal", vector(3, f64), ntri, persistent=False, used=meshes)
        g.entity("bucket_start", scalar(i32), len(tt.bucket_start) if meshes else 0, persistent=False,
                 used=meshes)
        g.entity("bucket_items", scalar(i32), len(tt.bucket_items) if meshes else 0, persistent=False,
                 used=meshes)

        # --- self-contact (method.md 7.3), used only when the scene asks for it
        # --- [[tie]] and [[spotweld]] (stages/joints.py, model/joints.py): per joint its slave,
        # masters and weights N_a, offset r and axis (turned with the masters), whether the
        # rotation is tied, a tie's segment, the kind, a weld's SN SS n m TF coincident; active
        # (1 until a weld fails or a tie's segment erodes), the failure time (-1: intact),
        # this step's normal (tension > 0) and shear force of a weld, their peaks; per node the
        # joint it follows (-1: none) and the slaves' mass, rotary inertia, force and moment
        # lumped on it this step (stages/joints.Joints.distribute)
        g = self.joints = Group("joints", allocate)
        jt = model.joints
        on = fx.joints
        nj = len(jt) if jt is not None else 0
        g.table("count", scalar(i32), (), used=on)
        g.entity("slave", scalar(i32), nj, used=on)
        g.entity("masters", vector(4, i32), nj, used=on)
        g.entity("weights", vector(4, f64), nj, used=on)
        g.entity("offset", vector(3, f64), nj, used=on)
        g.entity("axis", vector(3, f64), nj, used=on)
        g.entity("rotations", scalar(i32), nj, used=on)
        g.entity("element", scalar(i32), nj, used=on)
        g.entity("kind", scalar(i32), nj, used=on)
        g.entity("strength", vector(6, f64), nj, used=on)
        g.entity("active", scalar(i32), nj, used=on)
        g.entity("failure_time", scalar(f64), nj, used=on)
        g.entity("force_normal", scalar(f64), nj, used=on)
        g.entity("force_shear", scalar(f64), nj, used=on)
        g.entity("peak_normal", scalar(f64), nj, used=on)
        g.entity("peak_shear", scalar(f64), nj, used=on)
        g.entity("slave_force", vector(3, f64), nj, persistent=False, used=on, host=False)
        g.entity("node_joint", scalar(i32), n, used=on)
        for name in ("node_mass", "node_inertia"):
            g.entity(name, scalar(f64), n, persistent=False, used=on, host=False)
        for name in ("node_force", "node_moment"):
            g.entity(name, vector(3, f64), n, persistent=False, used=on, host=False)

        g = contact = Group("contact", allocate)
        self.contact = g if fx.contact else None
        for name, dtype in (("max_penetration", f64), ("pairs", i32), ("rebuild", i32), ("skin", f64),
                            ("thickness", f64), ("stiffness", f64), ("damping", f64), ("friction", f64),
                            ("slip_speed", f64), ("hash_cell", f64), ("hash_size", i32), ("candidate_capacity", i32)):
            g.table(name, scalar(dtype), (), used=fx.contact)
        # max_penetration: largest g / t_c seen; rebuild: 1 = rebuild the candidate lists at the
        # next step; skin: s (contact.skin_width); thickness ... slip_speed: the contact law
        g.table("velocity_high", vector(3, f64), (), used=fx.contact)   # per-axis extremes of the
        g.table("velocity_low", vector(3, f64), (), used=fx.contact)    # nodal velocities: their
        # spread bounds any approach speed (stages/timestep.py)
        on = fx.contact
        g.entity("force", vector(3, f64), n, used=on)
        # candidate (Verlet) lists: per node, the elements that can come within t_c before any
        # node moves skin/2 from where the lists were built (stages/contact.py)
        g.entity("build_position", vector(3, f64), n, used=on)
        g.entity("candidate_start", scalar(i32), n + 1, used=on)
        g.entity("candidate_elements", scalar(i32), CANDIDATES_PER_NODE * n, used=on)
        # side memory: the element a node touched last step, and on which side of its normal
        g.entity("last_element", scalar(i32), n, used=on)
        g.entity("last_side", scalar(f64), n, used=on)
        # this step's pair of each node: force on it and barycentric weights of the segment point
        g.entity("pair_force", vector(3, f64), n, persistent=False, used=on)
        g.entity("pair_weight", vector(4, f64), n, persistent=False, used=on)
        # exclusion ring, CSR: the nodes sharing an element with node c
        g.entity("neighbor_start", scalar(i32), n + 1, used=on)
        g.entity("neighbor_nodes", scalar(i32),
                 len(model.neighbor_nodes) if on else 0, used=on)
        # spatial hash of element centroids: scratch of a rebuild
        table = 1 << int(np.ceil(np.log2(2 * m)))
        g.entity("hash_count", scalar(i32), table, persistent=False, used=on)
        g.entity("hash_start", scalar(i32), table + 1, persistent=False, used=on)
        g.entity("hash_elements", scalar(i32), m, persistent=False, used=on)
        g.entity("element_slot", scalar(i32), m, persistent=False, used=on)
        g.entity("element_radius", scalar(f64), m, persistent=False, used=on)
        # the smallest pair thickness (model/contact_pairs.py; the step limit, stages/timestep.py)
        g.table("step_thickness", scalar(f64), (), persistent=False, used=on)
        g.table("approach", scalar(f64), (), persistent=False, used=fx.contact_pairs)   # timestep.contact_approach
        # [[contact_pair]] interfaces (model/contact_pairs.py): role bits of each node and face,
        # each direction's law and interface, this step's pair direction of each node, and the
        # force on each interface's slave side (this step's)
        pairs = fx.contact_pairs
        g.entity("node_role", scalar(i32), n, persistent=False, used=pairs)
        g.entity("segment_role", scalar(i32), m, persistent=False, used=pairs)
        g.table("law", vector(len(LAW_COLUMNS), f64), (DIRECTIONS,), persistent=False, used=pairs)
        g.table("law_interface", scalar(i32), (DIRECTIONS,), persistent=False, used=pairs)
        g.table("interface_count", scalar(i32), (), persistent=False, used=pairs)
        g.table("interface_force", vector(3, f64), (MAX_CONTACT_PAIRS,), used=pairs)
        g.entity("pair_direction", scalar(i32), n, persistent=False, used=pairs)

        # --- through-thickness point state (stages/material.py); after every group whose shape does
        # not depend on the features, so that only its own SNodes change with the points' count
        g = self.points = Group("points", allocate)
        g.entity("stress", vector(5, f64), m, (nk,))   # local (sxx, syy, sxy, txz, tyz)
        g.entity("plastic_strain", scalar(f64), m, (nk,),    # equivalent plastic strain
                 used=fx.plastic)
        g.entity("strain_rate", scalar(f64), m, (nk,),       # the filtered strain rate of the rate law
                 used=fx.rate_filter)

        # --- background grid (mpm): hashed, unbounded (stages/grid.py).  Only the grid nodes of
        # the shell nodes' stencils exist: a hash table maps a grid node's integer coordinates
        # to a slot of the dense storage below, whose size class follows the shell's free nodes.
        # Last in the tree: its layout depends on Features.grid_force.
        g = grid = Group("grid", allocate)
        self.grid = g if model.grid is not None else None
        on = model.grid is not None
        free = model.grid.free_nodes if on else 0
        slots = grid_capacity(GRID_SLOTS_PER_NODE * free) if on else CAPACITY_MIN
        self.grid_slots = slots
        for name in ("h", "inv_h"):
            g.table(name, scalar(f64), (), used=on)
        g.table("bound_lo", vector(3, i32), (), used=on)    # the cells a stencil base may take:
        g.table("bound_hi", vector(3, i32), (), used=on)    # the grid box, or the key range
        g.table("slab_axis", scalar(i32), (), used=on)
        g.table("planes", scalar(i32), (), used=on)                 # symmetry grid planes: count,
        g.table("plane_axis", scalar(i32), (3,), used=on)           # their axes
        g.table("plane_index", scalar(i32), (3,), used=on)          # and absolute grid indices
        # the hash table (open addressing, linear probing; key + 1, 0 = empty) and its slot pool
        g.table("slot_count", scalar(i32), (), used=on, persistent=False)   # slots handed out
        g.table("slot_capacity", scalar(i32), (), used=on)
        g.table("table_bits", scalar(i32), (), used=on)
        g.table("collections", scalar(i32), (), used=on, persistent=False)  # full re-hashes so far
        g.entity("table_key", scalar(ti.i64), 2 * slots if on else 0, used=on, host=False)
        g.entity("table_slot", scalar(i32), 2 * slots if on else 0, used=on, host=False)
        # per shell node: the stencil base cell its addresses were found for, and the 8 slots
        # (corner (i, j, k) at 4 i + 2 j + k); on_grid 0 for prescribed nodes; the nodes whose
        # base changed this step (found in parallel, hashed serially)
        g.entity("node_base", vector(3, i32), n, used=on, host=False)
        g.entity("node_slots", scalar(i32), n, (8,), used=on, host=False)   # scalars: no dynamic
        #                                                   index into a vector (a stack slot per use)
        g.entity("on_grid", scalar(i32), n, used=on, host=False)
        g.table("moved_count", scalar(i32), (), used=on, persistent=False)
        g.entity("moved_nodes", scalar(i32), n, used=on, host=False)
        # P2G order (stages/mapping.py): the free nodes binned by the grid plane of their
        # stencil's base across the slab axis (counting sort, rebuilt every step); scratch
        g.table("slab_low", scalar(i32), (), used=on, persistent=False)
        g.table("slab_high", scalar(i32), (), used=on, persistent=False)
        g.table("slab_start", scalar(i32), (MAX_SLAB_PLANES + 1,), used=False)
        g.table("slab_fill", scalar(i32), (MAX_SLAB_PLANES,), used=False)
        g.entity("slab_nodes", scalar(i32), n, used=on, host=False)
        # multi-field grid (stages/grid.py): per grid node, the shell node + 1 that opened each
        # of its fields (0: none; zero between steps); per shell node, the field of each of
        # its 8 corners (2 bits each; bits 16-23: decided, GPU claim rounds)
        multi = on and fx.multi_field
        g.table("field_radius_sq", scalar(f64), (), used=multi)         # (FIELD_RADIUS_CELLS h)^2
        # field overflow (a grid node reached by more layers than MAX_FIELDS): joins of a full
        # grid node so far; grid nodes overflowed this step (scratch) and a per-slot flag of it
        # (zero between steps); the first step with an overflow, its time and grid nodes (step
        # -1: none yet), which the host warns of (Simulation.check_fields)
        g.table("field_overflow", scalar(i32), (), used=multi)
        g.table("overflow_nodes", scalar(i32), (), used=multi, persistent=False)
        g.entity("overflowed", scalar(i32), slots if multi else 0, used=multi, persistent=False, host=False)
        g.table("first_overflow_step", scalar(i32), (), used=multi)
        g.table("first_overflow_time", scalar(f64), (), used=multi)
        g.table("first_overflow_nodes", scalar(i32), (), used=multi)
        g.entity("anchor", scalar(i32), slots if multi else 0, (MAX_FIELDS,), used=multi, host=False)
        g.entity("node_fields", scalar(i32), n, used=multi, host=False)
        touch = multi and fx.grid_contact               # the grid contact condition's t_c and mu
        g.table("field_gap", scalar(f64), (), used=touch)
        g.table("field_friction", scalar(f64), (), used=touch)
        # mass, momentum (without grid_force: p + dt f, stages/grid.py), force: an array of
        # structures, one grid node's data in one cache line.  Never read or written by the
        # host: zero between steps.
        placed = {"mass": scalar(f64), "momentum": vector(3, f64)}
        if fx.grid_force:
            placed["force"] = vector(3, f64)
        if touch:        # per field: sum N m x and sum N m n (the grid contact condition)
            placed["field_position"] = vector(3, f64)
            placed["field_normal"] = vector(3, f64)
        g.together(slots * (MAX_FIELDS if multi else 1), **placed)
        self._groups = (self.nodes, self.elements, self.sections, self.step, self.bodies, self.loads, self.tools,
                        self.joints, contact, self.points, grid)      # every tree, used or not
        if allocate:        # (False: only its layout is wanted, program.py; nothing is allocated)
            for group in self._groups:
                group.finalize()
    
    # ------------------------------------------------------------ the model's data
    def load(self, model) -> None:
        """Write the model (assembly.Model) into the fields: the initial state, the tables and
        the step's run-time parameters.  The arrays are written together at the end, the
        fields of a dtype by one kernel (:meth:`_write_later`)."""
        self._pending, self._pending_rows = [], {}
        try:
            self._load(model)
            pending, rows = self._pending, self._pending_rows
        finally:
            self._pending, self._pending_rows = None, None
        for field, values in rows.values():          # `later(field)[i] = value`, i = 0, 1, ...
            if sorted(values) == list(range(len(values))):
                pending.append((len(pending), field, len(values), np.array([values[i] for i in range(len(values))])))
            else:
                for i, value in values.items():
                    field[i] = value
        self._write_pending(pending)

    def _write_later(self, field, array, size: int | None = None) -> None:
        """:meth:`write` of an array into a field with a shape, made by :meth:`load` at its end
        with the other arrays, the fields of a dtype by one kernel (:func:`_write_fields`) [issue
        32: a kernel per field written was built, and on a cold kernel cache compiled, in every
        run: ~30 of them, ~1 s of a cold run's start]."""
        array = np.asarray(array)
        if self._pending is None:
            self.write(field, array, size)
            return
        n = None if len(field.shape) == 0 else len(array) if size is None else size
        if n is None or n > 0:
            self._pending.append((len(self._pending), field, n, array))

    def _later(self, field) -> "_Later":
        """`later(field)[None] = value` (`later(field)[i] = value`): a 0-d field's value (an
        entry of a 1-d field), written with the arrays at the end of :meth:`load` (Taichi
        builds, and on a cold cache compiles, a writer per field set with `field[key] = value`:
        ~34 ms each, 71 of them for the tube's bodies and walls)."""
        return _Later(self, field)

    def _write_pending(self, pending) -> None:
        plan = self._batches([(key, field, n) for key, field, n, _ in pending], lambda key, field, size: size)
        self._write_batches(plan, {key: array for key, _, _, array in pending})

    def _load(self, model) -> None:
        w, n, m = self._write_later, self.n_nodes, self.n_elements
        later = self._later
        nd, el, sec, st, bd = self.nodes, self.elements, self.sections, self.step, self.bodies
        later(nd.count)[None], later(el.count)[None] = n, m
        for name, array in (("position", model.points), ("position_ref", model.points),
                            ("velocity", model.velocity0), ("grid_velocity", model.velocity0),
                            ("omega", model.omega0), ("mass", model.node_mass), ("inertia", model.node_inertia),
                            ("thickness", model.node_thickness),
                            ("load_force", model.load_force), ("load_moment", model.load_moment),
                            ("fix_mask", model.fix_mask), ("body", model.node_body)):
            w(getattr(nd, name), array)
        q = np.zeros((n, 4))
        q[:, 0] = 1.0
        w(nd.rotation, q)
        if self.features.mass_update:
            point_mass, point_inertia = node_point_masses(model.point_masses, n)
            w(nd.point_mass, point_mass)
            w(nd.point_inertia, point_inertia)
        w(el.corners, model.elements)
        data = model.element
        for name in ("thickness", "shear_factor", "wave_speed", "rotational_frequency", "hourglass_membrane",
                     "hourglass_bending", "hourglass_transverse", "drilling_factor", "section"):
            w(getattr(sec, name), getattr(data, name))
        if self.features.reciprocal_mass:
            w(sec.shear_wave_speed, data.shear_wave_speed)
        if self.features.triangle_opt:
            for name in ("opt_modulus", "opt_poisson", "opt_floor"):
                w(getattr(sec, name), getattr(data, name))
        tables = model.sections
        ns = len(tables.names)
        pad = np.zeros((MAX_SECTIONS - ns, tables.points))
        w(sec.point_count, np.concatenate([tables.point_count, np.zeros(MAX_SECTIONS - ns, np.int32)]))
        w(sec.zeta, np.concatenate([tables.zeta, pad]))
        w(sec.weight, np.concatenate([tables.weight, pad]))
        w(sec.point_material, np.concatenate([tables.point_material, pad.astype(np.int32)]))
        if self.features.oriented:
            w(sec.material_axis, data.material_axis)
            angle = np.concatenate([tables.point_angle, pad])
            w(sec.ply_axis, np.stack([np.cos(angle), np.sin(angle)], axis=-1))
        mats = model.materials
        nm = len(mats.names)
        w(sec.material_kind, np.concatenate([mats.kind, np.zeros(MAX_MATERIALS - nm, np.int32)]))
        w(sec.material, np.concatenate([mats.rows, np.zeros((MAX_MATERIALS - nm, mats.rows.shape[1]))]))
        if self.features.erosion:
            w(sec.failure, np.concatenate([mats.failure, np.zeros((MAX_MATERIALS - nm, len(FAILURE_COLUMNS)))]))
        if "tabulated" in self.features.hardening:
            w(sec.curve_strain, mats.curve_strain)
            w(sec.curve_stress, mats.curve_stress)
        if self.features.mass_update:
            w(el.corner_mass, model.corner_mass)
            w(el.corner_inertia, model.corner_inertia)
        if self.features.mass_scaling:
            w(el.mass_factor, model.mass_factor)
            p = model.parameters
            later(st.target_dt)[None] = p.target_dt
            later(st.added_mass_cap)[None] = p.added_mass_cap
            if self.features.selective_mass:        # adds no mass (stages/selective_mass.py)
                later(st.sms_tolerance)[None] = p.sms_tolerance
                later(st.sms_max_iterations)[None] = p.sms_max_iterations
                arm, inverse_inertia, normal, radius_sq = added_mass_geometry(model.points, model.elements,
                                                                              model.corner_mass)
                w(el.sms_arm, arm)
                w(el.sms_inverse_inertia, inverse_inertia)
                w(el.sms_normal, normal)
                w(el.sms_radius_sq, radius_sq)
            else:
                later(st.added_mass)[None] = float(np.dot(model.mass_factor - 1.0, model.corner_mass.sum(axis=1)))
        if self.features.launch != "batched" or self.features.mass_update or self.features.triangle_ns:
            flat = model.elements.ravel()
            slots = np.argsort(np.where(flat >= 0, flat, n), kind="stable")[:int((flat >= 0).sum())]
            w(el.node_slots, slots.astype(np.int32))
            counts = np.bincount(flat[flat >= 0], minlength=n)
            w(el.node_slot_start, np.concatenate([[0], np.cumsum(counts)]).astype(np.int32))
        # rigid bodies and walls
        later(bd.count)[None], later(bd.wall_count)[None] = len(model.rigid_bodies), len(model.walls)
        start = 0
        for i, b in enumerate(model.rigid_bodies):
            later(bd.velocity)[i], later(bd.total_mass)[i], later(bd.added_mass)[i] = b.velocity0.tolist(), b.total_mass, b.added_mass
            later(bd.direction)[i] = b.direction if b.direction is not None else (0.0, 0.0, 0.0)
            later(bd.first_slave)[i], later(bd.slave_count)[i] = start, len(b.nodes)
            later(bd.center0)[i], later(bd.rotation)[i] = b.center.tolist(), (1.0, 0.0, 0.0, 0.0)
            later(bd.inertia)[i], later(bd.translation_free)[i] = b.inertia.tolist(), b.translation_free.tolist()
            later(bd.rotation_free)[i] = b.rotation_free.tolist()
            free = int(np.count_nonzero(np.diag(b.rotation_free)))
            later(bd.rotation_mode)[i] = ROTATION_FREE if free == 3 else ROTATION_CONSTRAINED if free else ROTATION_HELD
            later(bd.omega)[i], later(bd.angular_momentum)[i] = b.spin0.tolist(), (b.inertia @ b.spin0).tolist()
            later(bd.kinetic_rotation)[i] = 0.5 * float(b.spin0 @ b.inertia @ b.spin0)
            later(bd.stable_step)[i] = min(b.stable_step, 1e300)
            later(bd.inertia_min)[i] = b.inertia_min
            if len(model.loading.body_motion_mask):
                later(bd.motion_mask)[i], later(bd.motion)[i] = int(model.loading.body_motion_mask[i]), model.loading.body_motion[i].tolist()
            else:
                later(bd.motion_mask)[i], later(bd.motion)[i] = 0, [-1] * 6
            start += len(b.nodes)
        if model.rigid_bodies:
            w(bd.slave_nodes, np.concatenate([b.nodes for b in model.rigid_bodies]).astype(np.int32))
        for i, wall in enumerate(model.walls):
            later(bd.wall_point)[i], later(bd.wall_normal)[i], later(bd.wall_body)[i] = wall.point, wall.normal, wall.body
        if self.features.joints:
            self._load_joints(model.joints, n)
        self._load_loading(model.loading)
        self._load_tools(model.tools)
        # the step's run-time parameters
        p = model.parameters
        c_max = float(data.wave_speed.max())
        later(st.dt_safety)[None], later(st.flip_blend)[None] = p.dt_safety, p.flip_blend
        later(st.ns_blend)[None] = p.ns_blend
        later(st.length_ref)[None] = model.mean_edge
        later(st.mass_floor)[None] = 1e-12 * float(model.node_mass.mean())
        later(st.runaway_speed)[None] = 10.0 * c_max
        later(st.restart_factor)[None] = 1.0
        later(st.velocity_keep)[None] = 1.0
        later(st.time_limit)[None] = np.inf
        later(self.tools.slip_speed)[None] = 1e-6 * c_max if self.features.tools else 0.0
        if self.contact is not None:
            ct = self.contact
            w(ct.neighbor_start, model.neighbor_start)
            w(ct.neighbor_nodes, model.neighbor_nodes)
            w(ct.last_element, np.full(n, -1, np.int32))
            later(ct.rebuild)[None] = 1
            later(ct.thickness)[None], later(ct.stiffness)[None] = p.contact_thickness, p.contact_stiffness
            later(ct.step_thickness)[None] = p.contact_step_thickness
            if self.features.contact_pairs:
                laws = model.contact
                w(ct.node_role, laws.node_role)
                w(ct.segment_role, laws.segment_role)
                w(ct.law, laws.law)
                w(ct.law_interface, laws.law_interface)
                later(ct.interface_count)[None] = len(laws.names)
            later(ct.damping)[None], later(ct.friction)[None] = p.contact_damping, p.contact_friction
            later(ct.slip_speed)[None] = 1e-6 * c_max
            later(ct.hash_size)[None] = 1 << int(np.ceil(np.log2(2 * m)))
            later(ct.candidate_capacity)[None] = CANDIDATES_PER_NODE * n
        if self.grid is not None:
            gg, geo = self.grid, model.grid
            later(gg.h)[None], later(gg.inv_h)[None] = geo.h, 1.0 / geo.h
            later(gg.bound_lo)[None], later(gg.bound_hi)[None] = geo.bound_lo, geo.bound_hi
            later(gg.slab_axis)[None] = geo.slab_axis
            later(gg.planes)[None] = len(geo.planes)
            for i, (axis, index) in enumerate(geo.planes):
                later(gg.plane_axis)[i], later(gg.plane_index)[i] = axis, index
            later(gg.slot_capacity)[None] = self.grid_slots
            later(gg.table_bits)[None] = int(np.log2(gg.table_key.shape[0]))
            w(gg.node_base, np.full((n, 3), NO_CELL, np.int32))      # every node looks its slots up
            if self.features.multi_field:
                later(gg.field_radius_sq)[None] = (FIELD_RADIUS_CELLS * geo.h) ** 2
                later(gg.first_overflow_step)[None] = -1
                if self.features.grid_contact:
                    later(gg.field_gap)[None] = model.parameters.field_gap
                    later(gg.field_friction)[None] = model.parameters.field_friction
                part = np.full(n, np.iinfo(np.int32).max, np.int64)
                np.minimum.at(part, model.elements[model.elements >= 0],
                              np.repeat(model.element.part, 4)[model.elements.ravel() >= 0])
                w(nd.part, part.astype(np.int32))
            later(st.dilatational_speed)[None] = model.materials.dilatational_speed

    def _load_joints(self, jt, n: int) -> None:
        """The joints' tables and initial state (model/joints.py)."""
        g, w = self.joints, self._write_later
        later = self._later
        later(g.count)[None] = len(jt)
        for name in ("slave", "masters", "weights", "offset", "axis", "rotations", "element", "kind", "strength"):
            w(getattr(g, name), getattr(jt, name))
        w(g.active, np.ones(len(jt), np.int32))
        w(g.failure_time, np.full(len(jt), -1.0))
        node_joint = np.full(n, -1, np.int32)
        node_joint[jt.slave] = np.arange(len(jt), dtype=np.int32)
        w(g.node_joint, node_joint)

    def _load_tools(self, tt) -> None:
        """The tables of tools.ToolTable."""
        g, w = self.tools, self._write_later
        later = self._later
        later(g.count)[None] = len(tt.names) if tt is not None else 0
        if not self.features.tools:
            return
        for name in ("kind", "motion", "body", "curve", "origin", "size", "value", "coefficients", "frame"):
            w(getattr(g, name), getattr(tt, name))
        w(g.axes, tt.frame)
        later(g.reach)[None] = tt.reach
        w(g.centre, tt.origin)
        if "mesh" in self.features.tool_kinds:
            for name in ("tri_first", "bucket_first", "grid_lo", "grid_h", "grid_dims", "triangles", "tri_normal",
                         "bucket_start", "bucket_items"):
                w(getattr(g, name), getattr(tt, name))

    def _load_loading(self, ld) -> None:
        """The tables of loading.Loading (curves, load entries, pressure, gravity, motions)."""
        w, fx, L, nd = self._write_later, self.features, self.loads, self.nodes
        later = self._later
        if fx.loads:
            cv = ld.curves
            later(L.curve_count)[None] = len(cv.kind)
            for name, array in (("curve_kind", cv.kind), ("curve_first", cv.first), ("curve_rows", cv.count),
                                ("curve_parameter", cv.parameter), ("curve_origin", cv.origin),
                                ("curve_table", cv.rows)):
                w(getattr(L, name), array)
            w(nd.physical_mass, ld.physical_mass)
            w(nd.load_start, ld.entry_start)
            later(L.entry_count)[None] = len(ld.entry_curve)
            for name in ("entry_node", "entry_curve", "entry_neighbor", "entry_frame", "entry_force", "entry_moment",
                         "pressure_element",
                         "pressure_value", "pressure_curve", "pressure_nodes", "pressure_node_start",
                         "pressure_node_slots"):
                w(getattr(L, name), getattr(ld, name))
            later(L.pressure_count)[None], later(L.pressure_node_count)[None] = len(ld.pressure_element), len(ld.pressure_nodes)
            later(L.gravity)[None], later(L.gravity_curve)[None] = ld.gravity.tolist(), ld.gravity_curve
            w(nd.motion_mask, ld.motion_mask)
            w(nd.motion, ld.node_motion)
            later(L.motion_count)[None] = len(ld.motions)
            w(L.motion_kind, np.array([m.kind for m in ld.motions], np.int32))
            w(L.motion_curve, np.array([m.curve for m in ld.motions], np.int32))
            w(L.motion_value, np.array([m.value for m in ld.motions]))
            if self.features.motion_windows:
                w(L.motion_window, np.array([m.window for m in ld.motions], np.float64))

    # ------------------------------------------------------------ host access
    def groups(self) -> dict[str, Group]:
        return {name: g for name, g in (("nodes", self.nodes), ("elements", self.elements),
                                        ("sections", self.sections), ("points", self.points),
                                        ("step", self.step), ("bodies", self.bodies), ("loads", self.loads),
                                        ("tools", self.tools), ("joints", self.joints), ("contact", self.contact),
                                        ("grid", self.grid)) if g is not None}

    def layout(self) -> tuple:
        """What the kernels built on this state depend on besides the features: every field's
        place (group, name, type, shape) and the host's sizes, and the state's other
        attributes (a run of another model with an equal layout can reuse this state, its
        kernels included: program.py)."""
        fields = tuple((g._role, tuple(g._layout)) for g in self._groups)
        rest = tuple(sorted((k, repr(v)) for k, v in vars(self).items()
                            if not isinstance(v, Group)
                            and k not in ("_cache", "_snapshot_of", "_snapshot_plans", "_groups", "features")))
        return fields, rest

    def clear(self) -> None:
        """Every field back to zero, as Taichi allocated it (program.py: before the next
        run's load)."""
        self._cache = None
        placed = [f for g in self._groups for f in g._placed]
        for k in range(0, len(placed), BATCH_FIELDS):
            _zero_fields(tuple(placed[k:k + BATCH_FIELDS]))

    def read(self, field, size: int) -> np.ndarray:
        """The first `size` entries of `field` (all of a 0-d or fixed table) as a numpy array
        (within :meth:`reads_cached`: the one read there, read-only).  A field of SNAPSHOTS
        comes with the rest of its set, in one launch (:meth:`_read_snapshot`)."""
        member = self._snapshot_member(field)
        if member is not None and size <= member[1]:
            snapshot = None if self._cache is None else self._cache.get(member[0])
            if snapshot is None:
                snapshot = self._read_snapshot(member[0])
                if self._cache is not None:
                    self._cache[member[0]] = snapshot
            out = snapshot[id(field)][:size]
            return out if self._cache is not None else out.copy()
        if self._cache is None:
            return self._read(field, size)
        key = (id(field), size)
        out = self._cache.get(key)
        if out is None:
            out = self._cache[key] = self._read(field, size)
            out.flags.writeable = False
        return out

    def _snapshot_member(self, field) -> tuple[str, int] | None:
        """(its set in SNAPSHOTS, its host size) of `field`, or None."""
        if self._snapshot_of is None:
            groups = self.groups()
            self._snapshot_of = {id(entry[0]): (group, entry[1]) for group, names in SNAPSHOTS.items()
                                 if group in groups for name in names
                                 if (entry := groups[group]._entries.get(name)) is not None}
        return self._snapshot_of.get(id(field))

    def _read_snapshot(self, group: str) -> dict[int, np.ndarray]:
        """The fields of SNAPSHOTS[group] (their used entries), read-only, keyed by id(field):
        one kernel per dtype (:func:`_read_fields`; its plan made once)."""
        plan = self._snapshot_plans.get(group)
        if plan is None:
            entries = self.groups()[group]._entries
            fields = [(id(entries[name][0]), *entries[name][:2]) for name in SNAPSHOTS[group] if name in entries]
            plan = self._snapshot_plans[group] = self._batches(fields, lambda k, f, size: size)
        return self._read_batches(plan)

    @contextlib.contextmanager
    def reads_cached(self):
        """Each field read once within (a launch each, ~0.1-1 ms): for the host's work on one
        state between two batches of steps -- the checks, the record (probes, energies,
        frames), the progress line -- which read the same fields and write none.  Nested
        scopes share the outermost one's reads."""
        if self._cache is not None:
            yield
            return
        self._cache = {}
        try:
            yield
        finally:
            self._cache = None

    def derived(self, key: str, make):
        """make(), a value the host derives from this state's reads (the energies), made once
        within :meth:`reads_cached` (where the state does not change) and kept under `key`;
        outside, made anew."""
        if self._cache is None:
            return make()
        if ("derived", key) not in self._cache:
            self._cache[("derived", key)] = make()
        return self._cache[("derived", key)]

    @staticmethod
    def _read(field, size: int) -> np.ndarray:
        if len(field.shape) == 0:
            return np.array(field.to_numpy())
        out = np.zeros(_entry_shape(field, size), dtype=_numpy_dtype(field.dtype))
        if size > 0:
            _read_field(field, out.reshape(-1), size)
        return out

    @staticmethod
    def write(field, array, size: int | None = None) -> None:
        """Set the first len(array) entries of `field` (0-d: the value)."""
        array = np.asarray(array)
        if len(field.shape) == 0:
            field.from_numpy(array.astype(_numpy_dtype(field.dtype)))
            return
        n = len(array) if size is None else size
        if n > 0:
            _write_field(field, np.ascontiguousarray(array, dtype=_numpy_dtype(field.dtype)).reshape(-1), n)

    def arrays_index(self) -> set[str]:
        """The ``group.name`` of every field the host reads and writes."""
        return {f"{g}.{n}" for g, group in self.groups().items() for n in group._entries}

    def fetch(self, path: str) -> np.ndarray:
        """The used entries of the field ``group.name`` (e.g. "nodes.position")."""
        group, name = path.split(".")
        field, size, _ = self.groups()[group]._entries[name]
        return self.read(field, size) if size is not None else field.to_numpy()

    def put(self, path: str, array) -> None:
        """Set the field ``group.name`` from `array` (its used entries)."""
        group, name = path.split(".")
        self.write(self.groups()[group]._entries[name][0], array)

    def arrays(self, persistent_only: bool = True) -> dict[str, np.ndarray]:
        """Every field's used entries, keyed ``group.name`` (checkpoints): the fields of a
        dtype read by one kernel (:func:`_read_fields`), each the array State.read gives."""
        plan = self._batches(self._host_fields(persistent_only), lambda key, field, size: size)
        return {key: array.copy() for key, array in self._read_batches(plan).items()}

    def restore(self, arrays: dict[str, np.ndarray], persistent_only: bool = True) -> None:
        """Write back what :meth:`arrays` gave (each field's first len(array) entries), the
        fields of a dtype by one kernel (:func:`_write_fields`)."""
        fields = self._host_fields(persistent_only)
        plan = self._batches(fields, lambda key, field, size: len(arrays[key]) if len(field.shape) else None)
        self._write_batches(plan, arrays)

    def _host_fields(self, persistent_only: bool) -> list[tuple[str, object, int | None]]:
        return [(f"{gname}.{name}", field, size) for gname, g in self.groups().items()
                for name, (field, size) in g.fields(persistent_only).items()]

    @staticmethod
    def _read_batches(plan) -> dict:
        """The entries the batches of :meth:`_batches` name, one kernel per batch
        (:func:`_read_fields`): key -> a read-only view of its array."""
        out = {}
        for (dtype, _), (keys, fields, shapes, offsets, sizes, total) in plan.items():
            flat = np.zeros(total, dtype=dtype)
            _read_fields(fields, flat, offsets, sizes)
            flat.flags.writeable = False
            for key, shape, start in zip(keys, shapes, offsets):
                out[key] = flat[start:start + int(np.prod(shape, dtype=np.int64))].reshape(shape)
        return out

    @staticmethod
    def _write_batches(plan, arrays: dict) -> None:
        """arrays[key] (its first entries, as many as the plan names) into the batches' fields,
        one kernel per batch (:func:`_write_fields`)."""
        for (dtype, _), (keys, fields, shapes, offsets, sizes, total) in plan.items():
            flat = np.zeros(total, dtype=dtype)
            for key, shape, start in zip(keys, shapes, offsets):
                count = int(np.prod(shape, dtype=np.int64))
                flat[start:start + count] = np.asarray(arrays[key], dtype=dtype).reshape(-1)[:count]
            _write_fields(fields, flat, offsets, sizes)

    @staticmethod
    def _batches(fields, entries) -> dict:
        """Per numpy dtype, in batches of BATCH_FIELDS: the keys, the fields (a tuple: the
        kernels' template), their shapes, offsets into one flat array (int64), entry counts
        (int32; `entries(key, field, size)`, None for a 0-d field) and the flat length."""
        plan: dict = {}
        counts: dict = {}
        for key, field, size in fields:
            n = entries(key, field, size)
            if n is None:
                n = field.shape[0] if len(field.shape) else 0
            shape = _entry_shape(field, n)
            dtype = _numpy_dtype(field.dtype)
            counts[dtype] = counts.get(dtype, 0) + 1       # batches of BATCH_FIELDS fields: Taichi
            batch = (dtype, (counts[dtype] - 1) // BATCH_FIELDS)    # warns above 32 unrolled loops
            b = plan.setdefault(batch, ([], [], [], [], [], [0]))
            for column, value in zip(b, (key, field, shape, b[5][0], n)):
                column.append(value)
            b[5][0] += int(np.prod(shape, dtype=np.int64))
        return {batch: (keys, tuple(fields), shapes, np.array(offsets, dtype=np.int64),
                        np.array(sizes, dtype=np.int32), total[0])
                for batch, (keys, fields, shapes, offsets, sizes, total) in plan.items()}


class _Later:
    """`field[None] = value` (or `field[i] = value`) through State._write_later (State.load)."""
    __slots__ = ("state", "field")

    def __init__(self, state: "State", field):
        self.state, self.field = state, field

    def __setitem__(self, key, value) -> None:
        if key is None:
            assert len(self.field.shape) == 0
            self.state._write_later(self.field, value)
        else:               # an entry of a 1-d field: the entries set are written as one array
            self.state._pending_rows.setdefault(id(self.field), (self.field, {}))[1][int(key)] = value


def _numpy_dtype(dtype):
    return {ti.f64: np.float64, ti.f32: np.float32, ti.i32: np.int32, ti.i64: np.int64}[dtype]
