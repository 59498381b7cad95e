"""Tests for mesh generation, import, checking (mesh.py) and node sets (nodesets.py)."""
from __future__ import annotations

import math

import meshio
import numpy as np
import pytest

from taichi_shell_mpm.mesh import Mesh, build_mesh, check_mesh
from taichi_shell_mpm.nodesets import select_nodes
from taichi_shell_mpm.scene import (FileMesh, HemisphereMesh, NodeSet, PlateMesh, SceneError,
                                    TubeMesh)


def quad_normals(mesh: Mesh) -> np.ndarray:
    """Vector-area normals (x3-x1) x (x4-x2) / 2 of every element."""
    x = mesh.points[mesh.elements]
    return 0.5 * np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1])


def total_area(mesh: Mesh) -> float:
    return float(np.linalg.norm(quad_normals(mesh), axis=1).sum())


def assert_outward(mesh: Mesh, centre_of=lambda c: c) -> None:
    """Every element normal has a positive component along ``centre_of(centroid)``."""
    centroid = mesh.points[mesh.elements].mean(axis=1)
    assert (np.einsum("ij,ij->i", quad_normals(mesh), centre_of(centroid)) > 0).all()


# ---------------------------------------------------------------- generators
def test_plate_counts_area_and_numbering():
    m = build_mesh(PlateMesh(lx=2.0, ly=3.0, nx=4, ny=6, origin=(1.0, -1.0, 0.5)))
    assert m.points.shape == (5 * 7, 3) and m.points.dtype == np.float64
    assert m.elements.shape == (24, 4) and m.elements.dtype == np.int32
    assert m.warnings == ()
    assert total_area(m) == pytest.approx(6.0)
    # node j*(nx+1)+i sits at (ox + i*dx, oy + j*dy, oz)
    np.testing.assert_allclose(m.points[2 * 5 + 3], [1.0 + 1.5, -1.0 + 1.0, 0.5])
    np.testing.assert_allclose(m.points[-1], [3.0, 2.0, 0.5])
    assert (quad_normals(m)[:, 2] > 0).all()
    assert np.allclose(quad_normals(m)[:, :2], 0.0)


def test_hemisphere_quarter():
    r, hole = 10.0, 18.0
    m = build_mesh(HemisphereMesh(radius=r, hole_deg=hole, n_around=16, n_meridian=16))
    assert m.points.shape == (17 * 17, 3) and m.elements.shape == (256, 4)
    np.testing.assert_allclose(np.linalg.norm(m.points, axis=1), r, rtol=1e-14)
    # first and last column lie exactly on the y=0 and x=0 planes
    assert (m.points[0::17, 1] == 0.0).all()
    assert (m.points[16::17, 0] == 0.0).all()
    assert (m.points[:, :2] >= 0.0).all()
    assert (m.points[:17, 2] == 0.0).all()               # equator row
    np.testing.assert_allclose(m.points[-17:, 2], r * math.sin(math.radians(90 - hole)))
    exact = 2 * math.pi * r**2 * math.sin(math.radians(90 - hole)) / 4
    area = total_area(m)
    assert area < exact and (exact - area) / exact < 0.02
    assert_outward(m)
    assert m.warnings == ()


def test_hemisphere_full_wraps_without_duplicates():
    m = build_mesh(HemisphereMesh(radius=2.0, hole_deg=10.0, n_around=12, n_meridian=5,
                                  quarter=False))
    assert m.points.shape == (6 * 12, 3) and m.elements.shape == (60, 4)
    assert len(np.unique(np.round(m.points, 9), axis=0)) == len(m.points)
    assert len(np.unique(m.elements)) == len(m.points)
    assert_outward(m)
    exact = 2 * math.pi * 4.0 * math.sin(math.radians(80.0))
    assert total_area(m) == pytest.approx(exact, rel=0.05)


def test_hemisphere_rejects_closed_pole():
    with pytest.raises(SceneError, match="hole_deg"):
        build_mesh(HemisphereMesh(radius=1.0, hole_deg=0.0, n_around=8, n_meridian=4))


