"""Scene + mesh -> the numerical model as plain numpy arrays (no Taichi here).

Everything that is computed once before time stepping lives here: element reference
areas and frozen CPDI2 corner weights (method.md 2.1), lumped corner mass and scaled
rotary inertia (2.3), boundary-condition masks (2.4-2.5), the reference load vector,
initial velocities and the background-grid geometry.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .mesh import Mesh
from .nodesets import select_nodes
from .quadrature import through_thickness_rule
from .scene import DOFS, Scene, SceneError

AXES = {"x": 0, "y": 1, "z": 2}
SYMMETRY_FIXES = {0: ("ux", "ry", "rz"), 1: ("uy", "rx", "rz"), 2: ("uz", "rx", "ry")}


@dataclass(frozen=True)
class GridGeometry:
    """Background grid: node (i, j, k) sits at (lo + (i, j, k)) * h, lo integer."""
    h: float
    lo: tuple[int, int, int]
    dims: tuple[int, int, int]
    planes: tuple[tuple[int, int], ...]
    """Symmetry grid planes as (axis, absolute grid index)."""
    slab_axis: int = 0
    """The axis of the mesh's longest extent: P2G bins the shell nodes into grid slabs across
    it (stages/mapping.py), so the most slabs hold nodes [choice: the mesh's, not the grid
    box's longest axis -- the tube in a grid 16x its area put its nodes in 24 of the 160
    x-slabs and stepped 38 % slower]."""

    @property
    def n_nodes(self) -> int:
        return int(np.prod(self.dims))

    @property
    def strides(self) -> tuple[int, int, int]:
        """Flat-index strides of the grid axes, the slab axis innermost [choice, measured in the
        note of issue 4]: a shell's longest extent lies along its surface, so its grid nodes
        then sit in long contiguous runs.  With the slab axis outermost the tube's grid nodes
        spread over a plane of memory per slab and its P2G + G2P ran 1.8x slower."""
        inner = [d for d in range(3) if d != self.slab_axis]
        out = [0, 0, 0]
        out[self.slab_axis] = 1
        out[inner[1]] = self.dims[self.slab_axis]
        out[inner[0]] = self.dims[self.slab_axis] * self.dims[inner[1]]
        return (out[0], out[1], out[2])


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
    direction: tuple[float, float, float]   # unit
    total_mass: float                       # added + slave nodes
    velocity0: float                        # initial speed along direction


@dataclass(frozen=True)
class WallSpec:
    point: tuple[float, float, float]
    normal: tuple[float, float, float]      # unit
    body: int                               # index of the rigid body it moves with, -1 = fixed


@dataclass(frozen=True)
class Model:
    points: np.ndarray            # (n, 3) reference coordinates
    quads: np.ndarray             # (m, 4) corner ids
    area0: np.ndarray             # (m,) reference element areas
    corner_weight: np.ndarray     # (m, 4) CPDI2 weights, frozen (paper eq 15)
    node_mass: np.ndarray         # (n,)
    node_inertia: np.ndarray      # (n,) scalar rotary inertia J_c
    node_area: np.ndarray         # (n,) tributary area sum_e w_ea A_e
    fix_mask: np.ndarray          # (n,) int bits 0..5 = ux uy uz rx ry rz fixed
    load_force: np.ndarray        # (n, 3) nodal force at load factor 1
    load_moment: np.ndarray       # (n, 3)
    velocity0: np.ndarray         # (n, 3)
    omega0: np.ndarray            # (n, 3)
    zeta: np.ndarray              # through-thickness points
    zeta_weight: np.ndarray
    grid: GridGeometry | None     # None in fem mode
    probes: tuple[ProbeSpec, ...]
    min_edge: float
    mean_edge: float
    max_edge: float
    rigid_bodies: tuple[RigidBodySpec, ...] = ()
    walls: tuple[WallSpec, ...] = ()
    node_body: np.ndarray | None = None   # (n,) rigid body index of each node, -1 = none
    neighbor_start: np.ndarray | None = None   # CSR: nodes sharing an element with node c (incl. c)
    neighbor_nodes: np.ndarray | None = None


def cpdi2_weights(points: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Element areas and CPDI2 corner weights (method.md 2.1), in each element's projected
    local frame (e3 from the diagonals). A parallelogram gives 1/4 each."""
    x = points[quads]                                    # (m, 4, 3)
    e3 = np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1])
    e3 /= np.linalg.norm(e3, axis=1)[:, None]
    r21 = x[:, 1] - x[:, 0]
    e1 = r21 - np.sum(r21 * e3, axis=1)[:, None] * e3
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(e3, e1)
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
                  2 * c1 + c2 + 4 * c3 + 2 * c4], axis=1) / (36.0 * area[:, None])
    return area, w


