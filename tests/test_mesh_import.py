"""Issue 17 (mesh side): triangles, element sets and LS-DYNA keyword decks (mesh.py, dyna.py).

No Taichi: every test reads or checks a small mesh written here.
"""
from __future__ import annotations

import meshio
import numpy as np
import pytest

from taichi_shell_mpm.dyna import Deck, DeckPart, read_deck
from taichi_shell_mpm.mesh import build_mesh, check_mesh, collapse_repeated_corners, merge_coincident
from taichi_shell_mpm.scene import FileMesh, HemisphereMesh, PlateMesh, SceneError, TubeMesh


def sets(mesh) -> dict[str, list[int]]:
    return {name: ids.tolist() for name, ids in mesh.element_sets.items()}


# ---------------------------------------------------------------- element sets through meshio
STRIP = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0], [1, 1, 0], [2, 1, 0], [3, 0, 0], [3, 1, 0]], float)
"""Two unit squares side by side and a triangle fan to x = 3."""


def test_gmsh22_physical_groups_with_quads_and_triangles(tmp_path):
    """Each physical group holds a quad and a triangle; sets by name and by tag, element ids
    in file order (the quad block, then the triangle block)."""
    path = tmp_path / "two.msh"
    quads, tris = np.array([[0, 1, 4, 3], [1, 2, 5, 4]]), np.array([[2, 6, 5], [6, 7, 5]])
    meshio.write(path, meshio.Mesh(STRIP, [("quad", quads), ("triangle", tris)],
                                   cell_data={"gmsh:physical": [np.array([1, 2]), np.array([1, 2])],
                                              "gmsh:geometrical": [np.array([1, 1]), np.array([1, 1])]},
                                   field_data={"roof": np.array([1, 2]), "wall": np.array([2, 2])}),
                 file_format="gmsh22", binary=False)
    m = build_mesh(FileMesh(path=path))
    assert m.elements.tolist() == [[0, 1, 4, 3], [1, 2, 5, 4], [2, 6, 5, -1], [6, 7, 5, -1]]
    assert m.elements.dtype == np.int32 and m.triangles.tolist() == [False, False, True, True]
    assert sets(m) == {"roof": [0, 2], "wall": [1, 3], "physical:1": [0, 2], "physical:2": [1, 3],
                       "block:0": [0, 1], "block:1": [2, 3]}
    assert all(ids.dtype == np.int64 for ids in m.element_sets.values())
    assert m.warnings == () and m.deck is None


MSH41 = """$MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
2
2 1 "roof"
2 2 "wall"
$EndPhysicalNames
$Entities
0 0 2 0
1 -1 0 0 1 1 0 1 1 0
2 1 0 0 3 1 0 1 2 0
$EndEntities
$Nodes
1 9 1 9
2 1 0 9
1
2
3
4
5
6
7
8
9
0 0 0
1 0 0
2 0 0
0 1 0
1 1 0
2 1 0
3 0 0
3 1 0
-1 0.5 0
$EndNodes
$Elements
4 4 1 4
2 1 3 1
1 1 2 5 4
2 1 2 1
2 1 4 9
2 2 3 1
3 2 3 6 5
2 2 2 1
4 3 7 6
$EndElements
"""


def test_gmsh41_physical_groups_hand_written(tmp_path):
    """MSH 4.1: meshio gives the groups both as gmsh:physical cell data and as cell sets; the
    two agree.  Node 8 is unused: dropped, and the triangle's -1 survives the renumbering."""
    path = tmp_path / "two41.msh"
    path.write_text(MSH41)
    m = build_mesh(FileMesh(path=path))
    assert m.elements.tolist() == [[0, 1, 4, 3], [0, 3, 7, -1], [1, 2, 5, 4], [2, 6, 5, -1]]
    assert sets(m) == {"roof": [0, 1], "wall": [2, 3], "physical:1": [0, 1], "physical:2": [2, 3],
                       "block:0": [0], "block:1": [1], "block:2": [2], "block:3": [3]}
    assert m.warnings == (f"{path}: removed 1 unused nodes (not referenced by any shell element) and "
                          "renumbered the rest",)


