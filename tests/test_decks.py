"""Issue 31, item 1: an LS-DYNA deck is a scene (dyna/scene.py, scene/document.load_scene).

Each keyword read is checked against the TOML scene it must equal (the parsed Scene objects
are equal), the whole deck against its TOML twin through the CLI (byte-identical outputs);
unread keywords are listed with their line numbers and stop the run unless --accept-unread;
hostile decks give one-line errors naming the line; --set, --restart and a TOML over a deck
work as with a TOML scene."""
from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from taichi_shell_mpm.scene import SceneError, load_scene, parse_scene

from .test_reliability import assert_clean_output, cli_run

# A 4 x 2 plate of 10 mm shells (part 1, nodes 101..115 row by row along x) and a rigid
# 1-element impactor above it (part 2, nodes 201..204); mm, s, tonne, N, MPa.
PLATE_NODES = [(101 + 5 * j + i, 10.0 * i, 10.0 * j, 0.0) for j in range(3) for i in range(5)]
IMPACTOR_NODES = [(201, 10.0, 5.0, 3.0), (202, 20.0, 5.0, 3.0), (203, 20.0, 15.0, 3.0), (204, 10.0, 15.0, 3.0)]
SHELLS = [(1 + 4 * j + i, 1, 101 + 5 * j + i, 102 + 5 * j + i, 107 + 5 * j + i, 106 + 5 * j + i)
          for j in range(2) for i in range(4)] + [(9, 2, 201, 202, 203, 204)]


def mesh_deck(rigid: bool = True) -> str:
    nodes = "\n".join(f"{n},{x},{y},{z}" for n, x, y, z in PLATE_NODES + IMPACTOR_NODES)
    shells = "\n".join(",".join(str(v) for v in s) for s in SHELLS)
    impactor = ("*MAT_RIGID\n2,7.85e-9,2.1e5,0.3\n1,4,7\n\n" if rigid else "*MAT_ELASTIC\n2,7.85e-9,2.1e5,0.3\n")
    return (f"*KEYWORD\n*NODE\n{nodes}\n*ELEMENT_SHELL\n{shells}\n*PART\nplate\n1,1,1\n*PART\nimpactor\n2,1,2\n"
            f"*SECTION_SHELL\n1,2,0.833,3\n1.0,1.0,1.0,1.0\n*MAT_ELASTIC\n1,7.85e-9,2.1e5,0.3\n{impactor}")


KEYWORDS = """*PARAMETER
R vz      -500.0
I nsid    7
*PARAMETER_EXPRESSION
R endt    2*1.0e-4
*DEFINE_CURVE
1
0.0,1.0
1.0,1.0
*SET_NODE_LIST_TITLE
left edge
7
101,106,111
*SET_SHELL_LIST
3
5,6
*BOUNDARY_SPC_SET
&nsid,0,1,1,1,1,1,1
*BOUNDARY_SPC_NODE
105,0,0,0,1,0,0,0
*BOUNDARY_PRESCRIBED_MOTION_RIGID
2,3,0,1,&vz
*LOAD_NODE_POINT
115,3,1,-2.0
*LOAD_SHELL_SET
3,1,0.01
*LOAD_BODY_Z
1,9810.0
*RIGIDWALL_PLANAR
0,0,0
0.0,0.0,-50.0,0.0,0.0,-40.0
*ELEMENT_MASS
900,108,1.0e-6
*CONTACT_AUTOMATIC_SINGLE_SURFACE
0,0,5,0
0.2,0.2,0,0,20.0
1.0,1.0
*CONTROL_TERMINATION
&endt
*CONTROL_TIMESTEP
0.0,0.8
*CONTROL_HOURGLASS
4,0.05
*CONTROL_SHELL
20.0,0,-1,0,2,1
*DATABASE_GLSTAT
2.0e-5
*DATABASE_BINARY_D3PLOT
1.0e-4
*DATABASE_HISTORY_NODE
115
*END
"""

TWIN = """
[scene]
name = "twin"
units = "mm, s, tonne, N, MPa"
[mesh]
kind = "file"
path = "mesh.k"
[element]
warping = "bwc"
hourglass = 0.05
[method]
kind = "fem"
[nodesets.set_7]
ids = [0, 5, 10]
[nodesets.spc_1]
ids = [4]
[nodesets.body_part_2]
ids = [15, 16, 17, 18]
[nodesets.node_115]
ids = [14]
[nodesets.load_0]
ids = [14]
[nodesets.mass_0]
ids = [7]
[elementsets.shells_3]
ids = [4, 5]
[curves.lc_1]
points = [[0.0, 1.0], [1.0, 1.0]]
[[boundary]]
nodes = "set_7"
fix = ["ux", "uy", "uz", "rx", "ry", "rz"]
[[boundary]]
nodes = "spc_1"
fix = ["uz"]
[[motion]]
name = "motion_0"
dofs = ["uz"]
kind = "velocity"
value = -500.0
curve = "lc_1"
body = "part_2"
[[load]]
nodes = "load_0"
force = [0.0, 0.0, -2.0]
distribute = "equal"
curve = "lc_1"
[[pressure]]
value = -0.01
elements = "shells_3"
curve = "lc_1"
[gravity]
acceleration = [0.0, 0.0, -9810.0]
curve = "lc_1"
[[wall]]
point = [0.0, 0.0, -50.0]
normal = [0.0, 0.0, 10.0]
[[point_mass]]
name = "mass_0"
nodes = "mass_0"
mass = 1.0e-6
[contact]
friction = 0.2
damping = 0.2
stiffness = 0.1
[solve]
kind = "dynamic"
end_time = 2.0e-4
dt_safety = 0.8
[output]
history_interval = 2.0e-5
frame_interval = 1.0e-4
[[probe]]
name = "node_115"
nodes = "node_115"
[[rigid_body]]
name = "part_2"
fixed = ["ux", "uy", "rx", "ry", "rz"]
nodes = "body_part_2"
"""


def write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.write_text(text)
    return path