def _edge_lengths(points, quads):
    x = points[quads]
    return np.linalg.norm(x - np.roll(x, -1, axis=1), axis=2)


def _grid_geometry(scene: Scene, points: np.ndarray, min_edge: float, planes_xyz) -> GridGeometry:
    m = scene.method
    h = m.cell_size if m.cell_size is not None else 0.5 * min_edge
    lo_pt, hi_pt = points.min(axis=0), points.max(axis=0)
    if m.grid_min is not None:
        gmin, gmax = np.array(m.grid_min), np.array(m.grid_max)
        if np.any(lo_pt < gmin) or np.any(hi_pt > gmax):
            raise SceneError(f"{scene.source.name}: [method].grid_min/grid_max: the grid box does not "
                             f"cover the mesh (mesh spans {lo_pt.round(6).tolist()} .. {hi_pt.round(6).tolist()})")
    else:
        pad = m.padding if m.padding is not None else 0.25 * float(np.max(hi_pt - lo_pt))
        gmin, gmax = lo_pt - pad, hi_pt + pad
    lo = np.floor(gmin / h).astype(int) - 1
    hi = np.ceil(gmax / h).astype(int) + 2
    dims = hi - lo + 1
    if np.prod(dims) > 60_000_000:
        raise SceneError(f"{scene.source.name}: [method].cell_size: grid of {dims.tolist()} nodes is too large; "
                         "use a larger cell_size or a smaller grid box")
    planes = []
    for axis, coord in planes_xyz:
        idx = coord / h
        if abs(idx - round(idx)) > 1e-9 * max(1.0, abs(idx)):
            raise SceneError(f"{scene.source.name}: [[boundary]].symmetry: the {'xyz'[axis]}-symmetry plane at "
                             f"{coord:g} is not a grid plane for cell_size {h:g}; choose a cell size dividing it")
        planes.append((axis, int(round(idx))))
    return GridGeometry(h=float(h), lo=tuple(int(v) for v in lo), dims=tuple(int(v) for v in dims),
                        planes=tuple(sorted(set(planes))), slab_axis=int(np.argmax(hi_pt - lo_pt)))


def uniform_dt_mass_factor(points: np.ndarray, quads: np.ndarray, area0: np.ndarray) -> np.ndarray:
    """Static solves, [solve].mass_scaling = "uniform_dt" [choice, issue 4]: dynamic
    relaxation only needs *some* mass matrix, and its step count grows with the spread of
    the elements' own stable steps dt_e = alpha L_e / c (L_e = area / longest diagonal,
    method.md 5), since the smallest element sets dt for all.  Scaling each element's
    density by (L_min / L_e)^2 raises its wave speed so that every element's dt_e equals
    the smallest one: the step does not change, the larger elements just stop being slower
    than they need to be.  Factors are <= 1 (1 on a uniform mesh)."""
    x = points[quads]
    longest = np.maximum(np.linalg.norm(x[:, 2] - x[:, 0], axis=1), np.linalg.norm(x[:, 3] - x[:, 1], axis=1))
    length = area0 / longest
    return (length.min() / length) ** 2