INP = """*HEADING
two shell sets
** a comment
*NODE
1, 0.0, 0.0, 0.0
2, 1.0, 0.0, 0.0
3, 2.0, 0.0, 0.0
4, 0.0, 1.0, 0.0
5, 1.0, 1.0, 0.0
6, 2.0, 1.0, 0.0
7, 3.0, 0.0, 0.0
*ELEMENT, TYPE=S4R, ELSET=Skin
1, 1, 2, 5, 4
2, 2, 3, 6, 5
*ELEMENT, TYPE=S3R, ELSET=Tip
3, 3, 7, 6
*ELSET, ELSET=Edge
2, 3
"""


def test_abaqus_elsets(tmp_path):
    path = tmp_path / "shell.inp"
    path.write_text(INP)
    m = build_mesh(FileMesh(path=path))
    assert m.elements.tolist() == [[0, 1, 4, 3], [1, 2, 5, 4], [2, 6, 5, -1]]
    assert sets(m) == {"Skin": [0, 1], "Tip": [2], "Edge": [1, 2], "block:0": [0, 1], "block:1": [2]}
    assert m.warnings == ()


def test_generated_meshes_have_no_sets():
    for spec in (PlateMesh(lx=1, ly=1, nx=2, ny=2), HemisphereMesh(radius=1, hole_deg=10, n_around=4, n_meridian=2),
                 TubeMesh(width=2, depth=1, corner_radius=0, length=1, n_flat=2, n_corner=0, n_length=1)):
        m = build_mesh(spec)
        assert m.element_sets == {} and m.deck is None and not m.triangles.any()


def test_second_order_triangles_linearised_with_one_warning(tmp_path):
    points = np.vstack([STRIP[[0, 1, 3]], [[0.5, 0, 0], [0.5, 0.5, 0], [0, 0.5, 0]],
                        STRIP[[4]], [[1, 0.5, 0]], [[0.5, 1, 0]]])
    tri6 = np.array([[0, 1, 2, 3, 4, 5], [1, 6, 2, 7, 8, 4]])
    path = tmp_path / "t6.vtu"
    meshio.write(path, meshio.Mesh(points, [("triangle6", tri6)]))
    m = build_mesh(FileMesh(path=path))
    assert m.elements.tolist() == [[0, 1, 2, -1], [1, 3, 2, -1]]
    assert m.warnings[0] == (f"{path}: 2 triangle6 elements (6-node triangles) used as 3-node linear shells: "
                             "their mid-side and centre nodes are dropped and curved edges become straight")
    assert "removed 5 unused nodes" in m.warnings[1] and len(m.warnings) == 2


def test_quad_with_a_repeated_corner_is_a_triangle(tmp_path):
    """[a, b, c, c] (LS-DYNA's n3 = n4) or any one repeated consecutive pair: a triangle, with a
    warning for a meshio file; check_mesh on the raw array still calls it a degenerate quad."""
    elements = np.array([[0, 1, 4, 3], [1, 2, 5, 5], [2, 2, 6, 5], [6, 7, 5, 6], [0, 1, 0, 1], [1, 1, 2, 2]])
    collapsed, n = collapse_repeated_corners(elements)
    assert n == 3
    assert collapsed.tolist() == [[0, 1, 4, 3], [1, 2, 5, -1], [2, 6, 5, -1], [6, 7, 5, -1],
                                  [0, 1, 0, 1], [1, 1, 2, 2]]
    path = tmp_path / "r.vtu"
    meshio.write(path, meshio.Mesh(STRIP, [("quad", elements[:3])]))
    m = build_mesh(FileMesh(path=path))
    assert m.elements.tolist() == [[0, 1, 4, 3], [1, 2, 5, -1], [2, 6, 5, -1]]
    assert m.warnings[0] == f"{path}: 2 quads with one corner repeated (e.g. n3 = n4) read as triangles"
    with pytest.raises(SceneError, match="element 1: degenerate quad \\(node 5 repeated\\)"):
        check_mesh(STRIP, elements[:2], "m")


def test_merge_nodes_keeps_triangles(tmp_path):
    """A slit between a quad and a triangle, closed on request; the triangle's -1 stays."""
    points = np.vstack([STRIP[[0, 1, 4, 3]], STRIP[[1, 4]], [[2, 0.5, 0]]])
    elements = np.array([[0, 1, 2, 3], [4, 6, 5, -1]])
    merged_points, merged, lines = merge_coincident(points, elements, "m")
    assert merged.tolist() == [[0, 1, 2, 3], [1, 4, 2, -1]] and len(merged_points) == 5
    assert lines[0].startswith("m: merged 2 coincident nodes into their twins")
    path = tmp_path / "slit.vtu"
    meshio.write(path, meshio.Mesh(points, [("quad", elements[:1]), ("triangle", elements[1:, :3])]))
    m = build_mesh(FileMesh(path=path, merge_nodes=True))
    assert m.elements.tolist() == [[0, 1, 2, 3], [1, 4, 2, -1]]