def comparable(scene):
    """The scene without what names its file (source, [scene] table, notes)."""
    return dataclasses.replace(scene, source=None, info=None, notes=(), mesh=None,
                               nodesets=tuple(sorted(scene.nodesets, key=lambda s: s.name)),
                               elementsets=tuple(sorted(scene.elementsets, key=lambda s: s.name)))


def test_every_keyword_read_equals_its_toml_twin(tmp_path):
    """The deck's keywords give the scene its TOML twin gives (equal Scene objects), and the
    two run byte-identically through the CLI (fem, 0.2 ms, ~100 steps: a rigid impactor
    driven by a *BOUNDARY_PRESCRIBED_MOTION_RIGID onto a plate with supports, loads,
    pressure, gravity, a wall, a point mass and self-contact)."""
    deck = write(tmp_path, "full.k", mesh_deck() + KEYWORDS)
    write(tmp_path, "mesh.k", mesh_deck(rigid=False) + "*END\n")     # the twin says the rigid body itself
    twin = write(tmp_path, "twin.toml", TWIN)
    from_deck = load_scene(deck, ["method.kind=fem"])
    from_toml = load_scene(twin)
    assert comparable(from_deck) == comparable(from_toml)
    assert from_deck.info.name == "full" and from_deck.mesh.path.name == "full.k"
    outputs = {}
    for name, path in (("deck", deck), ("toml", twin)):
        out = tmp_path / name
        r = cli_run("run", str(path), "--out", str(out), "--quiet", *(["--set", "method.kind=fem"] if name == "deck" else []))
        assert_clean_output(r)
        assert r.code == 0, r.out + r.err
        outputs[name] = out
    for table in ("energy.csv", "probes.csv", "force.csv", "parts.csv"):
        assert (outputs["deck"] / table).read_bytes() == (outputs["toml"] / table).read_bytes(), table
    summary = json.loads((outputs["deck"] / "summary.json").read_text())
    assert summary["steps"] > 50
    energy = np.genfromtxt(outputs["deck"] / "energy.csv", delimiter=",", names=True)
    assert len(energy) == 11                      # GLSTAT every 2e-5 to 2e-4, and t = 0
    frames = sorted((outputs["deck"] / "frames").iterdir())
    assert len(frames) == 3                       # t = 0, the D3PLOT interval 1e-4, the end


