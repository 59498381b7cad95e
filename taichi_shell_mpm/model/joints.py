"""Ties and spot welds at t = 0 (numpy; scene/joints.py declares them, stages/joints.py runs them).

Every joint is one slave node s that follows up to four master nodes a with weights N_a and
an offset r (stages/joints.py):

* a [[tie]] slave: the masters are the corners of its nearest segment of the surface, N_a
  the segment's shape functions at the slave's projection (xi, eta) and r = x_s - x(xi, eta)
  (along the segment normal when the projection falls inside the segment: the offset is
  kept; beside an edge the point clamped to the segment);
* a [[spotweld]] pair [N1, N2]: the one master N1, N = 1, r = x2 - x1 (the two nodes move
  as one rigid link), and the weld axis N1 -> N2 (coincident nodes: N1's shell normal).

Projection on a quad: x(xi, eta) = sum N_a(xi, eta) x_a, N_a = (1 + xi xi_a)(1 + eta eta_a) / 4,
the point nearest the slave by Gauss-Newton on |x(xi, eta) - x_s|^2, clamped to [-1, 1]^2
after each step (20 iterations: converged to round-off on a flat or gently warped quad); on a
triangle the barycentric projection on its plane, clamped to the triangle.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene import SceneError

TIE, WELD = 0, 1
FIRST_IDS = 8          # slave ids a warning or error names
QUAD_XI = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])


@dataclass(frozen=True)
class JointGroup:
    """One [[tie]] or [[spotweld]] entry: its joints are rows `first` .. `first + count` - 1."""
    name: str
    kind: int                  # TIE or WELD
    first: int
    count: int
    unfound: tuple[int, ...] = ()      # a tie's slave nodes without a segment within tolerance


@dataclass(frozen=True)
class JointTable:
    slave: np.ndarray          # (J,) slave node
    masters: np.ndarray        # (J, 4) master nodes, -1 padded
    weights: np.ndarray        # (J, 4) N_a
    offset: np.ndarray         # (J, 3) r at t = 0
    axis: np.ndarray           # (J, 3) a weld's axis (a tie's segment normal)
    rotations: np.ndarray      # (J,) 1: the slave's rotation is tied too
    element: np.ndarray        # (J,) a tie's segment (released when it erodes), -1 for a weld
    kind: np.ndarray           # (J,) TIE / WELD
    strength: np.ndarray       # (J, 6) SN, SS, n, m, failure time (1e300: never), coincident (1/0)
    group: np.ndarray          # (J,) index of the group
    groups: tuple[JointGroup, ...]

    def __len__(self) -> int:
        return len(self.slave)


def _shape(xi: np.ndarray) -> np.ndarray:
    """(k, 4) bilinear shape functions at (k, 2) points."""
    return 0.25 * (1.0 + xi[:, None, 0] * QUAD_XI[:, 0]) * (1.0 + xi[:, None, 1] * QUAD_XI[:, 1])


def project_quad(p: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k, 2) (xi, eta) of the points of the quads (k, 4, 3) nearest the points p (k, 3), and
    (k, 4) the shape functions there (module docstring)."""
    xi = np.zeros((len(p), 2))
    for _ in range(20):
        n = _shape(xi)
        dn_dxi = 0.25 * QUAD_XI[:, 0] * (1.0 + xi[:, None, 1] * QUAD_XI[:, 1])
        dn_deta = 0.25 * QUAD_XI[:, 1] * (1.0 + xi[:, None, 0] * QUAD_XI[:, 0])
        jac = np.stack([np.einsum("ka,kai->ki", dn_dxi, x), np.einsum("ka,kai->ki", dn_deta, x)], axis=2)  # (k, 3, 2)
        res = p - np.einsum("ka,kai->ki", n, x)
        lhs = np.einsum("kia,kib->kab", jac, jac)
        rhs = np.einsum("kia,ki->ka", jac, res)
        xi = np.clip(xi + np.linalg.solve(lhs, rhs[..., None])[..., 0], -1.0, 1.0)
    return xi, _shape(xi)


def project_triangle(p: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(k, 3) barycentric weights of the points of the triangles (k, 3, 3) nearest p (on the
    plane, clamped to the triangle and renormalised)."""
    e1, e2 = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]
    d = p - x[:, 0]
    a11, a12, a22 = np.sum(e1 * e1, 1), np.sum(e1 * e2, 1), np.sum(e2 * e2, 1)
    b1, b2 = np.sum(d * e1, 1), np.sum(d * e2, 1)
    det = a11 * a22 - a12 * a12
    u = (a22 * b1 - a12 * b2) / det
    v = (a11 * b2 - a12 * b1) / det
    w = np.clip(np.stack([1.0 - u - v, u, v], axis=1), 0.0, None)
    return w / w.sum(axis=1)[:, None]


def node_normals(points: np.ndarray, elements: np.ndarray) -> np.ndarray:
    """Unit nodal normals: the sum of the adjacent elements' A e3."""
    x = points[np.where(elements >= 0, elements, elements[:, :1])]
    normal = 0.5 * np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1])
    out = np.zeros_like(points)
    valid = elements >= 0
    np.add.at(out, elements[valid], np.repeat(normal[:, None, :], 4, axis=1)[valid])
    return out / np.maximum(np.linalg.norm(out, axis=1), 1e-300)[:, None]


