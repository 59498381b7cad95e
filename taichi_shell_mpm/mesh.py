"""Shell meshes: generated (plate, hemisphere, tube) or imported, then checked.

A :class:`Mesh` is a set of nodes (``points``, shape ``(n, 3)``) and shell elements
(``elements``, shape ``(m, 4)``, 0-based node ids): a bilinear quadrilateral uses the 4
columns, a 3-node triangle the first 3 with ``elements[e, 3] == -1``.  Corners run
counter-clockwise about the element normal; for the generated closed-form shapes (all quads)
that normal points outward (+z for the plate).

Files are read with meshio (``.msh``, ``.vtu``, ``.inp``, ...), or with this package's own
LS-DYNA keyword reader (:mod:`taichi_shell_mpm.dyna`; ``.k``, ``.key``, ``.dyn``, ``.kw``).
An imported mesh also carries named element sets (Gmsh physical groups, meshio cell sets,
LS-DYNA parts) and, for an LS-DYNA deck, the deck's parts, sections, materials and curves
(:class:`~taichi_shell_mpm.dyna.Deck`).

Every mesh goes through :func:`check_mesh` before use.  Fatal problems (bad node ids,
degenerate, inverted or non-convex elements, non-finite or overflowing coordinates) are
collected and raised together as one :class:`~taichi_shell_mpm.scene.SceneError`, one line
per problem; mild ones (warped quads, unused nodes, coincident nodes) come back as warning
lines.  Coincident nodes stay distinct (a slit, a crack or a seam is modelled so) unless
``[mesh].merge_nodes`` asks to join them (:func:`merge_coincident`).  Node and element
numbers in messages are the 0-based indices of ``points`` and ``elements`` (an LS-DYNA
deck's own ids follow in brackets).
"""
from __future__ import annotations

import contextlib
import io
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .scene import FileMesh, HemisphereMesh, MeshSpec, PlateMesh, SceneError, TubeMesh

if TYPE_CHECKING:
    from .dyna import Deck

MAX_LINES = 10
"""Most problem lines reported per category before a final 'and N more' line."""
AREA_RTOL = 1e-12
"""An element whose area is below this fraction of the median element area is degenerate
(the median: one stray node, whose elements' areas are huge, leaves the others' scale alone)."""
STRAY_RATIO = 1e6
"""An element whose longest edge exceeds this multiple of the median element's longest edge
has a stray node (a typo, or a fixed-format coordinate overflowing its columns): an error
naming that node; graded meshes stay far below (a 1e3 grading is already extreme)."""
DUPLICATE_RTOL = 1e-9
"""Nodes closer than this fraction of the bounding-box diagonal coincide."""
WARP_WARN_DEG = 5.0
"""Warn about quads whose two triangles (1,2,3) and (1,3,4) differ by more than this."""
FOLD_DEG = 150.0
"""A triangle whose normal turns by more than this from the normals of most of its
neighbours (oriented alike across the shared edge) is folded over them: inverted."""
MAX_COORDINATE = 1e100
"""Larger node coordinates are an error: products of lengths (areas, stiffness x length^2)
would overflow double precision; a unit mistake, not a model."""

# meshio cell type -> (corners used, what it is); the first corners of these are the vertices
_SHELL_CELLS = {"quad": (4, None), "quad8": (4, "8-node"), "quad9": (4, "9-node"),
                "triangle": (3, None), "triangle6": (3, "6-node"), "triangle7": (3, "7-node")}
_IGNORED_CELLS = ("vertex", "line")
_OTHER_2D_CELLS = ("triangle", "quad", "polygon")


@dataclass(frozen=True)
class Mesh:
    """A checked shell mesh of quadrilaterals and triangles."""
    points: np.ndarray
    """(n, 3) float64 node coordinates."""
    elements: np.ndarray
    """(m, 4) int32 node ids, counter-clockwise about the element normal; a triangle has
    ``elements[e, 3] == -1`` (its 3 corners in columns 0..2)."""
    warnings: tuple[str, ...] = ()
    """Non-fatal findings of the import and of :func:`check_mesh`, one line each."""
    element_sets: dict[str, np.ndarray] = field(default_factory=dict)
    """Named element sets of an imported mesh (name -> sorted unique int64 element ids):
    Gmsh physical groups (by name and as ``"physical:<tag>"``), meshio cell sets (Abaqus
    ELSETs ...), LS-DYNA parts (``"part:<pid>"`` and the part's heading).  Empty for the
    generated meshes."""
    deck: "Deck | None" = None
    """The LS-DYNA keyword data beyond the geometry (:class:`taichi_shell_mpm.dyna.Deck`),
    else None."""

    @property
    def triangles(self) -> np.ndarray:
        """(m,) bool: which elements are triangles (``elements[:, 3] < 0``)."""
        return self.elements[:, 3] < 0