SNIPPETS = [
    # (keyword text, TOML the scene must equal beyond the mesh-only scene)
    ("*INITIAL_VELOCITY\n7\n1.0,2.0,3.0\n*SET_NODE_LIST\n7\n101,102\n",
     "[nodesets.set_7]\nids = [0, 1]\n[[initial]]\nnodes = \"set_7\"\nvelocity = [1.0, 2.0, 3.0]\n"),
    ("*INITIAL_VELOCITY\n0,8\n1.0,0.0,0.0\n0.0,5.0,0.0\n*SET_NODE_LIST\n8\n115\n",
     "[nodesets.set_8]\nids = [14]\n[[initial]]\nnodes = \"all\"\nvelocity = [1.0, 0.0, 0.0]\n"
     "[[initial]]\nnodes = \"set_8\"\nvelocity = [0.0, 5.0, 0.0]\n"),
    ("*INITIAL_VELOCITY_NODE\n101,1.0,0.0,0.0\n102,1.0,0.0,0.0\n115,0.0,0.0,-1.0\n",
     "[nodesets.initial_0]\nids = [0, 1]\n[nodesets.initial_1]\nids = [14]\n"
     "[[initial]]\nnodes = \"initial_0\"\nvelocity = [1.0, 0.0, 0.0]\n"
     "[[initial]]\nnodes = \"initial_1\"\nvelocity = [0.0, 0.0, -1.0]\n"),
    ("*INITIAL_VELOCITY_GENERATION\n1,2,10.0,0.0,0.0,-3.0\n20.0,10.0,0.0,0.0,0.0,2.0\n",
     "[nodesets.part_1_nodes]\nids = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14]\n"
     "[[initial]]\nnodes = \"part_1_nodes\"\nvelocity = [0.0, 0.0, -3.0]\nangular_velocity = [0.0, 0.0, 10.0]\n"
     "center = [20.0, 10.0, 0.0]\n"),
    ("*BOUNDARY_SPC_NODE\n101,0,1,1,1,0,0,0\n102,0,1,1,1,0,0,0\n103,0,0,0,0,1,1,1\n",
     "[nodesets.spc_0]\nids = [0, 1]\n[nodesets.spc_1]\nids = [2]\n"
     "[[boundary]]\nnodes = \"spc_0\"\nfix = [\"ux\", \"uy\", \"uz\"]\n"
     "[[boundary]]\nnodes = \"spc_1\"\nfix = [\"rx\", \"ry\", \"rz\"]\n"),
    ("*BOUNDARY_PRESCRIBED_MOTION_SET\n7,1,2,4,0.5\n*SET_NODE_LIST\n7\n105,110,115\n"
     "*DEFINE_CURVE\n4,0,2.0,1.0\n0.0,0.0\n1.0,1.0\n",
     "[nodesets.set_7]\nids = [4, 9, 14]\n[curves.lc_4]\npoints = [[0.0, 0.0], [2.0, 1.0]]\n"
     "[[motion]]\nname = \"motion_0\"\nnodes = \"set_7\"\ndofs = [\"ux\"]\nkind = \"displacement\"\nvalue = 0.5\n"
     "curve = \"lc_4\"\n"),
    ("*BOUNDARY_PRESCRIBED_MOTION_NODE\n115,3,0,1,-2.0,0,0.5,0.1\n*DEFINE_CURVE\n1\n0.0,1.0\n",
     "[method]\nkind = \"fem\"\n[nodesets.motion_0]\nids = [14]\n[curves.lc_1]\npoints = [[0.0, 1.0]]\n"
     "[[motion]]\nname = \"motion_0\"\nnodes = \"motion_0\"\ndofs = [\"uz\"]\nkind = \"velocity\"\nvalue = -2.0\n"
     "curve = \"lc_1\"\nstart = 0.1\nend = 0.5\n"),
    ("*BOUNDARY_PRESCRIBED_MOTION_NODE\n115,7,1,1\n*DEFINE_CURVE\n1\n0.0,0.0\n1.0,1.0\n",
     "[nodesets.motion_0]\nids = [14]\n[curves.lc_1]\npoints = [[0.0, 0.0], [1.0, 1.0]]\n"
     "[[motion]]\nname = \"motion_0\"\nnodes = \"motion_0\"\ndofs = [\"rz\"]\nkind = \"acceleration\"\nvalue = 1.0\n"
     "curve = \"lc_1\"\n"),
    ("*LOAD_NODE_SET\n7,5,1,2.5\n*SET_NODE_LIST\n7\n105,110,115\n*DEFINE_CURVE\n1\n0.0,1.0\n",
     "[nodesets.set_7]\nids = [4, 9, 14]\n[curves.lc_1]\npoints = [[0.0, 1.0]]\n"
     "[[load]]\nnodes = \"set_7\"\nmoment = [7.5, 0.0, 0.0]\ndistribute = \"equal\"\ncurve = \"lc_1\"\n"),
    ("*LOAD_SHELL_ELEMENT\n1,1,2.0,0.5\n2,1,2.0,0.5\n*DEFINE_CURVE\n1\n0.0,1.0\n1.0,1.0\n",
     "[elementsets.pressure_0]\nids = [0, 1]\n[curves.lc_1_at_0p5]\npoints = [[0.0, 0.0], [0.5, 0.0], [1.5, 1.0]]\n"
     "[[pressure]]\nvalue = -2.0\nelements = \"pressure_0\"\ncurve = \"lc_1_at_0p5\"\n"),
    ("*LOAD_SEGMENT\n1,2.0,0.0,101,102,107,106\n1,2.0,0.0,103,102,107,108\n*DEFINE_CURVE\n1\n0.0,1.0\n",
     "[elementsets.pressure_0]\nids = [0]\n[elementsets.pressure_1]\nids = [1]\n[curves.lc_1]\npoints = [[0.0, 1.0]]\n"
     "[[pressure]]\nvalue = -2.0\nelements = \"pressure_0\"\ncurve = \"lc_1\"\n"
     "[[pressure]]\nvalue = 2.0\nelements = \"pressure_1\"\ncurve = \"lc_1\"\n"),
    ("*LOAD_BODY_X\n1,2.0\n*LOAD_BODY_Y\n1,-3.0\n*DEFINE_CURVE\n1\n0.0,1.0\n",
     "[curves.lc_1]\npoints = [[0.0, 1.0]]\n[gravity]\nacceleration = [-2.0, 3.0, 0.0]\ncurve = \"lc_1\"\n"),
    ("*RIGIDWALL_PLANAR_FINITE\n0\n0.0,0.0,-5.0,0.0,0.0,-4.0,0.3\n10.0,0.0,-5.0,40.0,20.0\n",
     "[[tool]]\nname = \"wall_0\"\nkind = \"rectangle\"\nnormal = [0.0, 0.0, 1.0]\naxis = [1.0, 0.0, 0.0]\n"
     "size = [40.0, 20.0]\ncenter = [20.0, 10.0, -5.0]\nfriction = 0.3\n"),
    ("*RIGIDWALL_PLANAR_MOVING\n0\n0.0,0.0,-5.0,0.0,0.0,-4.0\n2.0e-3,-3.0\n",
     "[[rigid_body]]\nname = \"rigidwall_0\"\nmass = 2.0e-3\ncenter = [0.0, 0.0, -5.0]\ndirection = [0.0, 0.0, 1.0]\n"
     "velocity = [0.0, 0.0, -3.0]\n"
     "[[wall]]\npoint = [0.0, 0.0, -5.0]\nnormal = [0.0, 0.0, 1.0]\nmoves_with = \"rigidwall_0\"\n"),
    ("*RIGIDWALL_PLANAR_FINITE_MOVING\n0\n0.0,0.0,-5.0,0.0,0.0,-4.0,0.3\n10.0,0.0,-5.0,40.0,20.0\n2.0e-3,4.0\n",
     "[[rigid_body]]\nname = \"rigidwall_0\"\nmass = 2.0e-3\ncenter = [0.0, 0.0, -5.0]\ndirection = [0.0, 0.0, 1.0]\n"
     "velocity = [0.0, 0.0, 4.0]\n"
     "[[tool]]\nname = \"wall_0\"\nkind = \"rectangle\"\nnormal = [0.0, 0.0, 1.0]\naxis = [1.0, 0.0, 0.0]\n"
     "size = [40.0, 20.0]\ncenter = [20.0, 10.0, -5.0]\nfriction = 0.3\nmoves_with = \"rigidwall_0\"\n"),
    ("*CONSTRAINED_NODAL_RIGID_BODY_SPC\n5,0,7\n1,7,0\n*SET_NODE_LIST\n7\n113,114,115\n",
     "[nodesets.body_nrb_5]\nids = [12, 13, 14]\n"
     "[[rigid_body]]\nname = \"nrb_5\"\nnodes = \"body_nrb_5\"\nfixed = [\"ux\", \"uy\", \"uz\"]\n"),
    ("*CONSTRAINED_NODAL_RIGID_BODY_INERTIA\n5,0,7\n20.0,10.0,0.0,4.0e-6\n1.0,0.1,0.2,2.0,0.3,3.0\n"
     "0.0,0.0,-2.0,0.0,0.5,0.0\n*SET_NODE_LIST\n7\n113,114,115\n",
     "[nodesets.body_nrb_5]\nids = [12, 13, 14]\n"
     "[[rigid_body]]\nname = \"nrb_5\"\nnodes = \"body_nrb_5\"\nmass_from_nodes = false\nmass = 4.0e-6\n"
     "center = [20.0, 10.0, 0.0]\ninertia = [1.0, 2.0, 3.0, 0.1, 0.3, 0.2]\nvelocity = [0.0, 0.0, -2.0]\n"
     "spin = [0.0, 0.5, 0.0]\n"),
    ("*CONSTRAINED_NODAL_RIGID_BODY_INERTIA\n5,0,7\n20.0,10.0,0.0,4.0e-6\n1.0,0.0,0.0,2.0,0.0,3.0\n\n"
     "6,0,8\n0.0,0.0,0.0,1.0e-6\n1.0,0.0,0.0,1.0,0.0,1.0\n"
     "*SET_NODE_LIST\n7\n113,114,115\n*SET_NODE_LIST\n8\n101\n",
     "[nodesets.body_nrb_5]\nids = [12, 13, 14]\n[nodesets.body_nrb_6]\nids = [0]\n"
     "[[rigid_body]]\nname = \"nrb_5\"\nnodes = \"body_nrb_5\"\nmass_from_nodes = false\nmass = 4.0e-6\n"
     "center = [20.0, 10.0, 0.0]\ninertia = [1.0, 2.0, 3.0, 0.0, 0.0, 0.0]\n"
     "[[rigid_body]]\nname = \"nrb_6\"\nnodes = \"body_nrb_6\"\nmass_from_nodes = false\nmass = 1.0e-6\n"
     "center = [0.0, 0.0, 0.0]\ninertia = [1.0, 1.0, 1.0, 0.0, 0.0, 0.0]\n"),
    ("*ELEMENT_MASS\n1,101,2.0e-6\n2,102,1.0e-6\n3,102,1.0e-6\n4,103,3.0e-6\n",
     "[nodesets.mass_0]\nids = [0, 1]\n[nodesets.mass_1]\nids = [2]\n"
     "[[point_mass]]\nname = \"mass_0\"\nnodes = \"mass_0\"\nmass = 2.0e-6\n"
     "[[point_mass]]\nname = \"mass_1\"\nnodes = \"mass_1\"\nmass = 3.0e-6\n"),
    ("*ELEMENT_MASS_PART\n1,3.0e-5\n",
     "[nodesets.mass_0]\nids = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14]\n"
     "[[point_mass]]\nname = \"mass_0\"\nnodes = \"mass_0\"\ntotal_mass = 3.0e-5\n"),
    ("*CONTROL_TIMESTEP\n0.0,0.0,0,0.0,-1.0e-6\n*CONTROL_TERMINATION\n1.0e-3,0,0.0,0.0,8.0\n",
     "[solve]\nkind = \"dynamic\"\nend_time = 1.0e-3\ndt_safety = 0.9\nmass_scaling = \"conventional\"\n"
     "target_dt = 0.9e-6\nadded_mass_limit = 8.0\n"),
    ("*CONTROL_TIMESTEP\n0.0,0.5,0,0.0,-2.0e-6\n0.0,0,1\n",
     "[method]\nkind = \"fem\"\n"
     "[solve]\nkind = \"dynamic\"\nend_time = 1.0e-3\ndt_safety = 0.5\nmass_scaling = \"selective\"\ntarget_dt = 1.0e-6\n"),
    ("*CONTROL_HOURGLASS\n4,0.08\n*CONTROL_CONTACT\n0.2\n*CONTACT_AUTOMATIC_SINGLE_SURFACE_ID\n1 contact\n0,0,5\n0.1\n"
     "2.0,1.0,0.8\n",
     "[element]\nhourglass = 0.08\n[contact]\nfriction = 0.1\ndamping = 0.0\nstiffness = 0.4\nthickness = 0.8\n"),
    ("*CONTACT_AUTOMATIC_SINGLE_SURFACE\n4,0,2\n0.1\n*SET_PART_LIST\n4\n1\n",
     "[elementsets.partset_4]\nids = [0, 1, 2, 3, 4, 5, 6, 7]\n"
     "[[contact_pair]]\nname = \"interface_0\"\nslave = \"partset_4\"\nmaster = \"partset_4\"\n"
     "friction = 0.1\ndamping = 0.0\nstiffness = 0.1\n"),
    ("*CONTACT_AUTOMATIC_SURFACE_TO_SURFACE\n1,2,3,3\n0.3,0.0,0.0,0.0,10.0\n1.0,1.0,0.5,0.8\n",
     "[[contact_pair]]\nname = \"interface_0\"\nslave = \"part:1\"\nmaster = \"part:2\"\nsymmetric = true\n"
     "friction = 0.3\ndamping = 0.1\nstiffness = 0.1\nslave_thickness = 0.5\nmaster_thickness = 0.8\n"),
    ("*CONTACT_AUTOMATIC_NODES_TO_SURFACE_ID\n4 lap\n3,2,1,3\n*SET_SHELL_LIST\n3\n5,6\n",
     "[elementsets.shells_3]\nids = [4, 5]\n"
     "[[contact_pair]]\nname = \"interface_0\"\nslave = \"shells_3\"\nmaster = \"part:2\"\nsymmetric = false\n"
     "friction = 0.0\ndamping = 0.0\nstiffness = 0.1\n"),
    ("*CONTACT_AUTOMATIC_NODES_TO_SURFACE\n7,2,4,3\n0.2\n*SET_NODE_LIST\n7\n111,112,113,114,115\n",
     "[nodesets.set_7]\nids = [10, 11, 12, 13, 14]\n"
     "[[contact_pair]]\nname = \"interface_0\"\nslave_nodes = \"set_7\"\nmaster = \"part:2\"\nsymmetric = false\n"
     "friction = 0.2\ndamping = 0.0\nstiffness = 0.1\n"),
    ("*CONTACT_TIED_SHELL_EDGE_TO_SURFACE_OFFSET\n7,2,4,3\n*SET_NODE_LIST\n7\n111,112,113,114,115\n",
     "[nodesets.set_7]\nids = [10, 11, 12, 13, 14]\n"
     "[[tie]]\nname = \"tie_0\"\nnodes = \"set_7\"\nsurface = \"part:2\"\nrotations = true\n"),
    ("*CONSTRAINED_SPOTWELD\n103,201,100.0,200.0\n104,202,100.0,200.0,4.0,3.0\n",
     "[[spotweld]]\nname = \"welds_0\"\npairs = [[2, 15]]\nnormal_strength = 100.0\nshear_strength = 200.0\n"
     "[[spotweld]]\nname = \"welds_1\"\npairs = [[3, 16]]\nnormal_strength = 100.0\nshear_strength = 200.0\n"
     "n = 4.0\nm = 3.0\n"),
    ("*NODE\n120,40.0,20.0,5.0,0,0\n*SET_NODE_LIST_GENERATE\n7\n111,115,118,121\n*DATABASE_HISTORY_NODE_SET\n7\n"
     "*DATABASE_NODOUT\n1.0e-5\n*DATABASE_RCFORC\n2.0e-5\n*DATABASE_BINARY_D3PLOT\n0.0,0,0,4\n",
     "[nodesets.set_7]\nids = [10, 11, 12, 13, 14]\n[[probe]]\nname = \"set_7\"\nnodes = \"set_7\"\n"
     "[output]\nhistory_interval = 1.0e-5\nframe_interval = 2.5e-4\n"),
]
MESH_ONLY = ("[scene]\nname = \"s\"\nunits = \"mm\"\n[mesh]\nkind = \"file\"\npath = \"mesh.k\"\n")
DEFAULT_SOLVE = "[solve]\nkind = \"dynamic\"\nend_time = 1.0e-3\n"