# ---------------------------------------------------------------- check_mesh on mixed meshes
FAN = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 0], [2, 0, 0], [2, 1, 0]], float)
FAN_ELEMENTS = [[0, 1, 4, -1], [1, 2, 4, -1], [2, 3, 4, -1], [3, 0, 4, -1], [1, 5, 6, 2]]
"""A square split into 4 triangles about its centre node 4, and a quad on its right side."""


def test_check_accepts_mixed_mesh():
    assert check_mesh(FAN, FAN_ELEMENTS, "m") == ()


def test_check_inverted_triangle():
    """The centre node pushed below edge 0-1 turns triangle 0 over (its normal -z, its two
    neighbours +z); the other triangles stay right side up and are not named."""
    points = FAN.copy()
    points[4] = [0.5, -0.3, 0.0]
    with pytest.raises(SceneError) as err:
        check_mesh(points, FAN_ELEMENTS, "m")
    assert err.value.messages == ["m: element 0: inverted triangle (folded back onto 2 of its 2 neighbours, e.g. "
                                  "element 3 across edge 0-4: a corner on the wrong side of the opposite edge)"]


def test_check_degenerate_triangles():
    points = np.vstack([FAN, [[3, 0, 0]]])
    with pytest.raises(SceneError) as err:
        check_mesh(points, [*FAN_ELEMENTS, [5, 7, 1, -1], [6, 2, 2, -1]], "m")
    assert err.value.messages == ["m: element 6: degenerate triangle (node 2 repeated)"]
    with pytest.raises(SceneError) as err:
        check_mesh(points, [*FAN_ELEMENTS, [5, 7, 1, -1]], "m")
    assert err.value.messages == ["m: element 5: degenerate triangle (area 0: its corners are collinear)"]


def test_check_triangle_ids():
    """-1 marks a triangle only in column 3; elsewhere (or -2 there) it is an out-of-range id."""
    with pytest.raises(SceneError) as err:
        check_mesh(FAN, [[0, 1, 4, -1], [0, -1, 4, -1], [1, 5, 6, -2]], "m")
    assert err.value.messages == ["m: element 1: node id -1 out of range (mesh has 7 nodes)",
                                  "m: element 2: node id -2 out of range (mesh has 7 nodes)"]


def test_check_orientation_across_quad_triangle_edge():
    """The quad runs edge 1->2; a triangle running it too (in any rotation of its corners) is
    reversed: a warning, not an inverted triangle.  The triangle is steep (35 deg) but only
    quads are checked for warping."""
    points = np.vstack([FAN[[0, 1, 2, 3]], [[2, 0.5, 0.7]]])
    assert check_mesh(points, [[0, 1, 2, 3], [1, 4, 2, -1]], "m") == ()
    assert check_mesh(points, [[0, 1, 2, 3], [1, 2, 4, -1]], "m") == (
        "m: elements 0 and 1 have opposite normals (both run edge 1->2): reverse the node order of one of them",)
    assert check_mesh(points, [[0, 1, 2, 3], [2, 4, 1, -1]], "m") == (
        "m: elements 0 and 1 have opposite normals (both run edge 1->2): reverse the node order of one of them",)


def test_check_unused_nodes_with_triangles():
    assert check_mesh(np.vstack([FAN, [[9, 9, 9]]]), FAN_ELEMENTS, "m") == (
        "m: 1 unused nodes (not referenced by any element)",)


