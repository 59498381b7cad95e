"""Rigid tools ([[tool]], docs/scenes.md): the host side.  The scene's tools as the step's
tables (stages/tools.py reads them): kind, pose, size, penalty and friction coefficients,
how each moves; a surface mesh's triangles and its bucket grid.  numpy and meshio only.

Pose.  Every tool has an origin (its ``center``) and a frame, the rows e1, e2, e3 of an
orthonormal matrix: a plane's and a rectangle's e3 is the normal (the side the shell stays
on), e1 a rectangle's first side; a cylinder's e3 is its axis; a sphere's and a mesh's frame
is the identity (a mesh's vertices are read in its own coordinates, relative to ``center``).
The step works in the tool's frame (q = F (x - c)), so a tool that turns with a rigid body
only changes F (stages/tools.RigidTools.pose).

Mesh search [choice, measured in tests/test_tools.py::test_mesh_bucket_grid_speed]: a uniform
grid of buckets over the mesh's box, built once here in the tool's frame (the tool moves
rigidly, so the buckets never change); each triangle is listed in every bucket its box,
grown by the capture distance ``reach``, overlaps, so a node's own bucket lists every facet
within ``reach`` of it.  The bucket size is the larger of ``reach`` and the median facet
extent (each facet in at most 27 buckets), grown until there are at most 8 buckets per facet.
"""
from __future__ import annotations

import contextlib
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

TOOL_KINDS = ("plane", "rectangle", "cylinder", "sphere", "mesh")
FIXED, BODY, VELOCITY, DISPLACEMENT = range(4)      # how a tool moves (state.tools.motion)
MAX_TOOLS = 8
BUCKETS_PER_FACET = 8


class ToolMeshError(ValueError):
    """A surface mesh that cannot be used as a tool (one-line message)."""