@pytest.mark.parametrize("snippet,expected", SNIPPETS, ids=[s[0].split("\n")[0].strip("*") + f"-{k}"
                                                          for k, s in enumerate(SNIPPETS)])
def test_each_keyword_maps_to_its_scene_table(tmp_path, snippet, expected):
    """One keyword (with what it needs) read as the scene tables it means: the Scene equals
    the one the TOML `expected` gives over the same mesh."""
    solve = "" if "*CONTROL_TERMINATION" in snippet else "*CONTROL_TERMINATION\n1.0e-3\n"
    write(tmp_path, "mesh.k", mesh_deck(rigid=False) + "*END\n")
    deck = write(tmp_path, "one.k", mesh_deck(rigid=False) + snippet + solve + "*END\n")
    scene = load_scene(deck, ["method.kind=fem"] if "[method]" in expected else [])
    toml = MESH_ONLY + ("" if "[solve]" in expected else DEFAULT_SOLVE) + expected
    import tomllib
    twin = parse_scene(tomllib.loads(toml), tmp_path / "twin.toml")
    assert comparable(scene) == comparable(twin)


def test_a_toml_over_a_deck(tmp_path):
    """A TOML that names the deck gives what it says and takes the rest from the deck: its
    keys win, its arrays of tables come first; --set acts on the result."""
    write(tmp_path, "full.k", mesh_deck() + KEYWORDS)
    over = write(tmp_path, "over.toml", "[scene]\nname = \"over\"\nunits = \"mm, s, tonne\"\n"
                                        "[mesh]\nkind = \"file\"\npath = \"full.k\"\n"
                                        "[solve]\nend_time = 1.0e-4\n"
                                        "[nodesets.corner]\nnearest = [40.0, 20.0, 0.0]\n"
                                        "[[probe]]\nname = \"corner\"\nnodes = \"corner\"\n")
    scene = load_scene(over, ["solve.dt_safety=0.7"])
    assert scene.solve.end_time == 1.0e-4 and scene.solve.dt_safety == 0.7 and scene.solve.kind == "dynamic"
    assert [p.name for p in scene.probes] == ["corner", "node_115"]
    assert scene.contact is not None and scene.contact.friction == 0.2
    # a deck value out of range is named by its deck line, through the TOML too
    bad = write(tmp_path, "bad.k", mesh_deck() + KEYWORDS.replace("*CONTROL_TIMESTEP\n0.0,0.8", "*CONTROL_TIMESTEP\n0.0,1.8"))
    with pytest.raises(SceneError) as e:
        load_scene(bad)
    line = 1 + (mesh_deck() + KEYWORDS).split("\n").index("*CONTROL_TIMESTEP") + 1
    assert e.value.messages == [f"{bad}:{line}: *CONTROL_TIMESTEP: [solve].dt_safety: expected a number in (0, 1], "
                                "got 1.8"]
    for args, expected in ((["--set", "mesh.scale=2"], "[mesh].scale = 2: the deck's keywords give lengths"),):
        r = cli_run("validate", str(over), *args)
        assert r.code == 2 and expected in r.err, r.err


