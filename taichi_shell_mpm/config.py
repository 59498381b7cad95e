"""What the step compiles: the feature set of a scene (issue 17).

Every field of :class:`Features` is a Python constant baked into the kernels
(``ti.static``), so a scene without a feature never compiles its code; everything else --
every value (E, nu, thickness, hourglass and contact coefficients, dt safety, masses,
walls ...) and every size (nodes, elements, grid) -- is run-time data in the fields of
state.py.  Two scenes with the same Features load each other's kernels from Taichi's
offline cache.
"""
from __future__ import annotations

from dataclasses import dataclass

from .model.assembly import Model
from .scene import Scene
from .model.tools import TOOL_KINDS
from .runtime import serial_node_loops


@dataclass(frozen=True)
class Features:
    method: str                 # "mpm" | "fem"
    transfer: str               # "apic" | "polypic" | "pic" | "flip" (mpm)
    static: bool                # dynamic relaxation (method.md 6)
    fire: bool                  # static: FIRE velocity mixing instead of plain kinetic damping
    points: int                 # through-thickness points: the most of any section
    materials: tuple[str, ...]  # material models the scene uses (materials.KINDS order)
    hardening: tuple[str, ...]  # J2 hardening laws the scene uses (materials.HARDENING_LAWS order)
    rate_laws: tuple[str, ...]  # J2 strain-rate laws the scene uses (materials.RATE_LAWS order)
    rate_filter: bool           # some material filters its strain rate (state.points.strain_rate)
    layered: bool               # a layered section: each point reads its own material (docs/laminates.md)
    kirchhoff_w_hourglass: bool  # stages/hourglass.py: w-mode rate less the Kirchhoff field's
    drilling_spring: bool       # drilling spring (stages/drilling.py); else the projection (method.md 2.3)
    warping_correction: bool    # BWC curvature of warped quads (stages/warping.py, method.md 3.8)
    triangles: bool             # the mesh has triangles: the C0 triangle (stages/triangle.py)
    physical_rotary_inertia: bool   # the rotational limit in the element's step (stages/timestep.py)
    grid_rule: bool             # the paper's grid rule in dt (dt_rule = "both", mpm)
    grid_planes: bool           # symmetry planes on the grid (stages/grid.py)
    bodies: bool                # rigid bodies (stages/bodies.py)
    walls: bool                 # rigid walls
    moving_walls: bool          # a wall moving with a rigid body
    contact: bool               # penalty contact, [contact] or [[contact_pair]] (stages/contact.py)
    friction: bool              # contact friction
    erosion: bool = False       # some material's elements fail (issue 18; stages/masses.py)
    mass_scaling: bool = False  # mass scaling to [solve].target_dt, either kind: the density factors (stages/masses.py)
    selective_mass: bool = False  # ... selective: the added mass matrix and its solve (stages/selective_mass.py)
    reciprocal_mass: bool = False  # ... with sms_solve = "reciprocal": no solve, its inverse applied directly
    multi_field: bool = False   # a velocity field per shell layer at each grid node (stages/grid.py)
    grid_contact: bool = False  # the fields interact by the grid contact condition (stages/grid.py)
    launch: str = "batched"     # "batched" | "threads" | "gpu" (solvers/stepper.py)
    serial_node_loops: bool = False  # threads launch, small mesh: the light node loops on one thread
    #                             (runtime.serial_node_loops; stages/accumulate.serial_loop)
    loads: bool = False         # curve or follower loads, pressure, gravity, prescribed motion
    #                             (stages/loads.py, stages/motion.py): one switch [choice: a
    #                             configuration costs 25-60 s to compile, and a scene with any of
    #                             them pays next to nothing for the others' empty loops]
    body_rotation: bool = False  # a rigid body free to rotate (stages/bodies.py): the rotation
    #                             update and the slaves' placement x = x_c + R (X - X_c); a
    #                             translation-only ram compiles the translation alone
    tool_kinds: tuple[str, ...] = ()   # rigid tool kinds the scene uses (tools.TOOL_KINDS order; stages/tools.py)
    motion_windows: bool = False  # a [[motion]] with start/end: its DOFs held only in its window
    #                             (stages/motion.PrescribedMotion.mask); else every step
    contact_pairs: bool = False  # [[contact_pair]] interfaces: the role masks and per-direction laws
    #                             (model/contact_pairs.py); without, the single-surface law's scalars
    pair_thickness: bool = False  # contact pairs touch at different thicknesses (several sections without
    #                             [contact].thickness, or interfaces): stages/contact.law_of; else at t_c
    joints: bool = False        # [[tie]] or [[spotweld]] (stages/joints.py)
    triangle_opt: bool = False  # the triangles' membrane is OPT ([element].triangle = "opt";
    #                             stages/opt_membrane.py); else the constant-strain one
    triangle_ns: bool = False   # the triangles' membrane strain is smoothed over each node's triangles
    #                             ([element].triangle = "ns"; stages/ns_membrane.py)
    finite_increment: bool = False  # the step is one large increment (Newton's trial,
    #                             solvers/tangent.py): mid-step shape from the end shapes
    #                             (stages/shell.mid_geometry)

    @property
    def mass_update(self) -> bool:
        """The nodal masses change during the run (erosion, mass scaling): stages/masses.py."""
        return self.erosion or self.mass_scaling

    @property
    def serial(self) -> bool:
        """One serial kernel for many steps: every scatter is a plain add."""
        return self.launch == "batched"

    @property
    def atomic_scatter(self) -> bool:
        """GPU: scatters to nodes and grid are atomic adds.  On the CPU they are arranged so
        that no two threads write the same place (element loads gathered at the nodes, P2G
        in grid slabs of alternating parity), because an f64 atomic add costs ~13 ns there
        against ~1 ns for a plain one (measured: 36 000 scattered vector adds)."""
        return self.launch == "gpu"

    @property
    def grid_force(self) -> bool:
        """Whether the grid keeps the nodal force apart from the momentum (stages/grid.py):
        FLIP needs v- and v+ separately, statics the grid residual; APIC and PIC dynamics
        scatter p + dt f in one field."""
        return self.transfer == "flip" or self.static

    @property
    def affine_transfer(self) -> bool:
        """The nodes carry an affine velocity C_c to the grid (APIC, and PolyPIC's first modes;
        stages/mapping.py)."""
        return self.method == "mpm" and self.transfer in ("apic", "polypic")

    @property
    def velocity_modes(self) -> bool:
        """The nodes also carry the bilinear and trilinear velocity modes of their cell
        (PolyPIC, stages/mapping.py)."""
        return self.method == "mpm" and self.transfer == "polypic"

    @property
    def tools(self) -> bool:
        """Rigid tools (stages/tools.py)."""
        return bool(self.tool_kinds)

    @property
    def nodal_normals(self) -> bool:
        """Whether the shell stage gathers the nodal normals (sum A e3, sum A): the drilling
        projection and the multi-field grid's layer test use them."""
        return not self.drilling_spring or self.multi_field

    @property
    def plastic(self) -> bool:
        from .model.materials import PLASTIC
        return any(PLASTIC[k] for k in self.materials)

    @property
    def oriented(self) -> bool:
        """A material with axes (orthotropic): the points read the element's material axis and
        their ply angle."""
        from .model.materials import ORIENTED
        return any(ORIENTED[k] for k in self.materials)

    @staticmethod
    def from_scene(scene: Scene, model: Model, launch: str = "batched") -> "Features":
        el = scene.element
        return Features(
            method=scene.method.kind, transfer=scene.method.transfer, static=scene.solve.kind == "static",
            fire=scene.solve.kind == "static" and scene.solve.relaxation == "fire",
            points=model.sections.points, materials=model.materials.kinds,
            hardening=model.materials.hardening, rate_laws=model.materials.rate_laws,
            rate_filter=model.materials.rate_filter,
            layered=bool(model.sections.layered.any()),
            kirchhoff_w_hourglass=el.w_hourglass == "kirchhoff", drilling_spring=el.drilling == "penalty",
            warping_correction=el.warping == "bwc",
            triangles=bool((model.elements[:, 3] < 0).any()),
            triangle_opt=el.triangle == "opt" and bool((model.elements[:, 3] < 0).any()),
            triangle_ns=el.triangle == "ns" and bool((model.elements[:, 3] < 0).any()),
            physical_rotary_inertia=scene.solve.physical_rotary_inertia,
            grid_rule=scene.solve.dt_rule == "both" and scene.method.kind == "mpm",
            grid_planes=model.grid is not None and bool(model.grid.planes),
            bodies=bool(model.rigid_bodies), walls=bool(model.walls),
            moving_walls=any(w.body >= 0 for w in model.walls),
            contact=model.contact is not None,
            friction=model.contact is not None and model.contact.friction,
            contact_pairs=model.contact is not None and model.contact.pairs,
            pair_thickness=model.contact is not None and (model.contact.pairs or model.contact.thickness_min
                                                          != model.contact.thickness_max),
            tool_kinds=tuple(k for k in TOOL_KINDS if model.tools is not None and k in model.tools.kinds),
            erosion=model.materials.erosion,
            mass_scaling=scene.solve.kind == "dynamic" and scene.solve.mass_scaling in ("selective", "conventional"),
            selective_mass=scene.solve.kind == "dynamic" and scene.solve.mass_scaling == "selective",
            reciprocal_mass=(scene.solve.kind == "dynamic" and scene.solve.mass_scaling == "selective"
                             and scene.solve.sms_solve == "reciprocal"),
            multi_field=model.grid is not None and scene.method.fields == "multi",
            grid_contact=(model.grid is not None and scene.method.fields == "multi"
                          and scene.method.field_contact == "grid"),
            launch=launch, serial_node_loops=serial_node_loops(launch, len(model.points)),
            loads=model.loading.loads or (model.tools is not None and model.tools.prescribed),
            body_rotation=any(b.rotates for b in model.rigid_bodies),
            motion_windows=model.loading is not None and any(m.window != (0.0, float("inf"))
                                                             for m in model.loading.motions),
            joints=model.joints is not None)