# ---------------------------------------------------------------- LS-DYNA decks
def fixed_deck(include_nodes: bool = True) -> str:
    """Two parts, 2 quads and a triangle (n3 = n4), fixed format; node 108 unused."""
    nodes = [(101, 0, 0), (102, 1, 0), (103, 2, 0), (104, 0, 1), (105, 1, 1), (106, 2, 1), (107, 3, 0.5),
             (108, 9, 9)]
    node_cards = "".join(f"{n:8d}{x:16.1f}{y:16.1f}{0.0:16.1f}{0:8d}{0:8d}\n" for n, x, y in nodes)
    shells = [(1001, 1, 101, 102, 105, 104), (1002, 2, 102, 103, 106, 105), (1003, 2, 103, 107, 106, 106)]
    shell_cards = "".join("".join(f"{v:8d}" for v in s) + "\n" for s in shells)
    return ("*KEYWORD\n"
            "$ a comment line\n"
            "*TITLE\n"
            "two-part plate\n"
            + ("*NODE\n$    nid               x               y               z      tc      rc\n" + node_cards
               if include_nodes else "")
            + "*ELEMENT_SHELL\n$    eid     pid      n1      n2      n3      n4\n" + shell_cards
            + "*PART\nskin\n$      pid     secid       mid\n         1         1         1\n"
            "*PART\nstiffener\n         2         2         2\n"
            "*SECTION_SHELL\n"
            "$    secid    elform      shrf       nip     propt        qr     icomp     setyp\n"
            "         1         2     0.833         5       1.0         0         0         1\n"
            "       1.5       1.5       1.5       1.5\n"
            "*SECTION_SHELL_TITLE\nthick section\n"
            "         2        16                 3\n"
            "       2.5\n"
            "*MAT_ELASTIC\n"
            "         1    7.8e-9  210000.0       0.3\n"
            "*MAT_PIECEWISE_LINEAR_PLASTICITY_TITLE\nsteel\n"
            "         2    7.8e-9  210000.0       0.3     250.0       0.0\n"
            "       0.0       0.0         7\n"
            "\n"
            "\n"
            "*DEFINE_CURVE\n"
            "$     lcid      sidr       sfa       sfo\n"
            "         7         0       1.0       2.0\n"
            "                 0.0               125.0\n"
            "                 0.1               150.0\n"
            "*CONTROL_TERMINATION\n"
            "      10.0\n"
            "*BOUNDARY_SPC_SET\n"
            "         1\n"
            "*END\n"
            "lines after *END are not read\n")


FREE_NODES = """$ nodes, free format
*NODE
101, 0.0, 0.0, 0.0
102, 1.0, 0.0, 0.0
103, 2.0, 0.0, 0.0
104, 0.0, 1.0, 0.0
105, 1.0, 1.0, 0.0
106, 2.0, 1.0, 0.0
107, 3.0, 0.5, 0.0
108, 9.0, 9.0, 9.0
*END
"""

FREE_DECK = """*KEYWORD
*TITLE
two-part plate
*INCLUDE
nodes/free_nodes.k
*ELEMENT_SHELL_THICKNESS
1001, 1, 101, 102, 105, 104
1.4, 1.4, 1.4, 1.4
*ELEMENT_SHELL
1002,2,102,103,106,105
1003,2,103,107,106,106
*PART
skin
1,1,1
*PART
stiffener
2,2,2
*SECTION_SHELL
1,2,0.833,5,1.0,0,0,1
1.5,1.5,1.5,1.5
*SECTION_SHELL_TITLE
thick section
2,16,,3
2.5
*MAT_001
1,7.8e-9,210000.0,0.3
*MAT_024_TITLE
steel
2,7.8e-9,210000.0,0.3,250.0,0.0
0.0,0.0,7
,
,
*DEFINE_CURVE
7,0,1.0,2.0
0.0,125.0
0.1,150.0
*CONTROL_TERMINATION
10.0
*BOUNDARY_SPC_SET
1
*END
"""


def write_free(tmp_path):
    (tmp_path / "nodes").mkdir()
    (tmp_path / "nodes" / "free_nodes.k").write_text(FREE_NODES)
    (tmp_path / "free.k").write_text(FREE_DECK)
    return tmp_path / "free.k"