def test_tube_counts_perimeter_and_normals():
    w, d, r, length = 4.0, 3.0, 0.5, 10.0
    nf, nc, nl = 4, 3, 5
    m = build_mesh(TubeMesh(width=w, depth=d, corner_radius=r, length=length,
                            n_flat=nf, n_corner=nc, n_length=nl))
    ring = 4 * (nf + nc)
    assert m.points.shape == ((nl + 1) * ring, 3) and m.elements.shape == (nl * ring, 4)
    assert m.warnings == ()
    xy = m.points[:ring, :2]
    assert (m.points[:ring, 2] == 0.0).all() and (m.points[-ring:, 2] == length).all()
    # counter-clockwise about +z: positive signed (shoelace) area
    shoelace = 0.5 * np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1])
    assert shoelace > 0
    perimeter = np.linalg.norm(np.roll(xy, -1, axis=0) - xy, axis=1).sum()
    chords = 2 * (w - 2 * r) + 2 * (d - 2 * r) + 4 * nc * 2 * r * math.sin(math.pi / (4 * nc))
    assert perimeter == pytest.approx(chords, rel=1e-12)
    analytic = 2 * (w - 2 * r) + 2 * (d - 2 * r) + 2 * math.pi * r
    assert abs(perimeter - analytic) / analytic < 0.01
    assert np.abs(xy[:, 0]).max() == pytest.approx(w / 2)
    assert np.abs(xy[:, 1]).max() == pytest.approx(d / 2)
    assert total_area(m) == pytest.approx(perimeter * length)
    assert_outward(m, centre_of=lambda c: c * [1.0, 1.0, 0.0])


def test_tube_sharp_corners():
    m = build_mesh(TubeMesh(width=2.0, depth=1.0, corner_radius=0.0, length=1.0,
                            n_flat=2, n_corner=0, n_length=1))
    assert m.points.shape == (16, 3)
    assert total_area(m) == pytest.approx(6.0)
    with pytest.raises(SceneError, match="corner_radius"):
        build_mesh(TubeMesh(width=2.0, depth=1.0, corner_radius=0.6, length=1.0,
                            n_flat=2, n_corner=2, n_length=1))


# ---------------------------------------------------------------- file import
@pytest.mark.parametrize("name, fmt", [("p.vtu", None), ("p.msh", "gmsh22"), ("p.inp", None)])
def test_file_round_trip(tmp_path, name, fmt):
    plate = build_mesh(PlateMesh(lx=2.0, ly=1.0, nx=4, ny=3))
    path = tmp_path / name
    meshio.write(path, meshio.Mesh(plate.points, [("quad", plate.elements)]), file_format=fmt)
    m = build_mesh(FileMesh(path=path, scale=2.0))
    np.testing.assert_allclose(m.points, 2.0 * plate.points)
    np.testing.assert_array_equal(m.elements, plate.elements)
    assert m.elements.dtype == np.int32 and m.warnings == ()


def test_file_quad9_lines_and_unused_nodes(tmp_path):
    plate = build_mesh(PlateMesh(lx=1.0, ly=1.0, nx=2, ny=2))
    # extra stray node, quad9 cells (first 4 = corners), and an ignored line cell
    points = np.vstack([plate.points, [[5.0, 5.0, 5.0]]])
    quad9 = np.column_stack([plate.elements, np.zeros((4, 5), dtype=np.int64) + plate.elements[:, :1]])
    path = tmp_path / "q.vtu"
    meshio.write(path, meshio.Mesh(points, [("quad9", quad9), ("line", np.array([[0, 1]]))]))
    m = build_mesh(FileMesh(path=path))
    np.testing.assert_array_equal(m.elements, plate.elements)
    assert len(m.points) == 9
    assert any("removed 1 unused node" in w for w in m.warnings)