def build_mesh(spec: MeshSpec) -> Mesh:
    """Generate or import the mesh described by ``spec`` and check it.

    Raises :class:`SceneError` for invalid parameters, unreadable files and every fatal
    problem found by :func:`check_mesh`.
    """
    generators = {"plate": _plate, "hemisphere": _hemisphere, "tube": _tube}
    sets: dict[str, np.ndarray] = {}
    deck = None
    labels = None
    if isinstance(spec, FileMesh):
        source = str(spec.path)
        points, elements, warnings, sets, deck = _read_file(spec)
        if spec.merge_nodes:
            points, elements, merged, keep = _merge_coincident(points, elements, source)
            warnings += merged
            if deck is not None and keep is not None:
                deck = replace(deck, node_ids=deck.node_ids[keep])
        if deck is not None:
            labels = (deck.element_ids, deck.node_ids)
    elif getattr(spec, "kind", None) in generators:
        points, elements = generators[spec.kind](spec)
        warnings, source = (), f"[mesh] {spec.kind}"
        if spec.triangles != "none":
            columns = {"plate": lambda: spec.nx, "hemisphere": lambda: spec.n_around,
                       "tube": lambda: 4 * (spec.n_flat + spec.n_corner)}[spec.kind]()
            elements = split_quads(points, elements, spec.triangles, columns)
    else:
        raise SceneError(f"[mesh]: unknown mesh kind {getattr(spec, 'kind', spec)!r}")
    warnings += check_mesh(points, elements, source, labels=labels)
    return Mesh(points=np.ascontiguousarray(points, dtype=np.float64),
                elements=np.ascontiguousarray(elements, dtype=np.int32),
                warnings=warnings, element_sets=sets, deck=deck)


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