def test_unread_keywords_are_listed_with_their_lines(tmp_path):
    """Keywords that change the physics stop the scene (every one listed with its line) unless
    --accept-unread; output requests and definitions are only listed."""
    extra = ("*CONTROL_DYNAMIC_RELAXATION\n0\n*DATABASE_SECFORC\n1.0e-5\n*DEFINE_VECTOR\n1,0,0,0,1,0,0\n"
             "*BOUNDARY_SPC_NODE\n101,3,1,1,1,0,0,0\n*LOAD_NODE_POINT\n115,4,1,1.0\n")
    text = mesh_deck() + KEYWORDS.replace("*END\n", extra + "*END\n")
    deck = write(tmp_path, "unread.k", text)
    lines = text.split("\n")
    at = {k: 1 + lines.index(k) for k in ("*CONTROL_DYNAMIC_RELAXATION", "*DATABASE_SECFORC", "*DEFINE_VECTOR")}
    spc = 2 + lines.index("*BOUNDARY_SPC_NODE", lines.index("*CONTROL_DYNAMIC_RELAXATION"))
    load = 2 + lines.index("*LOAD_NODE_POINT", lines.index("*CONTROL_DYNAMIC_RELAXATION"))
    r = cli_run("validate", str(deck))
    assert_clean_output(r)
    assert r.code == 2
    assert r.err.splitlines() == [
        f"error: {deck}:{at['*CONTROL_DYNAMIC_RELAXATION']}: *CONTROL_DYNAMIC_RELAXATION: not read: a keyword this "
        "reader has no counterpart for (it may change the physics)",
        f"error: {deck}:{spc}: *BOUNDARY_SPC_NODE: not read: CID = 3: a support in a local system is not read",
        f"error: {deck}:{load}: *LOAD_NODE_POINT: not read: DOF = 4: a follower or vector load is not read",
        "error: 3 keywords or fields above would change the physics and are not read: run with --accept-unread "
        "to run without them"]
    r = cli_run("validate", str(deck), "--accept-unread")
    assert r.code == 0, r.err
    warned = [line for line in r.out.splitlines() if line.startswith("warning: ") and "not read" in line]
    assert warned[0] == (f"warning: {deck}:{at['*CONTROL_DYNAMIC_RELAXATION']}: *CONTROL_DYNAMIC_RELAXATION: not read: "
                         "a keyword this reader has no counterpart for (it may change the physics)")
    assert f"warning: {deck}:{at['*DATABASE_SECFORC']}: *DATABASE_SECFORC: not read: an output request: not written" \
        in warned
    assert any(f"{deck}:{at['*DEFINE_VECTOR']}: *DEFINE_VECTOR: not read: a definition" in w for w in warned)