def read_surface(path: Path, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (v, 3), triangles (t, 3)) of the triangles and quads (split along their
    diagonal 1-3) of a meshio-readable file, times `scale`; every facet of non-zero area."""
    import meshio

    printed = io.StringIO()
    try:
        with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(printed):
            m = meshio.read(path)
    except SystemExit:      # meshio prints why no reader could read the file, then exits
        raise ToolMeshError(f"cannot read {Path(path).name}: {' '.join(printed.getvalue().split())}") from None
    except Exception as exc:   # meshio raises many types for a damaged file
        raise ToolMeshError(f"cannot read {Path(path).name}: {' '.join((str(exc) or type(exc).__name__).split())}") \
            from None
    points = np.asarray(m.points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] not in (2, 3):
        raise ToolMeshError(f"{Path(path).name}: points of shape {points.shape}, expected (n, 3)")
    if points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    tris = []
    for block in m.cells:
        data = np.asarray(block.data, dtype=np.int64)
        if block.type.startswith("triangle") and data.shape[1] >= 3:
            tris.append(data[:, :3])
        elif block.type.startswith("quad") and data.shape[1] >= 4:
            tris += [data[:, [0, 1, 2]], data[:, [0, 2, 3]]]
    if not tris:
        raise ToolMeshError(f"{Path(path).name}: no triangles or quads (a tool mesh is a surface)")
    tri = np.concatenate(tris)
    if tri.min() < 0 or tri.max() >= len(points):
        raise ToolMeshError(f"{Path(path).name}: a facet refers to a point that does not exist")
    vertices = scale * points
    if not np.all(np.isfinite(vertices)):
        raise ToolMeshError(f"{Path(path).name}: non-finite point coordinates")
    x = vertices[tri]
    area = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)
    bad = np.flatnonzero(area <= 1e-12 * max(float(np.ptp(vertices, axis=0).max()), 1e-300) ** 2)
    if len(bad):
        raise ToolMeshError(f"{Path(path).name}: facet {int(bad[0])} has zero area ({len(bad)} such facets)")
    return vertices, tri


def frame_from(e3, e1=None) -> np.ndarray:
    """Rows e1, e2, e3 of a right-handed orthonormal frame with e3 along `e3` and e1 along
    `e1` projected on the plane normal to it (None, or along e3: the axis least aligned with e3)."""
    e3 = np.asarray(e3, float) / np.linalg.norm(e3)
    guess = None if e1 is None else np.asarray(e1, float) - np.dot(e1, e3) * e3
    if guess is None or np.linalg.norm(guess) < 1e-9 * np.linalg.norm(e1):
        guess = np.eye(3)[int(np.argmin(np.abs(e3)))]
        guess = guess - np.dot(guess, e3) * e3
    u = guess / np.linalg.norm(guess)
    return np.stack([u, np.cross(e3, u), e3])


def bucket_grid(tri_points: np.ndarray, reach: float, cell: float | None = None
                ) -> tuple[np.ndarray, float, np.ndarray, np.ndarray, np.ndarray]:
    """(lo, h, dims, start, items) of the uniform bucket grid of the triangles `tri_points`
    (t, 3, 3) (module docstring): bucket (i, j, k) at lo + h (i, j, k), flat index
    i + dims_x (j + dims_y k), lists items[start[b]:start[b + 1]] (triangle indices, ascending).
    `cell` forces the bucket size (a size larger than the box: one bucket, the brute force)."""
    box_lo = tri_points.min(axis=1) - reach
    box_hi = tri_points.max(axis=1) + reach
    lo = box_lo.min(axis=0)
    extent = box_hi.max(axis=0) - lo
    if cell is None:
        h = max(reach, float(np.median((tri_points.max(axis=1) - tri_points.min(axis=1)).max(axis=1))))
        while np.prod(np.maximum(np.ceil(extent / h), 1.0)) > BUCKETS_PER_FACET * len(tri_points) + 64:
            h *= 1.25
    else:
        h = float(cell)
    dims = np.maximum(np.ceil(extent / h).astype(np.int64), 1)
    first = np.clip(np.floor((box_lo - lo) / h).astype(np.int64), 0, dims - 1)
    last = np.clip(np.floor((box_hi - lo) / h).astype(np.int64), 0, dims - 1)
    cells, owners = [], []
    span = last - first + 1
    for t in range(len(tri_points)):
        i, j, k = np.meshgrid(*(np.arange(first[t, d], last[t, d] + 1) for d in range(3)), indexing="ij")
        flat = (i + dims[0] * (j + dims[1] * k)).ravel()
        cells.append(flat)
        owners.append(np.full(int(np.prod(span[t])), t))
    cells, owners = np.concatenate(cells), np.concatenate(owners)
    order = np.lexsort((owners, cells))
    n_cells = int(np.prod(dims))
    start = np.searchsorted(cells[order], np.arange(n_cells + 1)).astype(np.int32)
    return lo, h, dims.astype(np.int32), start, owners[order].astype(np.int32)


@dataclass(frozen=True)
class ToolTable:
    """The tools of a scene as the step's tables (state.tools)."""
    names: tuple[str, ...]
    kinds: tuple[str, ...]          # TOOL_KINDS entries, one per tool
    kind: np.ndarray                # (k,) index into TOOL_KINDS
    motion: np.ndarray              # (k,) FIXED | BODY | VELOCITY | DISPLACEMENT
    body: np.ndarray                # (k,) rigid body index (BODY), else -1
    curve: np.ndarray               # (k,) curve index of VELOCITY / DISPLACEMENT, -1: constant 1
    origin: np.ndarray              # (k, 3) centre at t = 0
    frame: np.ndarray               # (k, 3, 3) rows e1, e2, e3
    size: np.ndarray                # (k, 3) rectangle: half sides; cylinder: R, half length; sphere: R
    value: np.ndarray               # (k, 3) the velocity or displacement times the curve
    coefficients: np.ndarray        # (k, 3) stiffness alpha, damping fraction, friction mu
    # surface meshes, all tools' one after the other (tool frame)
    tri_first: np.ndarray           # (k,) first triangle
    triangles: np.ndarray           # (t, 3, 3) vertices of each triangle
    tri_normal: np.ndarray          # (t, 3) unit facet normals (corner order, right hand)
    grid_lo: np.ndarray             # (k, 3)
    grid_h: np.ndarray              # (k,)
    grid_dims: np.ndarray           # (k, 3)
    bucket_first: np.ndarray        # (k,) first bucket of the tool in bucket_start
    bucket_start: np.ndarray        # (b + 1,) CSR bucket -> bucket_items
    bucket_items: np.ndarray        # global triangle indices
    reach: float                    # capture distance of the mesh search
    speed0: np.ndarray              # (k,) a bound of the speed of the tool's points at t = 0 (first_step_limit)
    bound: np.ndarray               # (k,) radius of a ball about the centre holding the tool (plane: inf)

    @property
    def prescribed(self) -> bool:
        """Some tool moves by a velocity or displacement curve (config.Features.loads)."""
        return bool(np.any((self.motion == VELOCITY) | (self.motion == DISPLACEMENT)))


