"""Shell meshes: generated (plate, hemisphere, tube) or imported with meshio, then checked.

A :class:`Mesh` is a set of nodes (``points``, shape ``(n, 3)``) and bilinear quadrilateral
elements (``quads``, shape ``(m, 4)``, 0-based node ids) whose corners run counter-clockwise
about the element normal; for the generated closed-form shapes that normal points outward
(+z for the plate).

Every mesh goes through :func:`check_mesh` before use.  Fatal problems (bad node ids,
degenerate, inverted or non-convex elements, non-finite or overflowing coordinates) are
collected and raised together as one :class:`~taichi_shell_mpm.scene.SceneError`, one line
per problem; mild ones (warped elements, unused nodes, coincident nodes) come back as
warning lines.  Coincident nodes stay distinct (a slit, a crack or a seam is modelled so)
unless ``[mesh].merge_nodes`` asks to join them (:func:`merge_coincident`).  Node and
element numbers in messages are the 0-based indices of ``points`` and ``quads``.
"""
from __future__ import annotations

import contextlib
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .scene import FileMesh, HemisphereMesh, MeshSpec, PlateMesh, SceneError, TubeMesh

MAX_LINES = 10
"""Most problem lines reported per category before a final 'and N more' line."""
AREA_RTOL = 1e-12
"""An element whose area is below this fraction of the mean element area is degenerate."""
DUPLICATE_RTOL = 1e-9
"""Nodes closer than this fraction of the bounding-box diagonal coincide."""
WARP_WARN_DEG = 5.0
"""Warn about elements whose two triangles (1,2,3) and (1,3,4) differ by more than this."""
MAX_COORDINATE = 1e100
"""Larger node coordinates are an error: products of lengths (areas, stiffness x length^2)
would overflow double precision; a unit mistake, not a model."""

_QUAD_CELLS = ("quad", "quad8", "quad9")
_HIGHER_ORDER_QUADS = {"quad8": "8-node", "quad9": "9-node"}
_IGNORED_CELLS = ("vertex", "line")
_NON_QUAD_2D_CELLS = ("triangle", "polygon")


@dataclass(frozen=True)
class Mesh:
    """A checked quadrilateral shell mesh."""
    points: np.ndarray
    """(n, 3) float64 node coordinates."""
    quads: np.ndarray
    """(m, 4) int32 node ids, counter-clockwise about the element normal."""
    warnings: tuple[str, ...] = ()
    """Non-fatal findings of the import and of :func:`check_mesh`, one line each."""


def build_mesh(spec: MeshSpec) -> Mesh:
    """Generate or import the mesh described by ``spec`` and check it.

    Raises :class:`SceneError` for invalid parameters, unreadable files and every fatal
    problem found by :func:`check_mesh`.
    """
    generators = {"plate": _plate, "hemisphere": _hemisphere, "tube": _tube}
    if isinstance(spec, FileMesh):
        points, quads, warnings = _read_file(spec)
        source = str(spec.path)
        if spec.merge_nodes:
            points, quads, merged = merge_coincident(points, quads, source)
            warnings += merged
    elif getattr(spec, "kind", None) in generators:
        points, quads = generators[spec.kind](spec)
        warnings, source = (), f"[mesh] {spec.kind}"
    else:
        raise SceneError(f"[mesh]: unknown mesh kind {getattr(spec, 'kind', spec)!r}")
    warnings += check_mesh(points, quads, source)
    return Mesh(points=np.ascontiguousarray(points, dtype=np.float64),
                quads=np.ascontiguousarray(quads, dtype=np.int32),
                warnings=warnings)