def split_quads(points: np.ndarray, quads: np.ndarray, select, columns: int) -> np.ndarray:
    """The generated quads (row-major, `columns` per row) with those that `select` picks
    ("all", or a box (min, max) of quad centroids) cut into two triangles each, in place (quad
    e becomes two consecutive elements), along alternating diagonals in a checkerboard
    [choice]: (1,2,3) + (1,3,4) where row + column is even, (1,2,4) + (2,3,4) where it is odd,
    so that no direction of the mesh is favoured (all along one diagonal, a strip of right
    triangles is stiffer in one sense of twist than the other).  A triangle's 4th id is -1;
    corners stay counter-clockwise about the quad's normal."""
    m = len(quads)
    if select == "all":
        chosen = np.ones(m, dtype=bool)
    else:
        centroid = points[quads].mean(axis=1)
        lo, hi = np.asarray(select[0]), np.asarray(select[1])
        chosen = np.all((centroid >= lo - 1e-12) & (centroid <= hi + 1e-12), axis=1)
    e = np.arange(m)
    even = (e // columns + e % columns) % 2 == 0
    q = quads
    first = np.where(even[:, None], q[:, [0, 1, 2]], q[:, [0, 1, 3]])
    second = np.where(even[:, None], q[:, [0, 2, 3]], q[:, [1, 2, 3]])
    size = 1 + chosen
    start = np.cumsum(size) - size
    out = np.full((int(size.sum()), 4), -1, dtype=q.dtype)
    out[start[~chosen]] = q[~chosen]
    out[start[chosen], :3] = first[chosen]
    out[start[chosen] + 1, :3] = second[chosen]
    return out


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
def _read_file(spec: FileMesh) -> tuple[np.ndarray, np.ndarray, tuple[str, ...], dict[str, np.ndarray],
                                        "Deck | None"]:
    """Read the shell cells of a mesh file, scaled: (points, elements, warnings, element
    sets, deck); quads with one repeated corner become triangles, unused nodes are dropped."""
    path = Path(spec.path)
    if path.is_dir():
        raise SceneError(f"{path}: is a directory, not a mesh file")
    if not path.is_file():
        raise SceneError(f"{path}: mesh file not found")
    from .dyna import DYNA_SUFFIXES, read_deck
    deck = None
    if path.suffix.lower() in DYNA_SUFFIXES:
        points, elements, sets, deck, warnings = read_deck(path)
    else:
        points, elements, sets, warnings = _read_meshio(path)
    points = points * spec.scale

    elements, collapsed = collapse_repeated_corners(elements)
    if collapsed and deck is None:      # LS-DYNA writes every triangle so; elsewhere it is unusual
        warnings += (f"{path}: {_count(collapsed, 'quad')} with one corner repeated (e.g. n3 = n4) read as "
                     "triangles",)
    corner = _corners(elements)
    used = np.unique(elements[corner])
    # renumber only when all ids are valid; check_mesh reports out-of-range ids
    if len(used) and used[0] >= 0 and used[-1] < len(points) and len(used) < len(points):
        new_id = np.full(len(points), -1, dtype=np.int64)
        new_id[used] = np.arange(len(used))
        warnings += (f"{path}: removed {len(points) - len(used)} unused nodes "
                     "(not referenced by any shell element) and renumbered the rest",)
        points, elements = points[used], np.where(corner, new_id[elements], -1)
        if deck is not None:
            deck = replace(deck, node_ids=deck.node_ids[used])
    return points, elements, warnings, sets, deck


def _read_meshio(path: Path) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray], tuple[str, ...]]:
    """Points, elements (-1 in column 3 for triangles), element sets and warnings of a
    meshio-readable file."""
    import meshio

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

    blocks, polygons, unsupported, others, higher = [], {}, {}, {}, {}
    offsets = {}         # meshio block index -> first element id of its cells
    n_elements = 0
    for b, block in enumerate(m.cells):
        data = np.asarray(block.data)
        corners = _SHELL_CELLS.get(block.type, (None, None))[0]
        if block.type == "polygon" and data.ndim == 2 and data.shape[1] in (3, 4):
            corners = data.shape[1]
        if corners is not None and data.ndim == 2 and data.shape[1] >= corners:
            rows = np.full((len(data), 4), -1, dtype=np.int64)
            rows[:, :corners] = data[:, :corners]
            blocks.append(rows)
            offsets[b] = n_elements
            n_elements += len(data)
            if _SHELL_CELLS.get(block.type, (0, None))[1] is not None:
                higher[block.type] = higher.get(block.type, 0) + len(data)
        elif block.type == "polygon":
            name = f"polygon with {data.shape[1]} corners" if data.ndim == 2 else "polygon"
            polygons[name] = polygons.get(name, 0) + len(data)
        elif block.type.startswith(_OTHER_2D_CELLS):
            unsupported[block.type] = unsupported.get(block.type, 0) + len(data)
        elif not block.type.startswith(_IGNORED_CELLS):
            others[block.type] = others.get(block.type, 0) + len(data)
    if polygons:
        listed = ", ".join(_count(n, name) for name, n in polygons.items())
        raise SceneError(
            f"{path}: mesh has polygonal cells with more than 4 corners ({listed}); this solver needs 3-node "
            "triangles and 4-node quadrilaterals: remesh (e.g. gmsh, with 'Mesh.RecombineAll = 1' for quads)")
    if unsupported:
        listed = ", ".join(f"{n} {t}" for t, n in unsupported.items())
        raise SceneError(f"{path}: mesh has surface cells of a kind this reader does not take ({listed}); "
                         "it reads triangle, triangle6, triangle7, quad, quad8, quad9 and 3- or 4-corner polygons")
    if others:
        listed = ", ".join(f"{n} {t}" for t, n in others.items())
        raise SceneError(f"{path}: mesh has volume cells ({listed}); this solver needs a "
                         "surface mesh of quadrilaterals and triangles")
    if not blocks:
        raise SceneError(f"{path}: mesh has no quadrilateral or triangular cells")
    elements = np.concatenate(blocks)
    for name, n in higher.items():
        corners, what = _SHELL_CELLS[name]
        shape = "quads" if corners == 4 else "triangles"
        kind = "4-node bilinear" if corners == 4 else "3-node linear"
        warnings += (f"{path}: {_count(n, name + ' element')} ({what} {shape}) used as {kind} shells: their "
                     "mid-side and centre nodes are dropped and curved edges become straight",)
    sets, set_warnings = _meshio_sets(m, offsets, n_elements, path)
    return points, elements, sets, warnings + set_warnings