def test_file_with_triangle(tmp_path):
    """Issue 17: triangles are read (a -1 in column 3)."""
    path = tmp_path / "t.vtu"
    points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0]], dtype=float)
    meshio.write(path, meshio.Mesh(points, [("quad", np.array([[0, 1, 2, 3]])),
                                            ("triangle", np.array([[1, 4, 2]]))]))
    m = build_mesh(FileMesh(path=path))
    assert m.elements.tolist() == [[0, 1, 2, 3], [1, 4, 2, -1]]
    assert m.triangles.tolist() == [False, True] and m.warnings == ()
    assert {k: v.tolist() for k, v in m.element_sets.items()} == {"block:0": [0], "block:1": [1]}


def test_file_with_pentagon_and_four_node_polygon(tmp_path):
    """A pentagon is named as one (issue 16.18: it was '1 triangles'); a 4-node polygon is a quad
    (and a 3-node one a triangle, issue 17)."""
    points = np.array([[0, 0, 0], [1, 0, 0], [1.5, 0.5, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    meshio.write(tmp_path / "p.vtu", meshio.Mesh(points, [("polygon", np.array([[0, 1, 2, 3, 4]]))]))
    with pytest.raises(SceneError) as err:
        build_mesh(FileMesh(path=tmp_path / "p.vtu"))
    assert err.value.messages == [f"{tmp_path / 'p.vtu'}: mesh has polygonal cells with more than 4 corners "
                                  "(1 polygon with 5 corners); this solver needs 3-node triangles and 4-node "
                                  "quadrilaterals: remesh (e.g. gmsh, with 'Mesh.RecombineAll = 1' for quads)"]
    meshio.write(tmp_path / "q.vtu", meshio.Mesh(points, [("polygon", np.array([[0, 1, 3, 4]]))]))
    assert build_mesh(FileMesh(path=tmp_path / "q.vtu")).elements.tolist() == [[0, 1, 2, 3]]
    meshio.write(tmp_path / "t.vtu", meshio.Mesh(points, [("polygon", np.array([[0, 1, 3]]))]))
    assert build_mesh(FileMesh(path=tmp_path / "t.vtu")).elements.tolist() == [[0, 1, 2, -1]]


def test_file_quad8_is_linearised_with_a_warning(tmp_path):
    """Issue 16.18: a quad8 mesh was silently used as 4-node quads."""
    plate = build_mesh(PlateMesh(lx=2.0, ly=1.0, nx=2, ny=1))
    mid = np.array([[0.5, 0, 0], [1.5, 0, 0], [2, 0.5, 0], [1.5, 1, 0], [0.5, 1, 0], [0, 0.5, 0], [1, 0.5, 0]])
    points = np.vstack([plate.points, mid])
    quad8 = np.array([[0, 1, 4, 3, 6, 11, 10, 5], [1, 2, 5, 4, 7, 8, 9, 11]])
    meshio.write(tmp_path / "q8.vtu", meshio.Mesh(points, [("quad8", quad8)]))
    m = build_mesh(FileMesh(path=tmp_path / "q8.vtu"))
    np.testing.assert_array_equal(m.elements, plate.elements)
    assert m.warnings[0] == (f"{tmp_path / 'q8.vtu'}: 2 quad8 elements (8-node quads) used as 4-node bilinear "
                             "shells: their mid-side and centre nodes are dropped and curved edges become straight")
    assert "removed 7 unused nodes" in m.warnings[1]


def test_file_missing_and_unreadable(tmp_path):
    with pytest.raises(SceneError, match="mesh file not found"):
        build_mesh(FileMesh(path=tmp_path / "nope.msh"))
    with pytest.raises(SceneError) as err:          # issue 16.18: it said "file not found"
        build_mesh(FileMesh(path=tmp_path))
    assert err.value.messages == [f"{tmp_path}: is a directory, not a mesh file"]
    bad = tmp_path / "bad.vtu"
    bad.write_text("this is not xml\n")
    with pytest.raises(SceneError) as err:
        build_mesh(FileMesh(path=bad))
    assert len(err.value.messages) == 1 and "\n" not in err.value.messages[0]
    assert err.value.messages[0].startswith(f"{bad}: cannot read mesh")


# ---------------------------------------------------------------- check_mesh
SQUARE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)


def test_check_accepts_square():
    assert check_mesh(SQUARE, [[0, 1, 2, 3]], "m") == ()


def test_check_out_of_range_and_repeated_node():
    with pytest.raises(SceneError) as err:
        check_mesh(SQUARE, [[0, 1, 2, 3], [0, 1, 2, 7], [0, 1, 1, 3]], "m")
    assert err.value.messages == ["m: element 1: node id 7 out of range (mesh has 4 nodes)",
                                  "m: element 2: degenerate quad (node 1 repeated)"]


def test_check_zero_area():
    points = np.vstack([SQUARE, [[2, 0, 0], [3, 0, 0]]])
    with pytest.raises(SceneError) as err:
        check_mesh(points, [[0, 1, 2, 3], [1, 4, 5, 0]], "m")
    assert err.value.messages == ["m: element 1: degenerate quad (area 0: collapsed, or a bow-tie whose "
                                  "corners are out of order)"]
    # a bow-tie whose diagonals are parallel has zero BT area too
    with pytest.raises(SceneError) as err:
        check_mesh(SQUARE, [[0, 2, 1, 3]], "m")
    assert err.value.messages[0].startswith("m: element 0: degenerate quad (area 0: collapsed, or a bow-tie")


def test_check_non_finite():
    points = SQUARE.copy()
    points[2, 1] = np.nan
    with pytest.raises(SceneError, match="node 2: non-finite"):
        check_mesh(points, [[0, 1, 2, 3]], "m")


def test_check_inverted_and_non_convex():
    dart = np.array([[0, 0, 0], [2, 0, 0], [0.5, 0.5, 0], [0, 2, 0]], dtype=float)
    with pytest.raises(SceneError) as err:
        check_mesh(dart, [[0, 1, 2, 3]], "m")
    assert err.value.messages == ["m: element 0: inverted or non-convex quad"]
    # a plate with one interior node pushed across its neighbours folds elements
    plate = build_mesh(PlateMesh(lx=3.0, ly=3.0, nx=3, ny=3))
    points = plate.points.copy()
    points[5] = [2.5, 2.5, 0.0]
    with pytest.raises(SceneError) as err:
        check_mesh(points, plate.elements, "m")
    assert err.value.messages == [f"m: element {e}: inverted or non-convex quad"
                                  for e in (1, 3, 4)]


SLIT = np.vstack([SQUARE, SQUARE[[1, 2]] + [[0, 0, 1e-12], [0, 0, 0]], [[2, 0, 0], [2, 1, 0]]])
"""Two squares sharing an edge geometrically but not topologically (a slit along x = 1)."""
SLIT_QUADS = [[0, 1, 2, 3], [4, 6, 7, 5]]


def test_check_duplicate_nodes_warn_and_stay_distinct():
    """Issue 16.17: coincident nodes model a slit, a crack or a seam: a warning with their
    count and one pair, not an error."""
    assert check_mesh(SLIT, SLIT_QUADS, "m") == (
        "m: 2 pairs of coincident nodes kept distinct (e.g. nodes 1 and 4 at [1.0, 0.0, 0.0]): the shell is not "
        "connected there (a slit, crack or seam); set [mesh].merge_nodes = true to join them",)


def test_file_merge_nodes_on_request(tmp_path):
    path = tmp_path / "slit.vtu"
    meshio.write(path, meshio.Mesh(SLIT, [("quad", np.array(SLIT_QUADS))]))
    kept = build_mesh(FileMesh(path=path))
    assert len(kept.points) == 8 and "2 pairs of coincident nodes kept distinct" in kept.warnings[0]
    merged = build_mesh(FileMesh(path=path, merge_nodes=True))
    assert len(merged.points) == 6
    assert merged.elements.tolist() == [[0, 1, 2, 3], [1, 4, 5, 2]]
    assert merged.warnings == (
        f"{path}: merged 2 coincident nodes into their twins ([mesh].merge_nodes; e.g. nodes 1 and 4 at "
        "[1.0, 0.0, 0.0]) and renumbered the rest: node ids in the messages and in ids = [...] node sets are "
        "those after merging",)


def test_check_duplicate_detection_is_fast_and_sparse():
    # 40 000 nodes on a grid: no false positives, and a single duplicate is found
    plate = build_mesh(PlateMesh(lx=1.0, ly=1.0, nx=199, ny=199))
    points = np.vstack([plate.points, plate.points[[12345]]])
    quads = np.vstack([plate.elements, [[12345 + 1, 12345 + 201, 12345 + 200, len(plate.points)]]])
    assert check_mesh(points, quads, "m")[0].startswith(
        f"m: 1 pair of coincident nodes kept distinct (e.g. nodes 12345 and 40000 at {points[12345].tolist()})")


def test_check_huge_coordinates_is_one_line():
    """Issue 16.18: 1e200 coordinates gave 'area inf ... and 231 more' on a 10-element mesh."""
    plate = build_mesh(PlateMesh(lx=10.0, ly=1.0, nx=10, ny=1))
    with pytest.raises(SceneError) as err:
        check_mesh(plate.points * 1e200, plate.elements, "m")
    assert err.value.messages == [
        "m: 21 nodes have coordinates above 1e+100 in magnitude (e.g. node 1 at [1e+200, 0.0, 0.0]; lengths "
        "squared would overflow): rescale the mesh ([mesh].scale) or use other units"]


def test_check_limits_lines():
    points = np.zeros((4, 3))
    points[:, 0] = np.nan
    with pytest.raises(SceneError) as err:
        check_mesh(np.repeat(points, 5, axis=0), [[0, 1, 2, 3]], "m")
    assert len(err.value.messages) == 11 and err.value.messages[-1] == "m: ... and 10 more"


def test_check_opposite_normals_warning():
    """Two neighbours with opposite node order: a warning naming both and the shared edge; the
    generated meshes are consistently oriented."""
    points = np.vstack([SQUARE, [[2, 0, 0], [2, 1, 0]]])
    assert check_mesh(points, [[0, 1, 2, 3], [1, 4, 5, 2]], "m") == ()
    assert check_mesh(points, [[0, 1, 2, 3], [2, 5, 4, 1]], "m") == (
        "m: elements 0 and 1 have opposite normals (both run edge 1->2): reverse the node order of one of them",)
    for spec in (PlateMesh(lx=3.0, ly=2.0, nx=3, ny=2), HemisphereMesh(radius=1, hole_deg=10, n_around=8,
                                                                       n_meridian=3, quarter=False),
                 TubeMesh(width=4, depth=3, corner_radius=0.5, length=5, n_flat=2, n_corner=2, n_length=3)):
        mesh = build_mesh(spec)
        assert not [w for w in check_mesh(mesh.points, mesh.elements, "m") if "opposite normals" in w]


def test_check_warp_and_unused_warnings():
    warped = SQUARE.copy()
    warped[2, 2] = 0.2
    points = np.vstack([warped, [[9, 9, 9]]])
    warnings = check_mesh(points, [[0, 1, 2, 3]], "m")
    # triangle normals (0, -0.2, 1) and (-0.2, 0, 1)
    angle = math.degrees(math.acos(1 / 1.04))
    assert warnings[0].startswith("m: element 0: warped by")
    assert float(warnings[0].split("by ")[1].split()[0]) == pytest.approx(angle, abs=0.05)
    assert warnings[1] == "m: 1 unused nodes (not referenced by any element)"
    slight = SQUARE.copy()
    slight[2, 2] = 0.05
    assert check_mesh(slight, [[0, 1, 2, 3]], "m") == ()


# ---------------------------------------------------------------- node sets
@pytest.fixture(scope="module")
def plate_points():
    return build_mesh(PlateMesh(lx=10.0, ly=2.0, nx=10, ny=2)).points


def test_nodeset_all_box_plane(plate_points):
    ids = select_nodes(NodeSet(name="all", kind="all"), plate_points)
    np.testing.assert_array_equal(ids, np.arange(33))
    assert ids.dtype == np.int64
    box = NodeSet(name="b", kind="box", box_min=(0, 0, 0), box_max=(1, 2, 0))
    np.testing.assert_array_equal(select_nodes(box, plate_points), [0, 1, 11, 12, 22, 23])
    plane = NodeSet(name="tip", kind="plane", point=(10, 5, 3), normal=(2, 0, 0))
    np.testing.assert_array_equal(select_nodes(plane, plate_points), [10, 21, 32])
    tilted = NodeSet(name="d", kind="plane", point=(0, 0, 0), normal=(-1, 1, 0), tol=1e-9)
    np.testing.assert_array_equal(select_nodes(tilted, plate_points), [0, 12, 24])


def test_nodeset_tolerance(plate_points):
    box = NodeSet(name="b", kind="box", box_min=(10 + 1e-7, 0, 0), box_max=(11, 0, 0))
    np.testing.assert_array_equal(select_nodes(box, plate_points), [10])
    strict = NodeSet(name="b", kind="box", box_min=(10 + 1e-7, 0, 0), box_max=(11, 0, 0),
                     tol=1e-8)
    with pytest.raises(SceneError, match="selects no node"):
        select_nodes(strict, plate_points)


def test_nodeset_nearest_and_ids(plate_points):
    near = NodeSet(name="c", kind="nearest", point=(4.9, 1.2, 0.3))
    np.testing.assert_array_equal(select_nodes(near, plate_points), [16])
    # a point outside the mesh's bounding box (grown by 5% of 10 = 0.5) is a mistake, not a node
    far = NodeSet(name="c", kind="nearest", point=(4.9, 1.2, 7.0))
    with pytest.raises(SceneError) as err:
        select_nodes(far, plate_points)
    assert err.value.messages == ["nodeset 'c' (nearest point=[4.9,1.2,7]): the point lies outside the mesh "
                                  "(its nodes span [0,0,0] .. [10,2,0]; the nearest node, 16, is 7 away)"]
    edge = NodeSet(name="c", kind="nearest", point=(10.49, -0.49, 0.49))
    np.testing.assert_array_equal(select_nodes(edge, plate_points), [10])
    ids = NodeSet(name="i", kind="ids", ids=(5, 3, 5))
    np.testing.assert_array_equal(select_nodes(ids, plate_points), [3, 5])
    with pytest.raises(SceneError, match="nodeset 'i': node id 33 out of range"):
        select_nodes(NodeSet(name="i", kind="ids", ids=(1, 33)), plate_points)


def test_nodeset_empty_messages(plate_points):
    tip = NodeSet(name="tip", kind="plane", point=(11, 0, 0), normal=(1, 0, 0))
    with pytest.raises(SceneError) as err:
        select_nodes(tip, plate_points)
    assert err.value.messages == [
        "nodeset 'tip' (plane point=[11,0,0] normal=[1,0,0] tol=1e-06) selects no node"]
    box = NodeSet(name="b", kind="box", box_min=(20, 0, 0), box_max=(30, 1, 1))
    with pytest.raises(SceneError) as err:
        select_nodes(box, plate_points)
    assert err.value.messages == [
        "nodeset 'b' (box min=[20,0,0] max=[30,1,1] tol=1e-06) selects no node"]
    with pytest.raises(SceneError, match=r"nodeset 'e' \(ids=\[\]\) selects no node"):
        select_nodes(NodeSet(name="e", kind="ids"), plate_points)
    with pytest.raises(SceneError, match="needs normal"):
        select_nodes(NodeSet(name="p", kind="plane", point=(0, 0, 0)), plate_points)


# ---------------------------------------------------------------- tube trigger
TUBE = dict(width=60.0, depth=40.0, corner_radius=5.0, length=60.0, n_flat=10, n_corner=2,
            n_length=30)


def test_tube_trigger_shape():
    a0, z0, lt = 0.5, 4.0, 16.0
    plain = build_mesh(TubeMesh(**TUBE))
    trig = build_mesh(TubeMesh(**TUBE, trigger_amplitude=a0, trigger_start=z0,
                               trigger_length=lt))
    np.testing.assert_array_equal(trig.elements, plain.elements)
    assert trig.warnings == ()
    delta = trig.points - plain.points
    assert (delta[:, 2] == 0.0).all()
    offset = np.linalg.norm(delta, axis=1)
    # z step 2 (a node row at z0 + L/2); flat steps 3 (x-faces, b = 30) and 5 (y-faces,
    # b = 50), with a node on each centre line: the sampled maximum is a0 itself
    assert offset.max() == pytest.approx(a0, rel=1e-12)
    peak = np.argmax(offset)
    assert plain.points[peak, 2] == pytest.approx(z0 + lt / 2)
    moved = offset > 1e-12
    z = plain.points[:, 2]
    assert (z[moved] > z0).all() and (z[moved] < z0 + lt).all()
    assert (offset[(z < z0) | (z > z0 + lt)] == 0.0).all()

    ca, cb = TUBE["width"] / 2 - 5.0, TUBE["depth"] / 2 - 5.0
    x, y = plain.points[:, 0], plain.points[:, 1]
    x_face = np.isclose(np.abs(x), TUBE["width"] / 2) & (np.abs(y) < cb - 1e-9)
    y_face = np.isclose(np.abs(y), TUBE["depth"] / 2) & (np.abs(x) < ca - 1e-9)
    fillet = ~(x_face | y_face)
    assert (offset[fillet] == 0.0).all()          # corners (and tangent points) untouched
    assert moved[x_face].any() and moved[y_face].any()
    # x-faces move inward along x only, y-faces outward along y only
    xf, yf = x_face & moved, y_face & moved
    assert (np.abs(trig.points[xf, 0]) < np.abs(x[xf])).all() and (delta[xf, 1] == 0.0).all()
    assert (np.abs(trig.points[yf, 1]) > np.abs(y[yf])).all() and (delta[yf, 0] == 0.0).all()
    # the formula, node by node: s across the flat from its tangent point
    zr = np.sin(np.pi * (z - z0) / lt)
    sx = (y + cb) / (2 * cb)
    sy = (x + ca) / (2 * ca)
    np.testing.assert_allclose(offset[xf], a0 * zr[xf] * np.sin(np.pi * sx[xf]), atol=1e-12)
    np.testing.assert_allclose(offset[yf], a0 * zr[yf] * np.sin(np.pi * sy[yf]), atol=1e-12)
    # the maximum of each face lies on its centre line at the mid-height of the trigger
    mid = np.isclose(z, z0 + lt / 2)
    for centre in (x_face & mid & np.isclose(y, 0.0), y_face & mid & np.isclose(x, 0.0)):
        assert centre.sum() == 2
        np.testing.assert_allclose(offset[centre], a0, rtol=1e-12)


def test_tube_trigger_default_is_untriggered():
    plain = build_mesh(TubeMesh(**TUBE))
    zero = build_mesh(TubeMesh(**TUBE, trigger_amplitude=0.0, trigger_start=0.0,
                               trigger_length=60.0))
    np.testing.assert_array_equal(zero.points, plain.points)
    assert TubeMesh(**TUBE).trigger_amplitude == 0.0


def test_tube_trigger_sharp_corners():
    spec = dict(width=2.0, depth=1.0, corner_radius=0.0, length=2.0, n_flat=4, n_corner=0,
                n_length=4)
    plain = build_mesh(TubeMesh(**spec))
    trig = build_mesh(TubeMesh(**spec, trigger_amplitude=0.1, trigger_start=0.0,
                               trigger_length=2.0))
    offset = np.linalg.norm(trig.points - plain.points, axis=1)
    corners = np.isclose(np.abs(plain.points[:, 0]), 1.0) & np.isclose(
        np.abs(plain.points[:, 1]), 0.5)
    assert (offset[corners] == 0.0).all()
    assert offset.max() == pytest.approx(0.1)
