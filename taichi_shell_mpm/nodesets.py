"""Node sets: resolve a :class:`~taichi_shell_mpm.scene.NodeSet` selector to node ids.

Selectors (``NodeSet.kind``): ``all`` every node; ``box`` nodes with
``box_min - tol <= x <= box_max + tol`` componentwise; ``plane`` nodes within ``tol`` of the
plane through ``point`` with normal ``normal``; ``nearest`` the single node nearest to
``point`` (lowest id on ties), which must lie within the mesh's bounding box grown by 5% of
its largest extent; ``ids`` the listed 0-based node ids.  A selection that comes out empty,
or a ``nearest`` point outside the mesh, is an error, so that a mistyped coordinate cannot
silently drop (or misplace) a boundary condition, a load or a probe.
"""
from __future__ import annotations

import numpy as np

from .scene import NodeSet, SceneError


NEAREST_SLACK = 0.05
"""A ``nearest`` point may lie this fraction of the mesh's largest extent outside its bounding box."""


def _vec(v) -> str:
    """Compact vector text, e.g. ``[10,0,0]``."""
    return "[" + ",".join(f"{float(c):g}" for c in v) + "]"


def describe(nodeset: NodeSet) -> str:
    """One-line description of the selector, e.g. ``plane point=[10,0,0] normal=[1,0,0] tol=1e-06``."""
    if nodeset.kind == "box":
        return (f"box min={_vec(nodeset.box_min)} max={_vec(nodeset.box_max)} "
                f"tol={nodeset.tol:g}")
    if nodeset.kind == "plane":
        return f"plane point={_vec(nodeset.point)} normal={_vec(nodeset.normal)} tol={nodeset.tol:g}"
    if nodeset.kind == "nearest":
        return f"nearest point={_vec(nodeset.point)}"
    if nodeset.kind == "ids":
        return f"ids={list(nodeset.ids)}"
    return nodeset.kind


def _require(nodeset: NodeSet, *fields: str) -> None:
    """Raise if a field the selector kind needs is unset."""
    missing = [f for f in fields if getattr(nodeset, f) is None]
    if missing:
        raise SceneError(f"nodeset '{nodeset.name}' ({nodeset.kind}) needs "
                         + " and ".join(missing))


def select_nodes(nodeset: NodeSet, points: np.ndarray) -> np.ndarray:
    """Sorted, unique int64 ids of the nodes of ``points`` (shape (n, 3)) that ``nodeset`` selects.

    Raises :class:`SceneError` for a missing selector field, a zero plane normal, an
    out-of-range id, a ``nearest`` point outside the mesh, an unknown kind, or an empty selection.
    """
    points = np.asarray(points, dtype=np.float64)
    n = len(points)
    kind = nodeset.kind
    if kind == "all":
        ids = np.arange(n)
    elif kind == "box":
        _require(nodeset, "box_min", "box_max")
        lo = np.asarray(nodeset.box_min, dtype=np.float64) - nodeset.tol
        hi = np.asarray(nodeset.box_max, dtype=np.float64) + nodeset.tol
        ids = np.nonzero(((points >= lo) & (points <= hi)).all(axis=1))[0]
    elif kind == "plane":
        _require(nodeset, "point", "normal")
        normal = np.asarray(nodeset.normal, dtype=np.float64)
        length = np.linalg.norm(normal)
        if length == 0.0:
            raise SceneError(f"nodeset '{nodeset.name}' ({describe(nodeset)}): normal is zero")
        distance = (points - np.asarray(nodeset.point, dtype=np.float64)) @ (normal / length)
        ids = np.nonzero(np.abs(distance) <= nodeset.tol)[0]
    elif kind == "nearest":
        _require(nodeset, "point")
        target = np.asarray(nodeset.point, dtype=np.float64)
        offset = points - target
        ids = np.argmin(np.einsum("ij,ij->i", offset, offset), keepdims=True) if n else []
        if n:
            lo, hi = points.min(axis=0), points.max(axis=0)
            slack = NEAREST_SLACK * float(np.max(hi - lo))
            if np.any(target < lo - slack) or np.any(target > hi + slack):
                raise SceneError(f"nodeset '{nodeset.name}' ({describe(nodeset)}): the point lies outside the "
                                 f"mesh (its nodes span {_vec(lo)} .. {_vec(hi)}; the nearest node, "
                                 f"{int(ids[0])}, is {float(np.linalg.norm(offset[ids[0]])):.3g} away)")
    elif kind == "ids":
        ids = np.asarray(nodeset.ids, dtype=np.int64)
        bad = ids[(ids < 0) | (ids >= n)]
        if bad.size:
            raise SceneError(f"nodeset '{nodeset.name}': node id {bad[0]} out of range "
                             f"(mesh has {n} nodes, ids 0..{n - 1})")
    else:
        raise SceneError(f"nodeset '{nodeset.name}': unknown kind {kind!r}")
    ids = np.unique(np.asarray(ids, dtype=np.int64))
    if ids.size == 0:
        raise SceneError(f"nodeset '{nodeset.name}' ({describe(nodeset)}) selects no node")
    return ids