def _meshio_sets(m, offsets: dict[int, int], n_elements: int, path: Path
                 ) -> tuple[dict[str, np.ndarray], tuple[str, ...]]:
    """Element sets of a meshio mesh: its cell blocks ("block:<index>", when it has several),
    Gmsh physical groups (by name and "physical:<tag>") and cell sets, restricted to the shell cells (``offsets``: first element id of each kept
    block); empty sets are left out, sets of the same name are joined."""
    found: dict[str, list[np.ndarray]] = {}
    warnings = []
    if len(m.cells) > 1:             # cell blocks (meshio's), by their index in the file
        for b, first in offsets.items():
            found[f"block:{b}"] = [first + np.arange(len(m.cells[b].data))]
    physical = m.cell_data.get("gmsh:physical")
    if physical is not None and len(physical) == len(m.cells):
        names = {}
        for name, value in (m.field_data or {}).items():
            value = np.asarray(value).ravel()
            if len(value) >= 2 and int(value[1]) == 2:
                names.setdefault(int(value[0]), []).append(name)
        for b, first in offsets.items():
            tags = np.asarray(physical[b]).ravel()
            if len(tags) != len(m.cells[b].data):
                continue
            for tag in np.unique(tags):
                if tag == 0:            # Gmsh: no physical group
                    continue
                ids = first + np.nonzero(tags == tag)[0]
                for name in (f"physical:{int(tag)}", *names.get(int(tag), ())):
                    found.setdefault(name, []).append(ids)
    for name, per_block in (m.cell_sets or {}).items():
        if name.startswith("gmsh:"):    # gmsh:bounding_entities: not a set of cells
            continue
        if len(per_block) != len(m.cells):
            warnings.append(f"{path}: cell set '{name}' does not match the file's cell blocks (meshio read "
                            f"{len(per_block)} parts for {len(m.cells)} blocks): left out")
            continue
        for b, first in offsets.items():
            local = per_block[b]
            if local is None:
                continue
            local = np.asarray(local, dtype=np.int64).ravel()
            if len(local) and (local.min() < 0 or local.max() >= len(m.cells[b].data)):
                warnings.append(f"{path}: cell set '{name}' refers to cells meshio did not read: left out")
                found.pop(name, None)
                break
            found.setdefault(name, []).append(first + local)
    sets = {}
    for name, parts in found.items():
        ids = np.unique(np.concatenate(parts).astype(np.int64))
        if len(ids):
            sets[name] = ids
    return sets, tuple(warnings)


def collapse_repeated_corners(elements: np.ndarray) -> tuple[np.ndarray, int]:
    """Quads with exactly one pair of consecutive corners equal (LS-DYNA's triangle, n3 = n4,
    or any other consecutive pair) and the other three distinct become triangles (the
    repeated corner dropped, the order kept); returns the new array and how many changed."""
    elements = np.asarray(elements)
    if elements.ndim != 2 or elements.shape[1] != 4 or len(elements) == 0:
        return elements, 0
    same = (elements == np.roll(elements, -1, axis=1)) & (elements[:, 3:] >= 0)
    s = np.sort(elements, axis=1)
    distinct = 1 + (s[:, 1:] != s[:, :-1]).sum(axis=1)
    convert = (same.sum(axis=1) == 1) & (distinct == 3)
    if not convert.any():
        return elements, 0
    elements = elements.copy()
    rows = elements[convert]
    kept = rows[~same[convert]].reshape(-1, 3)
    elements[convert, :3] = kept
    elements[convert, 3] = -1
    return elements, int(convert.sum())


def _corners(elements: np.ndarray) -> np.ndarray:
    """(m, 4) bool: the entries of ``elements`` that are corners (all but a triangle's -1)."""
    corner = np.ones(elements.shape, dtype=bool)
    corner[:, 3] = elements[:, 3] != -1
    return corner


def _count(n: int, name: str) -> str:
    """'1 triangle', '3 triangles', '2 polygons with 5 corners'."""
    if n == 1:
        return f"1 {name}"
    head, sep, tail = name.partition(" with ")
    return f"{n} {head}s{sep}{tail}"


