"""Scene + mesh -> the numerical model as plain numpy arrays (no Taichi here).

Everything that is computed once before time stepping lives here: element reference
areas and frozen CPDI2 corner weights (method.md 2.1), each element's section and material
data and the tables they index (the parts), lumped corner mass and scaled rotary inertia
(2.3), boundary-condition masks (2.4-2.5), the reference load vector, initial velocities
and the background-grid geometry.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from . import laminate, materials
from .loading import Loading, assemble_loading
from .mesh import Mesh
from .nodesets import select_nodes
from .scene import DOFS, Scene, SceneError, inertia_tensor
from .tools import ToolTable, build_tools

AXES = {"x": 0, "y": 1, "z": 2}
SYMMETRY_FIXES = {0: ("ux", "ry", "rz"), 1: ("uy", "rx", "rz"), 2: ("uz", "rx", "ry")}


KEY_BITS = 21
"""Bits of one axis in a grid node's hash key (stages/grid.py): stencil bases from -2^20 to
2^20 - 2 cells, i.e. +-2.6 km at h = 2.5 mm."""


@dataclass(frozen=True)
class GridGeometry:
    """Background grid: node (i, j, k) sits at (i, j, k) * h.  Unbounded [choice, issue 20]:
    only the grid nodes of the shell's stencils exist (stages/grid.py), so the cells a stencil
    base may take are limited only by the hash key's range, or by the optional grid box."""
    h: float
    bound_lo: tuple[int, int, int]
    bound_hi: tuple[int, int, int]
    """The stencil base cells allowed, inclusive: the [method] grid box, or the key range."""
    planes: tuple[tuple[int, int], ...]
    """Symmetry grid planes as (axis, absolute grid index)."""
    free_nodes: int
    """Shell nodes that move through the grid (not prescribed): the grid's size class."""
    slab_axis: int = 0
    """The axis of the mesh's longest extent: P2G bins the shell nodes into grid slabs across
    it (stages/mapping.py), so the most slabs hold nodes."""


@dataclass(frozen=True)
class ProbeSpec:
    name: str
    nodes: np.ndarray
    components: tuple[str, ...]


@dataclass(frozen=True)
class RigidBodySpec:
    name: str
    nodes: np.ndarray
    added_mass: float
    direction: tuple[float, float, float] | None   # unit: translation along it only (rotations held)
    total_mass: float                       # added + slave nodes (or the scene's, mass_from_nodes = false)
    velocity0: np.ndarray                   # (3,) initial centre velocity
    center: np.ndarray                      # (3,) reference centre X_c (the mass centre unless given)
    inertia: np.ndarray                     # (3, 3) about X_c, global axes at t = 0 (= the body frame)
    added_inertia: np.ndarray               # (3, 3) the scene's share of it
    spin0: np.ndarray                       # (3,) initial angular velocity
    translation_free: np.ndarray            # (3, 3) projector on the free translations (d d^T along a direction)
    rotation_free: np.ndarray               # (3, 3) projector on the free rotations (diagonal 0/1)
    turned: bool = False                    # a [[motion]] prescribes its rotations
    stable_step: float = math.inf           # the step its mass and inertia allow on its elements (body_step)

    @property
    def rotates(self) -> bool:
        return bool(self.rotation_free.any()) or self.turned

    @property
    def turns_freely(self) -> bool:
        """All three rotations free (stages/bodies.py's Simo-Wong drift)."""
        return bool(np.diag(self.rotation_free).all())

    @property
    def inertia_min(self) -> float:
        """The smallest principal inertia about the free rotation axes (0: none free)."""
        free = np.diag(self.rotation_free) > 0
        return float(np.linalg.eigvalsh(self.inertia[np.ix_(free, free)]).min()) if free.any() else 0.0


@dataclass(frozen=True)
class PointMassSpec:
    name: str
    nodes: np.ndarray
    mass: float                             # per node
    inertia: float                          # rotary, per node


@dataclass(frozen=True)
class WallSpec:
    point: tuple[float, float, float]
    normal: tuple[float, float, float]      # unit
    body: int                               # index of the rigid body it moves with, -1 = fixed


@dataclass(frozen=True)
class PartSpec:
    name: str
    elements: np.ndarray                    # element ids
    material: str | None                    # None: a layered section (its plies name their materials)
    section: str


@dataclass(frozen=True)
class ElementData:
    """Each element's section and material data (state.sections), from its part."""
    part: np.ndarray                        # (m,) part index
    section: np.ndarray                     # (m,) section index (into SectionTable)
    thickness: np.ndarray                   # (m,)
    shear_factor: np.ndarray                # (m,) kappa
    wave_speed: np.ndarray                  # (m,) plane-stress c_e of its stiffest material (physical density)
    rotational_frequency: np.ndarray        # (m,) sqrt(12 kappa G / rho) / t with physical rotary inertia, else 0
    # E, G below: the material's; a laminate's or an orthotropic material's effective isotropic
    # moduli (laminate.Layup: membrane E, bending E, mean transverse G)
    hourglass_membrane: np.ndarray          # (m,) r E t / 8      (stages/hourglass.py: x A beta -> C3)
    hourglass_bending: np.ndarray           # (m,) r E t^3 / 192  (x A beta -> C1)
    hourglass_transverse: np.ndarray        # (m,) r kappa G t^3 / 12 (x beta -> C2)
    drilling_factor: np.ndarray             # (m,) alpha E t^3 / 48 (stages/drilling.py: x A beta -> k)
    density: np.ndarray                     # (m,) mass per volume over the thickness (laminate.Layup)
    rotary_density: np.ndarray              # (m,) 12 I / t^3, I = int rho z^2 dz (= density for one material)
    material_axis: np.ndarray               # (m, 2) cos, sin of the angle from e1 to the section's material axis


@dataclass(frozen=True)
class SectionTable:
    """Through-thickness rules: point positions zeta in [-1, 1], weights (sum 2) and the
    material and ply angle of each point, per section (padded to the most points of any section)."""
    names: tuple[str, ...]
    point_count: np.ndarray                 # (ns,)
    zeta: np.ndarray                        # (ns, nk)
    weight: np.ndarray                      # (ns, nk)
    point_material: np.ndarray              # (ns, nk) material index
    point_angle: np.ndarray                 # (ns, nk) ply angle from the material axis, radians
    layered: np.ndarray                     # (ns,) bool: the points' materials come from plies

    @property
    def points(self) -> int:
        return self.zeta.shape[1]


@dataclass(frozen=True)
class MaterialTable:
    """One row of parameters per scene material (materials.py); ``kind`` indexes ``kinds``,
    the material models the scene uses (registry order); ``hardening`` and ``rate_laws``, the
    J2 flow-stress laws it uses; the tabulated hardening curves of all materials, one after
    the other (each row holds its curve's first point and count)."""
    names: tuple[str, ...]
    kinds: tuple[str, ...]
    kind: np.ndarray                        # (nm,)
    rows: np.ndarray                        # (nm, materials.row_width(kinds))
    dilatational_speed: float               # the largest of the paper's grid-rule speeds
    hardening: tuple[str, ...]              # materials.HARDENING_LAWS used (Features.hardening)
    rate_laws: tuple[str, ...]              # materials.RATE_LAWS used (Features.rate_laws)
    rate_filter: bool                       # some material filters its rate (Features.rate_filter)
    curve_strain: np.ndarray                # (points,) plastic strain of each curve point
    curve_stress: np.ndarray                # (points,) its yield stress
    erosion: bool = False                   # some material's elements can fail (Features.erosion)
    failure: np.ndarray | None = None       # (nm, 3) materials.failure_row of each (state.sections.failure)

    @property
    def plastic(self) -> bool:
        return any(materials.PLASTIC[k] for k in self.kinds)


@dataclass(frozen=True)
class StepParameters:
    """Run-time values of the step that are not per entity (state.step, state.contact)."""
    dt_safety: float
    flip_blend: float
    contact_thickness: float = 0.0      # t_c (no contact: 0)
    contact_stiffness: float = 0.0      # alpha_c
    contact_damping: float = 0.0
    contact_friction: float = 0.0
    field_gap: float = 0.0              # grid contact condition (stages/grid.py): t_c
    field_friction: float = 0.0         # and its Coulomb coefficient
    target_dt: float = 0.0              # mass scaling: the step (0: none)
    added_mass_cap: float = 0.0         # conventional: its limit on the added mass (0: none)
    sms_tolerance: float = 0.0          # selective: the solve's relative residual
    sms_max_iterations: int = 0         # and its iterations per step