# ---------------------------------------------------------------- generators
def _cos_sin_deg(deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """cos and sin of angles in degrees, exact (0.0, +-1.0) at multiples of 90 degrees."""
    deg = np.asarray(deg, dtype=np.float64)
    rad = np.radians(deg)
    cos, sin = np.cos(rad), np.sin(rad)
    quarters = np.round(deg / 90.0)
    exact = np.abs(deg / 90.0 - quarters) < 1e-12
    k = quarters.astype(np.int64) % 4
    cos = np.where(exact, np.array([1.0, 0.0, -1.0, 0.0])[k], cos)
    sin = np.where(exact, np.array([0.0, 1.0, 0.0, -1.0])[k], sin)
    return cos, sin


def _grid_quads(n_rows: int, n_cols: int, wrap: bool) -> np.ndarray:
    """Quads of a structured grid of ``n_rows`` x ``n_cols`` elements.

    Node (row j, column i) is ``j * nodes_per_row + i``, with ``nodes_per_row = n_cols``
    if the columns wrap around (no seam nodes) and ``n_cols + 1`` otherwise.  Corners go
    (i, j), (i+1, j), (i+1, j+1), (i, j+1): counter-clockwise about (column direction) x
    (row direction).
    """
    per_row = n_cols if wrap else n_cols + 1
    j, i = np.meshgrid(np.arange(n_rows), np.arange(n_cols), indexing="ij")
    i1 = (i + 1) % per_row
    q = np.stack([j * per_row + i, j * per_row + i1,
                  (j + 1) * per_row + i1, (j + 1) * per_row + i], axis=-1)
    return q.reshape(-1, 4)


def _plate(spec: PlateMesh) -> tuple[np.ndarray, np.ndarray]:
    """Flat rectangle in z = origin z; node j*(nx+1)+i at (x_i, y_j); normals +z."""
    ox, oy, oz = spec.origin
    x = np.linspace(ox, ox + spec.lx, spec.nx + 1)
    y = np.linspace(oy, oy + spec.ly, spec.ny + 1)
    yy, xx = np.meshgrid(y, x, indexing="ij")
    points = np.column_stack([xx.ravel(), yy.ravel(), np.full(xx.size, float(oz))])
    return points, _grid_quads(spec.ny, spec.nx, wrap=False)


def _hemisphere(spec: HemisphereMesh) -> tuple[np.ndarray, np.ndarray]:
    """Latitude rows from the equator up to 90-hole_deg; full or quarter in longitude."""
    if not 0.0 < spec.hole_deg < 90.0:
        raise SceneError(f"[mesh] hemisphere: hole_deg must be in (0, 90), got {spec.hole_deg}")
    if not spec.quarter and spec.n_around < 3:
        raise SceneError("[mesh] hemisphere: a full hemisphere needs n_around >= 3, "
                         f"got {spec.n_around}")
    phi = np.linspace(0.0, 90.0 - spec.hole_deg, spec.n_meridian + 1)
    if spec.quarter:
        theta = np.linspace(0.0, 90.0, spec.n_around + 1)
    else:
        theta = 360.0 * np.arange(spec.n_around) / spec.n_around
    cp, sp = _cos_sin_deg(phi)
    ct, st = _cos_sin_deg(theta)
    r = spec.radius
    points = np.column_stack([
        np.outer(r * cp, ct).ravel(),
        np.outer(r * cp, st).ravel(),
        np.repeat(r * sp, theta.size),
    ])
    # columns run eastward (theta), rows northward (phi): e_theta x e_phi is outward
    return points, _grid_quads(spec.n_meridian, spec.n_around, wrap=not spec.quarter)


def _tube(spec: TubeMesh) -> tuple[np.ndarray, np.ndarray]:
    """Rounded-rectangle tube along +z; rings counter-clockwise about +z from (w/2, -(d/2-r)).

    Ring layout: flat side x = +w/2 (going +y), fillet 0, flat y = +d/2 (going -x), fillet
    1, flat x = -w/2, fillet 2, flat y = -d/2, fillet 3.  Each flat holds its start node
    (the tangent point shared with the previous fillet) and its interior nodes.

    Geometric trigger (benchmarks.md 3.1), when ``trigger_amplitude`` a0 != 0: each node of
    a flat side is moved along that side's outward normal n by

        w(s, z) = a0 sin(pi (z - z0) / L) sin(pi s / b)    for z0 <= z <= z0 + L, else 0,

    with z0 = ``trigger_start``, L = ``trigger_length``, s in [0, b] the arc position across
    the flat from one tangent point to the other and b its width between the fillets
    (``depth`` - 2r on the two faces normal to x, ``width`` - 2r on the two faces normal to
    y).  The offset is inward (-w n, |x| decreases) on the faces normal to x and outward
    (+w n, |y| increases) on the faces normal to y, so adjacent sides buckle in opposite
    directions (symmetric folding mode).  The fillet nodes are untouched (w = 0 at both
    ends of a flat, so the section stays continuous), and so is every node outside
    [z0, z0 + L]; a0 = 0 gives the exact untriggered mesh.
    """
    r = spec.corner_radius
    if r < 0.0 or 2.0 * r > min(spec.width, spec.depth):
        raise SceneError("[mesh] tube: corner_radius must be in [0, min(width, depth)/2], "
                         f"got {r}")
    if r == 0.0 and spec.n_corner > 0:
        raise SceneError("[mesh] tube: corner_radius 0 (sharp corners) needs n_corner = 0, "
                         f"got {spec.n_corner}")
    ca, cb = spec.width / 2.0 - r, spec.depth / 2.0 - r
    centres = np.array([[ca, cb], [-ca, cb], [-ca, -cb], [ca, -cb]])
    t_flat = np.arange(spec.n_flat) / max(spec.n_flat, 1)
    t_arc = np.arange(spec.n_corner) / max(spec.n_corner, 1)
    ring = []
    for q in range(4):
        # flat side ending where fillet q starts (angle 90q), then fillet q itself;
        # each segment contributes its start node and its interior nodes
        dx, dy = _cos_sin_deg(90.0 * q)
        start = centres[q - 1] + r * np.array([dx, dy])
        end = centres[q] + r * np.array([dx, dy])
        ring.append(start + t_flat[:, None] * (end - start))
        c, s = _cos_sin_deg(90.0 * (q + t_arc))
        ring.append(centres[q] + r * np.column_stack([c, s]))
    ring = np.concatenate(ring)
    z = np.linspace(0.0, spec.length, spec.n_length + 1)
    points = np.column_stack([np.tile(ring, (z.size, 1)), np.repeat(z, len(ring))])
    if spec.trigger_amplitude != 0.0:
        points[:, :2] += _tube_trigger(spec, ring, z)
    # columns run counter-clockwise about +z, rows along +z: tangent x e_z is outward
    return points, _grid_quads(spec.n_length, len(ring), wrap=True)


def _tube_trigger(spec: TubeMesh, ring: np.ndarray, z: np.ndarray) -> np.ndarray:
    """(len(z) * len(ring), 2) in-plane offsets of the trigger (see :func:`_tube`)."""
    r, n_flat, n_corner = spec.corner_radius, spec.n_flat, spec.n_corner
    z0, length = spec.trigger_start, spec.trigger_length
    if not length > 0.0:
        raise SceneError(f"[mesh] tube: trigger_length must be > 0, got {length}")
    per_side = n_flat + n_corner
    # per ring node: arc position s across its flat, flat width b, signed direction
    s = np.zeros(len(ring))
    b = np.ones(len(ring))
    direction = np.zeros((len(ring), 2))
    t_flat = np.arange(n_flat) / max(n_flat, 1)
    for q in range(4):
        ids = q * per_side + np.arange(n_flat)
        width = (spec.depth if q % 2 == 0 else spec.width) - 2.0 * r
        normal = np.array(_cos_sin_deg(90.0 * q), dtype=np.float64)
        s[ids], b[ids] = t_flat * width, width
        # faces normal to x (q = 0, 2) inward, faces normal to y (q = 1, 3) outward
        direction[ids] = -normal if q % 2 == 0 else normal
    # a zero-width flat (2r = width) has no interior: leave it untouched
    across = np.sin(np.pi * np.clip(np.divide(s, b, out=np.zeros_like(s), where=b > 0.0),
                                    0.0, 1.0))
    inside = (z >= z0) & (z <= z0 + length)
    along = np.where(inside, np.sin(np.pi * np.clip((z - z0) / length, 0.0, 1.0)), 0.0)
    w = spec.trigger_amplitude * np.outer(along, across)           # (n_z, n_ring)
    return (w[:, :, None] * direction[None, :, :]).reshape(-1, 2)


# ---------------------------------------------------------------- import
def _read_file(spec: FileMesh) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """Read the quad cells of a meshio-readable file, scaled; drop unused nodes."""
    import meshio

    path = Path(spec.path)
    if path.is_dir():
        raise SceneError(f"{path}: is a directory, not a mesh file")
    if not path.is_file():
        raise SceneError(f"{path}: mesh file not found")
    printed = io.StringIO()
    reason = None
    try:
        with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(printed):
            m = meshio.read(path)
    except SystemExit:  # meshio prints why no reader could read the file, then exits
        reason = printed.getvalue()
    except Exception as exc:  # meshio raises many types (ReadError, ValueError, KeyError...)
        reason = str(exc) or type(exc).__name__
    if reason is not None:
        raise SceneError(f"{path}: cannot read mesh: {' '.join(reason.split())}")
    warnings = tuple(f"{path}: meshio: {line.strip()}"
                     for line in printed.getvalue().splitlines() if line.strip())

    points = np.asarray(m.points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] not in (2, 3):
        raise SceneError(f"{path}: points have shape {points.shape}, expected (n, 2) or (n, 3)")
    if points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    points = points * spec.scale

    quads, non_quad, others, higher = [], {}, {}, {}
    for block in m.cells:
        data = np.asarray(block.data)
        if block.type in _QUAD_CELLS or (block.type == "polygon" and data.ndim == 2 and data.shape[1] == 4):
            quads.append(data[:, :4])
            if block.type in _HIGHER_ORDER_QUADS:
                higher[block.type] = higher.get(block.type, 0) + len(data)
        elif block.type.startswith(_NON_QUAD_2D_CELLS):
            name = (f"polygon with {data.shape[1]} corners" if block.type == "polygon" and data.ndim == 2
                    else block.type)
            non_quad[name] = non_quad.get(name, 0) + len(data)
        elif not block.type.startswith(_IGNORED_CELLS):
            others[block.type] = others.get(block.type, 0) + len(data)
    if non_quad:
        listed = ", ".join(_count(n, name) for name, n in non_quad.items())
        raise SceneError(
            f"{path}: mesh has non-quad cells ({listed}); this solver needs 4-node "
            "quadrilateral shells: remesh with quads (e.g. gmsh 'Mesh.RecombineAll = 1')")
    if others:
        listed = ", ".join(f"{n} {t}" for t, n in others.items())
        raise SceneError(f"{path}: mesh has volume cells ({listed}); this solver needs a "
                         "quadrilateral surface mesh")
    if not quads:
        raise SceneError(f"{path}: mesh has no quadrilateral cells")
    quads = np.concatenate(quads).astype(np.int64)
    for name, n in higher.items():
        warnings += (f"{path}: {_count(n, name + ' element')} ({_HIGHER_ORDER_QUADS[name]} quads) used as "
                     "4-node bilinear shells: their mid-side and centre nodes are dropped and curved "
                     "edges become straight",)

    used = np.unique(quads)
    # renumber only when all ids are valid; check_mesh reports out-of-range ids
    if used[0] >= 0 and used[-1] < len(points) and len(used) < len(points):
        new_id = np.full(len(points), -1, dtype=np.int64)
        new_id[used] = np.arange(len(used))
        warnings += (f"{path}: removed {len(points) - len(used)} unused nodes "
                    "(not referenced by any quad) and renumbered the rest",)
        points, quads = points[used], new_id[quads]
    return points, quads, warnings


def _count(n: int, name: str) -> str:
    """'1 triangle', '3 triangles', '2 polygons with 5 corners'."""
    if n == 1:
        return f"1 {name}"
    head, sep, tail = name.partition(" with ")
    return f"{n} {head}s{sep}{tail}"


# ---------------------------------------------------------------- coincident nodes
def merge_coincident(points: np.ndarray, quads: np.ndarray, source: str
                     ) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """Join nodes that coincide (within DUPLICATE_RTOL x the bounding-box diagonal) into
    the lowest-numbered of them, drop the others and renumber; returns the new arrays and a
    warning line (none when nothing coincides).  Left to :func:`check_mesh` (unchanged)
    when ids are out of range or coordinates are not finite."""
    points = np.asarray(points, dtype=np.float64)
    quads = np.asarray(quads)
    n = len(points)
    if (quads.ndim != 2 or quads.size == 0 or quads.min() < 0 or quads.max() >= n
            or not np.isfinite(points).all() or np.abs(points).max() > MAX_COORDINATE):
        return points, quads, ()
    used = np.unique(quads)
    pairs = _coincident_pairs(points, used, DUPLICATE_RTOL * np.linalg.norm(np.ptp(points[used], axis=0)))
    if len(pairs) == 0:
        return points, quads, ()
    root = np.arange(n)

    def find(i: int) -> int:
        while root[i] != i:
            root[i] = root[root[i]]
            i = root[i]
        return i

    for a, b in pairs:
        ra, rb = find(int(a)), find(int(b))
        if ra != rb:
            root[max(ra, rb)] = min(ra, rb)
    rep = np.array([find(i) for i in range(n)])
    merged_quads = rep[quads]
    keep = np.unique(merged_quads)
    new_id = np.full(n, -1, dtype=np.int64)
    new_id[keep] = np.arange(len(keep))
    a, b = pairs[0]
    removed = len(used) - len(keep)
    line = (f"{source}: merged {removed} coincident node{'s' if removed != 1 else ''} into "
            f"{'their' if removed != 1 else 'its'} twin{'s' if removed != 1 else ''} ([mesh].merge_nodes; e.g. "
            f"nodes {a} and {b} at {points[a].tolist()}) and renumbered the rest: node ids in the messages "
            "and in ids = [...] node sets are those after merging")
    return points[keep], new_id[merged_quads], (line,)


# ---------------------------------------------------------------- checks
def _limited(lines: list[str], source: str) -> list[str]:
    """At most MAX_LINES lines, then one line counting the rest."""
    if len(lines) <= MAX_LINES:
        return lines
    return lines[:MAX_LINES] + [f"{source}: ... and {len(lines) - MAX_LINES} more"]


def _coincident_pairs(points: np.ndarray, ids: np.ndarray, tol: float) -> np.ndarray:
    """Pairs (k, 2) of ids whose points lie within ``tol`` of each other.

    Sorts the points by their projection on a fixed generic direction (so that grid-aligned
    meshes have no ties) and compares each point with its successors while the projections
    stay within ``tol``: O(n log n) for any mesh that is not extremely dense at scale tol.
    """
    p = points[ids]
    direction = np.array([1.0, np.sqrt(2.0), np.pi])
    proj = p @ (direction / np.linalg.norm(direction))
    order = np.argsort(proj, kind="stable")
    proj, p, ids = proj[order], p[order], ids[order]
    pairs = []
    for shift in range(1, len(ids)):
        near = np.nonzero(proj[shift:] - proj[:-shift] <= tol)[0]
        if near.size == 0:
            break
        close = near[np.linalg.norm(p[near + shift] - p[near], axis=1) <= tol]
        pairs.append(np.column_stack([ids[close], ids[close + shift]]))
    if not pairs:
        return np.empty((0, 2), dtype=np.int64)
    pairs = np.sort(np.concatenate(pairs), axis=1)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


def coincident_pairs(points: np.ndarray) -> np.ndarray:
    """Pairs (k, 2) of nodes of `points` that coincide (within DUPLICATE_RTOL x the
    bounding-box diagonal), as check_mesh finds them."""
    points = np.asarray(points, dtype=np.float64)
    tol = DUPLICATE_RTOL * np.linalg.norm(np.ptp(points, axis=0))
    return _coincident_pairs(points, np.arange(len(points)), tol)


def _orientation_warnings(quads: np.ndarray, source: str) -> list[str]:
    """Lines for neighbouring elements with opposite normals: an edge a->b that two elements
    both run in the same direction (a consistently oriented surface runs it a->b and b->a)."""
    edges = np.stack([quads, np.roll(quads, -1, axis=1)], axis=2).reshape(-1, 2)   # (4m, 2) directed
    owner = np.repeat(np.arange(len(quads)), 4)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    edges, owner = edges[order], owner[order]
    lines = []
    for k in np.nonzero((edges[1:] == edges[:-1]).all(axis=1))[0]:
        e, f = sorted((int(owner[k]), int(owner[k + 1])))
        if e != f:
            lines.append(f"{source}: elements {e} and {f} have opposite normals (both run edge "
                         f"{edges[k, 0]}->{edges[k, 1]}): reverse the node order of one of them")
    return lines


def check_mesh(points, quads, source: str) -> tuple[str, ...]:
    """Check a quad shell mesh; raise :class:`SceneError` for fatal problems, return warnings.

    ``source`` (a file name or ``'[mesh] plate'``) prefixes every line.  Fatal: wrong array
    shapes, no elements, non-finite coordinates or coordinates above MAX_COORDINATE,
    out-of-range or repeated node ids in an element, zero-area elements (area < AREA_RTOL x
    mean), inverted or non-convex elements (a corner normal (x_{a+1}-x_a) x (x_{a-1}-x_a) not
    along the element normal (x_3-x_1) x (x_4-x_2)).  Warnings: coincident nodes (within
    DUPLICATE_RTOL x bounding-box diagonal: one line with their count and one pair; they
    stay distinct), elements warped by more than WARP_WARN_DEG, neighbours with opposite
    normals (inconsistent node order), unused nodes.
    """
    points = np.asarray(points, dtype=np.float64)
    quads = np.asarray(quads)
    if points.ndim != 2 or points.shape[1] != 3:
        raise SceneError(f"{source}: node coordinates have shape {points.shape}, expected (n, 3)")
    if quads.ndim != 2 or quads.shape[1] != 4 or not np.issubdtype(quads.dtype, np.integer):
        raise SceneError(f"{source}: elements have shape {quads.shape} ({quads.dtype}), "
                         "expected (m, 4) integer node ids")
    if len(quads) == 0:
        raise SceneError(f"{source}: mesh has no elements")
    n = len(points)

    # -- structure: ids and coordinates must be usable before any geometry is computed
    errors = []
    for node in np.nonzero(~np.isfinite(points).all(axis=1))[0]:
        errors.append(f"{source}: node {node}: non-finite coordinates {points[node].tolist()}")
    bad_id = (quads < 0) | (quads >= n)
    for e in np.nonzero(bad_id.any(axis=1))[0]:
        errors.append(f"{source}: element {e}: node id {quads[e][bad_id[e]][0]} out of range "
                      f"(mesh has {n} nodes)")
    s = np.sort(quads, axis=1)
    repeated = s[:, 1:] == s[:, :-1]
    for e in np.nonzero(repeated.any(axis=1))[0]:
        errors.append(f"{source}: element {e}: degenerate quad "
                      f"(node {s[e, 1:][repeated[e]][0]} repeated)")
    big = np.nonzero(np.abs(np.where(np.isfinite(points), points, 0.0)).max(axis=1) > MAX_COORDINATE)[0]
    if len(big):
        which = f"node {big[0]} has" if len(big) == 1 else f"{len(big)} nodes have"
        errors.append(f"{source}: {which} coordinates above {MAX_COORDINATE:g} in magnitude (e.g. node "
                      f"{big[0]} at {points[big[0]].tolist()}; lengths squared would overflow): rescale the "
                      "mesh ([mesh].scale) or use other units")
    if errors:
        raise SceneError(_limited(errors, source))

    # -- geometry
    x = points[quads]                                                # (m, 4, 3)
    normal = np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1])          # = 2 * vector area
    area = 0.5 * np.linalg.norm(normal, axis=1)
    degenerate = area <= AREA_RTOL * area.mean()
    for e in np.nonzero(degenerate)[0]:
        errors.append(f"{source}: element {e}: degenerate quad (area {area[e]:.3g}: collapsed, or a bow-tie "
                      "whose corners are out of order)")
    corner = np.cross(np.roll(x, -1, axis=1) - x, np.roll(x, 1, axis=1) - x)  # (m, 4, 3)
    along = np.einsum("mai,mi->ma", corner, normal)
    inverted = (along <= 1e-10 * np.einsum("mi,mi->m", normal, normal)[:, None]).any(axis=1)
    for e in np.nonzero(inverted & ~degenerate)[0]:
        errors.append(f"{source}: element {e}: inverted or non-convex quad")
    used = np.unique(quads)
    if errors:
        raise SceneError(_limited(errors, source))

    # -- warnings
    warnings = []
    diagonal = np.linalg.norm(np.ptp(points[used], axis=0))
    pairs = _coincident_pairs(points, used, DUPLICATE_RTOL * diagonal)
    if len(pairs):
        a, b = pairs[0]
        count = f"{len(pairs)} pair{'s' if len(pairs) != 1 else ''}"
        warnings.append(f"{source}: {count} of coincident nodes kept distinct (e.g. nodes {a} and {b} at "
                        f"{points[a].tolist()}): the shell is not connected there (a slit, crack or seam); "
                        "set [mesh].merge_nodes = true to join them")
    n1 = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    n2 = np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 0])
    cos_warp = np.einsum("mi,mi->m", n1, n2) / (
        np.linalg.norm(n1, axis=1) * np.linalg.norm(n2, axis=1))
    warp = np.degrees(np.arccos(np.clip(cos_warp, -1.0, 1.0)))
    for e in np.nonzero(warp > WARP_WARN_DEG)[0]:
        warnings.append(f"{source}: element {e}: warped by {warp[e]:.1f} deg")
    warnings += _orientation_warnings(quads, source)
    warnings = _limited(warnings, source)
    if len(used) < n:
        warnings.append(f"{source}: {n - len(used)} unused nodes (not referenced by any element)")
    return tuple(warnings)
