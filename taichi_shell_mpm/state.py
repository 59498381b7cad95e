"""The one owner of Taichi fields: shell nodes, elements (with through-thickness points),
the background grid and the scalar step state.  Allocated from an assembled
:class:`~taichi_shell_mpm.assembly.Model`; nothing else allocates fields.

Sign convention (method.md 0): ``force_int``/``moment_int`` are *resisting* nodal
forces; m a = f_ext - f_int through the grid.
"""
from __future__ import annotations

import numpy as np
import taichi as ti

from .assembly import Model

(STATUS_OK, STATUS_CONVERGED, STATUS_INVERTED, STATUS_LEFT_GRID, STATUS_NONFINITE, STATUS_DT_COLLAPSE,
 STATUS_CONTACT_FULL, STATUS_ENERGY, STATUS_RETURN_FAILED) = range(9)
CANDIDATES_PER_NODE = 64     # capacity of the contact candidate lists, on average per node


@ti.data_oriented
class State:
    """All fields of a run (SOA layout, except the grid: one node's data together).
    ``n_nodes``, ``n_elements``, ``n_points`` and the grid dimensions are fixed at
    construction; sizes are compile-time constants of the kernels.  ``launch`` (config.py)
    decides the scratch fields of the parallel launches, ``grid_force``
    (StepConfig.grid_force) whether the grid keeps its force apart from the momentum."""

    def __init__(self, model: Model, transfer: str, plastic: bool, contact: bool, launch: str = "batched",
                 grid_force: bool = True, drilling_spring: bool = False):
        n, m = len(model.points), len(model.quads)
        nk = len(model.zeta)
        self.n_nodes, self.n_elements, self.n_points = n, m, nk
        vec3, f64 = ti.types.vector(3, ti.f64), ti.f64
        # --- shell nodes (= particle-domain corners), method.md 1
        self.position = ti.Vector.field(3, f64, n)        # x_c
        self.position_ref = ti.Vector.field(3, f64, n)    # X_c
        self.velocity = ti.Vector.field(3, f64, n)        # carried v_c (FLIP memory / APIC velocity)
        self.grid_velocity = ti.Vector.field(3, f64, n)   # v~_c: the velocity that moved the node
        self.omega = ti.Vector.field(3, f64, n)           # nodal angular velocity
        self.rotation = ti.Vector.field(4, f64, n)        # accumulated orientation quaternion (output only)
        self.corner_mass = ti.field(f64, n)
        self.corner_inertia = ti.field(f64, n)
        self.force_int = ti.Vector.field(3, f64, n)       # resisting internal force
        self.moment_int = ti.Vector.field(3, f64, n)
        self.load_force = ti.Vector.field(3, f64, n)      # external force at load factor 1
        self.load_moment = ti.Vector.field(3, f64, n)
        self.fix_mask = ti.field(ti.i32, n)               # bits ux uy uz rx ry rz
        # sum_e A_e e3 and sum_e A_e: the nodal normal of the drilling projection (method.md
        # 2.3); nothing reads them with the drilling spring (stages/drilling.py)
        self.normal_sum = ti.Vector.field(3, f64, n) if not drilling_spring else None
        self.area_sum = ti.field(f64, n) if not drilling_spring else None
        self.node_body = ti.field(ti.i32, n)              # rigid body of the node, -1 = none
        self.affine = ti.Matrix.field(3, 3, f64, n) if transfer == "apic" else None   # C_c (method.md 2.2)
        # --- elements (= material points)
        self.corners = ti.Vector.field(4, ti.i32, m)
        self.stress = ti.Vector.field(5, f64, (m, nk))    # local (sxx, syy, sxy, txz, tyz) per point
        self.hourglass_resultant = ti.Vector.field(5, f64, m)   # Q = (QMx, QMy, QW, QBx, QBy), local
        self.plastic_strain = ti.field(f64, (m, nk)) if plastic else None   # equivalent plastic strain
        # corner moments M_a of the drilling spring about e3 (stages/shell.py), penalty drilling only
        self.drilling_moment = ti.Vector.field(4, f64, m) if drilling_spring else None
        # --- scalar step state
        self.dt = ti.field(f64, ())
        self.dt_next = ti.field(f64, ())
        self.dt_first = ti.field(f64, ())
        self.dt_stable = ti.field(f64, ())               # last stable dt before clipping to time_limit
        self.time = ti.field(f64, ())
        self.step = ti.field(ti.i64, ())
        self.load_factor = ti.field(f64, ())
        self.restart_factor = ti.field(f64, ())          # 0.5 on a central-difference restart from rest, else 1
        self.velocity_keep = ti.field(f64, ())           # 0 right after a kinetic-damping reset, else 1
        self.fire_mix = ti.field(f64, ())                # FIRE: v += fire_mix * F / m (a time)
        self.fire_alpha = ti.field(f64, ())              # FIRE: current mixing parameter alpha
        self.fire_uphill = ti.field(ti.i32, ())          # FIRE: steps since the power was last <= 0
        self.fire_power = ti.field(f64, ())              # FIRE scratch: P = F.v, |v|_M^2, |F|_M^-1^2
        self.fire_speed_sq = ti.field(f64, ())
        self.fire_force_sq = ti.field(f64, ())
        self.residual_target_sq = ti.field(f64, ())      # (tolerance * |F_ext|)^2 of the current load level
        self.time_limit = ti.field(f64, ())              # advance() stops here exactly (next output time)
        # --- energy bookkeeping (energy.py): per-entity accumulators (what is reported) and
        # the step's 0-d running totals (its in-kernel decisions)
        self.element_energy = ti.Vector.field(5, f64, m)  # internal, plastic work, hourglass, drilling; stagger (this step)
        self.node_energy = ti.Vector.field(3, f64, n)     # external work, contact, wall
        self.kinetic = ti.field(f64, ())                 # KE of this step (half-step velocities)
        self.kinetic_prev = ti.field(f64, ())
        self.kinetic_initial = ti.field(f64, ())         # KE_0 of the balance
        self.energy_limit = ti.field(f64, ())            # balance guard: stop above this x absorbed (0: off)
        self.internal_energy = ti.field(f64, ())
        self.hourglass_energy = ti.field(f64, ())
        self.drilling_energy = ti.field(f64, ())         # stored in the drilling springs (stages/drilling.py)
        self.plastic_work = ti.field(f64, ())            # plastic dissipation (part of internal_energy)
        self.external_work = ti.field(f64, ())
        self.damped_energy = ti.field(f64, ())
        self.stagger_energy = ti.field(f64, ())          # this step's stagger term (energy.py)
        self.contact_energy = ti.field(f64, ())          # work done against contact forces
        self.residual_sq = ti.field(f64, ())
        self.load_norm_sq = ti.field(f64, ())
        self.max_speed = ti.field(f64, ())
        self.reaction = ti.Vector.field(3, f64, ())      # force the supports (clamped nodes, fixed walls) exert on the shell
        self.reaction_impulse = ti.Vector.field(3, f64, ())   # its time integral since the start
        self.wall_energy = ti.field(f64, ())             # energy taken out by (inelastic) rigid walls
        self.status = ti.field(ti.i32, ())
        self.status_index = ti.field(ti.i32, ())
        # --- rigid bodies (method.md 2.5c): speed and displacement along their direction
        nb = max(1, len(model.rigid_bodies))
        self.body_velocity = ti.field(f64, nb)
        self.body_velocity_start = ti.field(f64, nb)      # V^(n-1/2) of the current step
        self.body_wall_energy = ti.field(f64, nb)         # work of the walls moving with the body, on it
        self.body_displacement = ti.field(f64, nb)
        self.body_force = ti.field(f64, nb)               # force on the body from its slave nodes
        self.body_impulse = ti.field(f64, nb)             # wall impulse on the body this step
        self.slave_nodes = ti.field(ti.i32, max(1, sum(len(b.nodes) for b in model.rigid_bodies)))
        if launch == "threads" and any(w.body >= 0 for w in model.walls):
            # each node's impulse on each wall-carrying body, summed in node order (stages/bodies.py)
            self.node_wall_impulse = ti.field(f64, (n, nb))
        # --- self-contact (method.md 7.3), only when the scene asks for it
        self.contact = contact
        if contact:
            self.force_contact = ti.Vector.field(3, f64, n)
            self.max_penetration = ti.field(f64, ())     # largest g / t_c seen
            self.contact_pairs = ti.field(ti.i32, ())
            # per-axis largest and smallest nodal velocity of the step: their spread bounds the
            # approach speed of any two nodes (the contact limit on dt, stages/timestep.py)
            self.velocity_high = ti.Vector.field(3, f64, ())
            self.velocity_low = ti.Vector.field(3, f64, ())
            # candidate (Verlet) lists, stages/contact.py: per node, the elements that can come
            # within t_c before any node moves skin/2 from where the lists were built
            self.contact_rebuild = ti.field(ti.i32, ())               # 1: rebuild at the next step
            self.contact_skin = ti.field(f64, ())                     # s (contact.skin_width); a field: one kernel for any s
            self.contact_build_position = ti.Vector.field(3, f64, n)  # x_c when the lists were built
            self.candidate_start = ti.field(ti.i32, n + 1)            # CSR into candidate_elements
            self.candidate_elements = ti.field(ti.i32, CANDIDATES_PER_NODE * n)
            # side memory (method.md 7.3): the element a node touched last step, and on which
            # side of its facet normal
            self.contact_last_element = ti.field(ti.i32, n)
            self.contact_last_side = ti.field(f64, n)
            # this step's pair of each node (element: contact_last_element): force on the
            # node and barycentric weights of the segment point, scattered after the search
            self.contact_pair_force = ti.Vector.field(3, f64, n)
            self.contact_pair_weight = ti.Vector.field(4, f64, n)
            # exclusion ring (method.md 7.3), CSR: the nodes sharing an element with node c
            self.neighbor_start = ti.field(ti.i32, n + 1)
            self.neighbor_nodes = ti.field(ti.i32, len(model.neighbor_nodes))
            # spatial hash of element centroids, scratch of a rebuild (checkpoint.TRANSIENT_FIELDS)
            table = 1 << int(np.ceil(np.log2(2 * m)))
            self.hash_cell = ti.field(f64, ())
            self.hash_count = ti.field(ti.i32, table)
            self.hash_start = ti.field(ti.i32, table + 1)
            self.hash_elements = ti.field(ti.i32, m)
            self.element_slot = ti.field(ti.i32, m)
            self.element_radius = ti.field(f64, m)
        # --- element loads gathered at the nodes (parallel launches, stages/accumulate.py):
        # each element writes its four corners' (force, moment[, A e3, A]) to its own slots;
        # the normal sums only for the drilling projection (no drilling spring)
        self.gather_loads = launch != "batched"
        if self.gather_loads:
            self.corner_loads = ti.Vector.field(6 if drilling_spring else 10, f64, (m, 4))
            self.node_slot_start = ti.field(ti.i32, n + 1)        # CSR node -> 4 e + a, e ascending
            self.node_slots = ti.field(ti.i32, 4 * m)
        # --- background grid (mpm only), flattened; only the nodes around shell nodes are
        # written, read and cleared
        self.grid = model.grid
        if model.grid is not None:
            g = model.grid.n_nodes
            self.grid_mass = ti.field(f64)
            self.grid_momentum = ti.Vector.field(3, f64)   # without grid_force: p + dt f (stages/grid.py)
            # array of structures: one grid node's data share a cache line (the grid is much
            # larger than the cache and is touched at scattered places)
            if grid_force:
                self.grid_force = ti.Vector.field(3, f64)
                ti.root.dense(ti.i, g).place(self.grid_mass, self.grid_momentum, self.grid_force)
            else:
                self.grid_force = None
                ti.root.dense(ti.i, g).place(self.grid_mass, self.grid_momentum)
            # P2G order (stages/mapping.py): the free nodes binned by the grid plane of their
            # stencil's base across the slab axis (counting sort, rebuilt every step)
            planes = model.grid.dims[model.grid.slab_axis] - 1
            self.node_cell = ti.field(ti.i32, n)          # flat index of the stencil base, -1: not on the grid
            self.slab_start = ti.field(ti.i32, planes + 1)
            self.slab_fill = ti.field(ti.i32, planes)
            self.slab_nodes = ti.field(ti.i32, n)
        self._load(model)

    def _load(self, model: Model) -> None:
        self.position.from_numpy(model.points)
        self.position_ref.from_numpy(model.points)
        self.velocity.from_numpy(model.velocity0)
        self.grid_velocity.from_numpy(model.velocity0)
        self.omega.from_numpy(model.omega0)
        q = np.zeros((self.n_nodes, 4))
        q[:, 0] = 1.0
        self.rotation.from_numpy(q)
        self.corner_mass.from_numpy(model.node_mass)
        self.corner_inertia.from_numpy(model.node_inertia)
        self.load_force.from_numpy(model.load_force)
        self.load_moment.from_numpy(model.load_moment)
        self.fix_mask.from_numpy(model.fix_mask)
        self.corners.from_numpy(model.quads.astype(np.int32))
        self.node_body.from_numpy(model.node_body)
        if model.rigid_bodies:
            self.body_velocity.from_numpy(np.array([b.velocity0 for b in model.rigid_bodies]))
            self.slave_nodes.from_numpy(np.concatenate([b.nodes for b in model.rigid_bodies]).astype(np.int32))
        if self.gather_loads:
            slots = np.argsort(model.quads.ravel(), kind="stable").astype(np.int32)
            self.node_slots.from_numpy(slots)
            counts = np.bincount(model.quads.ravel(), minlength=self.n_nodes)
            self.node_slot_start.from_numpy(np.concatenate([[0], np.cumsum(counts)]).astype(np.int32))
        if self.contact:
            self.neighbor_start.from_numpy(model.neighbor_start)
            self.neighbor_nodes.from_numpy(model.neighbor_nodes)
            self.contact_last_element.fill(-1)
            self.contact_rebuild[None] = 1
        self.restart_factor[None] = 1.0
        self.velocity_keep[None] = 1.0
        self.time_limit[None] = np.inf

    # ------------------------------------------------------------ snapshots for output/restart
    def node_arrays(self) -> dict[str, np.ndarray]:
        return {"position": self.position.to_numpy(), "position_ref": self.position_ref.to_numpy(),
                "velocity": self.grid_velocity.to_numpy(), "omega": self.omega.to_numpy(),
                "rotation": self.rotation.to_numpy()}