@dataclass(frozen=True)
class Model:
    points: np.ndarray            # (n, 3) reference coordinates
    elements: np.ndarray          # (m, 4) corner ids; a triangle's 4th is -1
    parts: tuple[PartSpec, ...]
    element: ElementData
    sections: SectionTable
    materials: MaterialTable
    area0: np.ndarray             # (m,) reference element areas
    corner_weight: np.ndarray     # (m, 4) CPDI2 weights, frozen (paper eq 15)
    corner_mass: np.ndarray       # (m, 4) w_ea m_e: element e's share of its corners' masses
    corner_inertia: np.ndarray    # (m, 4) w_ea m_e arm_e: its share of their rotary inertias
    mass_factor: np.ndarray       # (m,) f_e >= 1 of selective mass scaling at the start (1: none)
    node_mass: np.ndarray         # (n,) sum of f_e x the corner shares
    node_inertia: np.ndarray      # (n,) scalar rotary inertia J_c
    node_area: np.ndarray         # (n,) tributary area sum_e w_ea A_e
    node_thickness: np.ndarray    # (n,) the thickest adjacent element's thickness (walls keep half of it)
    fix_mask: np.ndarray          # (n,) int bits 0..5 = ux uy uz rx ry rz fixed
    load_force: np.ndarray        # (n, 3) nodal force at load factor 1 (plain loads; the rest: loading)
    load_moment: np.ndarray       # (n, 3)
    velocity0: np.ndarray         # (n, 3)
    omega0: np.ndarray            # (n, 3)
    grid: GridGeometry | None     # None in fem mode
    probes: tuple[ProbeSpec, ...]
    min_edge: float
    mean_edge: float
    max_edge: float
    parameters: StepParameters | None = None
    notes: tuple[str, ...] = ()           # warnings of the assembly (e.g. an LS-DYNA card approximated)
    rigid_bodies: tuple[RigidBodySpec, ...] = ()
    point_masses: tuple[PointMassSpec, ...] = ()
    walls: tuple[WallSpec, ...] = ()
    tools: ToolTable | None = None        # rigid tools ([[tool]], tools.py); None: none
    node_body: np.ndarray | None = None   # (n,) rigid body index of each node, -1 = none
    neighbor_start: np.ndarray | None = None   # CSR: nodes sharing an element with node c (incl. c)
    neighbor_nodes: np.ndarray | None = None
    loading: Loading | None = None        # curve and follower loads, pressure, gravity, prescribed motion


def element_frames(points: np.ndarray, elements: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """e1, e2, e3 (each (m, 3)) of every element's BT frame at `points` (method.md 3.1): e3
    from the diagonals (a triangle: from edges 1-2 and 1-3), e1 along edge 1-2 projected."""
    quad = elements[:, 3] >= 0
    x = points[np.where(elements >= 0, elements, elements[:, :1])]     # (m, 4, 3), a triangle's 4th = 1st
    e3 = np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1])
    e3 = np.where(quad[:, None], e3, np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]))
    e3 /= np.linalg.norm(e3, axis=1)[:, None]
    r21 = x[:, 1] - x[:, 0]
    e1 = r21 - np.sum(r21 * e3, axis=1)[:, None] * e3
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    return e1, np.cross(e3, e1), e3


