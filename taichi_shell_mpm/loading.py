"""Scene loads and prescribed motions -> the model's arrays (numpy, no Taichi here; the step
reads them in stages/loads.py and stages/motion.py).

* ``[[load]]``: a plain load (no curve, not a follower) goes into the dense nodal vectors at
  load factor 1 (``Model.load_force`` / ``load_moment``), as before; a load with a curve or
  one that follows its node becomes entries of a per-node list (CSR ``entry_start``: the
  node, curve, force and moment of that node's share, and for a follower its reference
  frame, :func:`follower_frames`), so that the step pays for them only at the nodes they load.
* ``[[pressure]]``: one entry per element of each table (value, curve); the corner forces are
  gathered at the loaded nodes in entry order (``pressure_nodes``, CSR slots 4 i + a).
* ``[gravity]``: g and its curve; body force m g with the *physical* node mass (a static
  run's masses are scaled, assembly.uniform_dt_mass_factor).
* ``[[motion]]``: per node a mask of prescribed DOFs and the motion of each DOF.

Curves are numbered in scene order; -1 stands for the load factor (lambda in a static run,
1 in a dynamic one).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from . import curves as curve_tables
from .scene import DOFS, MOTION_KINDS, Scene, SceneError


@dataclass(frozen=True)
class CurveTable:
    """The scene's curves as the step's tables (curves.py): per curve its kind, rows and
    parameters; the rows of all table curves concatenated."""
    specs: tuple                    # scene.Curve, for the host twin (curves.evaluate)
    kind: np.ndarray                # (nc,) curves.TABLE | curves.SMOOTH_STEP
    first: np.ndarray               # (nc,) first row in `rows`
    count: np.ndarray               # (nc,) rows
    parameter: np.ndarray           # (nc, 3) start, end, scale
    origin: np.ndarray              # (nc, 2) I(0), J(0)
    rows: np.ndarray                # (r, curves.COLUMNS)


@dataclass(frozen=True)
class MotionSpec:
    name: str
    nodes: np.ndarray
    dofs: tuple[str, ...]
    kind: int                       # index into scene.MOTION_KINDS
    curve: int                      # -1: the load factor
    value: np.ndarray               # (6,) per DOF (ux .. rz), 0 where not prescribed
    body: int = -1                  # the rigid body it moves (nodes empty), -1: its nodes
    window: tuple[float, float] = (0.0, float("inf"))   # prescribed from .. until (start, end)


@dataclass(frozen=True)
class Loading:
    curves: CurveTable
    entry_start: np.ndarray         # (n + 1,) CSR node -> load entries
    entry_node: np.ndarray          # (e,)
    entry_curve: np.ndarray         # (e,)
    entry_neighbor: np.ndarray      # (e,) a follower's in-plane reference node, -1: not a follower
    entry_frame: np.ndarray         # (e, 3, 3) a follower's reference frame (rows; follower_frames)
    entry_force: np.ndarray         # (e, 3) the node's share
    entry_moment: np.ndarray        # (e, 3)
    pressure_element: np.ndarray    # (p,)
    pressure_value: np.ndarray      # (p,)
    pressure_curve: np.ndarray      # (p,)
    pressure_nodes: np.ndarray      # (q,) the loaded nodes
    pressure_node_start: np.ndarray  # (q + 1,) CSR loaded node -> slots 4 i + a
    pressure_node_slots: np.ndarray
    gravity: np.ndarray             # (3,) g (0: none)
    gravity_curve: int
    physical_mass: np.ndarray       # (n,)
    motions: tuple[MotionSpec, ...]
    motion_mask: np.ndarray         # (n,) bits ux .. rz prescribed by a motion
    node_motion: np.ndarray         # (n, 6) motion of each DOF, -1 = none
    body_motion_mask: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))   # (bodies,) DOF bits
    body_motion: np.ndarray = field(default_factory=lambda: np.zeros((0, 6), np.int32))   # (bodies, 6) motion, -1 = none

    @property
    def loads(self) -> bool:
        """Loads beyond the plain nodal ones (curve or follower entries, pressure, gravity) or
        prescribed motion (config.Features.loads)."""
        return bool(len(self.entry_curve) or len(self.pressure_element) or np.any(self.gravity) or self.motions)


def load_shares(distribute: str, ids: np.ndarray, node_area: np.ndarray, points: np.ndarray,
                elements: np.ndarray) -> np.ndarray:
    """Each node's share (not normalised) of a [[load]] on the nodes `ids`: its tributary area,
    1, or (``length``) half the length of every element edge joining it to another node of
    the set, the consistent nodal loads of a uniform line load along those edges."""
    if distribute == "area":
        return node_area[ids]
    if distribute == "equal":
        return np.ones(len(ids))
    nxt = np.roll(elements, -1, axis=1)
    tri = elements[:, 3] < 0
    nxt[tri, 2] = elements[tri, 0]
    pairs = np.stack([elements.ravel(), nxt.ravel()], axis=1)
    pairs = np.unique(np.sort(pairs[(pairs >= 0).all(axis=1)], axis=1), axis=0)
    inside = np.zeros(len(points), bool)
    inside[ids] = True
    pairs = pairs[inside[pairs].all(axis=1)]
    length = np.linalg.norm(points[pairs[:, 0]] - points[pairs[:, 1]], axis=1)
    share = np.zeros(len(points))
    np.add.at(share, pairs.ravel(), np.repeat(0.5 * length, 2))
    return share[ids]


def follower_frames(nodes: np.ndarray, points: np.ndarray, elements: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(neighbor, frame) of follower loads on `nodes`: the next corner after the node in the
    first element that has it, and the rows e0, n0 x e0, n0 of the reference frame, n0 the
    node's unit normal (the sum of its elements' vector areas) and e0 the unit direction to
    the neighbour projected onto the plane normal to n0 (stages/loads.ExternalLoads.follow)."""
    corners = np.where(elements >= 0, elements, elements[:, :1])
    x = points[corners]
    quad = 0.5 * np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1])
    tri = 0.5 * np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    vector_area = np.where((elements[:, 3] < 0)[:, None], tri, quad)
    normal = np.zeros_like(points)
    valid = elements >= 0
    np.add.at(normal, elements[valid], np.repeat(vector_area, 4, axis=0).reshape(-1, 4, 3)[valid])
    count = valid.sum(axis=1)
    first = np.full(len(points), elements.size)                 # each node's first slot 4 e + a
    np.minimum.at(first, elements[valid], np.flatnonzero(valid.ravel()))
    e, a = np.divmod(first[nodes], 4)
    neighbor = elements[e, (a + 1) % count[e]]
    n0 = normal[nodes] / np.linalg.norm(normal[nodes], axis=1, keepdims=True)
    edge = points[neighbor] - points[nodes]
    edge -= np.sum(edge * n0, axis=1, keepdims=True) * n0
    e0 = edge / np.linalg.norm(edge, axis=1, keepdims=True)
    return neighbor, np.stack([e0, np.cross(n0, e0), n0], axis=1)