# ---------------------------------------------------------------- coincident nodes
def merge_coincident(points: np.ndarray, elements: np.ndarray, source: str
                     ) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """Join nodes that coincide (within DUPLICATE_RTOL x the bounding-box diagonal) into
    the lowest-numbered of them, drop the others and renumber; returns the new arrays and a
    warning line (none when nothing coincides).  Left to :func:`check_mesh` (unchanged)
    when ids are out of range or coordinates are not finite.  A triangle's -1 stays -1."""
    points, elements, lines, _ = _merge_coincident(points, elements, source)
    return points, elements, lines


def _merge_coincident(points, elements, source: str):
    """:func:`merge_coincident`, also returning the old ids of the kept nodes (None when
    nothing changed)."""
    points = np.asarray(points, dtype=np.float64)
    elements = np.asarray(elements)
    n = len(points)
    if elements.ndim != 2 or elements.shape[1] != 4 or elements.size == 0:
        return points, elements, (), None
    corner = _corners(elements)
    ids = elements[corner]
    if (ids.min() < 0 or ids.max() >= n or not np.isfinite(points).all()
            or np.abs(points).max() > MAX_COORDINATE):
        return points, elements, (), None
    used = np.unique(ids)
    pairs = _coincident_pairs(points, used, DUPLICATE_RTOL * np.linalg.norm(np.ptp(points[used], axis=0)))
    if len(pairs) == 0:
        return points, elements, (), None
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
    merged = np.where(corner, rep[np.where(corner, elements, 0)], -1)
    keep = np.unique(merged[corner])
    new_id = np.full(n, -1, dtype=np.int64)
    new_id[keep] = np.arange(len(keep))
    a, b = pairs[0]
    removed = len(used) - len(keep)
    line = (f"{source}: merged {removed} coincident node{'s' if removed != 1 else ''} into "
            f"{'their' if removed != 1 else 'its'} twin{'s' if removed != 1 else ''} ([mesh].merge_nodes; e.g. "
            f"nodes {a} and {b} at {points[a].tolist()}) and renumbered the rest: node ids in the messages "
            "and in ids = [...] node sets are those after merging")
    return points[keep], np.where(corner, new_id[np.where(corner, merged, 0)], -1), (line,), keep


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