HOSTILE = [
    # (replace in the good deck, the one error line expected after the file name)
    (("*CONTROL_TERMINATION\n&endt", "*CONTROL_TERMINATION\n&endtime"),
     ":{n}: *CONTROL_TERMINATION: parameter &endtime is not defined by a *PARAMETER card (defined: ENDT, NSID, VZ)",
     "&endtime"),
    (("R endt    2*1.0e-4", "R endt    2*other\nR other   endt/2"),
     ":{n}: *PARAMETER_EXPRESSION: parameter ENDT refers to itself (ENDT -> OTHER -> ENDT)", "R endt    2*other"),
    (("*BOUNDARY_SPC_SET\n&nsid", "*BOUNDARY_SPC_SET\n8"),
     ":{n}: *BOUNDARY_SPC_SET: NSID 8 is not a *SET_NODE of this deck", "8,0,1,1,1,1,1,1"),
    (("*LOAD_NODE_POINT\n115,3,1", "*LOAD_NODE_POINT\n115,3,9"),
     ":{n}: *LOAD_NODE_POINT: load curve 9 is not a *DEFINE_CURVE of this deck", "115,3,9,-2.0"),
    (("*RIGIDWALL_PLANAR\n0,0,0\n0.0,0.0,-50.0,0.0,0.0,-40.0\n", "*RIGIDWALL_PLANAR\n0,0,0\n"),
     ":{n}: *RIGIDWALL_PLANAR: incomplete card group (1 of 2 cards)", "0,0,0"),
    (("*ELEMENT_MASS\n900,108,1.0e-6", "*ELEMENT_MASS\n900,999,1.0e-6"),
     ":{n}: *ELEMENT_MASS: element 900: node 999 is not defined by a *NODE card", "900,999,1.0e-6"),
    (("*CONTROL_TIMESTEP\n0.0,0.8", "*CONTROL_TIMESTEP\n0.0,0.8x"),
     ":{n}: *CONTROL_TIMESTEP: TSSFAC (field 2): expected a number, got '0.8x'", "0.0,0.8x"),
]


@pytest.mark.parametrize("change,expected,marker", HOSTILE, ids=[h[1].split(": ", 2)[1] + f"-{k}"
                                                                 for k, h in enumerate(HOSTILE)])
def test_hostile_decks_give_one_line_errors_with_the_line(tmp_path, change, expected, marker):
    text = (mesh_deck() + KEYWORDS).replace(*change)
    assert text != mesh_deck() + KEYWORDS
    deck = write(tmp_path, "hostile.k", text)
    n = 1 + next(k for k, line in enumerate(text.split("\n")) if line.startswith(marker))
    r = cli_run("run", str(deck), "--out", str(tmp_path / "out"))
    assert_clean_output(r)
    assert r.code == 2
    assert r.err.splitlines() == [f"error: {deck}" + expected.format(n=n)]


def test_a_deck_restarts_bit_for_bit(tmp_path, monkeypatch):
    """run model.k stopped half-way and --restart: the tables and the last frame equal the
    uninterrupted run's (tests/test_restart.py's round trip, on the deck; --set applies)."""
    from .test_restart import restart_roundtrip
    # a light deck (supports, a load, an initial velocity, gravity; no contact or body): the
    # restart is the subject, and its batch size compiles the step again
    light = ("*SET_NODE_LIST\n7\n101,106,111\n*BOUNDARY_SPC_SET\n7,0,1,1,1,1,1,1\n*DEFINE_CURVE\n1\n0.0,1.0\n"
             "*LOAD_NODE_POINT\n115,3,1,-2.0\n*INITIAL_VELOCITY\n0\n0.0,0.0,-300.0\n*LOAD_BODY_Z\n1,9810.0\n"
             "*CONTROL_TERMINATION\n1.0e-4\n*DATABASE_GLSTAT\n1.0e-5\n*DATABASE_HISTORY_NODE\n115\n*END\n")
    deck = write(tmp_path, "light.k", mesh_deck(rigid=False) + light)
    # 9 elements, 20-step batches
    stopped, periodic = restart_roundtrip(tmp_path, monkeypatch, [str(deck), "--set", "method.kind=fem"],
                                          stop_step=30, every=20, batch_element_steps=180)
    assert stopped["event"] > 0


def test_a_deck_in_a_sweep(tmp_path):
    """`sweep model.k` checks each case's scene from the deck (and --accept-unread passes on
    to the cases' runs); --list plans without a cluster."""
    from taichi_shell_mpm.sweep.task import run_case
    from taichi_shell_mpm.cli import main
    deck = write(tmp_path, "full.k", mesh_deck() + KEYWORDS.replace("*END\n", "*CONTROL_DYNAMIC_RELAXATION\n0\n*END\n"))
    args = ("sweep", str(deck), "--param", "solve.dt_safety=0.5,0.7", "--set", "method.kind=fem", "--list")
    r = cli_run(*args)
    assert r.code == 2 and "*CONTROL_DYNAMIC_RELAXATION: not read" in r.err, r.err
    r = cli_run(*args, "--accept-unread")
    assert r.code == 0, r.err
    assert len(r.out.strip().splitlines()) == 2
    case = run_case(main, str(deck), ("method.kind=fem", "solve.end_time=2e-5"), str(tmp_path / "case"),
                    flags=("--accept-unread",))
    assert case["exit_code"] == 0 and case["summary"]["steps"] > 5, case