def pressure_corner_forces(x: np.ndarray, triangle: np.ndarray) -> np.ndarray:
    """(p, 4, 3) nodal forces of a unit pressure on elements with corners x (p, 4, 3), along
    the corner order's normal: the consistent int N_a n dA over the bilinear surface through
    the corners, c0 + (xi_a c1 + eta_a c2) / 3 with x_xi x x_eta = c0 + xi c1 + eta c2
    (its total, 4 c0 = d13 x d24 / 2, is the vector area); a triangle's third of
    (x2 - x1) x (x3 - x1) / 2 at each corner.  numpy twin of stages/loads.pressure_corner_forces."""
    a1 = 0.25 * (-x[:, 0] + x[:, 1] + x[:, 2] - x[:, 3])
    a2 = 0.25 * (-x[:, 0] - x[:, 1] + x[:, 2] + x[:, 3])
    a3 = 0.25 * (x[:, 0] - x[:, 1] + x[:, 2] - x[:, 3])
    c0, c1, c2 = np.cross(a1, a2), np.cross(a1, a3), np.cross(a3, a2)
    xi, eta = np.array([-1.0, 1.0, 1.0, -1.0]), np.array([-1.0, -1.0, 1.0, 1.0])
    quad = c0[:, None, :] + (xi[None, :, None] * c1[:, None, :] + eta[None, :, None] * c2[:, None, :]) / 3.0
    third = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]) / 6.0
    tri = np.concatenate([np.repeat(third[:, None, :], 3, axis=1), np.zeros((len(x), 1, 3))], axis=1)
    return np.where(triangle[:, None, None], tri, quad)


def _curve_table(scene: Scene) -> CurveTable:
    specs = tuple(scene.curves.values())
    rows, first, count, kind, parameter, origin = [], [], [], [], [], []
    at = 0
    for c in specs:
        smooth = c.kind == "smooth_step"
        block = np.zeros((0, curve_tables.COLUMNS)) if smooth else curve_tables.table_rows(curve_tables.points_of(c))
        rows.append(block)
        first.append(at)
        count.append(len(block))
        at += len(block)
        kind.append(curve_tables.SMOOTH_STEP if smooth else curve_tables.TABLE)
        parameter.append((c.start, c.end, c.scale))
        origin.append(curve_tables.origin(c))
    return CurveTable(specs=specs, kind=np.array(kind, np.int32), first=np.array(first, np.int32),
                      count=np.array(count, np.int32), parameter=np.array(parameter).reshape(-1, 3),
                      origin=np.array(origin).reshape(-1, 2),
                      rows=np.concatenate(rows) if rows else np.zeros((0, curve_tables.COLUMNS)))


