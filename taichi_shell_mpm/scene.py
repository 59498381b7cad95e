"""Scene files: TOML (+ ``--set`` overrides) parsed once into frozen, validated dataclasses.

The dataclasses below are the single source of truth for every key and its default;
``docs/scenes.md`` documents them key by key.  Everything downstream (mesh, nodesets,
state, solvers, output) reads only these objects, never the raw TOML.

Errors in a scene are collected (all of them, not just the first) and raised as one
:class:`SceneError`, whose ``messages`` are single lines of the form
``scene.toml: [[boundary]][2].fix: expected ... , got ...``.
"""
from __future__ import annotations

import copy
import csv
import difflib
import json
import math
import re
import tomllib
from collections.abc import Callable, Iterable, Sequence
from dataclasses import MISSING, dataclass, field, fields
from pathlib import Path
from typing import Any, Literal, Union

import numpy as np

Vec3 = tuple[float, float, float]
DOFS = ("ux", "uy", "uz", "rx", "ry", "rz")
MAX_CURVES = 64          # [curves.NAME] tables of a scene (state.loads tables)
MAX_MOTIONS = 64         # [[motion]] entries of a scene
MAX_BODIES = 16          # [[rigid_body]] entries of a scene (state.bodies tables)


class SceneError(Exception):
    """A user mistake in a scene file or a mesh (one line per problem)."""

    def __init__(self, messages: list[str] | str, mesh: "MeshSpec | None" = None):
        self.messages = [messages] if isinstance(messages, str) else list(messages)
        self.mesh = mesh
        """The scene's valid [mesh] table when other tables had problems (so that the mesh can
        be checked as well and every problem reported at once), else None."""
        super().__init__("\n".join(self.messages))


# ---------------------------------------------------------------- [scene]
@dataclass(frozen=True)
class SceneInfo:
    name: str
    """Name used for the output directory and summary."""
    units: str
    """Free text stating the consistent unit system (required, e.g. 'kN-mm-ms-kg')."""
    description: str = ""


# ---------------------------------------------------------------- [mesh]
MAX_GENERATED_ELEMENTS = 10_000_000     # a generated mesh larger than this is a typo, not a model
GENERATED_COUNT_KEYS = {"plate": ("nx", "ny"), "hemisphere": ("n_around", "n_meridian"),
                        "tube": ("n_flat", "n_corner", "n_length")}


def _generated_elements(kind: str, v: dict) -> int | None:
    """Element count of a generator's table once its count keys are valid, else None."""
    keys = GENERATED_COUNT_KEYS.get(kind)
    if keys is None or not all(isinstance(v.get(k), int) for k in keys):
        return None
    if kind == "tube":
        return 4 * (v["n_flat"] + v["n_corner"]) * v["n_length"]
    count = 1
    for k in keys:
        count *= v[k]
    return count


TriangleSplit = Union[Literal["none", "all"], tuple[Vec3, Vec3]]
"""`triangles` of a generated mesh: "none", "all", or a box (min, max) of quad centroids:
the quads it selects are cut into two triangles each (mesh.split_quads)."""


@dataclass(frozen=True)
class PlateMesh:
    """Flat rectangle in the x-y plane, nx x ny quads, normals +z."""
    lx: float
    ly: float
    nx: int
    ny: int
    origin: Vec3 = (0.0, 0.0, 0.0)
    triangles: TriangleSplit = "none"
    kind: Literal["plate"] = "plate"


@dataclass(frozen=True)
class HemisphereMesh:
    """Hemisphere of mid-surface radius `radius` about +z, open within `hole_deg` of the pole.

    Latitude phi in [0, 90-hole_deg] deg (n_meridian uniform rows), longitude theta in
    [0, 360) (full, n_around elements) or [0, 90] (quarter, n_around elements on the
    quarter).  Normals point outward.
    """
    radius: float
    hole_deg: float
    n_around: int
    n_meridian: int
    quarter: bool = True
    triangles: TriangleSplit = "none"
    kind: Literal["hemisphere"] = "hemisphere"


@dataclass(frozen=True)
class TubeMesh:
    """Rectangular tube along +z from z=0 to `length`, section width x depth (mid-surface),
    corner fillets of radius `corner_radius`, n_flat elements per flat side, n_corner per
    fillet, n_length along z. Normals point outward."""
    width: float
    depth: float
    corner_radius: float
    length: float
    n_flat: int
    n_corner: int
    n_length: int
    trigger_amplitude: float = 0.0
    """Geometric trigger (benchmarks.md 3.1): normal offset a0 sin(pi (z - z0)/L) sin(pi s/b) on
    each flat side for z in [z0, z0 + L], inward on the two x-faces and outward on the two
    y-faces; corners untouched. 0 = no trigger."""
    trigger_start: float = 5.0
    trigger_length: float = 15.0
    triangles: TriangleSplit = "none"
    kind: Literal["tube"] = "tube"


@dataclass(frozen=True)
class FileMesh:
    """Any quad surface mesh meshio reads (.msh, .vtk, .vtu, .inp, ...)."""
    path: Path
    scale: float = 1.0
    merge_nodes: bool = False
    """Join coincident nodes into one (mesh.merge_coincident); by default they stay distinct
    (a slit, a crack or a seam that must stay open), with a warning."""
    kind: Literal["file"] = "file"


MeshSpec = Union[PlateMesh, HemisphereMesh, TubeMesh, FileMesh]


# ---------------------------------------------------------------- physics
@dataclass(frozen=True)
class Material:
    E: float
    nu: float
    density: float
    model: Literal["elastic", "j2"] = "elastic"
    """elastic: linear, corotational; j2: von Mises plane-stress plasticity (method.md 3.4)."""
    yield_stress: float = 0.0
    """Initial yield stress sigma_y0 (linear, ludwik: A, voce: sigma_0; required for these laws)."""
    hardening: float = 0.0
    """Linear isotropic hardening modulus H (linear; the linear term of swift, ludwik, voce; 0 = none)."""
    hardening_law: Literal["linear", "swift", "ludwik", "voce", "tabulated"] = "linear"
    """sigma_y(ebar): linear sigma_y0 + H ebar; swift K (eps0 + ebar)^n + H ebar (eps0 given, or
    (sigma_y0 / K)^(1/n) from yield_stress); ludwik sigma_y0 + B ebar^n + H ebar (capped at
    max_stress); voce sigma_y0 + Q (1 - exp(-b ebar)) + H ebar; tabulated: `curve`."""
    K: float = 0.0
    eps0: float = 0.0
    n: float = 0.0
    B: float = 0.0
    max_stress: float | None = None
    Q: float = 0.0
    b: float = 0.0
    curve: tuple[tuple[float, float], ...] = ()
    """tabulated: (ebar, sigma_y) points, ebar from 0 strictly increasing, sigma_y non-decreasing
    (from `curve` or the CSV file `curve_file`); linear between points."""
    curve_file: Path | None = None
    beyond_curve: Literal["flat", "extrapolate"] = "flat"
    """Beyond the last point: its stress, or the last segment's line."""
    rate_law: Literal["none", "cowper_symonds", "johnson_cook"] = "none"
    """Flow stress factor R(rate): cowper_symonds 1 + (rate/C)^(1/p); johnson_cook
    1 + c ln(rate/reference_rate), not below 1."""
    C: float = 0.0
    p: float = 0.0
    c: float = 0.0
    reference_rate: float = 0.0
    rate_measure: Literal["total", "plastic"] = "total"
    """The rate: the effective total strain rate (LS-DYNA VP = 0) or the equivalent plastic
    strain rate (VP = 1; solved in the return map)."""
    rate_filter_time: float = 0.0
    """Time constant of the exponential filter of the rate (0 = unfiltered)."""
    rate_cutoff_frequency: float = 0.0
    """The filter as a cutoff frequency f_c: time constant 1 / (2 pi f_c)."""
    failure_strain: float = 0.0
    """Erosion (issue 18): an element fails once failure_points of its through-thickness points
    reach this equivalent plastic strain (LS-DYNA FAIL; 0 = never)."""
    failure_points: int = 1
    """How many points must reach failure_strain (LS-DYNA NUMFIP > 0)."""
    failure_min_dt: float = 0.0
    """An element also fails once its stable step falls below this (LS-DYNA TDEL; 0 = never)."""


@dataclass(frozen=True)
class OrthotropicMaterial:
    """Linear elastic, orthotropic in plane stress with its own transverse shear moduli
    (docs/laminates.md): 1 = the fibre direction, 2 = across it in the shell's plane,
    3 = the shell normal.  Its axes are the section's material axes turned by the ply angle."""
    E1: float
    E2: float
    G12: float
    G13: float
    G23: float
    nu12: float
    """Major Poisson ratio (strain in 2 from stress in 1); nu21 = nu12 E2 / E1."""
    density: float
    model: Literal["orthotropic"] = "orthotropic"


AnyMaterial = Union[Material, OrthotropicMaterial]


@dataclass(frozen=True)
class Ply:
    """One layer of a layered section (docs/laminates.md)."""
    material: str
    """A [materials.NAME]."""
    thickness: float
    angle: float = 0.0
    """Degrees from the section's material axis to the ply's 1-axis, counter-clockwise about
    the element normal e3."""


@dataclass(frozen=True)
class Section:
    thickness: float
    """Shell thickness; of a layered section the sum of its plies' thicknesses."""
    points: int = 3
    """Number of through-thickness integration points (layered: plies x points_per_ply)."""
    rule: Literal["lobatto", "gauss"] = "lobatto"
    shear_factor: float = 5.0 / 6.0
    hourglass: float | None = None
    """Hourglass coefficient r of this section's elements (None: [element].hourglass)."""
    drilling_stiffness: float | None = None
    """Drilling-spring alpha of this section's elements (None: [element].drilling_stiffness)."""
    plies: tuple[Ply, ...] = ()
    """Layered section: the plies from the bottom (-e3) to the top (+e3) surface, each with its
    own material; empty: one material over the thickness (the part's)."""
    points_per_ply: int = 2
    """Layered: Gauss points through each ply (2 integrate a linear elastic ply exactly)."""
    reference_direction: Vec3 | None = None
    """The material axis (ply angle 0): this vector projected onto each element in the
    reference configuration; None: the element's edge 1-2 (LS-DYNA's AOPT = 0)."""

    @property
    def layered(self) -> bool:
        return bool(self.plies)


@dataclass(frozen=True)
class ElementSet:
    """A selection of elements. Exactly one selector kind."""
    name: str
    kind: Literal["all", "box", "ids", "mesh"]
    box_min: Vec3 | None = None
    box_max: Vec3 | None = None
    """box: the elements whose centroid (reference configuration) lies inside."""
    ids: tuple[int, ...] = ()
    mesh_set: str | None = None
    """mesh: a set of the mesh file (a Gmsh physical group, an ELSET, an LS-DYNA part ...)."""


@dataclass(frozen=True)
class Part:
    """A group of elements with one section and, unless the section is layered (its plies
    name their materials), one material."""
    name: str
    section: str
    material: str | None = None
    elements: str = "all"
    """An [elementsets.NAME], a set of the mesh file (its name), or "all"."""


@dataclass(frozen=True)
class ElementOptions:
    hourglass: float = 0.05
    """BT hourglass coefficient r (r_m = r_w = r_theta), method.md section 4."""
    w_hourglass: Literal["bt", "kirchhoff"] = "kirchhoff"
    """Rate of the transverse (w) hourglass mode: "bt" = sum gamma_a w_a (paper eq 30-36),
    which also resists the bilinear part of a Kirchhoff twist or bending field on a
    non-rectangular quad; "kirchhoff" subtracts the rate that the element's own curvature
    rate implies (stages/hourglass.py)."""
    drilling: Literal["projection", "penalty"] = "penalty"
    """Rotation about the shell normal: "projection" removes it at every node (method.md 2.3,
    the paper's; bends a curved mesh under rigid rotation); "penalty" keeps it as a degree
    of freedom tied to each element's in-plane spin by a drilling spring (stages/drilling.py)."""
    drilling_stiffness: float = 0.1
    """alpha of the drilling spring k = alpha D A beta / 4: 1 = the bending stiffness one
    corner rotation meets (stages/drilling.py)."""
    warping: Literal["none", "bwc"] = "none"
    """Warped quads: "none" = the flat-facet BT element (the paper's); "bwc" adds the
    Belytschko-Wong-Chiang (1992) coupling of in-plane motion to the curvature rate
    (stages/warping.py, method.md 3.8)."""


@dataclass(frozen=True)
class Method:
    kind: Literal["mpm", "fem"] = "mpm"
    cell_size: float | None = None
    """Grid cell size h; None = half the shortest element edge (method.md 2.2)."""
    grid_min: Vec3 | None = None
    grid_max: Vec3 | None = None
    """Optional grid box: a node leaving it stops the run; None = unbounded (the grid follows
    the shell, stages/grid.py)."""
    transfer: Literal["apic", "polypic", "pic", "flip"] = "apic"
    flip_blend: float = 0.99
    fields: Literal["single", "multi"] = "single"
    """Velocity fields per grid node (stages/grid.py): ``multi`` keeps a field per shell layer
    at each grid node, ``single`` one velocity."""
    field_contact: Literal["penalty", "grid"] = "penalty"
    """How the fields of a multi-field grid interact (stages/grid.py): ``penalty`` only through
    [contact]; ``grid`` also through the grid contact condition (Bardenhagen et al. 2001)."""
    field_friction: float = 0.0
    """Coulomb coefficient of the grid contact condition."""