def test_rigid_part_extra_nodes_and_part_hourglass(tmp_path):
    """*CONSTRAINED_EXTRA_NODES joins nodes to a *MAT_RIGID part's body; a part's HGID takes
    its *HOURGLASS QM (a rigid part's does not count), and deformable parts that disagree are
    listed as physics not read (one coefficient per scene)."""
    text = mesh_deck().replace("*PART\nplate\n1,1,1\n", "*PART\nplate\n1,1,1,0,3\n")
    deck = write(tmp_path, "extra.k", text + "*HOURGLASS\n3,4,0.07\n*CONSTRAINED_EXTRA_NODES_NODE\n2,115\n"
                                             "*CONTROL_HOURGLASS\n1,0.1\n*CONTROL_TERMINATION\n1.0e-4\n*END\n")
    scene = load_scene(deck)
    body = scene.rigid_bodies[0]
    assert (body.name, body.fixed) == ("part_2", ("ux", "uy", "rx", "ry", "rz"))
    assert scene.nodeset(body.nodes).ids == (14, 15, 16, 17, 18)
    assert scene.element.hourglass == 0.07
    assert not any("hourglass" in n for n in scene.notes), scene.notes
    text = mesh_deck(rigid=False).replace("*PART\nplate\n1,1,1\n", "*PART\nplate\n1,1,1,0,3\n")
    differ = write(tmp_path, "differ.k", text + "*CONTROL_HOURGLASS\n1,0.1\n*HOURGLASS\n3,4,0.07\n"
                                                "*CONTROL_TERMINATION\n1.0e-4\n*END\n")
    with pytest.raises(SceneError) as e:
        load_scene(differ)
    assert "hourglass coefficients differ between parts (0.07, 0.1): one per scene, 0.07" in e.value.messages[0]


def test_the_top_hat_deck_runs(tmp_path):
    """scenes/top_hat.k (benchmarks/top_hat.py; docs/decks.md, worked example) through the CLI,
    shortened to the first 0.4 ms (the impactor's first 2 mm past touch): the deck is read with
    nothing left unread, the section pushes back, no weld fails yet, the balance closes."""
    out = tmp_path / "top_hat"
    r = cli_run("run", str(Path(__file__).resolve().parents[1] / "scenes" / "top_hat.k"), "--set", "method.kind=fem",
                "--set", "solve.end_time=0.4", "--out", str(out), "--quiet")
    assert_clean_output(r)
    assert r.code == 0, r.err
    assert "not read" not in r.out, r.out
    summary = json.loads((out / "summary.json").read_text())
    welds = summary["spotwelds"][0]
    force = np.genfromtxt(out / "force.csv", delimiter=",", names=True)
    energy = np.genfromtxt(out / "energy.csv", delimiter=",", names=True)
    balance = abs(energy["balance_error"][-1]) / energy["motion_work"][-1]
    print(f"\ntop hat, 0.4 ms: {summary['steps']} steps, peak reaction {np.abs(force['support_z']).max():.1f} kN, "
          f"welds {welds['welds']} ({welds['failed']} failed, peak shear {welds['peak_shear']:.2f} kN), "
          f"balance {balance:.1e} of the motion's work")
    assert welds["welds"] == 14 and welds["failed"] == 0
    assert np.abs(force["support_z"]).max() > 10.0
    assert balance < 1e-3
    # the worked example's reader on this output: the measures of docs/decks.md, and the closed
    # cell's closed forms P_m = k M0 (C/t)^(1/3), M0 = sigma_y t^2 / 4, C = 60 mm, t = 1.5 mm
    # (k = 38.12, 52.22), against which the full run's mean force is stated
    import subprocess
    import sys
    root = Path(__file__).resolve().parents[1]
    read = subprocess.run([sys.executable, str(root / "benchmarks" / "top_hat.py"), "--read", str(out)],
                          capture_output=True, text=True, cwd=root)
    assert read.returncode == 0, read.stderr
    measures = json.loads(read.stdout[read.stdout.index("{"):])
    m0 = 0.30 * 1.5 ** 2 / 4.0
    for name, k in (("wierzbicki_abramowicz", 38.12), ("abramowicz_jones", 52.22)):
        assert measures["closed_cell_theory_kN"][name] == pytest.approx(k * m0 * (60.0 / 1.5) ** (1.0 / 3.0), rel=1e-12)
    assert np.isnan(measures["mean_force_kN"])          # 2 mm of crush: the 10-90 mm window not reached
    # the mean flow stress W_p / int(eps_p dV) of a bilinear law: sigma_y + H eps2/(2 eps) with
    # H = E E_t / (E - E_t), so between sigma_y and sigma_y + H max(eps_p) (< 1 here)
    flow = measures["mean_flow_stress_GPa"]
    print(f"mean flow stress {flow:.4f} GPa")
    assert 0.999 * 0.30 <= flow <= 0.30 + 210.0 * 0.6 / (210.0 - 0.6)
    assert measures["closed_cell_theory_at_flow_stress_kN"]["abramowicz_jones"] == pytest.approx(
        measures["closed_cell_theory_kN"]["abramowicz_jones"] * flow / 0.30, rel=1e-12)
    assert measures["half_wavelength_theory_mm"] == pytest.approx(0.983 * 60.0 ** (2.0 / 3.0) * 1.5 ** (1.0 / 3.0),
                                                                   rel=1e-12)
    assert measures["welds"][0]["failed"] == 0 and measures["crush_mm"] == pytest.approx(2.0, abs=0.5)
    assert measures["balance_over_work"] == pytest.approx(balance, rel=1e-9)


MOVING_WALL = (3.0e-5, 5000.0)      # the wall's MASS (5 x the plate's) and V0


def moving_wall_deck(tmp_path: Path) -> Path:
    """The plate of mesh_deck (part 1 alone, at rest) and a *RIGIDWALL_PLANAR_MOVING 2 mm below
    it moving up at V0."""
    plate = mesh_deck(rigid=False).split("*PART\nimpactor")[0].replace("\n9,2,201,202,203,204", "")
    mass, speed = MOVING_WALL
    return write(tmp_path, "wall.k", plate + "*SECTION_SHELL\n1,2,0.833,3\n1.0,1.0,1.0,1.0\n"
                 "*MAT_ELASTIC\n1,7.85e-9,2.1e5,0.3\n*RIGIDWALL_PLANAR_MOVING\n0\n0.0,0.0,-2.0,0.0,0.0,-1.0\n"
                 f"{mass},{speed}\n*CONTROL_TERMINATION\n1.0e-3\n*END\n")