def _ids(nodes: list[int]) -> str:
    return ", ".join(map(str, nodes[:FIRST_IDS])) + (" ..." if len(nodes) > FIRST_IDS else "")


def tie_rows(scene, tie, slaves: np.ndarray, surface: np.ndarray, points: np.ndarray, elements: np.ndarray,
             thickness: np.ndarray, node_thickness: np.ndarray):
    """The rows of one [[tie]]: for each slave within tolerance of a segment of `surface` (not
    one of its own elements), its segment's corners, the shape functions and the offset."""
    tol = tie.tolerance
    if tol is None:
        tol = float(max(node_thickness[slaves].max(), thickness[surface].max() if len(surface) else 0.0))
    corners = elements[surface]
    quad = corners[:, 3] >= 0
    xs = points[np.where(corners >= 0, corners, corners[:, :1])]
    centre = xs.mean(axis=1)
    radius = np.linalg.norm(xs - centre[:, None], axis=2).max(axis=1)
    rows, unfound = [], []
    for s in slaves:
        p = points[s]
        near = np.flatnonzero(np.linalg.norm(centre - p, axis=1) <= radius + tol)
        near = near[~np.any(corners[near] == s, axis=1)]          # never the slave's own elements
        if not len(near):
            unfound.append(int(s))
            continue
        weights = np.zeros((len(near), 4))
        q = near[quad[near]]
        if len(q):
            _, weights[quad[near]] = project_quad(np.repeat(p[None], len(q), 0), xs[q])
        t = near[~quad[near]]
        if len(t):
            weights[~quad[near], :3] = project_triangle(np.repeat(p[None], len(t), 0), xs[t, :3])
        foot = np.einsum("ka,kai->ki", weights, xs[near])
        dist = np.linalg.norm(p - foot, axis=1)
        best = int(np.argmin(dist))
        if dist[best] > tol * (1.0 + 1e-9):
            unfound.append(int(s))
            continue
        e = int(surface[near[best]])
        rows.append((int(s), np.where(elements[e] >= 0, elements[e], -1), weights[best], p - foot[best], e))
    if unfound:
        text = (f"{scene.source.name}: [[tie]] '{tie.name}': {len(unfound)} slave node{'s' if len(unfound) > 1 else ''} "
                f"without a segment within tolerance {tol:.6g} (nodes {_ids(unfound)})")
        if tie.strict:
            raise SceneError(text)
    else:
        text = None
    return rows, unfound, text


def build_joints(scene, points: np.ndarray, elements: np.ndarray, thickness: np.ndarray,
                 node_thickness: np.ndarray, nodes_of, element_selection, fix_mask: np.ndarray,
                 node_body: np.ndarray, motion_mask: np.ndarray | None) -> tuple[JointTable | None, list[str]]:
    """The joints of the scene's [[tie]] and [[spotweld]] entries, and the notes (warnings) of
    their set-up; raises SceneError naming the entry and node for a joint that cannot be."""
    if not scene.ties and not scene.spotwelds:
        return None, []
    n = len(points)
    name = scene.source.name
    rows, groups, notes, strengths = [], [], [], []
    for k, tie in enumerate(scene.ties):
        slaves = nodes_of(tie.nodes)
        check_slaves(f"{name}: [[tie]] '{tie.name}'", slaves, fix_mask, node_body, motion_mask)
        try:
            surface = element_selection(tie.surface, f"[[tie]][{k}]")
        except SceneError as exc:          # parts.element_selection names the key `elements`
            raise SceneError(str(exc).replace(f"[[tie]][{k}].elements", f"[[tie]][{k}].surface")) from None
        found, unfound, text = tie_rows(scene, tie, slaves, surface, points, elements, thickness, node_thickness)
        if text:
            notes.append(text)
        groups.append(JointGroup(tie.name, TIE, len(rows), len(found), tuple(unfound)))
        for s, masters, w, r, e in found:
            rows.append((s, masters, w, r, np.zeros(3), int(tie.rotations), e, TIE))
            strengths.append((0.0, 0.0, 0.0, 0.0, 1e300, 0.0))
    normals = None
    for k, weld in enumerate(scene.spotwelds):
        first = len(rows)
        for a, b in weld.pairs:
            for node in (a, b):
                if node >= n:
                    raise SceneError(f"{name}: [[spotweld]][{k}].pairs: node {node} out of range (the mesh has "
                                     f"{n} nodes)")
            r = points[b] - points[a]
            size = np.linalg.norm(r)
            coincident = size <= 1e-9 * max(1.0, float(np.abs(points).max()))
            if coincident:
                if normals is None:
                    normals = node_normals(points, elements)
                axis = normals[a]
            else:
                axis = r / size
            rows.append((b, np.array([a, -1, -1, -1]), np.array([1.0, 0.0, 0.0, 0.0]), r, axis, 1, -1, WELD))
            strengths.append((weld.normal_strength, weld.shear_strength, weld.n, weld.m,
                              weld.failure_time if weld.failure_time is not None else 1e300, float(coincident)))
        groups.append(JointGroup(weld.name, WELD, first, len(weld.pairs)))
    if not rows:
        return None, notes
    slave = np.array([r[0] for r in rows], np.int32)
    masters = np.stack([r[1] for r in rows]).astype(np.int32)
    table = JointTable(
        slave=slave, masters=masters, weights=np.stack([r[2] for r in rows]), offset=np.stack([r[3] for r in rows]),
        axis=np.stack([r[4] for r in rows]), rotations=np.array([r[5] for r in rows], np.int32),
        element=np.array([r[6] for r in rows], np.int32), kind=np.array([r[7] for r in rows], np.int32),
        strength=np.array(strengths, float),
        group=np.repeat(np.arange(len(groups)), [g.count for g in groups]).astype(np.int32), groups=tuple(groups))
    check_joints(scene, table, fix_mask, node_body, motion_mask)
    return table, notes