# ---------------------------------------------------------------- node sets, BCs, loads
@dataclass(frozen=True)
class NodeSet:
    """A geometric selection of shell nodes. Exactly one selector kind."""
    name: str
    kind: Literal["all", "box", "plane", "nearest", "ids"]
    box_min: Vec3 | None = None
    box_max: Vec3 | None = None
    point: Vec3 | None = None
    """plane: a point on it; nearest: the target point."""
    normal: Vec3 | None = None
    tol: float = 1e-6
    ids: tuple[int, ...] = ()


@dataclass(frozen=True)
class Boundary:
    nodes: str
    fix: tuple[str, ...] = ()
    """Subset of DOFS fixed to zero displacement/rotation."""
    symmetry: Literal["x", "y", "z"] | None = None
    """Symmetry plane normal to this axis through the nodes: fixes u_n and the two
    in-plane rotations; the plane must be a grid plane in mpm mode."""


@dataclass(frozen=True)
class Load:
    nodes: str
    force: Vec3 = (0.0, 0.0, 0.0)
    """Total force, spread over the set (scaled by the load factor, or by `curve`)."""
    moment: Vec3 = (0.0, 0.0, 0.0)
    distribute: Literal["area", "equal", "length"] = "area"
    """Shares of the set's nodes: tributary shell area, equal, or tributary length along the
    element edges joining two nodes of the set (a consistent line load)."""
    force_per_length: Vec3 = (0.0, 0.0, 0.0)
    """A line load: force per unit length along the element edges joining two nodes of the set
    (each node gets it times half the length of its edges: the consistent nodal loads)."""
    moment_per_length: Vec3 = (0.0, 0.0, 0.0)
    curve: str | None = None
    """A [curves.NAME] the load follows (of time in a dynamic run, of the load factor in a
    static one); None: the load factor (1 in a dynamic run)."""
    follower: bool = False
    """Force and moment turn with their node (its orientation quaternion)."""


# ---------------------------------------------------------------- curves, motion, pressure, gravity
CURVE_SHAPES = ("constant", "ramp", "smooth_step")


@dataclass(frozen=True)
class Curve:
    """A time function f (curves.py): of the time in a dynamic run, of the load factor in a
    static one."""
    name: str
    kind: Literal["points", "constant", "ramp", "smooth_step"]
    points: tuple[tuple[float, float], ...] = ()
    """points (also read from `file`): (t, f), t strictly increasing; linear between them, flat
    beyond the ends."""
    file: Path | None = None
    start: float = 0.0
    end: float = 1.0
    """ramp: 0 up to start, linear to 1 at end, then 1; smooth_step: the same with the quintic
    10 s^3 - 15 s^4 + 6 s^5 (zero slope and curvature at both ends)."""
    scale: float = 1.0
    """Every value times this."""


MOTION_KINDS = ("displacement", "velocity", "acceleration")


@dataclass(frozen=True)
class Motion:
    """Prescribed motion of DOFs of a node set (stages/motion.py) or of a rigid body
    (stages/bodies.py): u, v or a = value x f."""
    name: str
    dofs: tuple[str, ...]
    kind: Literal["displacement", "velocity", "acceleration"]
    value: tuple[float, ...]
    """One per DOF (a single number in the scene applies to every DOF)."""
    curve: str | None = None
    """None: the load factor (1 in a dynamic run; lambda in a static one)."""
    nodes: str | None = None
    body: str | None = None
    """The [[rigid_body]] moved (instead of `nodes`)."""


@dataclass(frozen=True)
class Pressure:
    """Follower pressure on elements: force p A n on each element along its current normal
    (the corner order's), shared by its corners (stages/loads.py)."""
    value: float
    elements: str = "all"
    curve: str | None = None


@dataclass(frozen=True)
class Gravity:
    """Body force m g on every node (its physical mass)."""
    acceleration: Vec3
    curve: str | None = None


@dataclass(frozen=True)
class InitialVelocity:
    nodes: str = "all"
    velocity: Vec3 = (0.0, 0.0, 0.0)
    angular_velocity: Vec3 = (0.0, 0.0, 0.0)
    center: Vec3 = (0.0, 0.0, 0.0)
    """v = velocity + angular_velocity x (x - center); nodal omega = angular_velocity."""


@dataclass(frozen=True)
class Probe:
    name: str
    nodes: str
    components: tuple[str, ...] = DOFS
    """Recorded components, averaged over the set's nodes."""


@dataclass(frozen=True)
class ReferenceColumn:
    column: str
    probe: str
    """'<probe>.<component>' whose value, times `scale`, is compared with `column`."""
    scale: float = 1.0


@dataclass(frozen=True)
class Reference:
    file: Path
    load_column: str
    compare: tuple[ReferenceColumn, ...]
    floor: float = 0.1
    """Relative-error floor: e_i = |sim-ref| / max(|ref_i|, floor*max|ref|)."""
    along: Literal["load", "path"] = "load"
    """"load": rows matched by load level; "path": each row (compared value, load) against the
    simulated path, as a distance in the plane scaled by the table's largest values
    (reference.py; a path with limit points, issue 19)."""


@dataclass(frozen=True)
class RigidBody:
    """Nodes moving as one rigid body (stages/bodies.py): six DOFs, or translating along
    `direction` only (the tube's 500 kg ram, method.md 2.5c), carrying an added `mass` and
    `inertia` (about the centre, global axes at t = 0: 3 diagonal entries or xx yy zz xy yz zx)."""
    name: str
    nodes: str
    mass: float = 0.0
    direction: Vec3 | None = None
    inertia: tuple[float, ...] = ()
    center: Vec3 | None = None
    mass_from_nodes: bool = True
    velocity: Vec3 | None = None
    spin: Vec3 | None = None
    fixed: tuple[str, ...] = ()


@dataclass(frozen=True)
class PointMass:
    """Mass (and rotary inertia) added to each node of a set, constraining nothing."""
    name: str
    nodes: str
    mass: float | None = None
    total_mass: float | None = None
    inertia: float = 0.0


@dataclass(frozen=True)
class Wall:
    """Rigid planar wall the shell mid-surface cannot approach closer than half the thickness
    from the side `normal` points to (node-level, frictionless, method.md 7.5)."""
    point: Vec3
    normal: Vec3
    moves_with: str | None = None
    """Name of a [[rigid_body]] the wall translates with (None = fixed)."""


TOOL_KINDS = ("plane", "rectangle", "cylinder", "sphere", "mesh")     # tools.TOOL_KINDS


@dataclass(frozen=True)
class Tool:
    """A rigid tool (stages/tools.py, docs/scenes.md [[tool]]): penalty contact with the
    shell's mid-surface at half its thickness, Coulomb friction; fixed, moving with a rigid
    body, or moved by a velocity or displacement (times a curve)."""
    name: str
    kind: Literal["plane", "rectangle", "cylinder", "sphere", "mesh"]
    center: Vec3 = (0.0, 0.0, 0.0)
    normal: Vec3 | None = None
    """plane, rectangle: the side the shell stays on."""
    axis: Vec3 | None = None
    """cylinder: its axis; rectangle: the direction of its first side (size[0])."""
    radius: float | None = None
    length: float | None = None
    size: tuple[float, float] | None = None
    file: Path | None = None
    scale: float = 1.0
    stiffness: float = 0.1
    damping: float = 0.1
    friction: float = 0.0
    moves_with: str | None = None
    velocity: Vec3 | None = None
    displacement: Vec3 | None = None
    curve: str | None = None


def penalty_damping_limit(stiffness: float) -> float:
    """The largest damping fraction the penalty law (stages/contact.py, stages/tools.py) takes
    at `stiffness` alpha: alpha + 2 zeta sqrt(alpha) <= 2 [issue 28 item 4; docs/contact.md,
    "Penalty parameters"].  The damper acts on the lagged velocity v^(n-1/2): a node that
    arrives at the speed v and is found v dt deep gets the impulse (alpha + 2 zeta sqrt(alpha))
    m v in one step, which sends it back faster than it came once it exceeds 2 m v (at alpha =
    zeta = 1: 2 v, booked as negative contact energy).  The 1-DOF model over every arrival
    phase puts the bound there for every alpha in (0, 1] (no damping is refused below
    alpha = 0.536)."""
    return (2.0 - stiffness) / (2.0 * math.sqrt(stiffness))


@dataclass(frozen=True)
class Contact:
    """Penalty node-to-segment self-contact (method.md 7.3); present table = enabled."""
    thickness: float | None = None
    """Contact thickness t_c; None = the section thickness."""
    stiffness: float = 0.1
    """alpha_c in k = alpha_c m* / dt^2."""
    friction: float = 0.0
    damping: float = 0.1
    """Fraction of critical damping of the contact spring."""


@dataclass(frozen=True)
class Crush:
    """Crush post-processing of a dynamic run (crush.py, docs/crush.md); present table = on.
    The crush distance is the displacement of `body` along `axis`; the crush force is the
    support reaction (clamped nodes and fixed walls) against `axis`; its mean over the
    crush-distance `window` is the work of the support impulse over that distance."""
    axis: Vec3
    """Direction in which the crushing body moves (e.g. [0, 0, -1])."""
    window: tuple[float, float]
    """Crush distances [from, to] of the mean force (the tube: [20, 200] mm, first peak left out)."""
    body: str | None = None
    """Name of the [[rigid_body]] whose motion is the crush (None = the first one)."""
    folds: bool = False
    """Count lobes and the fold half-wavelength on the flat faces of a prismatic tube along `axis`."""
    mean_force_reference: tuple[float | str, ...] = ()
    """Reference mean forces: numbers, or the names of closed-form estimates for a tube mesh
    (CRUSH_FORMULAS, evaluated with the run's yield stress, thickness and tube size); the
    summary gives the ratio to each."""
    half_wavelength_reference: float | None = None
    """Reference fold half-wavelength (e.g. Wierzbicki-Abramowicz); the summary gives the ratio."""


# ---------------------------------------------------------------- solve / output
@dataclass(frozen=True)
class Solve:
    kind: Literal["static", "dynamic"]
    load_steps: int = 20
    tolerance: float = 1e-4
    max_steps_per_load_step: int = 500_000
    end_time: float = 0.0
    dt_safety: float = 0.9
    dt_rule: Literal["both", "shell"] = "both"
    rotary_inertia: Literal["scaled", "physical"] = "scaled"
    relaxation: Literal["fire", "kinetic"] = "fire"
    """Static solves: dynamic relaxation by FIRE (velocity mixing towards the force) or plain
    kinetic damping (method.md 6.2)."""
    mass_scaling: Literal["auto", "uniform_dt", "selective", "conventional", "none"] = "auto"
    """Static solves: fictitious densities that give every element the same stable step
    (``uniform_dt``, the default of ``auto`` in statics); ``none`` (and ``auto`` in dynamics)
    keeps the physical masses.  The equilibrium does not depend on the masses.  Dynamic
    solves: ``selective`` adds to each element whose stable step is below target_dt a mass
    matrix that is zero on rigid translations (Olovsson et al. 2005; fem mode;
    stages/selective_mass.py); ``conventional`` raises those elements' densities
    (LS-DYNA DT2MS < 0; what ``selective`` meant before issue 29)."""
    target_dt: float | Literal["auto"] = 0.0
    """mass scaling: the step every element is given at least (after dt_safety); ``"auto"``:
    AUTO_TARGET_FACTOR (10) times the smallest element's own stable step at the start (the
    peers' usual ratio; docs/mass_scaling.md)."""
    added_mass_limit: float = 5.0
    """conventional mass scaling: the run stops once the added mass exceeds this percentage
    of the shell's physical mass (0: no limit)."""
    sms_tolerance: float = 1e-5
    """selective mass scaling: the solve's relative residual (preconditioned norm) that ends it."""
    sms_max_iterations: int = 200
    """selective mass scaling: conjugate-gradient iterations of one step before the run stops."""
    progress_every: float = 2.0
    """Seconds of wall time between progress lines."""
    solver: Literal["relaxation", "newton"] = "relaxation"
    """Static solves: dynamic relaxation (solvers/static.py) or Newton-Raphson with path
    following (solvers/newton.py, docs/newton.md; fem mode)."""
    control: Literal["load", "displacement", "arc_length"] = "load"
    """Newton: what the path is stepped in: the load factor, the mean displacement of a node
    set's DOF (control_nodes, control_dof, control_displacement), or Crisfield's arc length."""
    control_nodes: str | None = None
    """Node set of the controlled (displacement) or monitored (arc length) DOF."""
    control_dof: str = "uz"
    control_displacement: float = 0.0
    """Displacement control: the final mean value of the controlled DOF; arc length: stop
    once the monitored DOF passes it (0: no such stop)."""
    arc_length: float = 0.0
    """Arc length of the first point (0: the linear displacement at load factor 1 / load_steps)."""
    max_load_factor: float = 1.0
    """Arc length: stop once |load factor| reaches it."""
    target_iterations: int = 5
    """Arc length: the iteration count the arc length is adapted to."""
    max_iterations: int = 20
    """Newton iterations of one point before it is cut back."""
    max_cutbacks: int = 10
    """Halvings of one increment before the run stops."""
    increment_tolerance: float = 1e-3
    """Newton: |last correction| / |increment| that ends a point (with tolerance and energy_tolerance)."""
    energy_tolerance: float = 1e-6
    """Newton: |correction . residual| of the last iteration over the first's."""

    @property
    def physical_rotary_inertia(self) -> bool:
        """Whether the nodes get the physical rotary inertia m t^2/12: ``rotary_inertia =
        "physical"`` in a dynamic solve.  A static solve's masses are the relaxation's own
        (Newton has none), so it keeps the scaled inertia [measured: the 10 x 1 cantilever in
        fem at 2 load levels relaxes in 10 098 steps with it; with the physical one its
        rotational mode sets dt 7.9x smaller (7.35e-5 against 5.81e-4) and FIRE stalls at a
        residual of 0.70 of the load after 400 000 steps, with or without mass scaling]."""
        return self.rotary_inertia == "physical" and self.kind == "dynamic"