def cpdi2_weights(points: np.ndarray, elements: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Element areas and CPDI2 corner weights (method.md 2.1), in each element's projected
    local frame (e3 from the diagonals). A parallelogram gives 1/4 each; a triangle (a
    linear domain) 1/3 at each corner and 0 in the unused 4th column."""
    quad = elements[:, 3] >= 0
    x = points[np.where(elements >= 0, elements, elements[:, :1])]     # (m, 4, 3), a triangle's 4th = 1st
    e1, e2, e3 = element_frames(points, elements)
    centre = x.mean(axis=1)[:, None, :]
    lx = np.sum((x - centre) * e1[:, None, :], axis=2)
    ly = np.sum((x - centre) * e2[:, None, :], axis=2)

    def d(a, b):
        return lx[:, a] - lx[:, b], ly[:, a] - ly[:, b]

    x21, y21 = d(1, 0)
    x41, y41 = d(3, 0)
    x32, y32 = d(2, 1)
    x34, y34 = d(2, 3)
    c1 = x21 * y41 - y21 * x41
    c2 = x21 * y32 - y21 * x32
    c3 = x34 * y41 - y34 * x41
    c4 = x34 * y32 - y34 * x32
    area = (c1 + c2 + c3 + c4) / 4.0
    w = np.stack([4 * c1 + 2 * c2 + 2 * c3 + c4,
                  2 * c1 + 4 * c2 + c3 + 2 * c4,
                  c1 + 2 * c2 + 2 * c3 + 4 * c4,
                  2 * c1 + c2 + 4 * c3 + 2 * c4], axis=1) / (36.0 * np.where(quad, area, 1.0)[:, None])
    x31 = x[:, 2] - x[:, 0]
    area = np.where(quad, area, 0.5 * np.sum(np.cross(x[:, 1] - x[:, 0], x31) * e3, axis=1))
    w = np.where(quad[:, None], w, np.array([1.0, 1.0, 1.0, 0.0]) / 3.0)
    return area, w


def _edge_lengths(points, elements) -> np.ndarray:
    """Lengths of every element edge (a triangle's 3)."""
    nxt = np.roll(elements, -1, axis=1)
    tri = elements[:, 3] < 0
    nxt[tri, 2] = elements[tri, 0]
    valid = (elements >= 0) & (nxt >= 0)
    lengths = np.linalg.norm(points[np.where(valid, elements, 0)] - points[np.where(valid, nxt, 0)], axis=2)
    return lengths[valid]


def triangle_shear_gain(points: np.ndarray, elements: np.ndarray) -> np.ndarray:
    """g per element (1 for a quad): how stiffly a triangle's edge transverse shear
    (stages/triangle.py) ties its corner rotations, against the mean rotation of the quad's
    shear.  The rotation part of the shear rate is sum_a P_a beta_a with
    P_a = (1 / 2A) sum over the two edges k at corner a of (e3 x (m_k - centroid)) e_k^T;
    g = 3 sigma_max^2 of [P_1 P_2 P_3] (the mean rotation, P_a = I/3, gives 1): 1.25 for an
    equilateral triangle, 1.5 for a right isosceles one, growing without bound as a sliver
    flattens.  The rotary inertia (assemble) and the time step (stages/timestep.triangle_limit)
    scale with it."""
    gain = np.ones(len(elements))
    tri = np.flatnonzero(elements[:, 3] < 0)
    if not len(tri):
        return gain
    x = points[elements[tri, :3]]                                   # (k, 3, 3)
    normal = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    twice_area = np.linalg.norm(normal, axis=1)
    e3 = normal / twice_area[:, None]
    centre = x.mean(axis=1)
    p = np.zeros((len(tri), 3, 3, 3))                                # P_a, corner a
    for k in range(3):
        j = (k + 1) % 3
        lever = np.cross(e3, 0.5 * (x[:, k] + x[:, j]) - centre)
        term = lever[:, :, None] * (x[:, j] - x[:, k])[:, None, :]
        p[:, k] += term
        p[:, j] += term
    p /= twice_area[:, None, None, None]
    s = np.einsum("kaij,kalj->kil", p, p)
    gain[tri] = 3.0 * np.linalg.eigvalsh(s)[:, -1]
    return gain


def element_length(points: np.ndarray, elements: np.ndarray, area: np.ndarray) -> np.ndarray:
    """L_e of the element rule (method.md 5): area / longest diagonal of a quad; for a
    triangle 4A / sqrt(3 (l1^2 + l2^2 + l3^2)) = 2 / sqrt(3 beta) (stages/triangle.py); the
    host twin of the element stages' lengths."""
    x = points[np.where(elements >= 0, elements, elements[:, :1])]
    quad = elements[:, 3] >= 0
    diag = np.maximum(np.linalg.norm(x[:, 2] - x[:, 0], axis=1), np.linalg.norm(x[:, 3] - x[:, 1], axis=1))
    edges_sq = sum(np.sum((x[:, b] - x[:, a]) ** 2, axis=1) for a, b in ((0, 1), (1, 2), (2, 0)))
    return np.where(quad, area / diag, 4.0 * area / np.sqrt(3.0 * edges_sq))


def element_steps(points: np.ndarray, elements: np.ndarray, element: "ElementData", dt_safety: float) -> np.ndarray:
    """Each element's stable step in the configuration `points` with its physical mass: the
    host twin of stages/timestep.element_limit (quads) and triangle_limit (triangles)."""
    x = points[np.where(elements >= 0, elements, elements[:, :1])]
    d13, d24 = x[:, 2] - x[:, 0], x[:, 3] - x[:, 1]
    area = 0.5 * np.linalg.norm(np.cross(d13, d24), axis=1)
    longest = np.maximum(np.linalg.norm(d13, axis=1), np.linalg.norm(d24, axis=1))
    inv = np.maximum(element.wave_speed * longest / area, 0.5 * element.rotational_frequency)
    tri = elements[:, 3] < 0
    if tri.any():
        tri_area = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)
        inv_tri = element.wave_speed / element_length(points, elements, np.where(tri, tri_area, 1.0))
        inv_tri = np.sqrt(inv_tri ** 2 + triangle_shear_gain(points, elements) * (0.5 * element.rotational_frequency) ** 2)
        inv = np.where(tri, inv_tri, inv)
    return dt_safety / inv


def added_mass_geometry(x: np.ndarray, elements: np.ndarray, corner_mass: np.ndarray) -> tuple:
    """Selective mass scaling's element geometry at positions x (host twin of
    stages/selective_mass.SelectiveMass.geometry): the corners' arms r_a about the element's
    mass centre (m, 4, 3; 0 at a triangle's fourth), J^-1 (m, 3, 3) with
    J = sum_a m_a (|r_a|^2 I - r_a r_a^T), the unit normal (m, 3) and rho^2 = sum m_a |r_a|^2 / (2 m_e)."""
    valid = elements >= 0
    m = corner_mass * valid
    corner_x = x[np.where(valid, elements, 0)]
    mass = m.sum(axis=1)
    centre = np.einsum("ea,eak->ek", m, corner_x) / mass[:, None]
    arm = (corner_x - centre[:, None]) * valid[..., None]
    r2 = np.sum(arm ** 2, axis=2)
    inertia = (np.einsum("ea,ea->e", m, r2)[:, None, None] * np.eye(3)
               - np.einsum("ea,eak,eal->ekl", m, arm, arm))
    tri = ~valid[:, 3]
    normal = np.where(tri[:, None], np.cross(corner_x[:, 1] - corner_x[:, 0], corner_x[:, 2] - corner_x[:, 0]),
                      np.cross(corner_x[:, 2] - corner_x[:, 0], corner_x[:, 3] - corner_x[:, 1]))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    return arm, np.linalg.inv(inertia), normal, np.einsum("ea,ea->e", m, r2) / (2.0 * mass)


AUTO_TARGET_FACTOR = 10.0
"""``target_dt = "auto"``: the target step over the smallest element's own stable step at the
start [choice, issue 29]: the ratio the peers' selective scaling runs crash models at (the
box beam of the issue: 5 340 cycles against our 70 781 steps unscaled).  Measured at 10x
(docs/mass_scaling.md): the 16x2 strip's lowest period +0.57 %, the fem tube's mean crush
force +1.1 %, its fold count unchanged."""


def target_step(target_dt: float | str, steps: np.ndarray) -> float:
    """The target step of mass scaling: the scene's, or for "auto" AUTO_TARGET_FACTOR times the
    smallest of `steps` (each element's stable step at the start)."""
    return AUTO_TARGET_FACTOR * float(steps.min()) if target_dt == "auto" else float(target_dt)


def element_mass_factor(steps: np.ndarray, target_dt: float) -> np.ndarray:
    """Mass scaling [issue 18; conventional as LS-DYNA's DT2MS < 0]: the factor
    f_e = (target / dt_e)^2 of each element whose stable step dt_e is below the target (its
    step, which goes as 1/sqrt(mass), becomes the target), 1 for the others: the density
    factor of conventional scaling, 1 + beta_e of selective scaling (stages/selective_mass.py)."""
    return np.maximum(1.0, (target_dt / steps) ** 2)


def _grid_geometry(scene: Scene, points: np.ndarray, min_edge: float, planes_xyz, free_nodes: int) -> GridGeometry:
    m = scene.method
    h = m.cell_size if m.cell_size is not None else 0.5 * min_edge
    lo_pt, hi_pt = points.min(axis=0), points.max(axis=0)
    reach = 1 << (KEY_BITS - 1)
    bound_lo, bound_hi = np.full(3, -reach), np.full(3, reach - 2)
    if m.grid_min is not None:
        gmin, gmax = np.array(m.grid_min), np.array(m.grid_max)
        if np.any(lo_pt < gmin) or np.any(hi_pt > gmax):
            raise SceneError(f"{scene.source.name}: [method].grid_min/grid_max: the grid box does not "
                             f"cover the mesh (mesh spans {lo_pt.round(6).tolist()} .. {hi_pt.round(6).tolist()})")
        bound_lo = np.maximum(bound_lo, np.floor(gmin / h))
        bound_hi = np.minimum(bound_hi, np.floor(gmax / h))
    if np.any(np.floor(lo_pt / h) < bound_lo) or np.any(np.floor(hi_pt / h) > bound_hi):
        raise SceneError(f"{scene.source.name}: [method].cell_size: the mesh spans more than the grid's "
                         f"{reach} cells from the origin on some axis at cell_size {h:g}; use a larger "
                         "cell_size or move the mesh nearer to the origin")
    planes = []
    for axis, coord in planes_xyz:
        idx = coord / h
        if abs(idx - round(idx)) > 1e-9 * max(1.0, abs(idx)):
            raise SceneError(f"{scene.source.name}: [[boundary]].symmetry: the {'xyz'[axis]}-symmetry plane at "
                             f"{coord:g} is not a grid plane for cell_size {h:g}; choose a cell size dividing it")
        planes.append((axis, int(round(idx))))
    return GridGeometry(h=float(h), bound_lo=tuple(int(v) for v in bound_lo), bound_hi=tuple(int(v) for v in bound_hi),
                        planes=tuple(sorted(set(planes))), free_nodes=int(free_nodes),
                        slab_axis=int(np.argmax(hi_pt - lo_pt)))


def uniform_dt_mass_factor(points: np.ndarray, elements: np.ndarray, area0: np.ndarray) -> np.ndarray:
    """Static solves, [solve].mass_scaling = "uniform_dt" [choice, issue 4]: dynamic
    relaxation only needs *some* mass matrix, and its step count grows with the spread of
    the elements' own stable steps dt_e = alpha L_e / c (method.md 5), since the smallest
    element sets dt for all.  Scaling each element's density by (L_min / L_e)^2 raises its
    wave speed so that every element's dt_e equals the smallest one: the step does not
    change, the larger elements just stop being slower than they need to be.  Factors are
    <= 1 (1 on a uniform mesh)."""
    length = element_length(points, elements, area0)
    return (length.min() / length) ** 2


def _element_selection(name: str, scene: Scene, mesh: Mesh, points: np.ndarray, elements: np.ndarray,
                       path: str) -> np.ndarray:
    """The element ids `name` selects: "all", an [elementsets.NAME], or a set of the mesh file."""
    m = len(elements)
    if name == "all":
        return np.arange(m)
    where = f"{scene.source.name}: {path}.elements"
    sets = {s.name: s for s in scene.elementsets}
    if name in sets:
        spec = sets[name]
        where = f"{scene.source.name}: [elementsets.{name}]"
        if spec.kind == "all":
            ids = np.arange(m)
        elif spec.kind == "ids":
            ids = np.unique(np.asarray(spec.ids, dtype=np.int64))
            if ids.max() >= m:
                raise SceneError(f"{where}.ids: element {int(ids.max())} out of range (the mesh has {m} elements)")
        elif spec.kind == "box":
            x = points[np.where(elements >= 0, elements, elements[:, :1])]
            count = np.where(elements[:, 3] >= 0, 4, 3)
            centroid = np.where(elements[:, 3:4] >= 0, x.sum(axis=1), x[:, :3].sum(axis=1)) / count[:, None]
            inside = np.all((centroid >= np.asarray(spec.box_min) - 1e-12) & (centroid <= np.asarray(spec.box_max) + 1e-12),
                            axis=1)
            ids = np.flatnonzero(inside)
        else:
            ids = _mesh_set(spec.mesh_set, mesh, f"{where}.mesh")
        if not len(ids):
            raise SceneError(f"{where}: selects no element")
        return ids
    return _mesh_set(name, mesh, where, extra=tuple(sets))


def _mesh_set(name: str, mesh: Mesh, where: str, extra: tuple = ()) -> np.ndarray:
    if name in mesh.element_sets:
        return np.asarray(mesh.element_sets[name], dtype=np.int64)
    known = sorted(mesh.element_sets) + list(extra)
    hint = f" (sets: {', '.join(known[:12])}{' ...' if len(known) > 12 else ''})" if known else \
        " (the mesh has no element sets)"
    raise SceneError(f"{where}: no element set or mesh set named {name!r}{hint}")


def _deck_specs(deck, source: str):
    """Scene materials and sections for an LS-DYNA deck's parts (dyna.Deck): *MAT_001 elastic;
    *MAT_003 and *MAT_024 J2: a *MAT_024 stress-strain curve (LCSS or EPS/ES) is the tabulated
    hardening law, extrapolated beyond its last point as LS-DYNA does, else linear hardening
    H = E E_t / (E - E_t) from the tangent modulus; their Cowper-Symonds C and P (*MAT_003 SRC,
    SRP) the cowper_symonds rate law on the total strain rate (VP = 0, -1) or the plastic strain
    rate (VP = 1); FAIL (*MAT_003 FS) > 0 the failure strain (one point, LS-DYNA's NUMFIP
    default), *MAT_024 TDEL the failure step of erosion; *MAT_037 Hill 1948 (hill48) with
    r0 = r45 = r90 = |R| and linear hardening of its ETAN (the plastic hardening modulus, used
    as given) or its HLCID curve; *SECTION_SHELL thickness T1, NIP
    Gauss points (QR = 0; NIP = 0 means 2), QR = 1 (trapezoidal) as Lobatto with a note, SHRF.

    A deck's value is checked as strictly as the same scene key (scene.value_problem, the
    scene's own validator): the third result maps a scene name (mat_<mid>, sec_<secid>) to the
    problems of its card, each naming the deck file, line, keyword and field; the caller
    reports those of the cards its parts use (a card the scene replaces is not used)."""
    from .scene import Material, Section, value_problem
    materials, sections, notes, problems = {}, {}, [], {}

    def check(name: str, where: str, fields: tuple) -> None:
        """Each (deck field, scene table, scene key, value) against the scene's validator."""
        for deck_key, table, key, value in fields:
            problem = value_problem(table, key, value)
            if problem is not None:
                problems.setdefault(name, []).append(f"{where}: {deck_key} (the scene's {key}): {problem}")
    for mid, card in deck.materials.items():
        v = card.values
        E, nu, rho = v.get("e", 0.0), v.get("pr", 0.0), v.get("ro", 0.0)
        label = f"{card.where or source} (mid {mid})"
        check(f"mat_{mid}", label, (("RO", "material", "density", rho), ("E", "material", "E", E),
                                    ("PR", "material", "nu", nu)))
        if card.kind != "elastic" and not card.curve:
            etan = v.get("etan", 0.0)
            check(f"mat_{mid}", label, (("SIGY", "material", "yield_stress", v.get("sigy", 0.0)),))
            if card.kind == "transversely_anisotropic":
                check(f"mat_{mid}", label, (("ETAN", "material", "hardening", etan),))
            elif not 0.0 <= etan < E and E > 0.0:
                problems.setdefault(f"mat_{mid}", []).append(
                    f"{label}: ETAN = {etan:g}: expected 0 <= ETAN < E = {E:g} (the tangent modulus of the "
                    "plastic range; ETAN >= E has no hardening modulus H = E ETAN/(E - ETAN) >= 0)")
        if card.kind == "elastic":
            materials[f"mat_{mid}"] = Material(E=E, nu=nu, density=rho)
            continue
        keyword = {"piecewise_linear": "*MAT_024", "plastic_kinematic": "*MAT_003",
                   "transversely_anisotropic": "*MAT_037"}[card.kind]
        where = f"{source}: {keyword} {mid}"
        law = {"yield_stress": v.get("sigy", 0.0), "hardening": 0.0}
        if card.curve:
            law = {"hardening_law": "tabulated", "curve": _deck_curve(card.curve, where, notes),
                   "beyond_curve": "extrapolate" if len(card.curve) > 1 else "flat"}
        elif card.kind == "transversely_anisotropic":       # its ETAN is the plastic hardening modulus
            law["hardening"] = v.get("etan", 0.0)
        else:
            etan = v.get("etan", 0.0)
            law["hardening"] = E * etan / (E - etan) if 0.0 < etan < E else 0.0
        if card.kind == "transversely_anisotropic":          # Hill 1948 with normal anisotropy |R|
            r = abs(v.get("r", 0.0))
            check(f"mat_{mid}", label, (("R", "material", "r0", r),))
            if v.get("r", 0.0) < 0.0:
                notes.append(f"{where}: R = {v['r']:g} (LS-DYNA's stabilised algorithm) is read as r = {r:g}")
            materials[f"mat_{mid}"] = Material(E=E, nu=nu, density=rho, model="hill48", **law,
                                               model_parameters=(("r0", r), ("r45", r), ("r90", r)))
            continue
        C, P = (v.get("src", 0.0), v.get("srp", 0.0)) if card.kind == "plastic_kinematic" else \
            (v.get("c", 0.0), v.get("p", 0.0))
        if C > 0.0 and P > 0.0:
            vp = int(v.get("vp", 0.0))
            law.update(rate_law="cowper_symonds", C=C, p=P, rate_measure="plastic" if vp == 1 else "total")
            if vp not in (0, -1, 1):
                notes.append(f"{where}: VP = {vp} is read as VP = 0 (Cowper-Symonds on the total strain rate)")
        if card.kind == "piecewise_linear" and int(v.get("lcsr", 0)) > 0:
            notes.append(f"{where}: the strain-rate scaling curve LCSR {int(v['lcsr'])} is not read")
        fail = v.get("fs", 0.0) if card.kind == "plastic_kinematic" else v.get("fail", 0.0)
        if 0.0 < fail < 1e20:                 # LS-DYNA's default 1e21 (and 0): no failure
            law["failure_strain"] = fail
        elif fail < 0.0:
            notes.append(f"{where}: FAIL/FS = {fail:g} (a user failure subroutine) is not read")
        if card.kind == "piecewise_linear" and v.get("tdel", 0.0) > 0.0:
            law["failure_min_dt"] = v["tdel"]
        materials[f"mat_{mid}"] = Material(E=E, nu=nu, density=rho, model="j2", **law)
    for secid, card in deck.sections.items():
        label = f"{card.where or source} (secid {secid})"
        check(f"sec_{secid}", label, (("T1", "section", "thickness", card.thickness),
                                      ("NIP", "section", "points", int(card.nip)),
                                      ("SHRF", "section", "shear_factor", card.shear_factor)))
        points = int(card.nip) if card.nip > 0 else 2             # NIP = 0: LS-DYNA's default, 2
        rule = "gauss"
        if card.quadrature == 1 and points > 1:
            rule = "lobatto"
            notes.append(f"{source}: *SECTION_SHELL {secid}: QR = 1 (trapezoidal) is integrated with the "
                         f"{points}-point Lobatto rule (both have points on the two surfaces)")
        elif card.quadrature != 0:
            notes.append(f"{source}: *SECTION_SHELL {secid}: QR = {card.quadrature} (a user rule) is not read: "
                         f"{points}-point Gauss rule")
        sections[f"sec_{secid}"] = Section(thickness=card.thickness, points=points, rule=rule,
                                           shear_factor=card.shear_factor)
    return materials, sections, notes, problems


def _deck_curve(curve, where: str, notes: list) -> tuple[tuple[float, float], ...]:
    """A *MAT_024 stress-strain curve as a tabulated hardening curve (keys.curve_points):
    starting at plastic strain 0 (its first stress there if it starts later), points that do
    not advance in plastic strain dropped, a falling stress held at the highest before it
    (softening is not supported), each change in a note."""
    points = []
    for eps, sig in curve:
        if sig <= 0.0:
            raise SceneError(f"{where}: the stress-strain curve has a yield stress <= 0 ({sig:g} at plastic "
                             f"strain {eps:g})")
        if points and eps <= points[-1][0]:
            notes.append(f"{where}: curve point ({eps:g}, {sig:g}) does not advance in plastic strain: dropped")
            continue
        if points and sig < points[-1][1]:
            notes.append(f"{where}: the curve falls at plastic strain {eps:g} ({points[-1][1]:g} -> {sig:g}): "
                         f"held at {points[-1][1]:g} (softening is not supported)")
            sig = points[-1][1]
        points.append((float(eps), float(sig)))
    if points[0][0] > 0.0:
        notes.append(f"{where}: the curve starts at plastic strain {points[0][0]:g}: its first stress is taken "
                     "from plastic strain 0")
        points.insert(0, (0.0, points[0][1]))
    elif points[0][0] < 0.0:
        raise SceneError(f"{where}: the stress-strain curve starts at a negative plastic strain {points[0][0]:g}")
    return tuple(points)


def _part_data(scene: Scene, mesh: Mesh, points: np.ndarray, elements: np.ndarray):
    """The parts (PartSpec: element ids, material and section names), the materials and the
    sections by name.  [[part]] assigns them; without it the scene's one material and section
    cover the mesh, or an LS-DYNA deck's *PART cards assign its own (scene tables of the same
    name -- mat_<mid>, sec_<secid> -- replace the deck's; a [[part]] may name the deck's).
    Every element belongs to exactly one part: overlaps and orphans are errors naming the
    parts and elements.  With a deck, a scene table no part uses (an override of nothing) is
    an error, and so is a value of a deck card some part uses that the same scene key would
    refuse (_deck_specs)."""
    m = len(elements)
    materials, sections = dict(scene.materials), dict(scene.sections)
    notes: list[str] = []
    thickness = None
    if not scene.parts and scene.material is not None:
        if mesh.deck is not None and mesh.deck.parts:
            notes.append(f"{scene.source.name}: [material] and [section] cover every element: the deck's "
                         f"{len(mesh.deck.parts)} *PART cards and their sections and materials are not used (leave "
                         "[material] and [section] out to use them; [materials.mat_<mid>] or "
                         "[sections.sec_<secid>] replaces one)")
        return (PartSpec("all", np.arange(m), "material", "section"),), {"material": scene.material}, \
            {"section": scene.section}, thickness, notes
    if not scene.parts and mesh.deck is None:
        (sname, sec), = sections.items()
        if sec.layered:
            used = {ply.material: materials[ply.material] for ply in sec.plies}
            return (PartSpec("all", np.arange(m), None, sname),), used, {sname: sec}, thickness, notes
        (mname, mat), = materials.items()
        return (PartSpec("all", np.arange(m), mname, sname),), {mname: mat}, {sname: sec}, thickness, notes
    deck_problems = {}
    if mesh.deck is not None:                    # the deck's materials and sections, by scene name
        deck_materials, deck_sections, notes, deck_problems = _deck_specs(mesh.deck, scene.source.name)
        materials = {**deck_materials, **materials}
        sections = {**deck_sections, **sections}
        thickness = _deck_element_thickness(mesh.deck, scene, notes)
    if not scene.parts:                          # an LS-DYNA deck's parts
        from .scene import Part
        entries = tuple(Part(name=(p.title if p.title and p.title in mesh.element_sets else f"part:{pid}"),
                             material=f"mat_{p.mid}", section=f"sec_{p.secid}", elements=f"part:{pid}")
                        for pid, p in sorted(mesh.deck.parts.items()) if f"part:{pid}" in mesh.element_sets)
    else:
        entries = scene.parts
    errors = []
    owner = np.full(m, -1)
    parts = []
    for i, part in enumerate(entries):
        path = f"[[part]][{i}]" if scene.parts else f"part {part.name}"
        section = sections.get(part.section)
        if section is None:
            errors.append(f"{scene.source.name}: {path}.section: no section named {part.section!r}")
        elif section.layered:
            errors += [f"{scene.source.name}: section {part.section}.plies[{j}].material: no material named "
                       f"{ply.material!r}" for j, ply in enumerate(section.plies) if ply.material not in materials]
        elif part.material not in materials:
            errors.append(f"{scene.source.name}: {path}.material: no material named {part.material!r}")
        try:
            ids = _element_selection(part.elements, scene, mesh, points, elements, path)
        except SceneError as exc:
            errors += exc.messages
            continue
        taken = ids[owner[ids] >= 0]
        if len(taken):
            other = entries[int(owner[taken[0]])].name
            errors.append(f"{scene.source.name}: {path} '{part.name}': {len(taken)} elements also in part '{other}' "
                          f"(e.g. {', '.join(map(str, taken[:5]))}): every element belongs to one part")
        owner[ids] = i
        parts.append(PartSpec(part.name, ids, None if section is not None and section.layered else part.material,
                              part.section))
    orphans = np.flatnonzero(owner < 0)
    if len(orphans) and not errors:
        errors.append(f"{scene.source.name}: [[part]]: {len(orphans)} elements belong to no part "
                      f"(e.g. {', '.join(map(str, orphans[:5]))})")
    if errors:
        raise SceneError(errors)
    used_s = {p.section for p in parts}
    used_m = {p.material for p in parts} | {ply.material for name in used_s for ply in sections[name].plies}
    if mesh.deck is not None:
        from .scene import name_hint
        for label, table, used, deck_names in (("materials", scene.materials, used_m, sorted(deck_materials)),
                                               ("sections", scene.sections, used_s, sorted(deck_sections))):
            for name in table:
                if name not in used:
                    errors.append(f"{scene.source.name}: [{label}.{name}]: replaces nothing: no part of the deck "
                                  f"or [[part]] uses {name!r}" + name_hint(name, deck_names, "the deck's"))
        errors += [line for name in sorted(used_s | used_m) if name not in scene.materials
                   and name not in scene.sections for line in deck_problems.get(name, ())]
        if thickness is not None:                # a scene section's thickness wins over the deck's
            for p in parts:
                if p.section in scene.sections:
                    thickness[p.elements] = np.nan
        if errors:
            raise SceneError(errors)
    return tuple(parts), {k: v for k, v in materials.items() if k in used_m}, \
        {k: v for k, v in sections.items() if k in used_s}, thickness, notes


def _deck_element_thickness(deck, scene: Scene, notes: list) -> np.ndarray | None:
    """(m,) thickness of each element from *ELEMENT_SHELL_THICKNESS (the mean of its corner
    values; NaN: the section's), as LS-DYNA takes it over the section's T1 -- except in parts
    whose section the scene redefines ([sections.sec_<id>]: the scene's value wins; _part_data)."""
    corner = deck.element_thickness
    if corner is None:
        return None
    given = np.where(corner > 0.0, corner, np.nan)
    count = np.sum(np.isfinite(given), axis=1)
    mean = np.where(count > 0, np.nansum(given, axis=1) / np.maximum(count, 1), np.nan)
    varying = int(np.sum(np.nanmax(given, axis=1, initial=0.0) - np.nanmin(given, axis=1, initial=np.inf) > 1e-12
                         * np.nanmax(given, axis=1, initial=1.0)))
    if varying:
        notes.append(f"{scene.source.name}: {varying} elements of *ELEMENT_SHELL_THICKNESS have corner "
                     "thicknesses that differ: each uses their mean (a constant thickness per element)")
    return mean if np.isfinite(mean).any() else None


def _tables(scene: Scene, parts, material_specs: dict, section_specs: dict, frames,
            element_thickness: np.ndarray | None = None):
    """SectionTable, MaterialTable and ElementData of the parts.  A row of the section table
    is a (section, material) pair of some part (a layered section's material is None): its
    through-thickness points, and the material and ply angle of each (laminate.layup).
    `frames` = (e1, e2) of every element (element_frames) for the material axes.
    `element_thickness` (NaN: the section's) overrides the section's thickness element by
    element (an LS-DYNA deck's *ELEMENT_SHELL_THICKNESS)."""
    e1, e2 = frames
    m = len(e1)
    material_names = tuple(material_specs)
    specs = [material_specs[n] for n in material_names]
    kinds = tuple(k for k in materials.KINDS if any(spec.model == k for spec in specs))
    hardening, rates = materials.hardening_laws(specs), materials.rate_laws(specs)
    curves = [spec.curve if materials.PLASTIC[spec.model] and spec.hardening_law == "tabulated" else ()
              for spec in specs]
    starts = np.concatenate([[0], np.cumsum([len(c) for c in curves])]).astype(int)
    points = np.array([point for c in curves for point in c]).reshape(-1, 2)
    material_table = MaterialTable(
        names=material_names, kinds=kinds,
        kind=np.array([kinds.index(spec.model) for spec in specs], dtype=np.int32),
        rows=np.array([materials.parameter_row(spec, materials.row_width(kinds), hardening, rates, start)
                       for spec, start in zip(specs, starts)]),
        dilatational_speed=max(materials.dilatational_speed(spec) for spec in specs),
        hardening=hardening, rate_laws=rates,
        rate_filter=any(materials.PLASTIC[spec.model] and spec.rate_law != "none"
                        and materials.rate_filter_time(spec) > 0
                        for spec in specs),
        curve_strain=points[:, 0].copy(), curve_stress=points[:, 1].copy(),
        erosion=any(materials.erodes(spec) for spec in specs),
        failure=np.array([materials.failure_row(spec) for spec in specs]))
    if material_table.erosion and scene.solve.kind == "static":
        name = next(n for n, spec in zip(material_names, specs) if materials.erodes(spec))
        raise SceneError(f"{scene.source.name}: material {name!r}: erosion (failure_strain, failure_min_dt; a deck's "
                         "FAIL, TDEL) needs [solve].kind = \"dynamic\"")
    pairs = tuple(dict.fromkeys((p.section, p.material) for p in parts))
    for sec, mat in pairs:                    # a layered section (mat None): each ply's material
        section = section_specs[sec]
        for name in dict.fromkeys([mat] if mat is not None else [ply.material for ply in section.plies]):
            spec = material_specs[name]
            if getattr(spec, "failure_strain", 0.0) > 0.0 and spec.failure_points > section.points:
                label = "[material]" if name == "material" else f"[materials.{name}]"
                where = "[section]" if sec == "section" else f"section '{sec}'"
                raise SceneError(f"{scene.source.name}: {label}.failure_points: expected at most the "
                                 f"{section.points} through-thickness points of {where}, got {spec.failure_points}")
    layups = [laminate.layup(section_specs[sec], material_specs, mat) for sec, mat in pairs]
    nk = max(len(lay.zeta) for lay in layups)
    zeta, weight, angle = (np.zeros((len(pairs), nk)) for _ in range(3))
    point_material = np.zeros((len(pairs), nk), dtype=np.int32)
    for i, lay in enumerate(layups):
        n = len(lay.zeta)
        zeta[i, :n], weight[i, :n], angle[i, :n] = lay.zeta, lay.weight, lay.point_angle
        point_material[i] = [material_names.index(name) for name in lay.point_material] \
            + [material_names.index(lay.point_material[0])] * (nk - n)
    section_table = SectionTable(names=tuple(sec if mat is None else f"{sec}/{mat}" for sec, mat in pairs),
                                 point_count=np.array([len(lay.zeta) for lay in layups], np.int32),
                                 zeta=zeta, weight=weight, point_material=point_material, point_angle=angle,
                                 layered=np.array([section_specs[sec].layered for sec, _ in pairs]))
    el = scene.element
    columns = {name: np.zeros(m) for name in ("thickness", "shear_factor", "wave_speed", "rotational_frequency",
                                              "hourglass_membrane", "hourglass_bending", "hourglass_transverse",
                                              "drilling_factor", "density", "rotary_density")}
    material_axis = np.tile([1.0, 0.0], (m, 1))
    part_of = np.zeros(m, dtype=np.int32)
    section_of = np.zeros(m, dtype=np.int32)
    errors = []
    for i, part in enumerate(parts):
        sec = section_specs[part.section]
        row = pairs.index((part.section, part.material))
        lay = layups[row]
        ids = part.elements
        t = np.full(len(ids), sec.thickness)
        if element_thickness is not None:
            t = np.where(np.isfinite(element_thickness[ids]), element_thickness[ids], t)
        kappa = sec.shear_factor
        part_of[ids] = i
        section_of[ids] = row
        r = sec.hourglass if sec.hourglass is not None else el.hourglass
        alpha = sec.drilling_stiffness if sec.drilling_stiffness is not None else el.drilling_stiffness
        # artificial stiffnesses of a laminate: the effective isotropic moduli of laminate.Layup
        values = {"thickness": t, "shear_factor": kappa, "wave_speed": lay.wave_speed,
                  "rotational_frequency": (np.sqrt(12.0 * kappa * lay.transverse_shear_max / lay.rotary_density) / t
                                           if scene.solve.physical_rotary_inertia else 0.0),
                  "hourglass_membrane": r * lay.membrane_modulus * t / 8.0,
                  "hourglass_bending": r * lay.bending_modulus * t ** 3 / 192.0,
                  "hourglass_transverse": r * kappa * lay.transverse_shear_modulus * t ** 3 / 12.0,
                  "drilling_factor": alpha * lay.bending_modulus * t ** 3 / 48.0 if el.drilling == "penalty" else 0.0,
                  "density": lay.density, "rotary_density": lay.rotary_density}
        for name, value in values.items():
            columns[name][ids] = value
        if lay.oriented and sec.reference_direction is not None:
            axis, undefined = laminate.material_axis(e1[ids], e2[ids], sec.reference_direction)
            material_axis[ids] = axis
            bad = ids[undefined]
            if len(bad):
                where = "[section]" if scene.section is not None else f"[sections.{part.section}]"
                errors.append(f"{scene.source.name}: {where}.reference_direction: "
                              f"{list(sec.reference_direction)} is within {laminate.AXIS_TOLERANCE_DEG:g} degree of "
                              f"the normal of element {int(bad[0])}"
                              + (f" (and {len(bad) - 1} more)" if len(bad) > 1 else "")
                              + ", where the material axis is undefined: choose a direction further from the normals")
    if errors:
        raise SceneError(errors)
    return section_table, material_table, ElementData(part=part_of, section=section_of, material_axis=material_axis,
                                                      **columns)


def node_point_masses(point_masses, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(n,) the mass and rotary inertia the [[point_mass]] entries put at each node (their sum
    at a node, in entry order): added to the elements' shares here and by the per-step mass
    rebuild of erosion and mass scaling (stages/masses.py, state.nodes.point_mass)."""
    mass, inertia = np.zeros(n), np.zeros(n)
    for p in point_masses:
        mass[p.nodes] += p.mass
        inertia[p.nodes] += p.inertia
    return mass, inertia


def assemble(scene: Scene, mesh: Mesh) -> Model:
    """Build the :class:`Model` for `scene` on `mesh` (raises SceneError on user mistakes)."""
    points, elements = mesh.points.astype(np.float64), mesh.elements.astype(np.int64)
    n, m = len(points), len(elements)
    parts, material_specs, section_specs, element_thickness, notes = _part_data(scene, mesh, points, elements)
    sections, material_table, element = _tables(scene, parts, material_specs, section_specs,
                                                element_frames(points, elements)[:2], element_thickness)
    area0, weight = cpdi2_weights(points, elements)
    edges = _edge_lengths(points, elements)
    element_mass = element.density * element.thickness * area0
    physical_mass = np.zeros(n)
    np.add.at(physical_mass, np.where(elements >= 0, elements, 0), weight * element_mass[:, None])
    if scene.solve.kind == "static" and scene.solve.mass_scaling != "none":
        element_mass *= uniform_dt_mass_factor(points, elements, area0)
    mass_factor = np.ones(m)
    scaling = scene.solve.mass_scaling if scene.solve.kind == "dynamic" else "none"
    target_dt = 0.0
    if scaling in ("selective", "conventional"):
        steps = element_steps(points, elements, element, scene.solve.dt_safety)
        target_dt = target_step(scene.solve.target_dt, steps)
        mass_factor = element_mass_factor(steps, target_dt)
    node_mass = np.zeros(n)
    node_area = np.zeros(n)
    node_inertia = np.zeros(n)
    inertia_arm = element.thickness ** 2 / 12.0 * (element.rotary_density / element.density)   # I / (rho t)
    if not scene.solve.physical_rotary_inertia:
        # a triangle max(t^2/12, A/4) g [choice, measured]: g (triangle_shear_gain) brings its
        # shear-rotation frequency, kappa G g / (rho arm), to that of an element whose shear
        # takes the mean rotation, and A/4 keeps it below the membrane's: the largest
        # omega dt / 2 of one triangle over 4000 random shapes (angles down to 0.1 deg, t from
        # 1e-3 to 2 sqrt(A)) was 0.81 alpha (A/8 g: 0.97 alpha; A/4 without g: 1.35 alpha at
        # smallest angles of 5-11 deg, 12 alpha below 5 deg; the quad's A/8 without g: the
        # 20x2 cantilever cut into triangles did not relax at dt_safety 0.9); g = 1 for a quad
        gain = triangle_shear_gain(points, elements)
        inertia_arm = np.maximum(inertia_arm, area0 / np.where(elements[:, 3] < 0, 4.0, 8.0)) * gain
    corners = np.where(elements >= 0, elements, 0)       # a triangle's 4th weight is 0
    corner_mass = weight * element_mass[:, None]
    corner_inertia = weight * (element_mass * inertia_arm)[:, None]
    # the order of stages/masses.py; selective scaling leaves the lumped masses and rotary
    # inertias physical (its added mass is a matrix, stages/selective_mass.py)
    np.add.at(node_mass, corners, corner_mass * (mass_factor[:, None] if scaling == "conventional" else 1.0))
    np.add.at(node_area, corners, weight * area0[:, None])
    np.add.at(node_inertia, corners, corner_inertia * (mass_factor[:, None] if scaling == "conventional" else 1.0))
    node_thickness = np.zeros(n)
    valid = elements >= 0
    np.maximum.at(node_thickness, elements[valid], np.repeat(element.thickness, 4).reshape(-1, 4)[valid])

    sets = {}

    def nodes_of(name: str) -> np.ndarray:
        if name not in sets:
            sets[name] = select_nodes(scene.nodeset(name), points)
        return sets[name]

    fix_mask = np.zeros(n, dtype=np.int32)
    planes_xyz = []
    for b in scene.boundaries:
        ids = nodes_of(b.nodes)
        dofs = set(b.fix)
        if b.symmetry is not None:
            axis = AXES[b.symmetry]
            dofs |= set(SYMMETRY_FIXES[axis])
            coords = points[ids, axis]
            if np.ptp(coords) > 1e-9 * max(1.0, float(np.max(np.abs(points)))):
                raise SceneError(f"{scene.source.name}: [[boundary]] on '{b.nodes}': symmetry '{b.symmetry}' needs "
                                 f"nodes on one plane {b.symmetry} = const (they span {np.ptp(coords):g})")
            planes_xyz.append((axis, float(coords.mean())))
        bits = sum(1 << DOFS.index(d) for d in dofs)
        fix_mask[ids] |= bits

    velocity0 = np.zeros((n, 3))
    omega0 = np.zeros((n, 3))
    for ic in scene.initial:
        ids = nodes_of(ic.nodes)
        w = np.asarray(ic.angular_velocity)
        velocity0[ids] = np.asarray(ic.velocity) + np.cross(w, points[ids] - np.asarray(ic.center))
        omega0[ids] = w

    point_masses = []
    for pm in scene.point_masses:
        ids = nodes_of(pm.nodes)
        each = pm.mass if pm.mass is not None else pm.total_mass / len(ids)
        point_masses.append(PointMassSpec(pm.name, ids, each, pm.inertia))
    point_mass, point_inertia = node_point_masses(point_masses, n)
    node_mass += point_mass                  # the order of stages/masses.py: elements, then point masses
    physical_mass += point_mass
    node_inertia += point_inertia

    node_body = np.full(n, -1, dtype=np.int32)
    bodies = []
    for i, rb in enumerate(scene.rigid_bodies):
        ids = nodes_of(rb.nodes)
        if np.any(node_body[ids] >= 0):
            raise SceneError(f"{scene.source.name}: [[rigid_body]] '{rb.name}': nodes already belong to "
                             "another rigid body")
        if np.any((fix_mask[ids] & 0b111) != 0):
            raise SceneError(f"{scene.source.name}: [[rigid_body]] '{rb.name}': nodes also have fixed "
                             "translations in a [[boundary]]")
        node_body[ids] = i
        bodies.append(_rigid_body(scene, rb, ids, points, node_mass, node_inertia, velocity0, float(edges.min())))
    if bodies:
        steps = element_steps(points, elements, element, scene.solve.dt_safety)
        for i, b in enumerate(bodies):
            bodies[i] = replace(b, stable_step=body_step(i, b, points, elements, node_body, steps, corner_mass,
                                                         corner_inertia, scene.solve.dt_safety))
            notes += _body_step_notes(scene, bodies[i], float(steps.min()))
    load_force, load_moment, loading = assemble_loading(
        scene, points, elements, node_area, physical_mass, fix_mask, node_body, nodes_of,
        lambda name, path: _element_selection(name, scene, mesh, points, elements, path))
    names = [b.name for b in bodies]
    walls = tuple(WallSpec(tuple(w.point), tuple(np.asarray(w.normal) / np.linalg.norm(w.normal)),
                           names.index(w.moves_with) if w.moves_with else -1) for w in scene.walls)
    tools = build_tools(scene.tools, bodies, scene.curves, float(node_thickness.max())) if scene.tools else None
    for d in range(3):                       # supports do not move: no initial velocity there
        velocity0[(fix_mask >> d) & 1 == 1, d] = 0.0
        omega0[(fix_mask >> (3 + d)) & 1 == 1, d] = 0.0
    probes = tuple(ProbeSpec(p.name, nodes_of(p.nodes), p.components) for p in scene.probes)
    min_edge = float(edges.min())
    free = int(np.sum(((fix_mask & 0b111) != 0b111) & (node_body < 0)))
    grid = _grid_geometry(scene, points, min_edge, planes_xyz, free) if scene.method.kind == "mpm" else None
    _check_arc_length(scene, points)
    contact = scene.contact
    parameters = StepParameters(
        dt_safety=scene.solve.dt_safety, flip_blend=scene.method.flip_blend,
        **({"contact_thickness": contact.thickness or float(element.thickness.max()),
            "contact_stiffness": contact.stiffness, "contact_damping": contact.damping,
            "contact_friction": contact.friction} if contact is not None else {}),
        **({"field_gap": (contact.thickness if contact is not None and contact.thickness else
                          float(element.thickness.max())),
            "field_friction": scene.method.field_friction} if scene.method.field_contact == "grid" else {}),
        **({"target_dt": target_dt} if scaling in ("selective", "conventional") else {}),
        **({"added_mass_cap": 0.01 * scene.solve.added_mass_limit * float(corner_mass.sum())}
           if scaling == "conventional" else {}),
        **({"sms_tolerance": scene.solve.sms_tolerance, "sms_max_iterations": scene.solve.sms_max_iterations}
           if scaling == "selective" else {}))
    if scene.solve.rotary_inertia == "physical" and not scene.solve.physical_rotary_inertia:
        notes.append(f"{scene.source.name}: [solve].rotary_inertia = \"physical\" is for dynamic solves: a static "
                     "solve keeps the scaled rotary inertia (its masses are fictitious; with the physical one the "
                     "relaxation stalls, docs/scenes.md)")
    return Model(points=points, elements=elements.astype(np.int32), parts=parts, element=element,
                 parameters=parameters, notes=tuple(notes),
                 sections=sections, materials=material_table, area0=area0, corner_weight=weight, node_mass=node_mass,
                 corner_mass=corner_mass, corner_inertia=corner_inertia, mass_factor=mass_factor,
                 node_thickness=node_thickness,
                 node_inertia=node_inertia, node_area=node_area, fix_mask=fix_mask, load_force=load_force,
                 load_moment=load_moment, velocity0=velocity0, omega0=omega0,
                 grid=grid, probes=probes, min_edge=min_edge, mean_edge=float(edges.mean()),
                 max_edge=float(edges.max()), rigid_bodies=tuple(bodies), point_masses=tuple(point_masses),
                 walls=walls, tools=tools, node_body=node_body,
                 loading=loading,
                 **(node_neighbors(elements, n) if scene.contact else {}))


MAX_ARC_SIZES = 10.0
"""[solve].arc_length above the arc in which every node moves this many times the
model's size is refused: such a first point is no path step (Newton then fails on a
'singular' tangent far from any equilibrium)."""


def _check_arc_length(scene: Scene, points: np.ndarray) -> None:
    """Bound a Newton [solve].arc_length: |W d| (solvers/path.py, translations weighted 1)
    of every node moving MAX_ARC_SIZES x the bounding-box diagonal (all nodes, fixed or not:
    the bound is a scale, and one value whatever the boundaries, so one message)."""
    sol = scene.solve
    if sol.solver != "newton" or sol.control != "arc_length" or sol.arc_length == 0.0:
        return
    size = float(np.linalg.norm(np.ptp(points, axis=0)))
    bound = MAX_ARC_SIZES * size * math.sqrt(3.0 * len(points))
    if sol.arc_length > bound:
        raise SceneError(f"{scene.source.name}: [solve].arc_length: expected at most {bound:.3g} (the arc in which "
                         f"each of the {len(points)} nodes moves {MAX_ARC_SIZES:g} times the model's size {size:.3g}), "
                         f"got {sol.arc_length:g}; 0 starts from the linear step at load factor 1 / load_steps")


def _rigid_body(scene: Scene, rb, ids: np.ndarray, points: np.ndarray, node_mass: np.ndarray,
                node_inertia: np.ndarray, velocity0: np.ndarray, min_edge: float) -> RigidBodySpec:
    """Mass, centre and inertia of a [[rigid_body]] (stages/bodies.py): the slave nodes' masses
    m_c at X_c and rotary inertias J_c, I = sum m_c (|r|^2 1 - r r^T) + J_c 1 (r = X_c - X_centre),
    plus the added mass (at the scene's `center`, else at the mass centre) and inertia (about
    that point); or the scene's mass and inertia alone (mass_from_nodes = false).  The initial
    velocity is the scene's, or the mean of the slaves' [[initial]] velocities; the free DOFs'
    projectors.

    The centre it turns about [choice, issue 28 item 2]: Newton-Euler in the form of
    stages/bodies.py (M dV/dt = F, dL/dt = M about the centre) holds about the mass centre G,
    or about a point held still.  So a rotating body whose `center` C is not its mass centre
    turns about G (I moved to G by its own sum) when its translations are free, about C when
    they are all fixed (a pivot), and is refused otherwise (some translations free: the
    coupling terms m (C - G) x a_C are not modelled); about C with free translations, a free
    body spinning changed its linear momentum with no force.  A body that does not rotate may
    have any centre."""
    where = f"{scene.source.name}: [[rigid_body]] '{rb.name}'"
    m = node_mass[ids] if rb.mass_from_nodes else np.zeros(len(ids))
    total = rb.mass + float(m.sum())
    if rb.center is not None:
        given = np.asarray(rb.center, dtype=float)
        mass_centre = (rb.mass * given + (m[:, None] * points[ids]).sum(axis=0)) / total if total > 0.0 else given
    elif m.sum() > 0.0:
        given = mass_centre = (m[:, None] * points[ids]).sum(axis=0) / m.sum()
    else:
        given = mass_centre = points[ids].mean(axis=0)
    rotation_free, translation_free, d, moved = _free_dofs(scene, rb)
    turned = any(m.body == rb.name and set(m.dofs) & set(DOFS[3:]) for m in scene.motions)
    size = max(float(np.linalg.norm(points[ids] - given, axis=1).max()), min_edge)
    center = given
    if (rotation_free.any() or turned) and np.linalg.norm(given - mass_centre) > 1e-9 * size:
        held = not translation_free.any()
        if d is None and np.diag(translation_free).all() and not moved & set(DOFS[:3]):
            center = mass_centre                           # free: about the mass centre
        elif not held:
            raise SceneError(f"{where}: center: {_vector(given)} is not its mass centre {_vector(mass_centre)}: a "
                             "rotating body may turn about another point only as a pivot (fixed = [\"ux\", \"uy\", "
                             "\"uz\"]); with all translations free it turns about its mass centre")
    r = points[ids] - center
    added = inertia_tensor(rb.inertia) + rb.mass * _arms((given - center)[None])[0]   # moved from `center` to the centre
    rotary = float(node_inertia[ids].sum()) if rb.mass_from_nodes else 0.0
    inertia = added + rotary * np.eye(3) + np.einsum("c,cij->ij", m, _arms(r))
    if d is not None:
        v0 = float(np.mean(velocity0[ids] @ d)) * d if rb.velocity is None else translation_free @ rb.velocity
    else:
        v0 = translation_free @ (np.mean(velocity0[ids], axis=0) if rb.velocity is None else np.asarray(rb.velocity))
    spin = rotation_free @ np.asarray(rb.spin if rb.spin is not None else (0.0, 0.0, 0.0))
    if rb.velocity is not None:                  # given at `center`: the mass centre's is V + omega x (G - C)
        v0 = v0 + translation_free @ np.cross(spin, center - given)
    if translation_free.any() and not total > 0.0:
        raise SceneError(f"{where}: the body has no mass (its nodes carry none): give mass")
    free = np.diag(rotation_free) > 0
    scale = max(float(np.abs(inertia).max()), 1e-300)
    if free.any():
        smallest = float(np.linalg.eigvalsh(inertia[np.ix_(free, free)]).min())
        if not smallest > 1e-12 * scale:
            raise SceneError(f"{where}: the inertia about its free rotation axes is singular: give inertia")
        # near-singular against the body's own scale, M l^2 (l: its size, at least an element's):
        # it passed the relative test above and failed at step 2 as "time step too large"
        if smallest < NEAR_SINGULAR * total * size ** 2:
            raise SceneError(f"{where}: inertia: {smallest:.3g} about a free axis is near-singular (below "
                             f"{NEAR_SINGULAR:g} M l^2 = {NEAR_SINGULAR * total * size ** 2:.3g}, M = {total:.3g} its "
                             f"mass, l = {size:.3g} its size): give its physical inertia")
    return RigidBodySpec(rb.name, ids, rb.mass, None if d is None else tuple(d), total, v0, center, inertia,
                         added, spin, translation_free, rotation_free, turned)


def _body_step_notes(scene: Scene, body: RigidBodySpec, element_step: float) -> list[str]:
    """A body that sets the step (body_step) is named in a warning; one that would need a step
    below STEP_COLLAPSE of its elements' (the run's dt-collapse guard) is refused."""
    if not body.stable_step < element_step:
        return []
    where = f"{scene.source.name}: [[rigid_body]] '{body.name}'"
    if body.stable_step < STEP_COLLAPSE * element_step:
        raise SceneError(f"{where}: mass, inertia: far too small for the elements it carries: they would need a "
                         f"step of {body.stable_step:.3g}, {body.stable_step / element_step:.1e} of the elements' "
                         f"{element_step:.3g}: give its physical mass and inertia")
    return [f"{where} limits the time step to {body.stable_step:.3g} (its elements allow {element_step:.3g}): its "
            "mass or inertia is small against the stiffness of the elements it carries"]


STEP_COLLAPSE = 1e-3     # = stages/timestep.py's collapse guard (dt < 1e-3 of the first step)
NEAR_SINGULAR = 1e-9     # smallest principal inertia / (M l^2) a body may have (a needle of radius 1e-4 l: 1e-8)


def _vector(v: np.ndarray) -> str:
    return "[" + ", ".join(f"{x:.6g}" for x in v) + "]"


def _arms(r: np.ndarray) -> np.ndarray:
    """|r|^2 1 - r r^T of each row of r: the inertia of a unit mass at r."""
    return np.einsum("ck,ck->c", r, r)[:, None, None] * np.eye(3) - r[:, :, None] * r[:, None, :]


def _free_dofs(scene: Scene, rb):
    """Projectors on a body's free rotations and translations, its unit direction (or None)
    and the DOFs its [[motion]]s prescribe."""
    moved = {d for m in scene.motions if m.body == rb.name for d in m.dofs}   # prescribed: held + set
    if rb.direction is not None:
        d = np.asarray(rb.direction) / np.linalg.norm(rb.direction)
        return np.zeros((3, 3)), np.outer(d, d), d, moved
    translation_free = np.diag([0.0 if dof in rb.fixed else 1.0 for dof in DOFS[:3]])
    rotation_free = np.diag([0.0 if dof in rb.fixed or dof in moved else 1.0 for dof in DOFS[3:]])
    return rotation_free, translation_free, None, moved


def body_step(index: int, body: RigidBodySpec, points: np.ndarray, elements: np.ndarray, node_body: np.ndarray,
              steps: np.ndarray, corner_mass: np.ndarray, corner_inertia: np.ndarray, dt_safety: float) -> float:
    """The stable step a body's own mass and inertia allow on the elements it carries
    [issue 28 item 7]: alpha 2 / omega_b with omega_b^2 = max(k / M, k_r / I_min) over its free
    DOFs.  Each element with corners on the body and off it ties each of its slave corners c to
    the rest by a stiffness k_ec = m_ec omega_e^2 / 2 (omega_e = 2 alpha / dt_e its highest
    frequency, m_ec its corner mass: the two-node bar's exact ratio), k = sum k_ec, and turns it
    with k_r = sum k_ec |x_c - x_b|^2 + J_ec omega_e^2 / 2 (J_ec the corner's rotary inertia);
    M, I_min: its mass and smallest principal inertia about its free axes.  A body no lighter
    than a corner's share of its elements' mass gets a step above theirs (the bar: sqrt 2 x),
    so the rule binds only where the body is the light part; inf where no element ties it."""
    valid = elements >= 0
    on = valid & (node_body[np.where(valid, elements, 0)] == index)
    tied = on.any(axis=1) & (valid & ~on).any(axis=1)
    if not tied.any():
        return math.inf
    omega_sq = (2.0 * dt_safety / steps[tied]) ** 2
    k = 0.5 * np.where(on[tied], corner_mass[tied], 0.0) * omega_sq[:, None]
    arms = np.linalg.norm(points[np.where(on[tied], elements[tied], 0)] - body.center, axis=2)
    rates = []
    free_t = np.diag(body.translation_free) > 0 if body.direction is None else np.ones(3, bool)
    if free_t.any() and body.total_mass > 0.0:
        rates.append(float(k.sum()) / body.total_mass)
    free_r = np.diag(body.rotation_free) > 0
    if free_r.any():
        k_r = float((k * arms ** 2).sum() + 0.5 * (np.where(on[tied], corner_inertia[tied], 0.0) * omega_sq[:, None]).sum())
        rates.append(k_r / float(np.linalg.eigvalsh(body.inertia[np.ix_(free_r, free_r)]).min()))
    return 2.0 * dt_safety / math.sqrt(max(rates)) if rates and max(rates) > 0.0 else math.inf


def node_neighbors(elements: np.ndarray, n: int) -> dict[str, np.ndarray]:
    """CSR lists of the nodes sharing an element with each node (itself included): the
    contact exclusion ring of method.md 7.3."""
    pairs = np.stack(np.broadcast_arrays(elements[:, :, None], elements[:, None, :]), axis=-1).reshape(-1, 2)
    pairs = np.unique(pairs[(pairs >= 0).all(axis=1)], axis=0)
    start = np.searchsorted(pairs[:, 0], np.arange(n + 1)).astype(np.int32)
    return {"neighbor_start": start, "neighbor_nodes": pairs[:, 1].astype(np.int32)}