@pytest.mark.parametrize("variant", ["fixed", "free"])
def test_dyna_deck(tmp_path, variant):
    if variant == "fixed":
        path = tmp_path / "plate.key"
        path.write_text(fixed_deck())
    else:
        path = write_free(tmp_path)
    m = build_mesh(FileMesh(path=path, scale=10.0))
    np.testing.assert_allclose(m.points[[0, 6]], [[0, 0, 0], [30, 5, 0]])
    assert m.elements.tolist() == [[0, 1, 4, 3], [1, 2, 5, 4], [2, 6, 5, -1]]
    deck = m.deck
    assert isinstance(deck, Deck) and deck.title == "two-part plate"
    assert deck.element_ids.tolist() == [1001, 1002, 1003]
    assert deck.node_ids.tolist() == [101, 102, 103, 104, 105, 106, 107]       # unused 108 dropped
    assert deck.element_parts.tolist() == [1, 2, 2]
    assert sets(m) == {"part:1": [0], "skin": [0], "part:2": [1, 2], "stiffener": [1, 2]}
    assert deck.parts == {1: DeckPart(1, "skin", 1, 1), 2: DeckPart(2, "stiffener", 2, 2)}
    # per element, as written: thickness and material through part -> section / material
    thickness = [deck.sections[deck.parts[p].secid].thickness for p in deck.element_parts]
    kinds = [deck.materials[deck.parts[p].mid].kind for p in deck.element_parts]
    assert thickness == [1.5, 2.5, 2.5]
    assert kinds == ["elastic", "piecewise_linear", "piecewise_linear"]
    one, two = deck.sections[1], deck.sections[2]
    assert (one.elform, one.shear_factor, one.nip, one.thicknesses, one.title) == (2, 0.833, 5, (1.5,) * 4, "")
    assert (two.elform, two.shear_factor, two.nip, two.thicknesses, two.title) == (
        16, 1.0, 3, (2.5,) * 4, "thick section")          # blank SHRF: 1; blank T2..T4: T1
    elastic, steel = deck.materials[1], deck.materials[2]
    assert elastic.values["e"] == 210000.0 and elastic.values["pr"] == 0.3 and elastic.values["ro"] == 7.8e-9
    assert elastic.curve == () and elastic.title == ""
    assert steel.title == "steel" and steel.values["sigy"] == 250.0 and steel.values["lcss"] == 7
    assert deck.curves == {7: ((0.0, 250.0), (0.1, 300.0))}       # SFO = 2
    assert steel.curve == ((0.0, 250.0), (0.1, 300.0))
    # the keywords beyond the mesh are kept for the scene reader (dyna/scene.py, tests/test_decks.py)
    assert [(b.name, b.line.number) for b in deck.keywords] == [("CONTROL_TERMINATION", 37 if variant == "free" else 48),
                                                                ("BOUNDARY_SPC_SET", 39 if variant == "free" else 50)]
    assert "removed 1 unused nodes" in m.warnings[0] and len(m.warnings) == 1
    if variant == "free":
        np.testing.assert_array_equal(deck.element_thickness[0], [1.4] * 4)
        assert np.isnan(deck.element_thickness[1:]).all()
    else:
        assert deck.element_thickness is None


def test_dyna_mat_003_and_024_points(tmp_path):
    """*MAT_003 with its second card, a *MAT_024 whose curve is EPS1.. / ES1..; a missing LCSS
    curve is a warning.  Blank lines are cards where a group needs them (the last *MAT_024's
    EPS and ES cards), spacing elsewhere (after the first *PART)."""
    body = fixed_deck().split("*PART\n")[0]
    path = tmp_path / "mats.k"
    path.write_text(body + "*PART\nskin\n1,1,1\n\n*PART\nstiffener\n2,1,2\n*PART\nrib\n3,1,3\n"
                    "*SECTION_SHELL\n1\n1.0\n"
                    "*MAT_PLASTIC_KINEMATIC\n1,7.8e-9,2.1e5,0.3,250.0,1000.0,1.0\n40.0,5.0,0.3,1.0\n"
                    "*MAT_024\n2,7.8e-9,2.1e5,0.3,250.0\n0,0,0\n0.0,0.05,0.2\n250,300,350\n"
                    "*MAT_PIECEWISE_LINEAR_PLASTICITY\n3,7.8e-9,2.1e5,0.3,250.0\n,,9\n\n\n")
    points, elements, element_sets, deck, warnings = read_deck(path)
    kin = deck.materials[1]
    assert kin.kind == "plastic_kinematic" and kin.values == {
        "ro": 7.8e-9, "e": 2.1e5, "pr": 0.3, "sigy": 250.0, "etan": 1000.0, "beta": 1.0,
        "src": 40.0, "srp": 5.0, "fs": 0.3, "vp": 1.0}
    assert deck.materials[2].curve == ((0.0, 250.0), (0.05, 300.0), (0.2, 350.0))
    assert deck.materials[3].curve == ()
    assert deck.sections[1].nip == 2 and deck.sections[1].elform == 2 and deck.sections[1].thickness == 1.0
    assert f"{path}:" in warnings[-1] and "material 3: LCSS 9 is not a *DEFINE_CURVE" in warnings[-1]
    assert "part" not in " ".join(warnings)           # every part has its section and material