def assemble_loading(scene: Scene, points: np.ndarray, elements: np.ndarray, node_area: np.ndarray,
                     physical_mass: np.ndarray, fix_mask: np.ndarray, node_body: np.ndarray,
                     nodes_of: Callable[[str], np.ndarray],
                     elements_of: Callable[[str, str], np.ndarray]) -> tuple[np.ndarray, np.ndarray, Loading]:
    """(load_force, load_moment, Loading) of the scene; raises SceneError for loads that cannot
    act (a set of fully fixed nodes, a line load without edges) and motions that clash with
    supports, rigid bodies or one another.  `elements_of(name, path)`: the element ids of a
    set (model/parts.element_selection)."""
    n = len(points)
    src = scene.source.name
    index = {name: i for i, name in enumerate(scene.curves)}
    load_force, load_moment = np.zeros((n, 3)), np.zeros((n, 3))
    entries = []                                       # (node, curve, follower, force, moment)
    for ld in scene.loads:
        ids = nodes_of(ld.nodes)
        share = load_shares(ld.distribute, ids, node_area, points, elements)
        if share.sum() <= 0.0:
            raise SceneError(f"{src}: [[load]] on '{ld.nodes}': a line load needs element edges "
                             "joining two nodes of the set (there are none)")
        per_length = any(ld.force_per_length) or any(ld.moment_per_length)
        if per_length:                     # q x the node's half edge lengths
            total_force, total_moment = np.asarray(ld.force_per_length), np.asarray(ld.moment_per_length)
        else:                              # the totals, by the shares
            share = share / share.sum()
            total_force, total_moment = np.asarray(ld.force), np.asarray(ld.moment)
        force = share[:, None] * total_force[None, :]
        moment = share[:, None] * total_moment[None, :]
        if ld.curve is None and not ld.follower:
            load_force[ids] += force
            load_moment[ids] += moment
        else:
            curve = index[ld.curve] if ld.curve is not None else -1
            entries += [(c, curve, int(ld.follower), f, m) for c, f, m in zip(ids, force, moment)]
        fully_fixed = ids[(fix_mask[ids] & 0b111) == 0b111]
        if len(fully_fixed) == len(ids) and np.any(total_force):
            raise SceneError(f"{src}: [[load]] on '{ld.nodes}': every node of the set has all "
                             "translations fixed, so the force would do nothing")
    entries.sort(key=lambda e: e[0])                   # stable: scene order within a node
    nodes = np.array([e[0] for e in entries], np.int64)
    entry_start = np.searchsorted(nodes, np.arange(n + 1)).astype(np.int32)
    follower = np.array([e[2] for e in entries], bool)
    entry_neighbor = np.full(len(entries), -1, np.int32)
    entry_frame = np.zeros((len(entries), 3, 3))
    if follower.any():
        neighbor, frame = follower_frames(nodes[follower], points, elements)
        entry_neighbor[follower], entry_frame[follower] = neighbor, frame

    pressure_element, pressure_value, pressure_curve = [], [], []
    for i, p in enumerate(scene.pressures):
        ids = elements_of(p.elements, f"[[pressure]][{i}]")
        pressure_element += list(ids)
        pressure_value += [p.value] * len(ids)
        pressure_curve += [index[p.curve] if p.curve is not None else -1] * len(ids)
    corners = elements[np.asarray(pressure_element, np.int64)].reshape(-1, 4)
    slot_node = corners.ravel()
    slots = np.flatnonzero(slot_node >= 0)
    slots = slots[np.argsort(slot_node[slots], kind="stable")]
    pressure_nodes, counts = np.unique(slot_node[slots], return_counts=True)

    gravity = np.asarray(scene.gravity.acceleration if scene.gravity else (0.0, 0.0, 0.0), dtype=float)
    gravity_curve = index[scene.gravity.curve] if scene.gravity and scene.gravity.curve else -1

    motions = []
    motion_mask = np.zeros(n, np.int32)
    node_motion = np.full((n, 6), -1, np.int32)
    body_names = [rb.name for rb in scene.rigid_bodies]
    body_motion_mask = np.zeros(len(body_names), np.int32)
    body_motion = np.full((len(body_names), 6), -1, np.int32)
    for k, mo in enumerate(scene.motions):
        where = f"{src}: [[motion]] '{mo.name}'"
        window = (mo.start, mo.end if mo.end is not None else float("inf"))
        bits = sum(1 << DOFS.index(d) for d in mo.dofs)
        value = np.array([mo.value[mo.dofs.index(d)] if d in mo.dofs else 0.0 for d in DOFS])
        if mo.body is not None:       # a rigid body's DOFs (stages/bodies.py)
            b = body_names.index(mo.body)
            rb = scene.rigid_bodies[b]
            held = sum(1 << DOFS.index(d) for d in rb.fixed)
            for label, clash in (("fixed by its `fixed`", held & bits),
                                 ("prescribed by another [[motion]]", body_motion_mask[b] & bits)):
                if clash:
                    raise SceneError(f"{where}: the body's {DOFS[int(np.log2(clash & -clash))]} is {label} too "
                                     "(a DOF takes one of them)")
            body_motion_mask[b] |= bits
            turned = (held | body_motion_mask[b]) >> 3
            if turned and turned != 0b111:
                raise SceneError(f"{where}: a body's prescribed rotation needs its other rotations fixed or "
                                 "prescribed too (fixed = [...] or dofs), got "
                                 + ", ".join(d for i, d in enumerate(DOFS[3:]) if (turned >> i) & 1))
            if window != (0.0, float("inf")) and bits >> 3:
                raise SceneError(f"{where}: start / end (a time window) hold a body's translations only: its "
                                 "rotations are held or free for the whole run")
            body_motion[b, [DOFS.index(d) for d in mo.dofs]] = k
            motions.append(MotionSpec(mo.name, np.zeros(0, np.int64), mo.dofs, MOTION_KINDS.index(mo.kind),
                                      index[mo.curve] if mo.curve is not None else -1, value, b, window))
            continue
        ids = nodes_of(mo.nodes)
        for label, clash in (("fixed by a [[boundary]]", fix_mask[ids] & bits),
                             ("prescribed by another [[motion]]", motion_mask[ids] & bits)):
            if np.any(clash):
                j = int(np.argmax(clash != 0))
                dof = DOFS[int(np.log2(clash[j] & -clash[j]))]
                raise SceneError(f"{where}: node {int(ids[j])} has {dof} {label} too (a DOF takes one of them)")
        if np.any(node_body[ids] >= 0):
            raise SceneError(f"{where}: node {int(ids[np.argmax(node_body[ids] >= 0)])} belongs to a "
                             "[[rigid_body]] (its motion is the body's)")
        motion_mask[ids] |= bits
        for d in mo.dofs:
            node_motion[ids, DOFS.index(d)] = k
        motions.append(MotionSpec(mo.name, ids, mo.dofs, MOTION_KINDS.index(mo.kind),
                                  index[mo.curve] if mo.curve is not None else -1, value, window=window))

    loading = Loading(
        curves=_curve_table(scene), entry_start=entry_start, entry_node=nodes.astype(np.int32),
        entry_curve=np.array([e[1] for e in entries], np.int32), entry_neighbor=entry_neighbor,
        entry_frame=entry_frame,
        entry_force=np.array([e[3] for e in entries]).reshape(-1, 3),
        entry_moment=np.array([e[4] for e in entries]).reshape(-1, 3),
        pressure_element=np.array(pressure_element, np.int32), pressure_value=np.array(pressure_value, float),
        pressure_curve=np.array(pressure_curve, np.int32), pressure_nodes=pressure_nodes.astype(np.int32),
        pressure_node_start=np.concatenate([[0], np.cumsum(counts)]).astype(np.int32),
        pressure_node_slots=slots.astype(np.int32), gravity=gravity, gravity_curve=gravity_curve,
        physical_mass=physical_mass, motions=tuple(motions), motion_mask=motion_mask, node_motion=node_motion,
        body_motion_mask=body_motion_mask, body_motion=body_motion)
    return load_force, load_moment, loading


def reference_loads(model, lam: float) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) nodal forces and moments of every load at load factor `lam` in the reference
    configuration (followers unturned): the scale of a static run's residual (solvers/static.py)."""
    force, moment = lam * model.load_force, lam * model.load_moment
    ld = model.loading
    specs = ld.curves.specs
    scale = np.array([curve_tables.evaluate(c, lam) for c in specs] + [lam])       # [-1]: the load factor
    if len(ld.entry_curve):
        node = np.repeat(np.arange(len(force)), np.diff(ld.entry_start))
        np.add.at(force, node, scale[ld.entry_curve][:, None] * ld.entry_force)
        np.add.at(moment, node, scale[ld.entry_curve][:, None] * ld.entry_moment)
    if len(ld.pressure_element):
        corners = model.elements[ld.pressure_element]
        x = model.points[np.where(corners >= 0, corners, corners[:, :1])]
        f = pressure_corner_forces(x, corners[:, 3] < 0) * (ld.pressure_value * scale[ld.pressure_curve])[:, None, None]
        valid = corners >= 0
        np.add.at(force, corners[valid], f[valid])
    return force + ld.physical_mass[:, None] * (scale[ld.gravity_curve] * ld.gravity)[None, :], moment
