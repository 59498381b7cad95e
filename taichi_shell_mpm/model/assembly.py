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

from ..loading import Loading, assemble_loading
from ..mesh import Mesh
from ..nodesets import select_nodes
from ..scene import DOFS, Scene, SceneError
from .contact_pairs import ContactTable, contact_table
from .joints import JointTable, build_joints, consistent_velocities
from .bodies import PointMassSpec, RigidBodySpec, WallSpec, body_step, body_step_notes, node_point_masses, rigid_body
from .parts import ElementData, MaterialTable, PartSpec, SectionTable, element_selection, part_data, tables
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
class StepParameters:
    """Run-time values of the step that are not per entity (state.step, state.contact)."""
    dt_safety: float
    flip_blend: float
    contact_thickness: float = 0.0      # t_c, the largest pair thickness (no contact: 0; model/contact_pairs.py)
    contact_step_thickness: float = 0.0  # the smallest pair thickness (the contact step limit, stages/timestep.py)
    contact_stiffness: float = 0.0      # alpha_c
    contact_damping: float = 0.0
    contact_friction: float = 0.0
    field_gap: float = 0.0              # grid contact condition (stages/grid.py): t_c
    field_friction: float = 0.0         # and its Coulomb coefficient
    target_dt: float = 0.0              # mass scaling: the step (0: none)
    added_mass_cap: float = 0.0         # conventional: its limit on the added mass (0: none)
    sms_tolerance: float = 0.0          # selective: the solve's relative residual
    sms_max_iterations: int = 0         # and its iterations per step
    ns_blend: float = 0.0               # [element].ns_blend: the ns triangles' own-strain share (stages/ns_membrane.py)


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
    contact: ContactTable | None = None   # [contact] and [[contact_pair]] laws (model/contact_pairs.py)
    joints: JointTable | None = None      # [[tie]] and [[spotweld]] (model/joints.py); None: none


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


def corner_areas(points: np.ndarray, elements: np.ndarray) -> tuple:
    """The elements' corner positions x (m, 4, 3; a triangle's fourth repeats its first), which
    are triangles, and the areas the device's step rules use: a quad's 1/2 |d13 x d24|, a
    triangle's 1/2 |x01 x x02| (stages/shell.py, stages/triangle.py)."""
    x = points[np.where(elements >= 0, elements, elements[:, :1])]
    tri = elements[:, 3] < 0
    quad_area = 0.5 * np.linalg.norm(np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1]), axis=1)
    tri_area = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)
    return x, tri, np.where(tri, tri_area, quad_area)


def element_steps(points: np.ndarray, elements: np.ndarray, element: "ElementData", dt_safety: float) -> np.ndarray:
    """Each element's stable step in the configuration `points` with its physical mass: the
    host twin of stages/timestep.element_limit (quads) and triangle_limit (triangles)."""
    x, tri, area = corner_areas(points, elements)
    d13, d24 = x[:, 2] - x[:, 0], x[:, 3] - x[:, 1]
    longest = np.maximum(np.linalg.norm(d13, axis=1), np.linalg.norm(d24, axis=1))
    inv = np.maximum(element.wave_speed * longest / area, 0.5 * element.rotational_frequency)
    if tri.any():
        inv_tri = element.wave_speed / element_length(points, elements, np.where(tri, area, 1.0))
        gain = triangle_shear_gain(points, elements)
        inv_tri *= np.sqrt(np.where(element.opt_modulus > 0.0, 1.0 + 0.5 * gain, 1.0))   # OPT (stages/triangle.py)
        inv_tri = np.sqrt(inv_tri ** 2 + gain * (0.5 * element.rotational_frequency) ** 2)
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


def target_step(target_dt: float | str, steps: np.ndarray, reach: float | None = None) -> float:
    """The target step of mass scaling: the scene's, or for "auto" AUTO_TARGET_FACTOR times the
    smallest of `steps` (each element's stable step at the start); with the reciprocal mass
    matrix, "auto" is `reach`, the largest step it allows (min_e max(cap_e, dt_e), cap_e each
    element's :func:`zigzag_steps`)."""
    if target_dt != "auto":
        return float(target_dt)
    return reach if reach is not None else AUTO_TARGET_FACTOR * float(steps.min())


def zigzag_steps(points: np.ndarray, elements: np.ndarray, element: "ElementData", dt_safety: float) -> np.ndarray:
    """(m,) each element's shear zigzags' step alpha h / c_s, the most the reciprocal
    mass matrix raises its step (host twin of stages/timestep.zigzag_limit: h = area / longest
    side of a quad, 2 area / longest edge of a triangle)."""
    x, tri, area = corner_areas(points, elements)
    sides = np.linalg.norm(np.roll(x, -1, axis=1) - x, axis=2)                    # 01, 12, 23, 30
    sides[tri, 2] = np.linalg.norm(x[tri, 0] - x[tri, 2], axis=1)             # a triangle's 20
    sides[tri, 3] = 0.0
    width = np.where(tri, 2.0, 1.0) * area / sides.max(axis=1)
    return dt_safety * width / element.shear_wave_speed


def element_mass_factor(steps: np.ndarray, target_dt: float, cap: np.ndarray | None = None) -> np.ndarray:
    """Mass scaling [issue 18; conventional as LS-DYNA's DT2MS < 0]: the factor
    f_e = (target / dt_e)^2 of each element whose stable step dt_e is below the target (its
    step, which goes as 1/sqrt(mass), becomes the target), 1 for the others: the density
    factor of conventional scaling, 1 + beta_e of selective scaling (stages/selective_mass.py);
    with the reciprocal mass matrix the step at most its zigzag step `cap` (:func:`zigzag_steps`)."""
    target = np.minimum(target_dt, np.maximum(cap, steps)) if cap is not None else target_dt
    return np.maximum(1.0, (target / steps) ** 2)


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