@dataclass(frozen=True)
class Output:
    every_steps: int = 0
    times: tuple[float, ...] = ()
    load_steps: bool = True
    history_interval: float = 0.0
    """Dynamic runs: also record probes, energies and forces every this much time (0 = only at frames)."""


@dataclass(frozen=True)
class Scene:
    source: Path
    info: SceneInfo
    mesh: MeshSpec
    material: AnyMaterial | None
    """The one material of a scene without [[part]] (None with [materials.NAME] / a deck)."""
    section: Section | None
    element: ElementOptions
    method: Method
    solve: Solve
    output: Output
    nodesets: tuple[NodeSet, ...] = ()
    boundaries: tuple[Boundary, ...] = ()
    loads: tuple[Load, ...] = ()
    initial: tuple[InitialVelocity, ...] = ()
    probes: tuple[Probe, ...] = ()
    reference: Reference | None = None
    rigid_bodies: tuple[RigidBody, ...] = ()
    point_masses: tuple[PointMass, ...] = ()
    walls: tuple[Wall, ...] = ()
    tools: tuple[Tool, ...] = ()
    contact: Contact | None = None
    crush: Crush | None = None
    materials: dict[str, AnyMaterial] = field(default_factory=dict)
    """Named materials ([materials.NAME]); with [[part]]."""
    sections: dict[str, Section] = field(default_factory=dict)
    elementsets: tuple[ElementSet, ...] = ()
    parts: tuple[Part, ...] = ()
    """[[part]] entries; empty: one part over the mesh ([material] and [section], or the one
    named material and section, or an LS-DYNA deck's parts)."""
    curves: dict[str, Curve] = field(default_factory=dict)
    motions: tuple[Motion, ...] = ()
    pressures: tuple[Pressure, ...] = ()
    gravity: Gravity | None = None

    def nodeset(self, name: str) -> NodeSet:
        for s in self.nodesets:
            if s.name == name:
                return s
        if name == "all":
            return NodeSet(name="all", kind="all")
        raise KeyError(name)


# ================================================================ public entry points
def load_scene(path: str | Path, overrides: Sequence[str] = ()) -> Scene:
    """Read the TOML scene at `path`, apply ``--set`` `overrides`, validate, return the Scene.

    Raises :class:`SceneError` with one line per problem: a single line for an unreadable
    file or a TOML syntax error, otherwise every problem found in the scene.
    """
    path = Path(path)
    try:
        with path.open("rb") as f:
            raw = tomllib.load(f)
    except FileNotFoundError:
        raise SceneError(f"{path}: file not found") from None
    except OSError as exc:
        raise SceneError(f"{path.name}: cannot read the file ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise SceneError(f"{path.name}: not a UTF-8 text file") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path.name}: TOML syntax error: {_one_line(exc)}") from None
    try:
        raw = apply_overrides(raw, overrides)
    except SceneError as exc:
        raise SceneError([f"{path.name}: {m}" for m in exc.messages]) from None
    return parse_scene(raw, path)


def apply_overrides(raw: dict, overrides: Sequence[str]) -> dict:
    """Return a copy of `raw` with each ``"a.b.c=VALUE"`` of `overrides` applied.

    VALUE is read as a TOML value (``20``, ``1e-3``, ``true``, ``[0, 0, 2]``,
    ``'text'``), or taken as a plain string when it is not one (``fem``).  Integer path
    components index arrays of tables (``load.1.force=[0,0,2]``).  The last key may be
    new, and missing tables on the way are created; validation then rejects what the
    scene does not know.  Raises :class:`SceneError` (``--set ITEM: problem`` lines) for
    an item without ``=``, an empty key, a path through a non-table or an index out of
    range.
    """
    result = copy.deepcopy(raw)
    errors = []
    for item in overrides:
        try:
            _apply_override(result, item)
        except _Invalid as exc:
            errors.append(f"--set {_one_line(item)}: {exc}")
    if errors:
        raise SceneError(errors)
    return result


def parse_scene(raw: dict, source: Path) -> Scene:
    """Validate the TOML document `raw` of the scene file `source` into a :class:`Scene`.

    `source` names the file in messages and anchors relative paths (mesh and reference
    files).  Raises :class:`SceneError` listing every problem found.
    """
    return _SceneParser(raw, Path(source)).parse()


# ================================================================ overrides
def _apply_override(document: dict, item: str) -> None:
    """Apply one ``KEY=VALUE`` override to `document` in place (raises _Invalid)."""
    key, sep, text = item.partition("=")
    if not sep:
        raise _Invalid("expected KEY=VALUE, e.g. mesh.nx=20")
    parts = [part.strip() for part in key.split(".")]
    if not all(parts):
        raise _Invalid(f"empty key in {key.strip()!r}")
    node: Any = document
    for depth, part in enumerate(parts):
        where = ".".join(parts[:depth]) or "the scene"
        if isinstance(node, dict):
            slot: str | int = part
        elif isinstance(node, list):
            if not part.isdigit():
                raise _Invalid(f"{where} is an array of tables; expected an index, got {part!r}")
            slot = int(part)
            if slot >= len(node):
                count = f"{len(node)} {'entry' if len(node) == 1 else 'entries'}"
                raise _Invalid(f"index {slot} out of range ({where} has {count})")
        else:
            raise _Invalid(f"{where} is not a table (it is {_show(node)})")
        if depth == len(parts) - 1:
            node[slot] = _override_value(text)
        else:
            if isinstance(node, dict) and slot not in node:
                node[slot] = {}
            node = node[slot]


def _override_value(text: str) -> Any:
    """The TOML value written in `text`, or `text` itself (stripped) if it is none."""
    try:
        return tomllib.loads("v = " + text)["v"]
    except tomllib.TOMLDecodeError:
        return text.strip()


# ================================================================ validators
# A validator checks one TOML value and returns it converted (ints -> float for real
# quantities, arrays -> tuples), or raises _Invalid with the problem (never None).
Validator = Callable[[Any], Any]

_TOML_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")
_SAFE_FILE_NAME = re.compile(r"(?!\.+$)[A-Za-z0-9_.-]+")
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


class _Invalid(Exception):
    """A validator's complaint: the ``<problem>`` part of one message."""


def _one_line(text: object) -> str:
    """`text` with its whitespace runs (newlines included) collapsed to single spaces."""
    return " ".join(str(text).split())


def _show(value: Any) -> str:
    """A short single-line rendering of a user's value, TOML-flavoured."""
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, bool):
        return "true" if value else "false"
    text = f"[{', '.join(map(_show, value))}]" if isinstance(value, list) else repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _key(name: str) -> str:
    """`name` as it appears in a key path: bare if TOML allows, else quoted."""
    return name if _TOML_BARE_KEY.fullmatch(name) else json.dumps(name)