@pytest.mark.parametrize("method", ["fem", "mpm"])
def test_a_moving_wall_is_a_body_without_nodes(tmp_path, method):
    """*RIGIDWALL_PLANAR_MOVING: a wall of mass MASS below the plate (part 1 alone, at rest)
    starting up at V0 along its normal strikes it and is slowed by it (a [[rigid_body]] without
    nodes that the [[wall]] moves with).  No external force: the plate's momentum plus the
    wall's stays M V0 (round-off), the balance closes, the plate leaves upwards, the wall
    slower than it came."""
    mass, speed = MOVING_WALL
    deck = moving_wall_deck(tmp_path)
    out = tmp_path / method
    r = cli_run("run", str(deck), "--set", f"method.kind={method}", "--out", str(out), "--quiet")
    assert_clean_output(r)
    assert r.code == 0, r.out + r.err
    summary = json.loads((out / "summary.json").read_text())
    (body,) = summary["rigid_bodies"]
    frame = sorted((out / "frames").glob("*.vtu"))[-1]
    import meshio
    mesh = meshio.read(frame)
    area = np.zeros(len(mesh.points))            # the plate's lumped masses: a quarter of each shell's
    for quad in mesh.cells[0].data:
        area[quad] += 100.0 / 4
    plate_momentum = float((7.85e-9 * 1.0 * area * mesh.point_data["velocity"][:, 2]).sum())
    total = plate_momentum + mass * body["velocity"][2]
    energy = np.genfromtxt(out / "energy.csv", delimiter=",", names=True)
    involved = 0.5 * mass * speed ** 2
    print(f"\n{method}: wall {body['velocity'][2]:.2f} (from {speed}), plate momentum {plate_momentum:.4e}, "
          f"total - M V0 {total - mass * speed:.2e} ({(total - mass * speed) / (mass * speed):.1e}), wall energy "
          f"{energy['wall'][-1]:.3e}, balance {energy['balance_error'][-1] / involved:.1e} of the wall's energy")
    assert body["velocity"][2] < speed and plate_momentum > 0.0
    assert abs(total - mass * speed) <= 1e-12 * mass * speed
    assert abs(energy["balance_error"][-1]) <= 1e-9 * involved


def test_part_inertia_gives_a_rigid_part_its_own_mass_and_inertia(tmp_path):
    """*PART_INERTIA on the *MAT_RIGID impactor: its body takes TM at XC, YC, ZC, the tensor
    IXX..IZZ and the initial velocities (mass_from_nodes = false); on a deformable part the
    cards are listed as not read (they mean nothing there), which stops the run."""
    inertia = "15.0,10.0,3.0,1.0e-5,0,0\n1.0,0.1,0.2,2.0,0.3,3.0\n0.0,0.0,-2.0,0.5,0.0,0.0\n"
    text = mesh_deck().replace("*PART\nimpactor\n2,1,2\n", "*PART_INERTIA\nimpactor\n2,1,2\n" + inertia)
    scene = load_scene(write(tmp_path, "inertia.k", text + "*CONTROL_TERMINATION\n1.0e-4\n*END\n"))
    (body,) = scene.rigid_bodies
    assert (body.name, body.mass_from_nodes, body.mass, body.center) == ("part_2", False, 1.0e-5, (15.0, 10.0, 3.0))
    assert body.inertia == (1.0, 2.0, 3.0, 0.1, 0.3, 0.2)
    assert body.velocity == (0.0, 0.0, -2.0) and body.spin == (0.5, 0.0, 0.0)
    text = mesh_deck().replace("*PART\nplate\n1,1,1\n", "*PART_INERTIA\nplate\n1,1,1\n" + inertia)
    deck = write(tmp_path, "deformable.k", text + "*CONTROL_TERMINATION\n1.0e-4\n*END\n")
    r = cli_run("validate", str(deck))
    print(r.err)
    assert r.code == 2 and "part 1 is not rigid: *PART_INERTIA's mass, inertia and velocities are read for *MAT_RIGID" \
        in r.err and "deformable.k:" in r.err


def test_a_rigid_part_motion_window(tmp_path):
    """*BOUNDARY_PRESCRIBED_MOTION_RIGID with BIRTH/DEATH: on a translation, a [[motion]] of the
    part's body with start/end; on a rotation, listed as not read (a body's rotations have no
    window)."""
    motion = "*BOUNDARY_PRESCRIBED_MOTION_RIGID\n2,3,0,1,-2.0,0,0.5,0.1\n*DEFINE_CURVE\n1\n0.0,1.0\n1.0,1.0\n"
    deck = write(tmp_path, "window.k", mesh_deck() + motion + "*CONTROL_TERMINATION\n1.0\n*END\n")
    (m,) = load_scene(deck, ["method.kind=fem"]).motions
    assert (m.body, m.dofs, m.kind, m.value, m.start, m.end) == ("part_2", ("uz",), "velocity", (-2.0,), 0.1, 0.5)
    turned = write(tmp_path, "turned.k", mesh_deck() + motion.replace("2,3,0,1", "2,7,0,1")
                   + "*CONTROL_TERMINATION\n1.0\n*END\n")
    r = cli_run("validate", str(turned), "--set", "method.kind=fem")
    print(r.err)
    assert r.code == 2 and "a rigid part's prescribed rotation holds over the whole run" in r.err


def test_a_moving_wall_restarts_bit_for_bit(tmp_path, monkeypatch):
    """The moving wall's body (no nodes) through tests/test_restart.py's round trip (mpm),
    stopped after the strike."""
    from .test_restart import restart_roundtrip
    stopped, _ = restart_roundtrip(tmp_path, monkeypatch, [str(moving_wall_deck(tmp_path)), "--set", "method.kind=mpm"],
                                   stop_step=600, every=400, batch_element_steps=800)
    assert stopped["started"]           # (the strike is at step ~400)