def assemble(scene: Scene, mesh: Mesh) -> Model:
    """Build the :class:`Model` for `scene` on `mesh` (raises SceneError on user mistakes)."""
    points, quads = mesh.points.astype(np.float64), mesh.quads.astype(np.int64)
    n = len(points)
    sec, mat = scene.section, scene.material
    area0, weight = cpdi2_weights(points, quads)
    edges = _edge_lengths(points, quads)
    element_mass = mat.density * sec.thickness * area0
    if scene.solve.kind == "static" and scene.solve.mass_scaling != "none":
        element_mass *= uniform_dt_mass_factor(points, quads, area0)
    node_mass = np.zeros(n)
    node_area = np.zeros(n)
    node_inertia = np.zeros(n)
    if scene.solve.rotary_inertia == "scaled":
        inertia_arm = np.maximum(sec.thickness ** 2 / 12.0, area0 / 8.0)
    else:
        inertia_arm = np.full_like(area0, sec.thickness ** 2 / 12.0)
    np.add.at(node_mass, quads, weight * element_mass[:, None])
    np.add.at(node_area, quads, weight * area0[:, None])
    np.add.at(node_inertia, quads, weight * (element_mass * inertia_arm)[:, None])

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

    load_force = np.zeros((n, 3))
    load_moment = np.zeros((n, 3))
    for ld in scene.loads:
        ids = nodes_of(ld.nodes)
        share = node_area[ids] if ld.distribute == "area" else np.ones(len(ids))
        share = share / share.sum()
        load_force[ids] += share[:, None] * np.asarray(ld.force)[None, :]
        load_moment[ids] += share[:, None] * np.asarray(ld.moment)[None, :]
        fully_fixed = ids[(fix_mask[ids] & 0b111) == 0b111]
        if len(fully_fixed) == len(ids) and np.any(ld.force):
            raise SceneError(f"{scene.source.name}: [[load]] on '{ld.nodes}': every node of the set has all "
                             "translations fixed, so the force would do nothing")

    velocity0 = np.zeros((n, 3))
    omega0 = np.zeros((n, 3))
    for ic in scene.initial:
        ids = nodes_of(ic.nodes)
        w = np.asarray(ic.angular_velocity)
        velocity0[ids] = np.asarray(ic.velocity) + np.cross(w, points[ids] - np.asarray(ic.center))
        omega0[ids] = w

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
        d = np.asarray(rb.direction) / np.linalg.norm(rb.direction)
        bodies.append(RigidBodySpec(rb.name, ids, rb.mass, tuple(d), rb.mass + float(node_mass[ids].sum()),
                                    float(np.mean(velocity0[ids] @ d))))
    names = [b.name for b in bodies]
    walls = tuple(WallSpec(tuple(w.point), tuple(np.asarray(w.normal) / np.linalg.norm(w.normal)),
                           names.index(w.moves_with) if w.moves_with else -1) for w in scene.walls)
    for d in range(3):                       # supports do not move: no initial velocity there
        velocity0[(fix_mask >> d) & 1 == 1, d] = 0.0
        omega0[(fix_mask >> (3 + d)) & 1 == 1, d] = 0.0
    probes = tuple(ProbeSpec(p.name, nodes_of(p.nodes), p.components) for p in scene.probes)
    zeta, zw = through_thickness_rule(sec.rule, sec.points)
    min_edge = float(edges.min())
    grid = _grid_geometry(scene, points, min_edge, planes_xyz) if scene.method.kind == "mpm" else None
    return Model(points=points, quads=quads, area0=area0, corner_weight=weight, node_mass=node_mass,
                 node_inertia=node_inertia, node_area=node_area, fix_mask=fix_mask, load_force=load_force,
                 load_moment=load_moment, velocity0=velocity0, omega0=omega0, zeta=zeta, zeta_weight=zw,
                 grid=grid, probes=probes, min_edge=min_edge, mean_edge=float(edges.mean()),
                 max_edge=float(edges.max()), rigid_bodies=tuple(bodies), walls=walls, node_body=node_body,
                 **(node_neighbors(quads, n) if scene.contact else {}))


def node_neighbors(quads: np.ndarray, n: int) -> dict[str, np.ndarray]:
    """CSR lists of the nodes sharing an element with each node (itself included): the
    contact exclusion ring of method.md 7.3."""
    pairs = np.stack(np.broadcast_arrays(quads[:, :, None], quads[:, None, :]), axis=-1).reshape(-1, 2)
    pairs = np.unique(pairs, axis=0)
    start = np.searchsorted(pairs[:, 0], np.arange(n + 1)).astype(np.int32)
    return {"neighbor_start": start, "neighbor_nodes": pairs[:, 1].astype(np.int32)}
