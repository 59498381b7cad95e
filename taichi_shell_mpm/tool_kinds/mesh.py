"""A triangulated surface tool (a die, a punch, a barrier: any triangles and quads meshio
reads), in its own coordinates relative to ``center`` (its frame is the identity).

Contact: the nearest facet within reach among those of the node's bucket; d = +-|q - p| (p:
the nearest point of that facet), the sign that of (q - p) . n_facet [choice: one-sided by the
facet normal, so a closed surface with outward normals is a solid and an open one (a die) has
a front; n = +-(q - p)/|q - p|, the facet normal where p lies inside the facet].  Nodes more
than ``reach`` (the thickest shell) behind the surface are not found.

Search [choice, measured in tests/test_tools.py::test_mesh_bucket_grid_speed]: a uniform grid
of buckets over the mesh's box, built once in the tool's frame (the tool moves rigidly, so the
buckets never change); each triangle is listed in every bucket its box, grown by the capture
distance ``reach``, overlaps, so a node's own bucket lists every facet within ``reach`` of it.
The bucket size is the larger of ``reach`` and the median facet extent (each facet in at most
27 buckets), grown until there are at most 8 buckets per facet.
"""
from __future__ import annotations

import contextlib
import io
from pathlib import Path

import numpy as np

from ..keys import Key, keys, positive, scene_file

NAME = "mesh"
KEYS = keys(
    Key("file", scene_file, "the surface (triangles, quads)", default=None,
        allowed="a file meshio reads, relative to the scene", default_text="required for mesh"),
    Key("scale", positive, "mesh coordinates times this", default=1.0))
REQUIRED = ("file",)
OPTIONAL = ("center", "scale")
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


def rules(r, path: str, data: dict, values: dict, clean: bool) -> None:
    """The surface is read here (when the rest of the entry is valid), so that an unusable
    file is a scene error."""
    if values.get("file") is not None and clean:
        try:
            read_surface(values["file"], values.get("scale", 1.0))
        except ToolMeshError as exc:
            r.error(f"{path}.file", str(exc))


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


def surface(tool, reach: float, cell: float | None = None):
    """(triangles (t, 3, 3), unit facet normals (t, 3), bucket grid (lo, h, dims, start, items),
    bound) of the tool's surface in its frame; bound: the radius of a ball about its centre
    that holds it."""
    vertices, tri = read_surface(tool.file, tool.scale)
    x = vertices[tri]
    normal = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    return (x, normal / np.linalg.norm(normal, axis=1)[:, None], bucket_grid(x, reach, cell),
            float(np.linalg.norm(x, axis=2).max()))


def kernel(tools, contact):
    import taichi as ti
    g = tools
    closest_point_on_triangle = contact.closest_point_on_triangle

    @ti.data_oriented
    class Mesh:
        @ti.func
        def distance(self, k, q):
            """The nearest facet of the node's bucket; none within reach: d = reach, a lower
            bound of the distance (a bucket lists every facet within reach of it)."""
            d, n, hit = g.reach[None], ti.Vector([0.0, 0.0, 1.0]), False
            cell = ti.floor((q - g.grid_lo[k]) / g.grid_h[k], ti.i32)
            dims = g.grid_dims[k]
            inside = True
            for a in ti.static(range(3)):
                if cell[a] < 0 or cell[a] >= dims[a]:
                    inside = False
            if inside:
                bucket = g.bucket_first[k] + cell[0] + dims[0] * (cell[1] + dims[1] * cell[2])
                best = 1e300
                best_r = ti.Vector([0.0, 0.0, 0.0])
                best_t = -1
                for i in range(g.bucket_start[bucket], g.bucket_start[bucket + 1]):
                    t = g.bucket_items[i]
                    x = g.triangles[t]
                    p, _ = closest_point_on_triangle(q, ti.Vector([x[0, 0], x[0, 1], x[0, 2]]),
                                                     ti.Vector([x[1, 0], x[1, 1], x[1, 2]]),
                                                     ti.Vector([x[2, 0], x[2, 1], x[2, 2]]))
                    r = q - p
                    if r.norm_sqr() < best:
                        best, best_r, best_t = r.norm_sqr(), r, t
                if best_t >= 0:
                    facet = g.tri_normal[best_t]
                    sign = 1.0 if best_r.dot(facet) >= 0.0 else -1.0
                    length = ti.sqrt(best)
                    d = sign * length
                    n = facet
                    if length > 1e-12 * g.grid_h[k]:
                        n = sign * best_r / length
                    hit = d > -g.reach[None]
            return d, n, hit

    return Mesh()