def assemble(scene: Scene, mesh: Mesh) -> Model:
    """Build the :class:`Model` for `scene` on `mesh` (raises SceneError on user mistakes)."""
    points, elements = mesh.points.astype(np.float64), mesh.elements.astype(np.int64)
    n, m = len(points), len(elements)
    parts, material_specs, section_specs, element_thickness, notes = part_data(scene, mesh, points, elements)
    sections, material_table, element = tables(scene, parts, material_specs, section_specs,
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
        cap = (zigzag_steps(points, elements, element, scene.solve.dt_safety)
               if scaling == "selective" and scene.solve.sms_solve == "reciprocal" else None)
        reach = float(np.maximum(cap, steps).min()) if cap is not None else None
        target_dt = target_step(scene.solve.target_dt, steps, reach)
        mass_factor = element_mass_factor(steps, target_dt, cap)
        if reach is not None and target_dt > reach:
            notes.append(f"{scene.source.name}: [solve].target_dt = {target_dt:g} is beyond the reciprocal mass "
                         f"matrix's reach on this mesh, {reach:.4g} (its elements' shear-zigzag steps; "
                         "docs/mass_scaling.md): the run starts at that step, and no mass is added beyond it")
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
        ids = nodes_of(rb.nodes) if rb.nodes is not None else np.zeros(0, dtype=np.int64)
        if np.any(node_body[ids] >= 0):
            raise SceneError(f"{scene.source.name}: [[rigid_body]] '{rb.name}': nodes already belong to "
                             "another rigid body")
        if np.any((fix_mask[ids] & 0b111) != 0):
            raise SceneError(f"{scene.source.name}: [[rigid_body]] '{rb.name}': nodes also have fixed "
                             "translations in a [[boundary]]")
        node_body[ids] = i
        bodies.append(rigid_body(scene, rb, ids, points, node_mass, node_inertia, velocity0, float(edges.min())))
    if bodies:
        steps = element_steps(points, elements, element, scene.solve.dt_safety)
        for i, b in enumerate(bodies):
            bodies[i] = replace(b, stable_step=body_step(i, b, points, elements, node_body, steps, corner_mass,
                                                         corner_inertia, scene.solve.dt_safety))
            notes += body_step_notes(scene, bodies[i], float(steps.min()))
    load_force, load_moment, loading = assemble_loading(
        scene, points, elements, node_area, physical_mass, fix_mask, node_body, nodes_of,
        lambda name, path: element_selection(name, scene, mesh, points, elements, path))
    names = [b.name for b in bodies]
    walls = tuple(WallSpec(tuple(w.point), tuple(np.asarray(w.normal) / np.linalg.norm(w.normal)),
                           names.index(w.moves_with) if w.moves_with else -1) for w in scene.walls)
    tools = build_tools(scene.tools, bodies, scene.curves, float(node_thickness.max())) if scene.tools else None
    for d in range(3):                       # supports do not move: no initial velocity there
        velocity0[(fix_mask >> d) & 1 == 1, d] = 0.0
        omega0[(fix_mask >> (3 + d)) & 1 == 1, d] = 0.0
    joints, joint_notes = build_joints(
        scene, points, elements, element.thickness, node_thickness, nodes_of,
        lambda name, path: element_selection(name, scene, mesh, points, elements, path), fix_mask, node_body,
        loading.motion_mask if loading is not None else None)
    if joints is not None:
        notes += joint_notes
        consistent_velocities(joints, velocity0, omega0)
    probes = tuple(ProbeSpec(p.name, nodes_of(p.nodes), p.components) for p in scene.probes)
    min_edge = float(edges.min())
    free = int(np.sum(((fix_mask & 0b111) != 0b111) & (node_body < 0)))
    grid = _grid_geometry(scene, points, min_edge, planes_xyz, free) if scene.method.kind == "mpm" else None
    _check_arc_length(scene, points)
    contact = scene.contact
    laws = contact_table(scene, mesh, points, elements, element.thickness, node_thickness)
    parameters = StepParameters(
        dt_safety=scene.solve.dt_safety, flip_blend=scene.method.flip_blend, ns_blend=scene.element.ns_blend,
        **({"contact_thickness": laws.thickness_max, "contact_step_thickness": laws.thickness_min}
           if laws is not None else {}),
        **({"contact_stiffness": contact.stiffness, "contact_damping": contact.damping,
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
                 loading=loading, contact=laws, joints=joints,
                 **(node_neighbors(elements, n) if laws is not None else {}))


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


def node_neighbors(elements: np.ndarray, n: int) -> dict[str, np.ndarray]:
    """CSR lists of the nodes sharing an element with each node (itself included): the
    contact exclusion ring of method.md 7.3."""
    pairs = np.stack(np.broadcast_arrays(elements[:, :, None], elements[:, None, :]), axis=-1).reshape(-1, 2)
    pairs = np.unique(pairs[(pairs >= 0).all(axis=1)], axis=0)
    start = np.searchsorted(pairs[:, 0], np.arange(n + 1)).astype(np.int32)
    return {"neighbor_start": start, "neighbor_nodes": pairs[:, 1].astype(np.int32)}