def build_tools(tools, bodies, curves: dict, reach: float, cell: float | None = None) -> ToolTable:
    """The ToolTable of the scene's [[tool]] entries (scene.Tool); `bodies`: the
    assembly.RigidBodySpec list, `curves`: the scene's curves by name; `reach`: how far behind
    a mesh's surface a node is still caught (the thickest shell's thickness)."""
    from .curves import evaluate
    body_names, curve_names = [b.name for b in bodies], list(curves)
    k = len(tools)
    kind = np.array([TOOL_KINDS.index(t.kind) for t in tools], np.int32)
    motion = np.full(k, FIXED, np.int32)
    body = np.full(k, -1, np.int32)
    curve = np.full(k, -1, np.int32)
    origin, frame = np.zeros((k, 3)), np.tile(np.eye(3), (k, 1, 1))
    size, value, coefficients = np.zeros((k, 3)), np.zeros((k, 3)), np.zeros((k, 3))
    tri_first = np.zeros(k, np.int32)
    speed0, bound = np.zeros(k), np.full(k, np.inf)
    grid_lo, grid_h, grid_dims = np.zeros((k, 3)), np.ones(k), np.ones((k, 3), np.int32)
    bucket_first = np.zeros(k, np.int32)
    triangles, normals, starts, items = [np.zeros((0, 3, 3))], [np.zeros((0, 3))], [], []
    n_tri = n_buckets = 0
    for i, t in enumerate(tools):
        origin[i] = t.center
        coefficients[i] = (t.stiffness, t.damping, t.friction)
        if t.moves_with is not None:
            motion[i], body[i] = BODY, body_names.index(t.moves_with)
        elif t.velocity is not None:
            motion[i], value[i] = VELOCITY, t.velocity
            speed0[i] = np.linalg.norm(t.velocity) * abs(evaluate(curves[t.curve], 0.0) if t.curve else 1.0)
        elif t.displacement is not None:
            motion[i], value[i] = DISPLACEMENT, t.displacement
        if t.curve is not None:
            curve[i] = curve_names.index(t.curve)
        if t.kind in ("plane", "rectangle"):
            frame[i] = frame_from(t.normal, t.axis)
            if t.kind == "rectangle":
                size[i, :2] = 0.5 * np.asarray(t.size)
                bound[i] = np.hypot(*size[i, :2])
        elif t.kind == "cylinder":
            frame[i] = frame_from(t.axis)
            size[i, :2] = t.radius, 0.5 * t.length
            bound[i] = np.hypot(*size[i, :2])
        elif t.kind == "sphere":
            size[i, 0] = bound[i] = t.radius
        else:
            vertices, tri = read_surface(t.file, t.scale)
            x = vertices[tri]
            bound[i] = float(np.linalg.norm(x, axis=2).max())
            normal = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
            lo, h, dims, start, listed = bucket_grid(x, reach, cell)
            tri_first[i], grid_lo[i], grid_h[i], grid_dims[i] = n_tri, lo, h, dims
            bucket_first[i] = n_buckets
            triangles.append(x)
            normals.append(normal / np.linalg.norm(normal, axis=1)[:, None])
            starts.append(start[:-1] + (len(np.concatenate(items)) if items else 0))
            items.append(listed + n_tri)
            n_tri += len(x)
            n_buckets += len(start) - 1
        if motion[i] == BODY:        # V + |omega| (the centre's arm + the tool's size; a plane's: its centre's)
            b = bodies[body[i]]
            arm = np.linalg.norm(np.asarray(t.center) - b.center) + (bound[i] if np.isfinite(bound[i]) else 0.0)
            speed0[i] = np.linalg.norm(b.velocity0) + np.linalg.norm(b.spin0) * arm
    total = sum(len(a) for a in items)
    bucket_start = np.concatenate(starts + [np.array([total])]).astype(np.int32) if starts else np.zeros(1, np.int32)
    return ToolTable(
        names=tuple(t.name for t in tools), kinds=tuple(t.kind for t in tools), kind=kind, motion=motion,
        body=body, curve=curve, origin=origin, frame=frame, size=size, value=value, coefficients=coefficients,
        tri_first=tri_first, triangles=np.concatenate(triangles), tri_normal=np.concatenate(normals),
        grid_lo=grid_lo, grid_h=grid_h, grid_dims=grid_dims, bucket_first=bucket_first, bucket_start=bucket_start,
        bucket_items=np.concatenate(items).astype(np.int32) if items else np.zeros(0, np.int32), reach=reach, speed0=speed0, bound=bound)


def first_step_limit(table: ToolTable, points: np.ndarray, thickness: np.ndarray, velocity: np.ndarray,
                     node_body: np.ndarray, step: np.ndarray) -> float:
    """The tools' step limit (stages/tools.py, Step limit) at t = 0, before the kernel has
    measured a closing speed: dt <= (step_k h + max(D - h/2, 0)) / (speed0_k + |v|) over nodes
    and tools (step_k: timestep.contact_step of the tool's stiffness), with D a lower bound of
    the distance (a plane's |d|, else the distance to the ball of radius `bound`) and the
    relative speed for the closing one, so a tool that starts near the shell and fast does not
    jump past it in the first step.  A displacement-driven tool counts as at rest (its curve
    starts at 0)."""
    limit = np.inf
    for k in range(len(table.names)):
        own = node_body == table.body[k] if table.motion[k] == BODY else np.zeros(len(points), bool)
        r = points[~own] - table.origin[k]
        if np.isfinite(table.bound[k]):
            distance = np.maximum(np.linalg.norm(r, axis=1) - table.bound[k], 0.0)
        else:
            distance = np.abs(r @ table.frame[k][2])
        h = thickness[~own]
        speed = table.speed0[k] + np.linalg.norm(velocity[~own], axis=1)
        moving = speed > 0.0
        if np.any(moving):
            room = step[k] * h + np.maximum(distance - 0.5 * h, 0.0)
            limit = min(limit, float(np.min(room[moving] / speed[moving])))
    return limit