def test_dyna_errors(tmp_path):
    path = tmp_path / "bad.k"
    deck = fixed_deck()
    path.write_text(deck.replace("     103             2.0", "     1x3             2.0"))
    line = deck.splitlines().index("     103             2.0             0.0             0.0       0       0") + 1
    with pytest.raises(SceneError) as err:
        build_mesh(FileMesh(path=path))
    assert err.value.messages == [f"{path}:{line}: *NODE: NID (columns 1-8): expected an integer, got '1x3'"]

    path.write_text(deck.replace("    1003       2     103     107", "    1003       2     103     999"))
    line = next(i for i, t in enumerate(path.read_text().splitlines(), 1) if t.startswith("    1003"))
    with pytest.raises(SceneError) as err:
        build_mesh(FileMesh(path=path))
    assert err.value.messages == [f"{path}:{line}: *ELEMENT_SHELL: element 1003 references node 999, which no "
                                  "*NODE defines"]

    path.write_text("*KEYWORD\n*NODE\n1,0,0,0\n*SECTION_SHELL\n1,2\n")
    with pytest.raises(SceneError) as err:
        build_mesh(FileMesh(path=path))
    assert err.value.messages == [f"{path}:5: *SECTION_SHELL: incomplete section (2 cards expected after the "
                                  "keyword)"]

    path.write_text(fixed_deck().replace("*NODE", "*NODE %"))
    with pytest.raises(SceneError, match="long and 10-digit-id keyword formats are not read"):
        build_mesh(FileMesh(path=path))

    path.write_text(FREE_DECK)                          # its include is missing
    with pytest.raises(SceneError) as err:
        build_mesh(FileMesh(path=path))
    assert err.value.messages[0].startswith(f"{path}:5: *INCLUDE: included file nodes/free_nodes.k not found")

    path.write_text("*KEYWORD\n*NODE\n1,0,0,0\n*END\n")
    with pytest.raises(SceneError) as err:
        build_mesh(FileMesh(path=path))
    assert err.value.messages == [f"{path}: deck has no *ELEMENT_SHELL cards"]


def test_dyna_check_messages_name_deck_ids(tmp_path):
    """check_mesh's element numbers are positions; a deck's own ids follow in brackets."""
    path = tmp_path / "flat.k"
    path.write_text(fixed_deck().replace("     107             3.0             0.5",
                                         "     107             2.0             0.5"))
    with pytest.raises(SceneError) as err:
        build_mesh(FileMesh(path=path))
    assert err.value.messages == [f"{path}: element 2 (id 1003): degenerate triangle (area 0: its corners are "
                                  "collinear)"]


def test_dyna_duplicates_includes_and_options(tmp_path):
    deck = fixed_deck()
    path = tmp_path / "dup.k"
    path.write_text(deck.replace("     104             0.0", "     102             0.0"))
    with pytest.raises(SceneError) as err:
        build_mesh(FileMesh(path=path))
    lines = deck.splitlines()
    first = next(i for i, t in enumerate(lines, 1) if t.startswith("     102"))
    assert err.value.messages == [f"{path}:{first + 2}: *NODE: node 102 is defined twice (also on {path}:{first})"]

    path.write_text(deck.replace("*PART\nstiffener\n         2", "*PART\nstiffener\n         1"))
    with pytest.raises(SceneError, match=r"\*PART: part 1 is defined twice"):
        build_mesh(FileMesh(path=path))

    (tmp_path / "loop.k").write_text("*INCLUDE\nloop.k\n")
    with pytest.raises(SceneError, match=r"loop.k:2: \*INCLUDE: loop.k includes itself"):
        build_mesh(FileMesh(path=tmp_path / "loop.k"))

    path.write_text(deck.replace("*ELEMENT_SHELL\n", "*ELEMENT_SHELL_COMPOSITE\n"))
    with pytest.raises(SceneError, match=r"\*ELEMENT_SHELL_COMPOSITE: this option of \*ELEMENT_SHELL is not read"):
        build_mesh(FileMesh(path=path))

    # Fortran-style numbers, lower-case keywords, a part without *PART, TC/RC codes
    path.write_text(deck.replace("*PART\nstiffener\n         2         2         2\n", "")
                    .replace("*NODE", "*node").replace("     101             0.0             0.0             0.0       0",
                                                       "     101           0.0d0          0.0e+0           1.0-3       1"))
    m = build_mesh(FileMesh(path=path))
    assert m.points[0].tolist() == [0.0, 0.0, 0.001]
    assert m.deck.node_constraints[0].tolist() == [1, 0]        # TC = 1: x held (dyna/scene.py's supports)
    assert f"{path}: part 2 (2 shells) has no *PART card" in m.warnings
    assert sets(m) == {"part:1": [0], "skin": [0], "part:2": [1, 2]}