def _directed_edges(elements: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k, 2) directed edges a->b of every element (4 per quad, 3 per triangle, in corner
    order) and (k,) their elements."""
    tri = elements[:, 3] < 0
    following = np.roll(elements, -1, axis=1)
    following[tri, 2] = elements[tri, 0]
    edges = np.stack([elements, following], axis=2)                 # (m, 4, 2)
    corner = _corners(elements)
    owner = np.broadcast_to(np.arange(len(elements))[:, None], elements.shape)
    return edges[corner], owner[corner]


def _orientation_warnings(elements: np.ndarray, source: str, name) -> list[str]:
    """Lines for neighbouring elements with opposite normals: an edge a->b that two elements
    both run in the same direction (a consistently oriented surface runs it a->b and b->a)."""
    edges, owner = _directed_edges(elements)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    edges, owner = edges[order], owner[order]
    lines = []
    for k in np.nonzero((edges[1:] == edges[:-1]).all(axis=1))[0]:
        e, f = sorted((int(owner[k]), int(owner[k + 1])))
        if e != f:
            lines.append(f"{source}: elements {name(e)} and {name(f)} have opposite normals (both run "
                         f"edge {edges[k, 0]}->{edges[k, 1]}): reverse the node order of one of them")
    return lines


def _folded_triangles(elements: np.ndarray, unit: np.ndarray, valid: np.ndarray
                      ) -> list[tuple[int, int, int, int, int, int]]:
    """Triangles folded over most of their neighbours: (e, folded, neighbours, f, a, b) with
    f one neighbour it folds over across edge a-b.  Neighbours share an edge; their normals
    are compared as a consistently oriented surface would have them (one flipped when both
    run the shared edge the same way, which :func:`_orientation_warnings` reports)."""
    tri = elements[:, 3] < 0
    if not tri.any():
        return []
    edges, owner = _directed_edges(elements)
    key = np.sort(edges, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    edges, key, owner = edges[order], key[order], owner[order]
    k = np.nonzero((key[1:] == key[:-1]).all(axis=1))[0]
    e, f = owner[k], owner[k + 1]
    keep = (e != f) & (tri[e] | tri[f]) & valid[e] & valid[f]
    k, e, f = k[keep], e[keep], f[keep]
    sign = np.where(edges[k, 0] == edges[k + 1, 0], -1.0, 1.0)
    folded = sign * np.einsum("ki,ki->k", unit[e], unit[f]) < np.cos(np.radians(FOLD_DEG))
    neighbours = np.bincount(np.concatenate([e, f]), minlength=len(elements))
    folds = np.bincount(np.concatenate([e[folded], f[folded]]), minlength=len(elements))
    found = []
    for t in np.nonzero(tri & (2 * folds > neighbours))[0]:
        j = np.nonzero(folded & ((e == t) | (f == t)))[0][0]
        other = int(f[j] if e[j] == t else e[j])
        found.append((int(t), int(folds[t]), int(neighbours[t]), other, int(key[k[j], 0]), int(key[k[j], 1])))
    return found


def check_mesh(points, elements, source: str, labels: tuple[np.ndarray, np.ndarray] | None = None
               ) -> tuple[str, ...]:
    """Check a shell mesh of quads and triangles; raise :class:`SceneError` for fatal
    problems, return warnings.

    ``elements`` is (m, 4) integer node ids, -1 in column 3 for a triangle.  ``source`` (a
    file name or ``'[mesh] plate'``) prefixes every line; ``labels`` = (element ids, node
    ids) of the file (an LS-DYNA deck's), named after the 0-based indices.  Fatal: wrong
    array shapes, no elements, non-finite coordinates or coordinates above MAX_COORDINATE,
    out-of-range or repeated node ids in an element, stray nodes (an element whose longest edge is
    above STRAY_RATIO x the median one: the corner farthest from the median node is named),
    zero-area elements (area < AREA_RTOL x median), inverted or non-convex quads (a corner normal (x_{a+1}-x_a) x (x_{a-1}-x_a) not
    along the element normal (x_3-x_1) x (x_4-x_2)), inverted triangles (folded by more than
    FOLD_DEG over most of their neighbours: a corner on the wrong side of the opposite edge).
    Warnings: coincident nodes (within DUPLICATE_RTOL x bounding-box diagonal: one line with
    their count and one pair; they stay distinct), quads warped by more than WARP_WARN_DEG,
    neighbours with opposite normals (inconsistent node order), unused nodes.
    """
    points = np.asarray(points, dtype=np.float64)
    elements = np.asarray(elements)
    if points.ndim != 2 or points.shape[1] != 3:
        raise SceneError(f"{source}: node coordinates have shape {points.shape}, expected (n, 3)")
    if elements.ndim != 2 or elements.shape[1] != 4 or not np.issubdtype(elements.dtype, np.integer):
        raise SceneError(f"{source}: elements have shape {elements.shape} ({elements.dtype}), "
                         "expected (m, 4) integer node ids")
    if len(elements) == 0:
        raise SceneError(f"{source}: mesh has no elements")
    n = len(points)
    element_ids, node_ids = labels if labels is not None else (None, None)

    def name(e: int) -> str:
        """'3', or '3 (id 1004)' for a file with its own ids."""
        return f"{e}" if element_ids is None else f"{e} (id {element_ids[e]})"

    def node(i: int) -> str:
        return f"node {i}" if node_ids is None else f"node {i} (id {node_ids[i]})"

    tri = elements[:, 3] == -1
    corner = _corners(elements)
    shape = np.where(tri, "triangle", "quad")

    # -- structure: ids and coordinates must be usable before any geometry is computed
    errors = []
    for i in np.nonzero(~np.isfinite(points).all(axis=1))[0]:
        errors.append(f"{source}: {node(i)}: non-finite coordinates {points[i].tolist()}")
    bad_id = ((elements < 0) | (elements >= n)) & corner
    for e in np.nonzero(bad_id.any(axis=1))[0]:
        errors.append(f"{source}: element {name(e)}: node id {elements[e][bad_id[e]][0]} out of range "
                      f"(mesh has {n} nodes)")
    # a triangle's -1 sorts first: compare its 3 corners only
    s = np.sort(elements, axis=1)
    repeated = (s[:, 1:] == s[:, :-1]) & ~(tri[:, None] & (s[:, :-1] == -1))
    for e in np.nonzero(repeated.any(axis=1))[0]:
        errors.append(f"{source}: element {name(e)}: degenerate {shape[e]} "
                      f"(node {s[e, 1:][repeated[e]][0]} repeated)")
    big = np.nonzero(np.abs(np.where(np.isfinite(points), points, 0.0)).max(axis=1) > MAX_COORDINATE)[0]
    if len(big):
        which = f"node {big[0]} has" if len(big) == 1 else f"{len(big)} nodes have"
        errors.append(f"{source}: {which} coordinates above {MAX_COORDINATE:g} in magnitude (e.g. node "
                      f"{big[0]} at {points[big[0]].tolist()}; lengths squared would overflow): rescale the "
                      "mesh ([mesh].scale) or use other units")
    if errors:
        raise SceneError(_limited(errors, source))

    # -- geometry (a triangle's corner 4 is read as its corner 1: x4 - x2 = x1 - x2)
    safe = np.where(tri[:, None], elements[:, [0, 1, 2, 0]], elements)
    x = points[safe]                                                 # (m, 4, 3)
    longest = np.linalg.norm(np.roll(x, -1, axis=1) - x, axis=2).max(axis=1)
    centre = np.median(points[elements[corner]], axis=0)
    stray = {}
    for e in np.nonzero(longest > STRAY_RATIO * np.median(longest))[0]:
        corners = elements[e][corner[e]]
        i = int(corners[np.argmax(np.linalg.norm(points[corners] - centre, axis=1))])
        stray.setdefault(i, e)
    for i, e in stray.items():
        errors.append(f"{source}: {node(i)} at {points[i].tolist()} is a stray node: element {name(e)} has an edge "
                      f"{longest[e] / np.median(longest):.3g} times the mesh's median longest edge (a typo, or a "
                      + ("*NODE field overflowing its fixed columns?)" if labels is not None else "unit mistake?)"))
    if errors:
        raise SceneError(_limited(errors, source))
    normal = np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1])          # = 2 * vector area
    area = 0.5 * np.linalg.norm(normal, axis=1)
    degenerate = area <= AREA_RTOL * np.median(area)
    for e in np.nonzero(degenerate)[0]:
        why = ("collapsed, or a bow-tie whose corners are out of order" if not tri[e]
               else "its corners are collinear")
        errors.append(f"{source}: element {name(e)}: degenerate {shape[e]} (area {area[e]:.3g}: {why})")
    corner_normal = np.cross(np.roll(x, -1, axis=1) - x, np.roll(x, 1, axis=1) - x)  # (m, 4, 3)
    along = np.einsum("mai,mi->ma", corner_normal, normal)
    inverted = (along <= 1e-10 * np.einsum("mi,mi->m", normal, normal)[:, None]).any(axis=1) & ~tri
    for e in np.nonzero(inverted & ~degenerate)[0]:
        errors.append(f"{source}: element {name(e)}: inverted or non-convex quad")
    unit = normal / np.where(degenerate, 1.0, 2.0 * area)[:, None]
    for e, folds, neighbours, f, a, b in _folded_triangles(elements, unit, ~degenerate):
        errors.append(f"{source}: element {name(e)}: inverted triangle (folded back onto {folds} of its "
                      f"{neighbours} neighbours, e.g. element {name(f)} across edge {a}-{b}: a corner on the "
                      "wrong side of the opposite edge)")
    used = np.unique(elements[corner])
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
    quad = np.nonzero(~tri)[0]
    cos_warp = np.einsum("mi,mi->m", n1[quad], n2[quad]) / (
        np.linalg.norm(n1[quad], axis=1) * np.linalg.norm(n2[quad], axis=1))
    warp = np.degrees(np.arccos(np.clip(cos_warp, -1.0, 1.0)))
    for i in np.nonzero(warp > WARP_WARN_DEG)[0]:
        warnings.append(f"{source}: element {name(quad[i])}: warped by {warp[i]:.1f} deg")
    warnings += _orientation_warnings(elements, source, name)
    warnings = _limited(warnings, source)
    if len(used) < n:
        warnings.append(f"{source}: {n - len(used)} unused nodes (not referenced by any element)")
    return tuple(warnings)