def _did_you_mean(word: str, options: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest of `options`, or ""."""
    close = difflib.get_close_matches(word, list(options), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _hint(word: str, options: Sequence[str], label: str) -> str:
    """A did-you-mean for `word`, or else the list of `options` under `label`."""
    if not options:
        return f" (none {label})"
    shown = [o if o.isprintable() else repr(o) for o in options]      # a mistyped name stays on one line
    return _did_you_mean(word, options) or f" ({label}: {', '.join(shown)})"


def _is_number(value: Any) -> bool:
    """A finite TOML integer or float (booleans are not numbers)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _ranged(what: str, accepts: Callable[[Any], bool], convert: Callable[[Any], Any],
            lo: float | None, hi: float | None, lo_open: bool, hi_open: bool) -> Validator:
    """Validator for `what` (e.g. 'a number') within [lo, hi], ends open as flagged."""
    if lo is not None and hi is not None:
        bounds = f" in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
    elif lo is not None:
        bounds = f" {'>' if lo_open else '>='} {lo:g}"
    elif hi is not None:
        bounds = f" {'<' if hi_open else '<='} {hi:g}"
    else:
        bounds = ""

    def check(value: Any) -> Any:
        if accepts(value) and (lo is None or value > lo or (value == lo and not lo_open)) \
                and (hi is None or value < hi or (value == hi and not hi_open)):
            return convert(value)
        raise _Invalid(f"expected {what}{bounds}, got {_show(value)}")
    return check


def _number(lo: float | None = None, hi: float | None = None, *,
            lo_open: bool = False, hi_open: bool = False) -> Validator:
    """Finite real number (ints accepted, returned as float) within the given bounds."""
    what = "a number" if lo is not None or hi is not None else "a finite number"
    return _ranged(what, _is_number, float, lo, hi, lo_open, hi_open)


def _int(lo: int, hi: int | None = None) -> Validator:
    """Integer in [lo, hi] (floats such as 3.0 are rejected)."""
    return _ranged("an integer", _is_int, int, lo, hi, False, False)


_positive = _number(0, lo_open=True)
_non_negative = _number(0)
_fraction = _number(0, 1, lo_open=True)        # (0, 1]
_unit_interval = _number(0, 1)                  # [0, 1]


def _target_dt(value: Any) -> float | str:
    """A step > 0, or "auto" (mass scaling's target step)."""
    if value == "auto" or (_is_number(value) and value > 0):
        return value if isinstance(value, str) else float(value)
    raise _Invalid(f'expected a number > 0 or "auto", got {_show(value)}')


def _nonzero(value: Any) -> float:
    if _is_number(value) and value != 0:
        return float(value)
    raise _Invalid(f"expected a non-zero finite number, got {_show(value)}")


def _bool(value: Any) -> bool:
    if isinstance(value, bool):
        return value
    raise _Invalid(f"expected true or false, got {_show(value)}")


def _true(value: Any) -> bool:
    if value is True:
        return value
    raise _Invalid(f"expected true, got {_show(value)}")


def _text(value: Any) -> str:
    if isinstance(value, str):
        return value
    raise _Invalid(f"expected a string, got {_show(value)}")


def _nonempty(value: Any) -> str:
    if isinstance(value, str) and value.strip():
        return value
    raise _Invalid(f"expected a non-empty string, got {_show(value)}")


def _matching(pattern: re.Pattern, what: str) -> Validator:
    """String that fully matches `pattern`, described as `what` in messages."""
    def check(value: Any) -> str:
        if isinstance(value, str) and pattern.fullmatch(value):
            return value
        raise _Invalid(f"expected {what}, got {_show(value)}")
    return check


_file_name = _matching(_SAFE_FILE_NAME, "a file name made of letters, digits, '_', '.', '-'")
_identifier = _matching(_IDENTIFIER, "an identifier (letters, digits, '_'; not starting with a digit)")


def _choice(*options: str) -> Validator:
    """One of the strings `options`."""
    def check(value: Any) -> str:
        if isinstance(value, str) and value in options:
            return value
        hint = _did_you_mean(value, options) if isinstance(value, str) else ""
        raise _Invalid(f"expected one of {', '.join(options)}, got {_show(value)}{hint}")
    return check


def _vec3(value: Any) -> Vec3:
    """Exactly three finite numbers, as a float tuple."""
    if isinstance(value, list) and len(value) == 3 and all(map(_is_number, value)):
        return tuple(float(c) for c in value)
    raise _Invalid(f"expected 3 finite numbers [x, y, z], got {_show(value)}")


def _nonzero_vec3(value: Any) -> Vec3:
    vec = _vec3(value)
    if not any(vec):
        raise _Invalid("expected a non-zero vector, got [0, 0, 0]")
    return vec


def _size2(value: Any) -> tuple[float, float]:
    if not (isinstance(value, list) and len(value) == 2 and all(_is_number(x) and x > 0 and math.isfinite(x)
                                                                for x in value)):
        raise _Invalid(f"expected two positive numbers [a, b], got {_show(value)}")
    return float(value[0]), float(value[1])


def _dofs(allow_all: bool) -> Validator:
    """Non-empty list of distinct DOF names (or the string "all" when `allow_all`)."""
    expected = f"a non-empty list of DOFs (some of {', '.join(DOFS)})" + (' or "all"' if allow_all else "")

    def check(value: Any) -> tuple[str, ...]:
        if allow_all and value == "all":
            return DOFS
        if not isinstance(value, list) or not value:
            raise _Invalid(f"expected {expected}, got {_show(value)}")
        for i, dof in enumerate(value):
            if dof not in DOFS:
                raise _Invalid(f"unknown DOF {_show(dof)} (expected some of {', '.join(DOFS)})")
            if dof in value[:i]:
                raise _Invalid(f"DOF {dof!r} is given twice")
        return tuple(value)
    return check


def _inertia(value: Any) -> tuple[float, ...]:
    """An inertia tensor: [Ixx, Iyy, Izz] or [Ixx, Iyy, Izz, Ixy, Iyz, Izx] (its entries, so
    Ixy = -sum m x y), symmetric positive semi-definite."""
    if not (isinstance(value, list) and len(value) in (3, 6) and all(map(_is_number, value))):
        raise _Invalid(f"expected 3 numbers [Ixx, Iyy, Izz] or 6 [Ixx, Iyy, Izz, Ixy, Iyz, Izx], got {_show(value)}")
    out = tuple(float(c) for c in value)
    if float(np.linalg.eigvalsh(inertia_tensor(out)).min()) < -1e-12 * max(abs(c) for c in out):
        raise _Invalid(f"not positive semi-definite: {_show(value)}")
    return out


def inertia_tensor(entries: Sequence[float]) -> np.ndarray:
    """The 3 x 3 tensor of a scene's inertia entries (see _inertia); () is zero."""
    out = np.zeros((3, 3))
    if entries:
        out[np.diag_indices(3)] = entries[:3]
    if len(entries) == 6:
        for (i, j), c in zip(((0, 1), (1, 2), (2, 0)), entries[3:]):
            out[i, j] = out[j, i] = c
    return out


def _element_ids(value: Any) -> tuple[int, ...]:
    if isinstance(value, list) and value and all(_is_int(i) and i >= 0 for i in value):
        return tuple(value)
    raise _Invalid(f"expected a non-empty list of element indices >= 0, got {_show(value)}")


def _node_ids(value: Any) -> tuple[int, ...]:
    if isinstance(value, list) and value and all(_is_int(i) and i >= 0 for i in value):
        return tuple(value)
    raise _Invalid(f"expected a non-empty list of node indices >= 0, got {_show(value)}")


def _window(value: Any) -> tuple[float, float]:
    """Two finite numbers [from, to] with 0 <= from < to."""
    if isinstance(value, list) and len(value) == 2 and all(map(_is_number, value)) and 0 <= value[0] < value[1]:
        return (float(value[0]), float(value[1]))
    raise _Invalid(f"expected [from, to] with 0 <= from < to, got {_show(value)}")


CRUSH_FORMULAS = ("wierzbicki_abramowicz", "abramowicz_jones")
"""Closed-form mean crush forces of a tube that [crush].mean_force_reference may name (crush.py)."""


def _force_references(value: Any) -> tuple[float | str, ...]:
    """A non-empty list of numbers > 0 and names of CRUSH_FORMULAS."""
    if isinstance(value, list) and value and all((_is_number(x) and x > 0) or x in CRUSH_FORMULAS for x in value):
        return tuple(x if isinstance(x, str) else float(x) for x in value)
    raise _Invalid(f"expected a non-empty list of numbers > 0 and of {' / '.join(map(repr, CRUSH_FORMULAS))}, "
                   f"got {_show(value)}")


def _layered_table(data: Any) -> bool:
    """Whether the raw section table `data` is a layered section (has plies)."""
    return isinstance(data, dict) and "plies" in data


def _lone_layered_section(data: Any) -> bool:
    """Whether the raw [sections] `data` is one layered section (its plies name the materials:
    no [[part]] needed)."""
    return isinstance(data, dict) and len(data) == 1 and _layered_table(next(iter(data.values())))


def _triangle_split(value: Any) -> TriangleSplit:
    """"none", "all" or a box {min = [x, y, z], max = [x, y, z]} (min <= max)."""
    if value in ("none", "all"):
        return value
    if isinstance(value, dict) and set(value) == {"min", "max"}:
        lo, hi = _vec3(value["min"]), _vec3(value["max"])
        if all(a <= b for a, b in zip(lo, hi)):
            return lo, hi
    raise _Invalid(f'expected "none", "all" or a box {{min = [x, y, z], max = [x, y, z]}} with min <= max, '
                   f"got {_show(value)}")


def _numbers(value: Any) -> tuple[float, ...]:
    """A finite number or a non-empty list of them, as a tuple."""
    if _is_number(value):
        return (float(value),)
    if isinstance(value, list) and value and all(map(_is_number, value)):
        return tuple(float(x) for x in value)
    raise _Invalid(f"expected a finite number or a non-empty list of them, got {_show(value)}")


def _time_curve_points(value: Any) -> tuple[tuple[float, float], ...]:
    """A [curves.NAME] table: a non-empty list of [t, f] pairs of finite numbers, t strictly increasing."""
    if not (isinstance(value, list) and value and all(isinstance(p, list) and len(p) == 2 and all(map(_is_number, p))
                                                      for p in value)):
        raise _Invalid(f"expected a non-empty list of [t, f] pairs of finite numbers, got {_show(value)}")
    return _increasing(tuple((float(t), float(f)) for t, f in value))


def _increasing(points: tuple[tuple[float, float], ...]) -> tuple[tuple[float, float], ...]:
    for (t0, _), (t1, _) in zip(points, points[1:]):
        if t1 <= t0:
            raise _Invalid(f"expected strictly increasing t, got t = {t0:g} then {t1:g}")
    return points


def _times(value: Any) -> tuple[float, ...]:
    """Increasing list of times >= 0."""
    if not (isinstance(value, list) and all(_is_number(t) and t >= 0 for t in value)):
        raise _Invalid(f"expected a list of numbers >= 0, got {_show(value)}")
    if any(a >= b for a, b in zip(value, value[1:])):
        raise _Invalid(f"expected strictly increasing times, got {_show(value)}")
    return tuple(float(t) for t in value)


def _curve_points(points: Sequence[tuple[float, float]], where: Callable[[int], str]) -> tuple[tuple[float, float], ...]:
    """A hardening curve's (plastic strain, yield stress) points, checked: from plastic strain 0,
    strictly increasing, yield stress > 0 and non-decreasing (the return map brackets its root
    with a flow stress that does not fall, method.md 3.4).  `where(i)` names point i in messages."""
    if not points:
        raise _Invalid("expected at least one [plastic strain, yield stress] point, got none")
    if points[0][0] != 0.0:
        raise _Invalid(f"{where(0)}: expected plastic strain 0 (the initial yield stress), got {points[0][0]:g}")
    for i, (eps, sig) in enumerate(points):
        if sig <= 0.0:
            raise _Invalid(f"{where(i)}: expected a yield stress > 0, got {sig:g}")
        if i and eps <= points[i - 1][0]:
            raise _Invalid(f"{where(i)}: expected a plastic strain above the previous point's {points[i - 1][0]:g}, "
                           f"got {eps:g}")
        if i and sig < points[i - 1][1]:
            raise _Invalid(f"{where(i)}: the yield stress falls ({points[i - 1][1]:g} -> {sig:g}): softening "
                           "curves are not supported")
    return tuple(points)


def _hardening_curve(value: Any) -> tuple[tuple[float, float], ...]:
    """A list of [plastic strain, yield stress] pairs (_curve_points)."""
    if not (isinstance(value, list) and value and all(isinstance(row, list) and len(row) == 2
                                                      and all(map(_is_number, row)) for row in value)):
        raise _Invalid(f"expected a list of [plastic strain, yield stress] pairs, got {_show(value)}")
    return _curve_points([(float(a), float(b)) for a, b in value], lambda i: f"point {i + 1}")


# ================================================================ table layout
_TABLES = ("scene", "mesh", "material", "section", "materials", "sections", "elementsets", "part", "element",
           "method", "nodesets", "boundary", "load", "initial", "probe", "reference", "solve", "output",
           "rigid_body", "point_mass", "wall", "tool", "contact", "crush", "curves", "motion", "pressure", "gravity")
_REQUIRED_TABLES = ("scene", "mesh", "solve")
# [[tool]] keys of each kind (required, optional); a shape key of another kind is an error
_TOOL_KEYS = {"plane": (("normal",), ("center",)),
              "rectangle": (("normal", "size"), ("center", "axis")),
              "cylinder": (("axis", "radius", "length"), ("center",)),
              "sphere": (("radius",), ("center",)),
              "mesh": (("file",), ("center", "scale"))}
_TOOL_SHAPE_KEYS = ("normal", "axis", "radius", "length", "size", "file", "scale")
DECK_SUFFIXES = (".k", ".key", ".dyn", ".kw")      # file endings read as LS-DYNA keyword decks (dyna.py)
_SELECTORS = ("all", "box", "plane", "nearest", "ids")

_INFO = {"name": _file_name, "units": _nonempty, "description": _text}
_MATERIAL_MODELS = ("elastic", "j2", "orthotropic")
_MATERIAL = {"E": _positive, "nu": _number(-1, 0.5, lo_open=True, hi_open=True),
             "density": _positive, "model": _choice(*_MATERIAL_MODELS), "yield_stress": _positive,
             "hardening": _non_negative,
             "hardening_law": _choice("linear", "swift", "ludwik", "voce", "tabulated"), "K": _positive,
             "eps0": _positive, "n": _positive, "B": _non_negative, "max_stress": _positive, "Q": _non_negative,
             "b": _non_negative, "curve": _hardening_curve, "beyond_curve": _choice("flat", "extrapolate"),
             "rate_law": _choice("none", "cowper_symonds", "johnson_cook"), "C": _positive, "p": _positive,
             "c": _non_negative, "reference_rate": _positive, "rate_measure": _choice("total", "plastic"),
             "rate_filter_time": _positive, "rate_cutoff_frequency": _positive,
             "failure_strain": _positive, "failure_points": _int(1, 10), "failure_min_dt": _positive}
# The keys of each hardening and rate law: (required, optional); a key of another law is an error.
_HARDENING_KEYS = {"linear": (("yield_stress",), ("hardening",)),
                   "swift": (("K", "n"), ("eps0", "yield_stress", "hardening")),
                   "ludwik": (("yield_stress", "B", "n"), ("max_stress", "hardening")),
                   "voce": (("yield_stress", "Q", "b"), ("hardening",)),
                   "tabulated": ((), ("curve", "curve_file", "beyond_curve"))}
_RATE_KEYS = {"none": ((), ()), "cowper_symonds": (("C", "p"), ("rate_measure", "rate_filter_time",
                                                                  "rate_cutoff_frequency")),
              "johnson_cook": (("c", "reference_rate"), ("rate_measure", "rate_filter_time",
                                                          "rate_cutoff_frequency"))}
_ORTHOTROPIC = {"E1": _positive, "E2": _positive, "G12": _positive, "G13": _positive, "G23": _positive,
                "nu12": _number(), "density": _positive, "model": _choice(*_MATERIAL_MODELS)}
_SECTION = {"thickness": _positive, "points": _int(1, 10),
            "rule": _choice("lobatto", "gauss"), "shear_factor": _fraction, "hourglass": _unit_interval,
            "drilling_stiffness": _positive, "reference_direction": _nonzero_vec3}
_LAYERED_ONLY = {"points_per_ply": _int(1, 5)}
_SINGLE_ONLY = ("thickness", "points", "rule")        # a layered section derives them from its plies
MAX_PLIES = 64
_PLY = {"material": _nonempty, "thickness": _positive, "angle": _number(-360, 360)}
_ELEMENT = {"hourglass": _unit_interval, "w_hourglass": _choice("kirchhoff", "bt"),
            "drilling": _choice("projection", "penalty"), "drilling_stiffness": _positive,
            "warping": _choice("none", "bwc")}
_METHOD = {"kind": _choice("mpm", "fem"), "cell_size": _positive, "grid_min": _vec3,
           "grid_max": _vec3, "fields": _choice("single", "multi"),
           "field_contact": _choice("penalty", "grid"), "field_friction": _non_negative,
           "transfer": _choice("apic", "polypic", "pic", "flip"), "flip_blend": _unit_interval}
_SOLVE = {"kind": _choice("static", "dynamic"), "load_steps": _int(1),
          "tolerance": _number(0, 0.1, lo_open=True), "max_steps_per_load_step": _int(1),
          "end_time": _non_negative, "dt_safety": _fraction,
          "dt_rule": _choice("both", "shell"), "rotary_inertia": _choice("scaled", "physical"),
          "relaxation": _choice("fire", "kinetic"),
          "mass_scaling": _choice("auto", "uniform_dt", "selective", "conventional", "none"),
          "target_dt": _target_dt, "added_mass_limit": _non_negative,
          "sms_tolerance": _number(0, 0.1, lo_open=True), "sms_max_iterations": _int(1),
          "progress_every": _non_negative, "solver": _choice("relaxation", "newton"),
          "control": _choice("load", "displacement", "arc_length"), "control_dof": _choice(*DOFS),
          "control_displacement": _number(), "arc_length": _non_negative, "max_load_factor": _positive,
          "target_iterations": _int(1), "max_iterations": _int(1), "max_cutbacks": _int(0),
          "increment_tolerance": _number(0, 1, lo_open=True), "energy_tolerance": _number(0, 1, lo_open=True)}
_OUTPUT = {"every_steps": _int(0), "times": _times, "load_steps": _bool, "history_interval": _non_negative}


def value_problem(table: str, key: str, value: Any) -> str | None:
    """What is wrong with `value` as the key `key` of [material] or [section] (`table`), or
    None: an LS-DYNA deck's values are checked by the scene's own validators
    (assembly._deck_specs), so a deck value is held to the same range as the scene key."""
    try:
        {"material": _MATERIAL, "section": _SECTION}[table][key](value)
    except _Invalid as exc:
        return str(exc)
    return None


def name_hint(word: str, options: Sequence[str], label: str) -> str:
    """`` (did you mean 'x'?)``, or else `` (label: a, b, ...)``: the scene's hint, for other modules."""
    return _hint(word, options, label)
_PLAIN_TABLES: dict[str, tuple[type, dict[str, Validator]]] = {
    "scene": (SceneInfo, _INFO),
    "element": (ElementOptions, _ELEMENT), "output": (Output, _OUTPUT)}
_MESHES: dict[str, tuple[type, dict[str, Validator]]] = {
    "plate": (PlateMesh, {"lx": _positive, "ly": _positive, "nx": _int(1), "ny": _int(1),
                          "origin": _vec3, "triangles": _triangle_split}),
    "hemisphere": (HemisphereMesh, {"radius": _positive,
                                    "hole_deg": _number(0, 90, lo_open=True, hi_open=True),
                                    "n_around": _int(1), "n_meridian": _int(1),
                                    "quarter": _bool, "triangles": _triangle_split}),
    "tube": (TubeMesh, {"width": _positive, "depth": _positive, "corner_radius": _non_negative,
                        "length": _positive, "n_flat": _int(1), "n_corner": _int(0),
                        "n_length": _int(1), "trigger_amplitude": _non_negative,
                        "trigger_start": _non_negative, "trigger_length": _positive,
                        "triangles": _triangle_split}),
    "file": (FileMesh, {"scale": _positive, "merge_nodes": _bool}),   # + "path", checked against the scene's folder
}


# ================================================================ the parser
class _SceneParser:
    """Validates one raw scene document, collecting every problem as a message line.

    Table readers return the built dataclass, or None when the table had a problem
    (already reported); cross-checks only look at values that passed their own check,
    so one mistake is reported once.
    """

    def __init__(self, raw: dict, source: Path):
        self.raw = raw
        self.source = source.resolve()
        self.file_name = source.name
        self.messages: list[str] = []
        sets = raw.get("nodesets")
        self.nodeset_names = sorted({"all", *(sets if isinstance(sets, dict) else ())})
        curves = raw.get("curves")
        self.curve_names = sorted(curves) if isinstance(curves, dict) else []
        self.recorded: dict[str, tuple[str, ...] | None] = {}
        """Probe name -> recorded components (None when those were invalid)."""

    # ------------------------------------------------------------ bookkeeping
    def error(self, path: str, problem: str) -> None:
        self.messages.append(f"{self.file_name}: {path}: {problem}")

    def check(self, path: str, validator: Validator, value: Any) -> Any:
        """validator(value), or None after reporting its problem at `path`."""
        try:
            return validator(value)
        except _Invalid as exc:
            self.error(path, str(exc))
            return None

    def read(self, path: str, data: Any, spec: dict[str, Validator], cls: type | None = None,
             required: Sequence[str] = (), extra: Sequence[str] = ()) -> dict | None:
        """Check the table `data` at `path` against `spec` (key -> validator).

        Reports unknown keys (in neither `spec` nor `extra`, which the caller reads) and
        missing required keys: `required`, or with `cls` its fields without a default.
        Returns the valid values over `cls`'s defaults (an invalid key is left out), or
        None if `data` is not a table.
        """
        if not isinstance(data, dict):
            self.error(path, f"expected a table, got {_show(data)}")
            return None
        values = {}
        if cls is not None:
            values = {f.name: f.default for f in fields(cls) if f.default is not MISSING}
            required = [f.name for f in fields(cls) if f.default is MISSING and f.name in spec]
        for key, value in data.items():
            if key in spec:
                result = self.check(f"{path}.{_key(key)}", spec[key], value)
                if result is None:
                    values.pop(key, None)
                else:
                    values[key] = result
            elif key not in extra:
                self.error(f"{path}.{_key(key)}", "unknown key" + _hint(key, [*spec, *extra], "allowed"))
        for key in required:
            if key not in data:
                self.error(f"{path}.{key}", "missing required key")
        return values

    def build(self, mark: int, cls: type, values: dict) -> Any:
        """cls(**values) if nothing was reported since message count `mark`, else None."""
        return cls(**values) if len(self.messages) == mark else None

    def table_object(self, path: str, data: Any, cls: type, spec: dict[str, Validator]) -> Any:
        """A table without cross-checks, read straight into `cls`."""
        mark = len(self.messages)
        values = self.read(path, data, spec, cls)
        return None if values is None else self.build(mark, cls, values)

    def entries(self, path: str, value: Any) -> list[tuple[str, Any]]:
        """(path, entry) pairs of the array of tables `value` (``[[x]][0]``, ...)."""
        if isinstance(value, list):
            return [(f"{path}[{i}]", item) for i, item in enumerate(value)]
        self.error(path, f"expected an array of tables ({path} sections), got {_show(value)}")
        return []

    def part(self, key: str, reader: Callable[[Any], Any]) -> Any:
        """reader(the top-level table `key`); an absent optional table reads as {}."""
        if key in self.raw:
            return reader(self.raw[key])
        if key in _REQUIRED_TABLES:
            self.error(f"[{key}]", "missing required table")
            return None
        return reader({})

    def plain(self, key: str) -> Any:
        """The top-level table `key` of _PLAIN_TABLES (no cross-checks), as its dataclass."""
        cls, spec = _PLAIN_TABLES[key]
        return self.part(key, lambda data: self.table_object(f"[{key}]", data, cls, spec))

    def array(self, key: str, reader: Callable[[str, Any], Any]) -> list:
        """reader(path, entry) for each entry of the top-level array of tables `key`."""
        return [reader(path, entry) for path, entry in self.entries(f"[[{key}]]", self.raw.get(key, []))]

    def check_order(self, path: str, lo: Vec3 | None, hi: Vec3 | None, names: tuple[str, str],
                    strict: bool) -> None:
        """Report unless lo < hi (`strict`) or lo <= hi in every component (skipped if unset)."""
        if lo is None or hi is None:
            return
        if any(a >= b if strict else a > b for a, b in zip(lo, hi)):
            relation = "<" if strict else "<="
            self.error(path, f"expected {names[0]} {relation} {names[1]} in every component, "
                             f"got {names[0]} = {_show(list(lo))}, {names[1]} = {_show(list(hi))}")

    # ------------------------------------------------------------ context-bound validators
    def file(self, value: Any) -> Path:
        """An existing file, relative to the scene file's folder; returned absolute."""
        if not isinstance(value, str) or not value:
            raise _Invalid(f"expected a file path (relative to the scene file), got {_show(value)}")
        try:
            path = (self.source.parent / value).resolve()
            found, folder = path.is_file(), path.is_dir()
        except (OSError, ValueError):
            found = folder = False
        if folder:
            raise _Invalid(f"expected a file, got the directory {str(self.source.parent / value)!r}")
        if not found:
            raise _Invalid(f"file not found: {str(self.source.parent / value)!r}")
        return path

    def nodes(self, value: Any) -> str:
        """The name of a node set defined in [nodesets], or 'all'."""
        if not isinstance(value, str):
            raise _Invalid(f"expected a node set name, got {_show(value)}")
        if value not in self.nodeset_names:
            raise _Invalid(f"unknown node set {value!r}" + _hint(value, self.nodeset_names, "defined"))
        return value

    def curve_name(self, value: Any) -> str:
        """The name of a curve defined in [curves]."""
        if not isinstance(value, str):
            raise _Invalid(f"expected a curve name, got {_show(value)}")
        if value not in self.curve_names:
            raise _Invalid(f"no [curves.{_key(value)}]" + _hint(value, self.curve_names, "defined"))
        return value

    def probe_component(self, value: Any) -> str:
        """'<probe>.<component>' naming a component that this probe records."""
        if not isinstance(value, str) or "." not in value:
            raise _Invalid(f"expected '<probe>.<component>' (e.g. 'tip.uz'), got {_show(value)}")
        name, _, component = value.rpartition(".")
        if name not in self.recorded:
            raise _Invalid(f"unknown probe {name!r}" + _hint(name, sorted(self.recorded), "defined"))
        if component not in DOFS:
            raise _Invalid(f"unknown component {component!r} (expected one of {', '.join(DOFS)})")
        recorded = self.recorded[name]
        if recorded is not None and component not in recorded:
            raise _Invalid(f"probe {name!r} does not record {component!r} "
                           f"(it records {', '.join(recorded)})")
        return value

    def csv_column(self, file: Path | None) -> Validator:
        """Validator for a column name in the header row of the CSV `file`.

        Only non-emptiness is checked when `file` is None (already reported) or its
        header cannot be read (reported here, once).
        """
        if file is None:
            return _nonempty
        try:
            with file.open(newline="", encoding="utf-8-sig") as f:
                header = [_one_line(name) for name in next(csv.reader(f), [])]
        except (OSError, UnicodeDecodeError, csv.Error) as exc:
            self.error("[reference].file", f"cannot read its header row ({_one_line(exc)})")
            return _nonempty

        def check(value: Any) -> str:
            name = _nonempty(value)
            if name not in header:
                raise _Invalid(f"no column {name!r} in the header of {file.name}"
                               + _hint(name, header, "columns"))
            return name
        return check

    # ------------------------------------------------------------ tables
    def parse(self) -> Scene:
        for key in self.raw:
            if key not in _TABLES:
                self.error(f"[{_key(key)}]", "unknown key" + _hint(key, _TABLES, "allowed"))
        info = self.plain("scene")
        mesh = self.part("mesh", self.mesh)
        material, section, materials, sections, elementsets, parts = self.parts(mesh)
        element = self.plain("element")
        method = self.part("method", self.method)
        nodesets = self.part("nodesets", self.nodesets)
        boundaries = self.array("boundary", self.boundary)
        curves = self.named("curves", self.curve)
        if len(curves) > MAX_CURVES:
            self.error("[curves]", f"expected at most {MAX_CURVES} curves, got {len(curves)}")
        loads = self.array("load", self.load)
        initial = self.array("initial", self.initial)
        probes = self.array("probe", self.probe)            # before [reference], which refers to them
        reference = self.reference(self.raw["reference"]) if "reference" in self.raw else None
        solve = self.part("solve", self.solve)
        output = self.plain("output")
        bodies = self.array("rigid_body", self.rigid_body)
        if len(bodies) > MAX_BODIES:
            self.error("[[rigid_body]]", f"expected at most {MAX_BODIES} entries, got {len(bodies)}")
        point_masses = self.array("point_mass", self.point_mass)
        walls = self.array("wall", self.wall)
        tools = self.array("tool", lambda path, data: self.tool(path, data, solve, curves))
        names = [t.name for t in tools if t is not None]
        for i, name in enumerate(names):
            if name in names[:i]:
                self.error("[[tool]]", f"duplicate tool name {name!r}")
        from .tools import MAX_TOOLS
        if len(tools) > MAX_TOOLS:
            self.error("[[tool]]", f"expected at most {MAX_TOOLS} tools, got {len(tools)}")
        contact = self.table_object("[contact]", self.raw["contact"], Contact, {
            "thickness": _positive, "stiffness": _number(0, 1, lo_open=True), "friction": _non_negative,
            "damping": _unit_interval}) if "contact" in self.raw else None
        if contact is not None:
            self.penalty_damping("[contact]", contact.stiffness, contact.damping)
        crush = self.crush(self.raw["crush"], solve) if "crush" in self.raw else None
        if solve is not None and solve.kind == "static":
            named = [("[material]", material), *((f"[materials.{_key(k)}]", m) for k, m in materials.items())]
            for path, spec in named:
                if spec is not None and getattr(spec, "rate_law", "none") != "none":
                    self.error(f"{path}.rate_law", "a static solve has no physical time: a rate law needs "
                                                   "[solve].kind = \"dynamic\"")
                for key in ("failure_strain", "failure_min_dt"):
                    if spec is not None and getattr(spec, key, 0.0) > 0.0:
                        self.error(f"{path}.{key}", "erosion needs [solve].kind = \"dynamic\"")
        motions = self.array("motion", lambda path, data: self.motion(path, data, solve, curves))
        names = [m.name for m in motions if m is not None]
        for i, name in enumerate(names):
            if name in names[:i]:
                self.error("[[motion]]", f"duplicate motion name {name!r}")
        if len(motions) > MAX_MOTIONS:
            self.error("[[motion]]", f"expected at most {MAX_MOTIONS} entries, got {len(motions)}")
        pressures = self.array("pressure", lambda path, data: self.pressure(path, data, mesh, elementsets))
        gravity = self.table_object("[gravity]", self.raw["gravity"], Gravity, {
            "acceleration": _nonzero_vec3, "curve": self.curve_name}) if "gravity" in self.raw else None
        if self.messages:
            raise SceneError(self.messages, mesh=mesh)
        return Scene(source=self.source, info=info, mesh=mesh, material=material, section=section,
                     element=element, method=method, solve=solve, output=output,
                     nodesets=tuple(nodesets), boundaries=tuple(boundaries), loads=tuple(loads),
                     initial=tuple(initial), probes=tuple(probes), reference=reference,
                     rigid_bodies=tuple(bodies), point_masses=tuple(point_masses), walls=tuple(walls),
                     tools=tuple(tools), contact=contact, crush=crush,
                     materials=materials, sections=sections, elementsets=tuple(elementsets), parts=tuple(parts),
                     curves=curves, motions=tuple(motions), pressures=tuple(pressures), gravity=gravity)

    def mesh(self, data: Any) -> MeshSpec | None:
        if not isinstance(data, dict):
            self.error("[mesh]", f"expected a table, got {_show(data)}")
            return None
        if "kind" not in data:
            self.error("[mesh].kind", f"missing required key (one of {', '.join(_MESHES)})")
            return None
        kind = self.check("[mesh].kind", _choice(*_MESHES), data["kind"])
        if kind is None:
            return None
        cls, spec = _MESHES[kind]
        if cls is FileMesh:
            spec = {"path": self.file, **spec}
        mark = len(self.messages)
        v = self.read("[mesh]", data, spec, cls, extra=("kind",))
        count = _generated_elements(kind, v)
        if count is not None and count > MAX_GENERATED_ELEMENTS:
            keys = {"plate": "nx x ny", "hemisphere": "n_around x n_meridian",
                    "tube": "4 (n_flat + n_corner) x n_length"}[kind]
            self.error(f"[mesh].{max(GENERATED_COUNT_KEYS[kind], key=v.get)}",
                       f"expected at most {MAX_GENERATED_ELEMENTS:,} elements ({keys}), got {count:,}")
        if kind == "tube":
            if {"width", "depth", "corner_radius"} <= v.keys():
                limit = min(v["width"], v["depth"]) / 2
                if v["corner_radius"] >= limit:
                    self.error("[mesh].corner_radius", "expected a number < min(width, depth)/2 = "
                                                       f"{limit:g}, got {v['corner_radius']:g}")
            if v.get("corner_radius", 0) > 0 and v.get("n_corner") == 0:
                self.error("[mesh].n_corner", "expected an integer >= 1 when corner_radius > 0, got 0")
        return self.build(mark, cls, v)

    def material_table(self, path: str, data: Any) -> AnyMaterial | None:
        """[material] or [materials.NAME]: an orthotropic material, or its keys, then those of
        its hardening and rate laws (each law takes its own keys: a key of another law is an
        error)."""
        if isinstance(data, dict) and data.get("model") == "orthotropic":
            material = self.table_object(path, data, OrthotropicMaterial, _ORTHOTROPIC)
            if material is not None and material.nu12 ** 2 >= material.E1 / material.E2:
                self.error(f"{path}.nu12", f"expected |nu12| < sqrt(E1/E2) = {math.sqrt(material.E1 / material.E2):g} "
                                           f"(a positive definite plane-stress stiffness), got {material.nu12:g}")
                return None
            return material
        mark = len(self.messages)
        values = self.read(path, data, {**_MATERIAL, "curve_file": self.curve_file}, Material)
        if values is None:
            return None
        plasticity = {k for table in (_HARDENING_KEYS, _RATE_KEYS) for keys in table.values() for group in keys
                      for k in group} | {"hardening_law", "rate_law"}
        if values.get("model") == "elastic":
            for key in data:
                if key in plasticity - {"yield_stress", "hardening"}:
                    self.error(f"{path}.{_key(key)}", "only for model = \"j2\"")
        elif "model" in values:
            for key, table in (("hardening_law", _HARDENING_KEYS), ("rate_law", _RATE_KEYS)):
                if key in values:
                    self.law_keys(path, data, key, values[key], table)
            if values.get("hardening_law") == "swift":
                if ("eps0" in data) == ("yield_stress" in data):
                    self.error(f"{path}.eps0", "expected exactly one of eps0 and yield_stress for hardening_law = "
                                               "\"swift\" (yield_stress sets eps0 = (yield_stress / K)^(1/n))")
                elif all(k in data and k in values for k in ("yield_stress", "K", "n")):
                    values["eps0"] = (values["yield_stress"] / values["K"]) ** (1.0 / values["n"])
            if values.get("hardening_law") == "tabulated" and ("curve" in data) == ("curve_file" in data):
                self.error(f"{path}.curve", "expected exactly one of curve and curve_file for "
                                            "hardening_law = \"tabulated\"")
            if "curve_file" in data and "curve_file" in values:
                values["curve_file"], values["curve"] = values["curve_file"]
            if values.get("beyond_curve") == "extrapolate" and 0 < len(values.get("curve", ())) < 2:
                self.error(f"{path}.beyond_curve", "\"extrapolate\" needs a curve of at least two points")
            cap, sy = values.get("max_stress"), values.get("yield_stress")
            if "max_stress" in data and "yield_stress" in data and cap is not None and sy is not None and cap <= sy:
                self.error(f"{path}.max_stress", f"expected a number above yield_stress = {sy:g}, got {cap:g}")
            if "rate_filter_time" in data and "rate_cutoff_frequency" in data:
                self.error(f"{path}.rate_cutoff_frequency", "give the rate filter either as rate_filter_time or "
                                                            "as rate_cutoff_frequency, not both")
        if "failure_strain" in data and values.get("model") == "elastic":
            self.error(f"{path}.failure_strain", "only for model = \"j2\" (the equivalent plastic strain); "
                                                 "failure_min_dt erodes elements of any model")
        if "failure_points" in data and "failure_strain" not in data:
            self.error(f"{path}.failure_points", "only with failure_strain")
        return self.build(mark, Material, values)

    def law_keys(self, path: str, data: dict, key: str, law: str, table: dict) -> None:
        """Report the keys of `table`'s other laws given with `key` = `law`, and its missing ones."""
        required, optional = table[law]
        own = (*required, *optional)
        for name in data:
            if any(name in group for keys in table.values() for group in keys) and name not in own:
                self.error(f"{path}.{_key(name)}", f"not used by {key} = \"{law}\""
                           + (f" (its keys: {', '.join(own)})" if own else ""))
        for name in required:
            if name not in data:
                self.error(f"{path}.{name}", "missing required key for model = \"j2\"" if key not in data else
                           f"missing required key for {key} = \"{law}\"")

    def curve_file(self, value: Any) -> tuple[Path, tuple[tuple[float, float], ...]]:
        """A CSV file of (plastic strain, yield stress) rows, relative to the scene file (an
        optional header row; blank lines and lines starting with '#' are skipped): its path
        and points (_curve_points)."""
        path = self.file(value)
        try:
            with path.open(newline="", encoding="utf-8-sig") as f:
                rows = [(i, row) for i, row in enumerate(csv.reader(f), 1)
                        if row and "".join(row).strip() and not row[0].lstrip().startswith("#")]
        except (OSError, UnicodeDecodeError, csv.Error) as exc:
            raise _Invalid(f"cannot read {path.name} ({_one_line(exc)})")

        def number(text: str) -> float | None:
            try:
                x = float(text)
            except ValueError:
                return None
            return x if math.isfinite(x) else None
        if rows and any(number(cell) is None for cell in rows[0][1]):
            rows = rows[1:]                           # the header
        points, lines = [], []
        for line, row in rows:
            cells = [number(cell) for cell in row]
            if len(cells) != 2 or None in cells:
                raise _Invalid(f"{path.name} line {line}: expected two numbers (plastic strain, yield stress), "
                               f"got {_show(','.join(row))}")
            points.append((cells[0], cells[1]))
            lines.append(line)
        return path, _curve_points(points, lambda i: f"{path.name} line {lines[i]}")

    def section(self, data: Any, path: str = "[section]") -> Section | None:
        """A section: one material over the thickness (`thickness`, `points`, `rule`), or
        layered (`plies`, `points_per_ply`; docs/laminates.md)."""
        mark = len(self.messages)
        if not _layered_table(data):
            v = self.read(path, data, _SECTION, Section, extra=tuple(_LAYERED_ONLY))
            if v is None:
                return None
            for key in _LAYERED_ONLY:
                if key in data:
                    self.error(f"{path}.{key}", "only for a layered section (with plies)")
            if v.get("rule") == "lobatto" and v.get("points") == 1:
                self.error(f"{path}.points", "expected an integer in [2, 10] for rule = lobatto, got 1")
            return self.build(mark, Section, v)
        spec = {key: check for key, check in _SECTION.items() if key not in _SINGLE_ONLY}
        v = self.read(path, data, {**spec, **_LAYERED_ONLY}, extra=("plies", *_SINGLE_ONLY))
        defaults = {f.name: f.default for f in fields(Section) if f.default is not MISSING}
        for key in _SINGLE_ONLY:
            if key in data:
                self.error(f"{path}.{key}", "a layered section takes it from its plies (thickness: their sum; "
                                            "points: points_per_ply Gauss points in each): leave it out")
        plies = self.plies(f"{path}.plies", data["plies"])
        if plies is None:
            return None
        v = {**defaults, **v, "plies": plies, "thickness": math.fsum(p.thickness for p in plies), "rule": "gauss"}
        v["points"] = len(plies) * v["points_per_ply"]
        return self.build(mark, Section, v)

    def plies(self, path: str, value: Any) -> tuple[Ply, ...] | None:
        """The `plies` array of a layered section: tables {material, thickness, angle}, bottom to top."""
        if not (isinstance(value, list) and 0 < len(value) <= MAX_PLIES):
            self.error(path, f"expected an array of 1 to {MAX_PLIES} ply tables "
                             f"{{material = \"NAME\", thickness = t, angle = degrees}}, got {_show(value)}")
            return None
        plies = [self.table_object(f"{path}[{i}]", item, Ply, _PLY) for i, item in enumerate(value)]
        return tuple(plies) if all(p is not None for p in plies) else None

    def named(self, key: str, reader) -> dict:
        """The [key.NAME] tables read by reader(path, data), by name (invalid ones left out)."""
        data = self.raw.get(key, {})
        if not isinstance(data, dict):
            self.error(f"[{key}]", f"expected tables [{key}.NAME], got {_show(data)}")
            return {}
        out = {}
        for name, value in data.items():
            path = f"[{key}.{_key(name)}]"
            if not _TOML_BARE_KEY.fullmatch(name):
                self.error(path, "a name may contain only letters, digits, '_' and '-'")
                continue
            item = reader(path, value)
            if item is not None:
                out[name] = item
        return out

    def parts(self, mesh):
        """[material]/[section] (one part), or [materials.NAME], [sections.NAME], [elementsets.NAME]
        and [[part]]; an LS-DYNA deck may supply all of them (assembly.py)."""
        raw = self.raw
        deck = isinstance(mesh, FileMesh) and mesh.path.suffix.lower() in DECK_SUFFIXES
        legacy = [k for k in ("material", "section") if k in raw]
        named = [k for k in ("materials", "sections", "part") if k in raw]
        material = self.material_table("[material]", raw["material"]) if "material" in raw else None
        section = self.section(raw["section"]) if "section" in raw else None
        if section is not None and section.layered:
            self.error("[section].plies", "a layered section is a [sections.NAME] table: its plies name "
                                          "[materials.NAME] tables")
        materials = self.named("materials", self.material_table)
        sections = self.named("sections", lambda path, data: self.section(data, path))
        elementsets = [self.elementset(name, value) for name, value in
                       (raw.get("elementsets") if isinstance(raw.get("elementsets"), dict) else {}).items()]
        if "elementsets" in raw and not isinstance(raw["elementsets"], dict):
            self.error("[elementsets]", f"expected tables [elementsets.NAME], got {_show(raw['elementsets'])}")
        parts = self.array("part", self.part_entry)
        if legacy and named:
            self.error(f"[{legacy[0]}]", f"a scene has either [material] and [section] (one part) or "
                       f"[materials.NAME], [sections.NAME] and [[part]], not both (found [{named[0]}])")
        elif not legacy and not named and not deck:
            for key in ("material", "section"):
                self.error(f"[{key}]", f"missing required table (or [{key}s.NAME] tables with [[part]])")
        elif legacy:
            for key in ("material", "section"):
                if key not in raw:
                    self.error(f"[{key}]", "missing required table")
        elif "part" not in raw and not deck and ("materials" in raw or "sections" in raw) \
                and (len(raw.get("materials", {})) != 1 or len(raw.get("sections", {})) != 1) \
                and not _lone_layered_section(raw.get("sections")):
            self.error("[[part]]", "missing: with several [materials.NAME] or [sections.NAME], [[part]] entries "
                                   "say which elements get which")
        defined = list(raw["materials"]) if isinstance(raw.get("materials"), dict) else []   # valid or not
        for name, sec in sections.items():        # the plies' materials (a deck's are checked in assembly.py)
            for i, ply in enumerate(sec.plies):
                if ply.material not in defined and not deck:
                    self.error(f"[sections.{_key(name)}].plies[{i}].material", f"no [materials.{ply.material}]"
                               + _hint(ply.material, defined, "defined"))
        if "part" in raw:
            names = [p.name for p in parts if p is not None]
            for i, name in enumerate(names):
                if name in names[:i]:
                    self.error("[[part]]", f"duplicate part name {name!r}")
            for key in ("materials", "sections"):
                if key not in raw and not deck:
                    self.error(f"[{key}]", f"missing: [[part]] needs [{key}.NAME] tables")
            # names as written, valid or not: an invalid table is reported once, by its own check
            set_names = list(raw["elementsets"]) if isinstance(raw.get("elementsets"), dict) else []
            written = {key: list(raw[key]) if isinstance(raw.get(key), dict) else [] for key in ("materials", "sections")}
            for i, part in enumerate(parts):
                if part is None:
                    continue
                for key, table, label in (("material", written["materials"], "materials"),
                                          ("section", written["sections"], "sections")):
                    value = getattr(part, key)
                    if value is not None and table and value not in table and not deck:
                        self.error(f"[[part]][{i}].{key}", f"no [{label}.{value}]" + _hint(value, list(table), "defined"))
                section_of = sections.get(part.section)
                if section_of is not None and section_of.layered and part.material is not None:
                    self.error(f"[[part]][{i}].material", f"section {part.section!r} is layered (its plies name "
                                                          "their materials): leave material out")
                elif section_of is not None and not section_of.layered and part.material is None:
                    self.error(f"[[part]][{i}].material", f"missing required key (section {part.section!r} "
                                                          "is not layered)")
                if part.elements in set_names or part.elements == "all":
                    continue
                if not isinstance(mesh, FileMesh):
                    self.error(f"[[part]][{i}].elements", f"no [elementsets.{part.elements}]"
                               + _hint(part.elements, set_names + ["all"], "defined"))
        return material, section, materials, sections, [s for s in elementsets if s is not None], parts

    def elementset(self, name: str, data: Any) -> ElementSet | None:
        path = f"[elementsets.{_key(name)}]"
        mark = len(self.messages)
        if name == "all":
            self.error(path, "the name 'all' is predefined (every element); choose another name")
        elif not _TOML_BARE_KEY.fullmatch(name):
            self.error(path, "an element set name may contain only letters, digits, '_' and '-'")
        v = self.read(path, data, {"all": _true, "ids": _element_ids, "mesh": _nonempty}, extra=("box",))
        if v is None:
            return None
        given = [key for key in ("all", "box", "ids", "mesh") if key in data]
        if len(given) != 1:
            self.error(path, f"expected exactly one selector (all, box, ids, mesh), got {', '.join(given) or 'none'}")
            return None
        values = {"name": name, "kind": given[0]}
        if given[0] == "box":
            box = self.read(f"{path}.box", data["box"], {"min": _vec3, "max": _vec3}, required=("min", "max"))
            if box:
                self.check_order(f"{path}.box", box.get("min"), box.get("max"), ("min", "max"), strict=False)
                values.update(box_min=box.get("min"), box_max=box.get("max"))
        elif given[0] == "ids":
            values["ids"] = v.get("ids")
        elif given[0] == "mesh":
            values["mesh_set"] = v.get("mesh")
        return self.build(mark, ElementSet, values)

    def part_entry(self, path: str, data: Any) -> Part | None:
        return self.table_object(path, data, Part, {"name": _identifier, "material": _nonempty,
                                                    "section": _nonempty, "elements": _nonempty})

    def method(self, data: Any) -> Method | None:
        mark = len(self.messages)
        v = self.read("[method]", data, _METHOD, Method)
        if v is None:
            return None
        if ("grid_min" in data) != ("grid_max" in data):
            missing = "grid_max" if "grid_min" in data else "grid_min"
            self.error(f"[method].{missing}", "missing required key (grid_min and grid_max come together)")
        self.check_order("[method]", v.get("grid_min"), v.get("grid_max"), ("grid_min", "grid_max"),
                         strict=True)
        if v.get("field_contact") == "grid" and v.get("fields") != "multi":
            self.error("[method].field_contact", '"grid" acts between the fields of a multi-field grid: set fields = "multi"')
        if "field_friction" in data and v.get("field_contact") != "grid":
            self.error("[method].field_friction", 'the friction of the grid contact condition: set field_contact = "grid"')
        return self.build(mark, Method, v)

    def nodesets(self, data: Any) -> list[NodeSet | None]:
        if not isinstance(data, dict):
            self.error("[nodesets]", f"expected a table of node sets, got {_show(data)}")
            return []
        return [self.nodeset(name, value) for name, value in data.items()]

    def nodeset(self, name: str, data: Any) -> NodeSet | None:
        path = f"[nodesets.{_key(name)}]"
        mark = len(self.messages)
        if name == "all":
            self.error(path, "the name 'all' is predefined (every node); choose another name")
        elif not _TOML_BARE_KEY.fullmatch(name):
            self.error(path, "a node set name may contain only letters, digits, '_' and '-'")
        v = self.read(path, data, {"all": _true, "nearest": _vec3, "ids": _node_ids, "tol": _positive},
                      extra=("box", "plane"))
        if v is None:
            return None
        given = [key for key in _SELECTORS if key in data]
        if len(given) != 1:
            self.error(path, f"expected exactly one selector ({', '.join(_SELECTORS)}), "
                             f"got {', '.join(given) or 'none'}")
            return None
        kind = given[0]
        if "tol" in data and kind != "box":
            self.error(f"{path}.tol", "allowed only beside box (a plane takes its tol inside plane = {...})")
        values = {"name": name, "kind": kind, **({"tol": v["tol"]} if "tol" in v else {})}
        if kind == "box":
            box = self.read(f"{path}.box", data["box"], {"min": _vec3, "max": _vec3}, required=("min", "max"))
            if box:
                self.check_order(f"{path}.box", box.get("min"), box.get("max"), ("min", "max"), strict=False)
                values.update(box_min=box.get("min"), box_max=box.get("max"))
        elif kind == "plane":
            plane = self.read(f"{path}.plane", data["plane"],
                              {"point": _vec3, "normal": _nonzero_vec3, "tol": _positive},
                              required=("point", "normal"))
            values.update(plane or {})
        elif kind == "nearest":
            values["point"] = v.get("nearest")
        elif kind == "ids":
            values["ids"] = v.get("ids")
        return self.build(mark, NodeSet, values)

    def boundary(self, path: str, data: Any) -> Boundary | None:
        mark = len(self.messages)
        v = self.read(path, data, {"nodes": self.nodes, "fix": _dofs(allow_all=True),
                                   "symmetry": _choice("x", "y", "z")}, Boundary)
        if v is None:
            return None
        if "fix" not in data and "symmetry" not in data:
            self.error(path, "expected fix and/or symmetry")
        return self.build(mark, Boundary, v)

    def load(self, path: str, data: Any) -> Load | None:
        mark = len(self.messages)
        v = self.read(path, data, {"nodes": self.nodes, "force": _vec3, "moment": _vec3,
                                   "distribute": _choice("area", "equal", "length"), "curve": self.curve_name,
                                   "follower": _bool, "force_per_length": _vec3, "moment_per_length": _vec3}, Load)
        if v is None:
            return None
        total = [k for k in ("force", "moment") if k in data]
        line = [k for k in ("force_per_length", "moment_per_length") if k in data]
        if total and line:
            self.error(path, f"give either force/moment (totals) or force_per_length/moment_per_length "
                             f"(a line load), got {', '.join(total + line)}")
        elif line:
            if data.get("distribute", "length") != "length":
                self.error(f"{path}.distribute", f'a line load is distributed by length, got {_show(data["distribute"])}')
            v["distribute"] = "length"
            if v.get("force_per_length") == (0, 0, 0) and v.get("moment_per_length") == (0, 0, 0):
                self.error(path, "force_per_length and moment_per_length are both zero")
        elif v.get("force") == (0, 0, 0) and v.get("moment") == (0, 0, 0):
            self.error(path, "force and moment are both zero (give a non-zero force and/or moment)")
        return self.build(mark, Load, v)

    def curve(self, path: str, data: Any) -> Curve | None:
        mark = len(self.messages)
        v = self.read(path, data, {"points": _time_curve_points, "file": self.file, "shape": _choice(*CURVE_SHAPES),
                                   "start": _number(), "end": _number(), "scale": _number()})
        if v is None:
            return None
        given = [key for key in ("points", "file", "shape") if key in data]
        if len(given) != 1:
            self.error(path, f"expected exactly one of points, file, shape, got {', '.join(given) or 'none'}")
            return None
        shape = v.get("shape")
        for key in ("start", "end"):
            if key in data and data.get("shape") not in ("ramp", "smooth_step"):
                self.error(f"{path}.{key}", 'allowed only with shape = "ramp" or "smooth_step"')
        if shape in ("ramp", "smooth_step"):
            if "end" not in data:
                self.error(f"{path}.end", f'missing required key for shape = "{shape}"')
            elif "start" in v and "end" in v and v["start"] >= v["end"]:
                self.error(path, f"expected start < end, got start = {v['start']:g}, end = {v['end']:g}")
        values = {"name": path[len("[curves."):-1], "kind": shape or "points",
                  **{k: v[k] for k in ("start", "end", "scale") if k in v}}
        if "file" in v:
            from .curves import CurveFileError, read_table
            try:
                values["points"] = _increasing(read_table(v["file"]))
                values["file"] = v["file"]
            except (CurveFileError, _Invalid) as exc:
                self.error(f"{path}.file", str(exc))
        elif "points" in v:
            values["points"] = v["points"]
        return self.build(mark, Curve, values)

    def motion(self, path: str, data: Any, solve: Solve | None, curves: dict[str, Curve]) -> Motion | None:
        mark = len(self.messages)
        v = self.read(path, data, {"name": _identifier, "nodes": self.nodes, "dofs": _dofs(allow_all=True),
                                   "kind": _choice(*MOTION_KINDS), "value": _numbers, "curve": self.curve_name,
                                   "body": _identifier}, Motion)
        if v is None:
            return None
        if ("nodes" in data) == ("body" in data):
            self.error(f"{path}.nodes", "give one of nodes (a node set) or body (a [[rigid_body]])")
        if "body" in data:
            listed = self.raw.get("rigid_body", [])
            bodies = {b["name"]: b for b in (listed if isinstance(listed, list) else [])
                      if isinstance(b, dict) and isinstance(b.get("name"), str)}
            if v.get("body") is not None and v["body"] not in bodies:
                self.error(f"{path}.body", f"no [[rigid_body]] named {v['body']!r}"
                           + _hint(v["body"], list(bodies), "defined"))
            elif v.get("body") is not None and "direction" in bodies[v["body"]]:
                self.error(f"{path}.body", f"the [[rigid_body]] {v['body']!r} translates along its direction only: "
                                           "a body with a prescribed motion has six DOFs (leave out direction)")
            if solve is not None and solve.kind == "static":
                self.error(f"{path}.body", "a body's motion is prescribed in dynamic runs only")
        dofs, value, kind, curve = v.get("dofs"), v.get("value"), v.get("kind"), v.get("curve")
        if dofs is not None and value is not None:
            if len(value) == 1:
                v["value"] = value * len(dofs)
            elif len(value) != len(dofs):
                self.error(f"{path}.value", f"expected one number or one per DOF ({len(dofs)}), got {len(value)}")
        if solve is not None and kind is not None:
            if solve.kind == "static" and kind != "displacement":
                self.error(f"{path}.kind", f'a static solve prescribes displacements only, got {_show(kind)}')
            elif solve.kind == "dynamic" and kind == "displacement":
                if "curve" not in data:
                    self.error(f"{path}.curve", "missing: a displacement in a dynamic run needs a curve "
                                                "(a constant displacement would jump at t = 0)")
                elif curve in curves and not self.messages:     # an invalid curve (start >= end, ...) is reported already
                    from .curves import evaluate
                    start = evaluate(curves[curve], 0.0)
                    if start != 0.0:
                        self.error(f"{path}.curve", f"the displacement curve {curve!r} is {start:g} at t = 0, not 0 "
                                                    "(the nodes would jump at t = 0)")
        return self.build(mark, Motion, v)

    def pressure(self, path: str, data: Any, mesh, elementsets) -> Pressure | None:
        mark = len(self.messages)
        v = self.read(path, data, {"elements": _nonempty, "value": _nonzero, "curve": self.curve_name}, Pressure)
        if v is None:
            return None
        names = [s.name for s in elementsets]
        if "elements" in v and v["elements"] != "all" and v["elements"] not in names and not isinstance(mesh, FileMesh):
            self.error(f"{path}.elements", f"no [elementsets.{v['elements']}]"
                       + _hint(v["elements"], names + ["all"], "defined"))
        return self.build(mark, Pressure, v)

    def rigid_body(self, path: str, data: Any) -> RigidBody | None:
        mark = len(self.messages)
        v = self.read(path, data, {
            "name": _identifier, "nodes": self.nodes, "mass": _non_negative, "direction": _nonzero_vec3,
            "inertia": _inertia, "center": _vec3, "mass_from_nodes": _bool, "velocity": _vec3, "spin": _vec3,
            "fixed": _dofs(allow_all=False)}, RigidBody)
        if v is None:
            return None
        if v.get("direction") is not None:
            for key in ("fixed", "spin", "inertia"):
                if key in data:
                    self.error(f"{path}.{key}", "a body with a direction translates along it only (its rotations "
                                                "are held): leave out direction for a 6-DOF body")
        if v.get("mass_from_nodes") is False and "mass" in v and not v["mass"] > 0.0:
            self.error(f"{path}.mass", "must be > 0 with mass_from_nodes = false (it is the body's whole mass)")
        return self.build(mark, RigidBody, v)

    def point_mass(self, path: str, data: Any) -> PointMass | None:
        mark = len(self.messages)
        v = self.read(path, data, {"name": _identifier, "nodes": self.nodes, "mass": _non_negative,
                                   "total_mass": _non_negative, "inertia": _non_negative}, PointMass)
        if v is None:
            return None
        if ("mass" in data) == ("total_mass" in data):
            self.error(f"{path}.mass", "give one of mass (each node's) or total_mass (shared equally by the nodes)")
        return self.build(mark, PointMass, v)

    def wall(self, path: str, data: Any) -> Wall | None:
        mark = len(self.messages)
        v = self.read(path, data, {"point": _vec3, "normal": _nonzero_vec3, "moves_with": _identifier}, Wall)
        if v is None:
            return None
        listed = self.raw.get("rigid_body", [])
        bodies = [b["name"] for b in (listed if isinstance(listed, list) else [])
                  if isinstance(b, dict) and isinstance(b.get("name"), str)]
        if v.get("moves_with") is not None and v["moves_with"] not in bodies:
            self.error(f"{path}.moves_with", f"no [[rigid_body]] named {v['moves_with']!r}"
                       + _hint(v["moves_with"], bodies, "defined"))
        return self.build(mark, Wall, v)

    def penalty_damping(self, path: str, stiffness: float, damping: float) -> None:
        """A penalty law's damping within penalty_damping_limit(stiffness)."""
        if damping > penalty_damping_limit(stiffness) * (1.0 + 1e-12):
            self.error(f"{path}.damping", f"{damping:g} with stiffness = {stiffness:g}: stiffness + 2 damping "
                       f"sqrt(stiffness) must be <= 2, else a node bounces back faster than it came; at most "
                       f"{penalty_damping_limit(stiffness):.3g} at this stiffness (docs/contact.md)")

    def tool(self, path: str, data: Any, solve: Solve | None, curves: dict[str, Curve]) -> Tool | None:
        """A [[tool]]: its kind's keys (a key of another kind is an error), at most one way to
        move, a surface mesh read here (so that an unusable file is a scene error)."""
        mark = len(self.messages)
        v = self.read(path, data, {"name": _identifier, "kind": _choice(*TOOL_KINDS), "center": _vec3,
                                   "normal": _nonzero_vec3, "axis": _nonzero_vec3, "radius": _positive,
                                   "length": _positive, "size": _size2, "file": self.file, "scale": _positive,
                                   "stiffness": _number(0, 1, lo_open=True), "damping": _unit_interval,
                                   "friction": _non_negative, "moves_with": _identifier, "velocity": _vec3,
                                   "displacement": _vec3, "curve": self.curve_name}, Tool)
        if v is None:
            return None
        kind = v.get("kind")
        if kind in _TOOL_KEYS:
            required, optional = _TOOL_KEYS[kind]
            own = (*required, *optional)
            for name in data:
                if name in _TOOL_SHAPE_KEYS and name not in own:
                    self.error(f"{path}.{_key(name)}", f'not used by kind = "{kind}" (its keys: {", ".join(own)})')
            for name in required:
                if name not in data:
                    self.error(f"{path}.{name}", f'missing required key for kind = "{kind}"')
            if kind == "rectangle" and v.get("axis") is not None and v.get("normal") is not None:
                (a1, a2, a3), (n1, n2, n3) = v["axis"], v["normal"]
                cross = math.hypot(a2 * n3 - a3 * n2, a3 * n1 - a1 * n3, a1 * n2 - a2 * n1)
                if cross <= 1e-9 * math.hypot(a1, a2, a3) * math.hypot(n1, n2, n3):
                    self.error(f"{path}.axis", "is parallel to normal (it gives the direction of the first side, "
                                               "in the rectangle's plane)")
        self.penalty_damping(path, v.get("stiffness", Tool.stiffness), v.get("damping", Tool.damping))
        moving = [key for key in ("moves_with", "velocity", "displacement") if key in data]
        if len(moving) > 1:
            self.error(f"{path}.{moving[1]}", f"a tool moves one way: give one of moves_with, velocity, "
                                              f"displacement, got {', '.join(moving)}")
        if "curve" in data and not ({"velocity", "displacement"} & set(data)):
            self.error(f"{path}.curve", "only with velocity or displacement (the curve scales them)")
        if v.get("moves_with") is not None:
            listed = self.raw.get("rigid_body", [])
            bodies = [b["name"] for b in (listed if isinstance(listed, list) else [])
                      if isinstance(b, dict) and isinstance(b.get("name"), str)]
            if v["moves_with"] not in bodies:
                self.error(f"{path}.moves_with", f"no [[rigid_body]] named {v['moves_with']!r}"
                           + _hint(v["moves_with"], bodies, "defined"))
        if solve is not None and solve.kind == "static" and ({"velocity", "displacement"} & set(data)):
            self.error(f"{path}.{'velocity' if 'velocity' in data else 'displacement'}",
                       'a tool moved by a curve needs [solve].kind = "dynamic"')
        if "displacement" in data and len(self.messages) == mark:
            if "curve" not in data:
                self.error(f"{path}.curve", "missing: a displacement needs a curve (a constant displacement "
                                            "would jump at t = 0)")
            elif v.get("curve") in curves:
                from .curves import evaluate
                start = evaluate(curves[v["curve"]], 0.0)
                if start != 0.0:
                    self.error(f"{path}.curve", f"the displacement curve {v['curve']!r} is {start:g} at t = 0, "
                                                "not 0 (the tool would jump at t = 0)")
        if kind == "mesh" and v.get("file") is not None and len(self.messages) == mark:
            from .tools import ToolMeshError, read_surface
            try:
                read_surface(v["file"], v.get("scale", 1.0))
            except ToolMeshError as exc:
                self.error(f"{path}.file", str(exc))
        return self.build(mark, Tool, v)

    def crush(self, data: Any, solve: Solve | None) -> Crush | None:
        mark = len(self.messages)
        v = self.read("[crush]", data, {"axis": _nonzero_vec3, "window": _window, "body": _identifier,
                                        "folds": _bool, "mean_force_reference": _force_references,
                                        "half_wavelength_reference": _positive}, Crush)
        if v is None:
            return None
        listed = self.raw.get("rigid_body", [])
        bodies = [b["name"] for b in (listed if isinstance(listed, list) else [])
                  if isinstance(b, dict) and isinstance(b.get("name"), str)]
        if not bodies:
            self.error("[crush]", "needs a [[rigid_body]] whose motion is the crush")
        elif v.get("body") is not None and v["body"] not in bodies:
            self.error("[crush].body", f"no [[rigid_body]] named {v['body']!r}" + _hint(v["body"], bodies, "defined"))
        if solve is not None and solve.kind != "dynamic":
            self.error("[crush]", "crush post-processing needs [solve].kind = \"dynamic\"")
        named = [x for x in v.get("mean_force_reference", ()) if isinstance(x, str)]
        mesh = self.raw.get("mesh")
        if named and not (isinstance(mesh, dict) and mesh.get("kind") == "tube"):
            self.error("[crush].mean_force_reference", f"{named[0]!r} is a formula for a tube: it needs "
                       "[mesh].kind = \"tube\" (its width and depth give the size C); give a number instead")
        return self.build(mark, Crush, v)

    def initial(self, path: str, data: Any) -> InitialVelocity | None:
        return self.table_object(path, data, InitialVelocity, {
            "nodes": self.nodes, "velocity": _vec3, "angular_velocity": _vec3, "center": _vec3})

    def probe(self, path: str, data: Any) -> Probe | None:
        mark = len(self.messages)
        v = self.read(path, data, {"name": _identifier, "nodes": self.nodes,
                                   "components": _dofs(allow_all=False)}, Probe)
        if v is None:
            return None
        name = v.get("name")
        if name in self.recorded:
            self.error(f"{path}.name", f"duplicate probe name {name!r}")
        elif name is not None:
            self.recorded[name] = v.get("components")
        return self.build(mark, Probe, v)

    def reference(self, data: Any) -> Reference | None:
        mark = len(self.messages)
        v = self.read("[reference]", data, {"file": self.file, "load_column": _nonempty, "floor": _fraction,
                                            "along": _choice("load", "path")},
                      Reference, extra=("compare",))
        if v is None:
            return None
        column = self.csv_column(v.get("file"))
        if "load_column" in v:
            self.check("[reference].load_column", column, v["load_column"])
        if "compare" not in data:
            self.error("[reference].compare", "missing required key (add [[reference.compare]] tables)")
        elif data["compare"] == []:
            self.error("[reference].compare", "expected at least one [[reference.compare]] table")
        spec = {"column": column, "probe": self.probe_component, "scale": _nonzero}
        compare = [self.table_object(p, d, ReferenceColumn, spec)
                   for p, d in self.entries("[[reference.compare]]", data.get("compare", []))]
        if len(self.messages) == mark and v.get("file") is not None:
            # the columns the comparison reads: every cell a finite number (the run reads them at its end)
            from .reference import table_problems
            try:
                problems = table_problems(v["file"], [v["load_column"], *(c.column for c in compare)])
            except (OSError, UnicodeDecodeError, csv.Error) as exc:
                problems = [f"cannot read {v['file'].name} ({_one_line(exc)})"]
            for problem in problems:
                self.error("[reference].file", problem)
        return self.build(mark, Reference, {**v, "compare": tuple(compare)})

    def newton_checks(self, v: dict, data: dict) -> None:
        """[solve] keys of the Newton solver (issue 19) against the rest of the scene."""
        raw = self.raw
        if v.get("solver") == "newton":
            method = raw.get("method", {})
            element = raw.get("element", {})
            if v.get("kind") == "dynamic":
                self.error("[solve].solver", '"newton" solves static scenes (kind = "static")')
            if isinstance(method, dict) and method.get("kind", "mpm") == "mpm":
                self.error("[solve].solver", '"newton" runs in fem mode: set [method].kind = "fem" (mpm statics keep '
                           '"relaxation"; why: docs/newton.md)')
            if isinstance(element, dict) and element.get("drilling") == "projection":
                self.error("[solve].solver", '"newton" needs the drilling spring ([element].drilling = "penalty"): the '
                           "projection leaves the drilling rotation without stiffness")
            for key in ("rigid_body", "wall", "tool", "contact", "motion", "pressure", "gravity"):
                if key in raw:       # loads and constraints the element pass of the tangent does not see
                    self.error("[solve].solver", f'"newton" does not handle [{key}] (use "relaxation")')
            loads = raw.get("load", [])
            for k, load in enumerate(loads if isinstance(loads, list) else []):
                if isinstance(load, dict) and (load.get("curve") or load.get("follower")):
                    self.error(f"[[load]] {k + 1}", '"newton" takes dead loads proportional to the load factor: no '
                               'curve or follower (use "relaxation")')
        else:
            for key in ("control", "control_nodes", "control_displacement", "arc_length", "max_load_factor",
                        "target_iterations", "max_iterations", "max_cutbacks", "increment_tolerance",
                        "energy_tolerance"):
                if key in data:
                    self.error(f"[solve].{key}", 'is a key of the Newton solver: set solver = "newton"')
        control = v.get("control")
        if control == "displacement":
            if "control_nodes" not in data:
                self.error("[solve].control_nodes", 'missing required key for control = "displacement" (the node '
                                                    "set whose control_dof is prescribed)")
            if "control_displacement" not in data:
                self.error("[solve].control_displacement", 'missing required key for control = "displacement" '
                                                           "(the final mean value of control_dof)")
            elif data["control_displacement"] == 0:
                self.error("[solve].control_displacement", 'expected a non-zero number for control = '
                                                           '"displacement", got 0')
        elif data.get("control_displacement") and not data.get("control_nodes"):
            self.error("[solve].control_nodes", "missing: control_displacement needs the node set it applies to")

    def solve(self, data: Any) -> Solve | None:
        mark = len(self.messages)
        v = self.read("[solve]", data, {**_SOLVE, "control_nodes": self.nodes}, Solve)
        if v is None:
            return None
        self.newton_checks(v, data)
        if v.get("kind") == "dynamic" and v.get("end_time") == 0:
            if "end_time" in data:
                self.error("[solve].end_time", "expected a number > 0 for a dynamic solve, got 0")
            else:
                self.error("[solve].end_time", "missing required key (a dynamic solve needs end_time > 0)")
        scaling = data.get("mass_scaling") if isinstance(data, dict) else None
        if v.get("kind") == "dynamic" and scaling == "uniform_dt":
            self.error("[solve].mass_scaling", 'expected "auto", "selective", "conventional" or "none" for a dynamic '
                       'solve, got "uniform_dt" (fictitious masses change the dynamics; they are for static solves)')
        if v.get("kind") == "static" and scaling in ("selective", "conventional"):
            self.error("[solve].mass_scaling", f'expected "auto", "uniform_dt" or "none" for a static solve, got '
                       f'"{scaling}" (mass scaling to a target step is for dynamic solves)')
        method = self.raw.get("method", {})
        if scaling == "selective" and isinstance(method, dict) and method.get("kind", "mpm") == "mpm":
            self.error("[solve].mass_scaling", '"selective" needs [method].kind = "fem" (in mpm the grid solves '
                       'with lumped masses: use "conventional"; docs/mass_scaling.md)')
        if scaling in ("selective", "conventional") and "target_dt" not in data:
            self.error("[solve].target_dt", f'missing required key for mass_scaling = "{scaling}"')
        if isinstance(data, dict):
            for key, kinds in (("target_dt", ("selective", "conventional")), ("added_mass_limit", ("conventional",)),
                               ("sms_tolerance", ("selective",)), ("sms_max_iterations", ("selective",))):
                if key in data and scaling not in kinds:
                    self.error(f"[solve].{key}", "only with mass_scaling = " + " or ".join(f'"{k}"' for k in kinds))
        if v.get("kind") == "static" and not any(self.raw.get(k) for k in ("load", "motion", "pressure", "gravity")):
            self.error("[[load]]", "a static solve needs at least one [[load]], [[motion]], [[pressure]] or [gravity]")
        return self.build(mark, Solve, v)