# ---------------------------------------------------------------- hostile decks (issue 28, item 9)
DECK_SCENE = """[scene]
name = "deck"
units = "N, mm, MPa"
[mesh]
kind = "file"
path = "plate.k"
[solve]
kind = "dynamic"
end_time = 1e-6
"""
ELASTIC_CARD = "         1    7.8e-9  210000.0       0.3"
SECTION_CARD = "         1         2     0.833         5       1.0         0         0         1"
STEEL_CARDS = "     250.0       0.0\n       0.0       0.0         7"        # SIGY, ETAN; C, P, LCSS


def deck_problems(tmp_path, deck: str, scene: str = "") -> list[str]:
    """The SceneError lines of validating DECK_SCENE (+ `scene`) on `deck`, [] when it passes."""
    from taichi_shell_mpm.preflight import prepare
    (tmp_path / "plate.k").write_text(deck)
    (tmp_path / "deck.toml").write_text(DECK_SCENE + scene)
    try:
        prepare(tmp_path / "deck.toml", ())
    except SceneError as exc:
        return exc.messages
    return []


def line_of(deck: str, text: str) -> int:
    return next(i for i, t in enumerate(deck.splitlines(), 1) if t.startswith(text))


@pytest.mark.parametrize("old,new,message", [
    (ELASTIC_CARD, "         1    7.8e-9 -210000.0       0.3",
     "*MAT_ELASTIC (mid 1): E (the scene's E): expected a number > 0, got -210000.0"),
    (ELASTIC_CARD, "         1       0.0  210000.0       0.3",
     "*MAT_ELASTIC (mid 1): RO (the scene's density): expected a number > 0, got 0.0"),
    (ELASTIC_CARD, "         1    7.8e-9  210000.0       0.5",
     "*MAT_ELASTIC (mid 1): PR (the scene's nu): expected a number in (-1, 0.5), got 0.5"),
    ("       1.5       1.5       1.5       1.5", "       0.0",
     "*SECTION_SHELL (secid 1): T1 (the scene's thickness): expected a number > 0, got 0.0"),
    ("       1.5       1.5       1.5       1.5", "      -1.5",
     "*SECTION_SHELL (secid 1): T1 (the scene's thickness): expected a number > 0, got -1.5"),
    (SECTION_CARD, SECTION_CARD.replace("     0.833", "    -0.833"),
     "*SECTION_SHELL (secid 1): SHRF (the scene's shear_factor): expected a number in (0, 1], got -0.833"),
    (SECTION_CARD, SECTION_CARD.replace("     0.833         5", "     0.833       100"),
     "*SECTION_SHELL (secid 1): NIP (the scene's points): expected an integer in [1, 10], got 100"),
    (STEEL_CARDS, "       0.0       0.0\n       0.0       0.0         0",
     "*MAT_PIECEWISE_LINEAR_PLASTICITY_TITLE (mid 2): SIGY (the scene's yield_stress): expected a number > 0, "
     "got 0.0"),
    (STEEL_CARDS, "     250.0  210000.0\n       0.0       0.0         0",
     "*MAT_PIECEWISE_LINEAR_PLASTICITY_TITLE (mid 2): ETAN = 210000: expected 0 <= ETAN < E = 210000"),
])
def test_deck_values_checked_as_scene_values(tmp_path, old, new, message):
    """A deck card's value is held to the range of the same scene key: one line naming the
    deck file, the card's line, the keyword and id, the field (was: an internal error, a NaN
    run, or accepted -- ETAN >= E silently perfectly plastic)."""
    deck = fixed_deck()
    assert old in deck
    bad = deck.replace(old, new)
    problems = deck_problems(tmp_path, bad)
    card = line_of(bad, new.split("\n")[0]) if "MAT_PIECEWISE" not in message else \
        line_of(bad, "         2    7.8e-9")
    if "SECTION" in message:
        card = line_of(bad, "         1         2 ")
    assert len(problems) == 1 and problems[0].startswith(f"{tmp_path / 'plate.k'}:{card}: {message}"), problems