def check_slaves(where: str, slaves: np.ndarray, fix_mask, node_body, motion_mask) -> None:
    """No slave is fixed, moved or in a rigid body (error naming the first such node)."""
    for s in slaves:
        s = int(s)
        if fix_mask[s] != 0:
            raise SceneError(f"{where}: node {s} is fixed by a [[boundary]] and cannot be a joint's slave")
        if motion_mask is not None and motion_mask[s] != 0:
            raise SceneError(f"{where}: node {s} is moved by a [[motion]] and cannot be a joint's slave")
        if node_body[s] >= 0:
            raise SceneError(f"{where}: node {s} is in a [[rigid_body]] and cannot be a joint's slave")


def check_joints(scene, table: JointTable, fix_mask, node_body, motion_mask) -> None:
    """One slave per node; a slave is neither fixed, moved nor in a rigid body, nor a master;
    a master is neither moved nor in a rigid body (it may be fixed: the slave's load then goes
    to the support)."""
    name = scene.source.name
    where = {}
    for g in table.groups:
        for j in range(g.first, g.first + g.count):
            where[j] = f"[[{'tie' if g.kind == TIE else 'spotweld'}]] '{g.name}'"
    seen: dict[int, int] = {}
    for j, s in enumerate(table.slave):
        s = int(s)
        if s in seen:
            raise SceneError(f"{name}: {where[j]}: node {s} is already the slave of {where[seen[s]]} (a node "
                             "follows one joint)")
        seen[s] = j
        check_slaves(f"{name}: {where[j]}", np.array([s]), fix_mask, node_body, motion_mask)
    for j, masters in enumerate(table.masters):
        for a in masters[masters >= 0]:
            a = int(a)
            if a in seen:
                raise SceneError(f"{name}: {where[j]}: node {a} is a master here and the slave of {where[seen[a]]} "
                                 "(joints do not chain)")
            if motion_mask is not None and motion_mask[a] != 0:
                raise SceneError(f"{name}: {where[j]}: master node {a} is moved by a [[motion]] (not supported)")
            if node_body[a] >= 0:
                raise SceneError(f"{name}: {where[j]}: master node {a} is in a [[rigid_body]] (not supported)")


def consistent_velocities(table: JointTable, velocity0: np.ndarray, omega0: np.ndarray) -> None:
    """A slave starts with its masters' motion (in place): v_s = sum N_a (v_a + omega_a x r),
    and with tied rotations omega_s = sum N_a omega_a (what the step keeps)."""
    for j in range(len(table)):
        valid = table.masters[j] >= 0
        a, w = table.masters[j][valid], table.weights[j][valid]
        spin = w @ omega0[a]
        velocity0[table.slave[j]] = w @ velocity0[a] + np.cross(spin, table.offset[j])
        if table.rotations[j]:
            omega0[table.slave[j]] = spin


def lumped(table: JointTable, active: np.ndarray, offset: np.ndarray, mass: np.ndarray,
           inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The masses and rotary inertias the step integrates (stages/joints.py): each active
    joint's slave mass N_a m_s (and N_a (m_s |r|^2 + J_s tied, m_s |r|^2 free)) moved to its
    masters; the slave keeps its rotary inertia when its rotation is free."""
    m, j_ = mass.copy(), inertia.copy()
    for j in np.flatnonzero(active):
        s = table.slave[j]
        valid = table.masters[j] >= 0
        a, w = table.masters[j][valid], table.weights[j][valid]
        r2 = float(offset[j] @ offset[j])
        np.add.at(m, a, w * mass[s])
        np.add.at(j_, a, w * (mass[s] * r2 + (inertia[s] if table.rotations[j] else 0.0)))
        m[s] = 0.0
        if table.rotations[j]:
            j_[s] = 0.0
    return m, j_