def test_deck_value_of_a_replaced_card_is_not_checked(tmp_path):
    """A scene [sections.sec_1] replaces the deck's card, bad value and all."""
    bad = fixed_deck().replace("       1.5       1.5       1.5       1.5", "       0.0")
    assert deck_problems(tmp_path, bad, "[sections.sec_1]\nthickness = 1.0\n") == []


def test_deck_negative_element_thickness(tmp_path):
    path = write_free(tmp_path)
    path.write_text(FREE_DECK.replace("1.4, 1.4, 1.4, 1.4", "1.4, -1.4, 1.4, 1.4"))
    with pytest.raises(SceneError) as err:
        read_deck(path)
    assert err.value.messages == [f"{path}:8: *ELEMENT_SHELL_THICKNESS: element 1001: THIC2 = -1.4: expected a "
                                  "thickness > 0 (or 0/blank: the section's T1)"]


def test_deck_stray_node_named(tmp_path):
    """One node at 3e15 (a typo, or an overflowing fixed field) is named; the other elements
    are not flagged degenerate (the area scale is the median, not the mean)."""
    path = tmp_path / "stray.k"
    path.write_text(fixed_deck().replace("     107             3.0", "     107          3.0e15"))
    with pytest.raises(SceneError) as err:
        build_mesh(FileMesh(path=path))
    assert err.value.messages == [f"{path}: node 6 (id 107) at [3000000000000000.0, 0.5, 0.0] is a stray node: "
                                  "element 2 (id 1003) has an edge 3e+15 times the mesh's median longest edge (a "
                                  "typo, or a *NODE field overflowing its fixed columns?)"]


def test_deck_include_of_a_folder_or_a_text_file(tmp_path):
    deck = fixed_deck()
    path = tmp_path / "inc.k"
    (tmp_path / "notes.txt").write_text("not a deck\n")
    for name, message in ((".", f". is a folder ({tmp_path}), not a file"),
                          ("notes.txt", "notes.txt is not an LS-DYNA keyword file (no line starts with a '*' "
                                        "keyword)"),
                          ("missing.k", f"included file missing.k not found (looked in {tmp_path})")):
        path.write_text(deck.replace("*TITLE", f"*INCLUDE\n{name}\n*TITLE"))
        with pytest.raises(SceneError) as err:
            read_deck(path)
        assert err.value.messages[0].startswith(f"{path}:4: *INCLUDE: {message}"), err.value.messages


def test_scene_parts_on_a_deck(tmp_path):
    """A [[part]] names the deck's sec_1 / mat_1; an override of nothing is an error with a
    suggestion; [material]/[section] beside a deck's parts is a warning."""
    from taichi_shell_mpm.preflight import prepare
    deck = fixed_deck()
    part = '[[part]]\nname = "one"\nmaterial = "mat_1"\nsection = "sec_2"\nelements = "all"\n'
    assert deck_problems(tmp_path, deck, part) == []
    scene, mesh, model = prepare(tmp_path / "deck.toml", ())
    assert [(p.name, p.material, p.section) for p in model.parts] == [("one", "mat_1", "sec_2")]
    np.testing.assert_array_equal(model.element.thickness, [2.5] * 3)
    assert deck_problems(tmp_path, deck, "[sections.sec_99]\nthickness = 1.0\n") == [
        "deck.toml: [sections.sec_99]: replaces nothing: no part of the deck or [[part]] uses 'sec_99' (did you mean "
        "'sec_2'?)"]
    assert deck_problems(tmp_path, deck, "[material]\nE = 1.0\nnu = 0.3\ndensity = 1.0\n[section]\nthickness = 1.0\n") \
        == []
    scene, mesh, model = prepare(tmp_path / "deck.toml", ())
    assert any("[material] and [section] cover every element: the deck's 2 *PART cards" in n for n in model.notes)


def test_hostile_deck_cli_exit_2(tmp_path):
    """The CLI: exit 2, one line, no traceback."""
    from .test_reliability import cli_run
    (tmp_path / "plate.k").write_text(fixed_deck().replace(ELASTIC_CARD, "         1    7.8e-9  210000.0       0.5"))
    (tmp_path / "deck.toml").write_text(DECK_SCENE)
    proc = cli_run("validate", str(tmp_path / "deck.toml"))
    lines = [t for t in proc.err.splitlines() if t.startswith("error")]
    print(proc.code, proc.err)
    assert proc.code == 2 and len(lines) == 1 and "Traceback" not in proc.err
    assert "plate.k:36: *MAT_ELASTIC (mid 1): PR" in lines[0]
