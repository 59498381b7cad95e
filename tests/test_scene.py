"""Scene parsing: schema, every class of user mistake, ``--set`` overrides, fuzzing."""
from __future__ import annotations

import copy
import json
import math
import re
import tomllib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from taichi_shell_mpm.scene import (
    DOFS, Boundary, ElementOptions, FileMesh, HemisphereMesh, InitialVelocity, Load,
    Material, Method, NodeSet, Output, PlateMesh, Probe, Reference, ReferenceColumn, Scene,
    SceneError, SceneInfo, Section, Solve, TubeMesh, apply_overrides, load_scene,
    parse_scene)

from .conftest import HEMISPHERE_SCENE, ROOT, TUBE_SCENE, locations

DOCS = Path(__file__).resolve().parents[1] / "docs" / "scenes.md"
REF_HEADER = "P_over_Pmax,P,minus_U_tip,W_tip\n0.05,0.20,0.026,0.663\n"

# A scene using every table (plate mesh, static).
FULL = """
[scene]
name = "strip"
units = "N-mm-s-t"
description = "every table"

[mesh]
kind = "plate"
lx = 10
ly = 1.0
nx = 10
ny = 1
origin = [0, -0.5, 0]

[material]
E = 1.2e6
nu = 0.0
density = 1

[section]
thickness = 0.1
points = 5
rule = "gauss"
shear_factor = 0.8

[element]
hourglass = 0.1

[method]
kind = "fem"
cell_size = 0.25
grid_min = [-1, -1, -1]
grid_max = [11, 1, 8]
transfer = "flip"
flip_blend = 0.95

[nodesets.clamped]
plane = {point = [0, 0, 0], normal = [1, 0, 0], tol = 1e-5}
[nodesets.tip]
box = {min = [10, -1, -1], max = [10, 1, 1]}
tol = 1e-4
[nodesets.corner]
nearest = [10, 0.5, 0]
[nodesets.some]
ids = [0, 3, 7]
[nodesets.everything]
all = true

[[boundary]]
nodes = "clamped"
fix = "all"
[[boundary]]
nodes = "corner"
fix = ["ux", "rz"]
symmetry = "y"

[[load]]
nodes = "tip"
force = [0, 0, 4]
[[load]]
nodes = "corner"
moment = [0, 1.5, 0]
distribute = "equal"

[[initial]]
velocity = [1, 0, 0]
[[initial]]
nodes = "some"
angular_velocity = [0, 0, 2]
center = [5, 0, 0]

[[probe]]
name = "tip"
nodes = "tip"
components = ["ux", "uz"]
[[probe]]
name = "corner_rot"
nodes = "corner"

[reference]
file = "ref.csv"
load_column = "P_over_Pmax"
floor = 0.2
[[reference.compare]]
column = "W_tip"
probe = "tip.uz"
[[reference.compare]]
column = "minus_U_tip"
probe = "tip.ux"
scale = -1

[solve]
kind = "static"
load_steps = 10
tolerance = 1e-5
max_steps_per_load_step = 1000
dt_safety = 0.5
dt_rule = "shell"
rotary_inertia = "physical"
progress_every = 0

[output]
every_steps = 100
times = [0, 0.5, 2]
load_steps = false
"""

# A minimal scene of the file mesh kind (optional tables left at their defaults); those of the
# tube and the hemisphere are conftest.TUBE_SCENE and HEMISPHERE_SCENE.
FILE_MESH = """
[scene]
name = "imported"
units = "m-kg-s"
[mesh]
kind = "file"
path = "meshes/strip.vtk"
scale = 1e-3
[material]
E = 2e11
nu = 0.3
density = 7850
[section]
thickness = 0.001
[[load]]
nodes = "all"
force = [0, 0, -1]
[solve]
kind = "static"
"""


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory) -> Path:
    """A folder with the files the scenes above refer to."""
    folder = tmp_path_factory.mktemp("scenes")
    (folder / "ref.csv").write_text(REF_HEADER)
    (folder / "cantilever_end_shear.csv").write_text(REF_HEADER)
    (folder / "steel.csv").write_text("plastic strain,yield stress\n0.0,0.25\n# a comment\n\n0.1,0.3\n")
    (folder / "meshes").mkdir()
    (folder / "meshes" / "strip.vtk").write_text("# vtk DataFile Version 2.0\n")
    return folder


def raw_of(text: str) -> dict:
    return tomllib.loads(text)


def errors(raw: dict, folder: Path, name: str = "case.toml") -> list[str]:
    """The messages of the SceneError that parse_scene must raise."""
    with pytest.raises(SceneError) as caught:
        parse_scene(raw, folder / name)
    return caught.value.messages


# ------------------------------------------------------------------ valid scenes
def test_full_scene_parses_into_expected_dataclasses(scene_dir):
    path = scene_dir / "strip.toml"
    path.write_text(FULL)
    scene = load_scene(path)
    assert isinstance(scene, Scene)
    assert scene.source == path.resolve()
    assert scene.info == SceneInfo(name="strip", units="N-mm-s-t", description="every table")
    assert scene.mesh == PlateMesh(lx=10.0, ly=1.0, nx=10, ny=1, origin=(0.0, -0.5, 0.0))
    assert isinstance(scene.mesh.lx, float) and isinstance(scene.mesh.origin[0], float)
    assert scene.material == Material(E=1.2e6, nu=0.0, density=1.0)
    assert scene.section == Section(thickness=0.1, points=5, rule="gauss", shear_factor=0.8)
    assert scene.element == ElementOptions(hourglass=0.1)
    assert scene.method == Method(kind="fem", cell_size=0.25, grid_min=(-1.0, -1.0, -1.0),
                                  grid_max=(11.0, 1.0, 8.0), transfer="flip",
                                  flip_blend=0.95)
    assert scene.nodesets == (
        NodeSet(name="clamped", kind="plane", point=(0.0, 0.0, 0.0), normal=(1.0, 0.0, 0.0), tol=1e-5),
        NodeSet(name="tip", kind="box", box_min=(10.0, -1.0, -1.0), box_max=(10.0, 1.0, 1.0), tol=1e-4),
        NodeSet(name="corner", kind="nearest", point=(10.0, 0.5, 0.0)),
        NodeSet(name="some", kind="ids", ids=(0, 3, 7)),
        NodeSet(name="everything", kind="all"),
    )
    assert scene.boundaries == (Boundary(nodes="clamped", fix=DOFS),
                                Boundary(nodes="corner", fix=("ux", "rz"), symmetry="y"))
    assert scene.loads == (Load(nodes="tip", force=(0.0, 0.0, 4.0)),
                           Load(nodes="corner", moment=(0.0, 1.5, 0.0), distribute="equal"))
    assert scene.initial == (InitialVelocity(velocity=(1.0, 0.0, 0.0)),
                             InitialVelocity(nodes="some", angular_velocity=(0.0, 0.0, 2.0),
                                             center=(5.0, 0.0, 0.0)))
    assert scene.probes == (Probe(name="tip", nodes="tip", components=("ux", "uz")),
                            Probe(name="corner_rot", nodes="corner"))
    assert scene.reference == Reference(
        file=(scene_dir / "ref.csv").resolve(), load_column="P_over_Pmax", floor=0.2,
        compare=(ReferenceColumn(column="W_tip", probe="tip.uz"),
                 ReferenceColumn(column="minus_U_tip", probe="tip.ux", scale=-1.0)))
    assert scene.solve == Solve(kind="static", load_steps=10, tolerance=1e-5,
                                max_steps_per_load_step=1000, dt_safety=0.5, dt_rule="shell",
                                rotary_inertia="physical", progress_every=0.0)
    assert scene.output == Output(every_steps=100, times=(0.0, 0.5, 2.0), load_steps=False)
    assert scene.nodeset("all") == NodeSet(name="all", kind="all")
    assert scene.nodeset("tip").kind == "box"


def test_other_mesh_kinds_and_defaults(scene_dir):
    tube = parse_scene(raw_of(TUBE_SCENE), scene_dir / "tube.toml")
    assert tube.mesh == TubeMesh(width=60.0, depth=40.0, corner_radius=5.0, length=40.0,
                                 n_flat=2, n_corner=1, n_length=4)
    assert tube.solve == Solve(kind="dynamic", end_time=0.1)
    assert (tube.method, tube.element, tube.output) == (Method(), ElementOptions(), Output())
    assert tube.section == Section(thickness=1.0)
    assert tube.loads == () and tube.reference is None
    assert tube.initial == (InitialVelocity(velocity=(0.0, 0.0, -15.0)),)

    hemi = parse_scene(raw_of(HEMISPHERE_SCENE), scene_dir / "hemi.toml")
    assert hemi.mesh == HemisphereMesh(radius=10.0, hole_deg=18.0, n_around=4, n_meridian=3)
    assert hemi.boundaries == (Boundary(nodes="sym_x", symmetry="x"),)
    assert hemi.nodeset("sym_x").tol == 1e-6

    imported = parse_scene(raw_of(FILE_MESH), scene_dir / "imported.toml")
    assert imported.mesh == FileMesh(path=(scene_dir / "meshes" / "strip.vtk").resolve(), scale=1e-3)
    assert imported.mesh.path.is_absolute()


def test_docs_example_is_a_valid_scene(scene_dir):
    blocks = re.findall(r"```toml\n(.*?)```", DOCS.read_text(), flags=re.S)
    example = next(b for b in blocks if "[scene]" in b)
    scene = parse_scene(raw_of(example), scene_dir / "cantilever.toml")
    assert scene.mesh == PlateMesh(lx=10.0, ly=1.0, nx=10, ny=1)
    assert scene.boundaries == (Boundary(nodes="clamped", fix=DOFS),)
    assert scene.loads == (Load(nodes="tip", force=(0.0, 0.0, 4.0)),)
    assert scene.probes == (Probe(name="tip", nodes="tip", components=("ux", "uz")),)
    assert [c.probe for c in scene.reference.compare] == ["tip.uz", "tip.ux"]
    assert scene.solve.kind == "static" and scene.solve.load_steps == 20


# ------------------------------------------------------------------ one message per class of error
def _set(raw: dict, path: str, value) -> dict:
    """raw with the dotted `path` (integer parts index arrays) set to `value`."""
    *parents, last = [int(p) if p.isdigit() else p for p in path.split(".")]
    node = raw
    for part in parents:
        node = node[part]
    node[last] = value
    return raw


def _del(raw: dict, path: str) -> dict:
    *parents, last = [int(p) if p.isdigit() else p for p in path.split(".")]
    node = raw
    for part in parents:
        node = node[part]
    del node[last]
    return raw


BAD_VALUES = [  # (dotted path, value, expected message after "case.toml: ")
    ("material.E", -3, "[material].E: expected a number > 0, got -3"),
    ("material.nu", math.nan, "[material].nu: expected a number in (-1, 0.5), got nan"),
    ("material.nu", 0.5, "[material].nu: expected a number in (-1, 0.5), got 0.5"),
    ("material.model", "plastic", "[material].model: expected one of elastic, j2, orthotropic, hill48, got 'plastic'"),
    ("section.thickness", True, "[section].thickness: expected a number > 0, got true"),
    ("section.shear_factor", math.inf, "[section].shear_factor: expected a number in (0, 1], got inf"),
    ("section.points", 11, "[section].points: expected an integer in [1, 10], got 11"),
    ("mesh.nx", 2.5, "[mesh].nx: expected an integer >= 1, got 2.5"),
    ("mesh.ny", 0, "[mesh].ny: expected an integer >= 1, got 0"),
    ("mesh.origin", [0, 1], "[mesh].origin: expected 3 finite numbers [x, y, z], got [0, 1]"),
    ("mesh.kind", "plat", "[mesh].kind: expected one of plate, hemisphere, tube, file, got 'plat' "
                          "(did you mean 'plate'?)"),
    ("scene.name", "my run", "[scene].name: expected a file name made of letters, digits, '_', '.', '-', "
                             "got 'my run'"),
    ("scene.name", "..", "[scene].name: expected a file name made of letters, digits, '_', '.', '-', "
                         "got '..'"),
    ("scene.units", " ", "[scene].units: expected a non-empty string, got ' '"),
    ("element.hourglass", 1.5, "[element].hourglass: expected a number in [0, 1], got 1.5"),
    ("method.transfer", "apci", "[method].transfer: expected one of apic, polypic, pic, flip, got 'apci' "
                                "(did you mean 'apic'?)"),
    ("method.cell_size", 0, "[method].cell_size: expected a number > 0, got 0"),
    ("boundary.1.fix", ["ux", "uw"], "[[boundary]][1].fix: unknown DOF 'uw' (expected some of "
                                     "ux, uy, uz, rx, ry, rz)"),
    ("boundary.1.fix", ["ux", "ux"], "[[boundary]][1].fix: DOF 'ux' is given twice"),
    ("boundary.1.fix", "none", "[[boundary]][1].fix: expected a non-empty list of DOFs (some of "
                               "ux, uy, uz, rx, ry, rz) or \"all\", got 'none'"),
    ("boundary.1.symmetry", "w", "[[boundary]][1].symmetry: expected one of x, y, z, got 'w'"),
    ("boundary.0.nodes", "clampd", "[[boundary]][0].nodes: unknown node set 'clampd' "
                                   "(did you mean 'clamped'?)"),
    ("load.0.nodes", "zz", "[[load]][0].nodes: unknown node set 'zz' "
                           "(defined: all, clamped, corner, everything, some, tip)"),
    ("load.0.force", [0, 0, "4"], "[[load]][0].force: expected 3 finite numbers [x, y, z], got [0, 0, '4']"),
    ("load.1.distribute", "even", "[[load]][1].distribute: expected one of area, equal, length, got 'even'"),
    ("initial.1.center", [0, 0, math.inf], "[[initial]][1].center: expected 3 finite numbers [x, y, z], "
                                           "got [0, 0, inf]"),
    ("nodesets.some.ids", [], "[nodesets.some].ids: expected a non-empty list of node indices >= 0, got []"),
    ("nodesets.some.ids", [1, -2], "[nodesets.some].ids: expected a non-empty list of node indices >= 0, "
                                   "got [1, -2]"),
    ("nodesets.everything.all", False, "[nodesets.everything].all: expected true, got false"),
    ("nodesets.clamped.plane.normal", [0, 0, 0], "[nodesets.clamped].plane.normal: expected a non-zero "
                                                 "vector, got [0, 0, 0]"),
    ("nodesets.clamped.plane.tol", -1, "[nodesets.clamped].plane.tol: expected a number > 0, got -1"),
    ("nodesets.tip.box.max", [9, 1, 1], "[nodesets.tip].box: expected min <= max in every component, "
                                        "got min = [10.0, -1.0, -1.0], max = [9.0, 1.0, 1.0]"),
    ("probe.1.name", "2rot", "[[probe]][1].name: expected an identifier (letters, digits, '_'; "
                             "not starting with a digit), got '2rot'"),
    ("probe.1.name", "tip", "[[probe]][1].name: duplicate probe name 'tip'"),
    ("probe.0.components", [], "[[probe]][0].components: expected a non-empty list of DOFs "
                               "(some of ux, uy, uz, rx, ry, rz), got []"),
    ("reference.file", "nothere.csv", "[reference].file: file not found: "),
    ("reference.floor", 0, "[reference].floor: expected a number in (0, 1], got 0"),
    ("reference.load_column", "P_over_Pmx", "[reference].load_column: no column 'P_over_Pmx' in the header "
                                            "of ref.csv (did you mean 'P_over_Pmax'?)"),
    ("reference.compare.0.column", "zzz", "[[reference.compare]][0].column: no column 'zzz' in the header of "
                                          "ref.csv (columns: P_over_Pmax, P, minus_U_tip, W_tip)"),
    ("reference.compare.0.probe", "tip.rz", "[[reference.compare]][0].probe: probe 'tip' does not "
                                            "record 'rz' (it records ux, uz)"),
    ("reference.compare.0.probe", "tp.uz", "[[reference.compare]][0].probe: unknown probe 'tp' "
                                           "(did you mean 'tip'?)"),
    ("reference.compare.0.probe", "tip.uw", "[[reference.compare]][0].probe: unknown component 'uw' "
                                            "(expected one of ux, uy, uz, rx, ry, rz)"),
    ("reference.compare.0.probe", "tip", "[[reference.compare]][0].probe: expected '<probe>.<component>' "
                                         "(e.g. 'tip.uz'), got 'tip'"),
    ("reference.compare.1.scale", 0, "[[reference.compare]][1].scale: expected a non-zero finite number, "
                                     "got 0"),
    ("solve.kind", "quasi", "[solve].kind: expected one of static, dynamic, got 'quasi'"),
    ("solve.load_steps", 0, "[solve].load_steps: expected an integer >= 1, got 0"),
    ("solve.tolerance", 0.5, "[solve].tolerance: expected a number in (0, 0.1], got 0.5"),
    ("solve.dt_rule", "grid", "[solve].dt_rule: expected one of both, shell, got 'grid'"),
    ("output.times", [0, 2, 1], "[output].times: expected strictly increasing times, got [0, 2, 1]"),
    ("output.times", [-1], "[output].times: expected a list of numbers >= 0, got [-1]"),
    ("output.load_steps", 1, "[output].load_steps: expected true or false, got 1"),
    ("output.every_steps", -1, "[output].every_steps: expected an integer >= 0, got -1"),
    ("method.cel_size", 0.5, "[method].cel_size: unknown key (did you mean 'cell_size'?)"),
    ("mesh.radius", 10, "[mesh].radius: unknown key (allowed: lx, ly, nx, ny, origin, triangles, kind)"),
    ("nodesets.tip.bx", 1, "[nodesets.tip].bx: unknown key (did you mean 'box'?)"),
    ("methd", {}, "[methd]: unknown key (did you mean 'method'?)"),
    ("boundary", {"nodes": "tip"}, "[[boundary]]: expected an array of tables ([[boundary]] sections), "
                                   "got a table"),
    ("material", 3, "[material]: expected a table, got 3"),
    ("nodesets.all", {"all": True}, "[nodesets.all]: the name 'all' is predefined (every node); "
                                    "choose another name"),
    ("nodesets.tip.plane", {"point": [0, 0, 0], "normal": [1, 0, 0]},
     "[nodesets.tip]: expected exactly one selector (all, box, plane, nearest, ids), got box, plane"),
    ("nodesets.corner.tol", 0.1, "[nodesets.corner].tol: allowed only beside box (a plane takes its tol "
                                 "inside plane = {...})"),
]


@pytest.mark.parametrize("path, value, expected", BAD_VALUES, ids=[f"{p}={v!r}" for p, v, _ in BAD_VALUES])
def test_each_mistake_is_reported_with_file_and_key_path(scene_dir, path, value, expected):
    messages = errors(_set(raw_of(FULL), path, value), scene_dir)
    assert len(messages) == 1, messages
    assert messages[0].startswith("case.toml: " + expected)


MISSING = [  # (dotted path to delete, expected message after "case.toml: ")
    ("material.E", "[material].E: missing required key"),
    ("scene.units", "[scene].units: missing required key"),
    ("solve", "[solve]: missing required table"),
    ("mesh.kind", "[mesh].kind: missing required key (one of plate, hemisphere, tube, file)"),
    ("mesh.nx", "[mesh].nx: missing required key"),
    ("boundary.1.nodes", "[[boundary]][1].nodes: missing required key"),
    ("nodesets.clamped.plane.point", "[nodesets.clamped].plane.point: missing required key"),
    ("nodesets.tip.box", "[nodesets.tip]: expected exactly one selector (all, box, plane, nearest, ids), "
                         "got none"),
    ("reference.compare", "[reference].compare: missing required key (add [[reference.compare]] tables)"),
    ("method.grid_max", "[method].grid_max: missing required key (grid_min and grid_max come together)"),
    ("load", "[[load]]: a static solve needs at least one [[load]], [[motion]], [[pressure]] or [gravity]"),
]


@pytest.mark.parametrize("path, expected", MISSING, ids=[p for p, _ in MISSING])
def test_missing_keys_and_tables(scene_dir, path, expected):
    messages = errors(_del(raw_of(FULL), path), scene_dir)
    assert messages == ["case.toml: " + expected]


def test_cross_checks(scene_dir):
    def one(changes: dict, expected: str, base: str = FULL):
        raw = raw_of(base)
        for path, value in changes.items():
            _set(raw, path, value)
        assert errors(raw, scene_dir) == ["case.toml: " + expected]

    one({"boundary.1": {"nodes": "corner"}}, "[[boundary]][1]: expected fix and/or symmetry")
    one({"load.0.force": [0, 0, 0]}, "[[load]][0]: force and moment are both zero "
                                     "(give a non-zero force and/or moment)")
    one({"section.rule": "lobatto", "section.points": 1},
        "[section].points: expected an integer in [2, 10] for rule = lobatto, got 1")
    one({"method.grid_min": [0, 1, 0]}, "[method]: expected grid_min < grid_max in every component, "
                                        "got grid_min = [0.0, 1.0, 0.0], grid_max = [11.0, 1.0, 8.0]")
    one({"method.field_contact": "grid"}, '[method].field_contact: "grid" acts between the fields of a '
        'multi-field grid: set fields = "multi"')
    one({"method.fields": "multi", "method.field_friction": 0.3},
        '[method].field_friction: the friction of the grid contact condition: set field_contact = "grid"')
    one({"mesh.corner_radius": 20}, "[mesh].corner_radius: expected a number < min(width, depth)/2 = 20, "
                                    "got 20", base=TUBE_SCENE)
    one({"mesh.n_corner": 0}, "[mesh].n_corner: expected an integer >= 1 when corner_radius > 0, got 0",
        base=TUBE_SCENE)
    one({"solve.end_time": 0}, "[solve].end_time: expected a number > 0 for a dynamic solve, got 0",
        base=TUBE_SCENE)
    one({"mesh.hole_deg": 90}, "[mesh].hole_deg: expected a number in (0, 90), got 90", base=HEMISPHERE_SCENE)
    # a typo that would generate billions of elements (found by the fuzz test: MemoryError)
    one({"mesh.n_around": 1_000_000_000}, "[mesh].n_around: expected at most 10,000,000 elements "
        "(n_around x n_meridian), got 3,000,000,000", base=HEMISPHERE_SCENE)
    one({"mesh.n_length": 10**6}, "[mesh].n_length: expected at most 10,000,000 elements "
        "(4 (n_flat + n_corner) x n_length), got 12,000,000", base=TUBE_SCENE)
    one({"solve.mass_scaling": "uniform_dt"}, '[solve].mass_scaling: expected "auto", "selective", "conventional" or '
        '"none" for a dynamic solve, got "uniform_dt" (fictitious masses change the dynamics; they are for static solves)',
        base=TUBE_SCENE)
    one({"mesh.path": "meshes/none.vtk"}, "[mesh].path: file not found: "
        f"{str(scene_dir / 'meshes/none.vtk')!r}", base=FILE_MESH)
    # a square tube without fillets needs no fillet elements
    raw = raw_of(TUBE_SCENE)
    _set(_set(raw, "mesh.corner_radius", 0), "mesh.n_corner", 0)
    assert parse_scene(raw, scene_dir / "case.toml").mesh.n_corner == 0
    # dynamic without end_time
    assert errors(_del(raw_of(TUBE_SCENE), "solve.end_time"), scene_dir) == [
        "case.toml: [solve].end_time: missing required key (a dynamic solve needs end_time > 0)"]


def test_reference_header_must_be_readable(scene_dir):
    (scene_dir / "binary.csv").write_bytes(b"\xff\xfe\x00bad")
    raw = _set(raw_of(FULL), "reference.file", "binary.csv")
    messages = errors(raw, scene_dir)
    assert len(messages) == 1
    assert messages[0].startswith("case.toml: [reference].file: cannot read its header row")


def test_reference_cells_must_be_finite_numbers(scene_dir):
    """Issue 16.9: a non-numeric cell passed validation and crashed the run at its end.  Every
    cell of the load column and of the compared columns is checked (file, line, column named);
    the other columns may hold anything."""
    (scene_dir / "cells.csv").write_text("P_over_Pmax,P,minus_U_tip,W_tip\n0.05,n/a,0.026,0.663\n"
                                         "0.1,0.4,abc,1.2\n\n0.15,0.6,0.1,nan\n0.2,0.8,0.2\n")
    raw = _set(raw_of(FULL), "reference.file", "cells.csv")
    assert errors(raw, scene_dir) == [
        "case.toml: [reference].file: cells.csv line 3, column 'minus_U_tip': expected a finite number, got 'abc'",
        "case.toml: [reference].file: cells.csv line 5, column 'W_tip': expected a finite number, got 'nan'",
        "case.toml: [reference].file: cells.csv line 6, column 'W_tip': expected a finite number, got nothing "
        "(the row is short)"]
    (scene_dir / "header_only.csv").write_text("P_over_Pmax,P,minus_U_tip,W_tip\n")
    assert errors(_set(raw_of(FULL), "reference.file", "header_only.csv"), scene_dir) == [
        "case.toml: [reference].file: header_only.csv has a header but no data rows"]


def test_a_directory_is_not_a_file(scene_dir):
    """Issue 16.18: a directory as mesh path said 'file not found'."""
    raw = raw_of(FILE_MESH)
    _set(raw, "mesh.path", "meshes")
    assert errors(raw, scene_dir) == [
        f"case.toml: [mesh].path: expected a file, got the directory {str(scene_dir / 'meshes')!r}"]


def test_all_errors_are_reported_at_once(scene_dir):
    raw = raw_of(FULL)
    _set(raw, "material.E", -3)
    _set(raw, "method.cel_size", 1)
    _set(raw, "boundary.1.fix", ["uw"])
    _set(raw, "probe.0.nodes", "tipp")
    _del(raw, "section.thickness")
    _set(raw, "output.times", "often")
    messages = errors(raw, scene_dir, name="many.toml")
    assert sorted(messages) == sorted([
        "many.toml: [material].E: expected a number > 0, got -3",
        "many.toml: [method].cel_size: unknown key (did you mean 'cell_size'?)",
        "many.toml: [[boundary]][1].fix: unknown DOF 'uw' (expected some of ux, uy, uz, rx, ry, rz)",
        "many.toml: [[probe]][0].nodes: unknown node set 'tipp' (did you mean 'tip'?)",
        "many.toml: [section].thickness: missing required key",
        "many.toml: [output].times: expected a list of numbers >= 0, got 'often'",
    ])
    assert str(SceneError(messages)) == "\n".join(messages)


def test_wall_moving_with_a_nameless_rigid_body(scene_dir):
    """A [[rigid_body]] without a name beside a [[wall]] that moves with one: clean errors."""
    raw = raw_of(TUBE_SCENE)
    raw["rigid_body"] = [{"nodes": "front"}, "not a table"]
    raw["wall"] = [{"point": [0, 0, 0], "normal": [0, 0, 1], "moves_with": "ram"}]
    assert errors(raw, scene_dir) == [
        "case.toml: [[rigid_body]][0].name: missing required key",
        "case.toml: [[rigid_body]][1]: expected a table, got 'not a table'",
        "case.toml: [[wall]][0].moves_with: no [[rigid_body]] named 'ram' (none defined)"]
    raw["rigid_body"] = {"name": "ram"}
    assert errors(raw, scene_dir)[-1] == "case.toml: [[wall]][0].moves_with: no [[rigid_body]] named 'ram' " \
                                         "(none defined)"


def test_invalid_probe_components_do_not_cascade(scene_dir):
    """A reference to a probe whose own components are wrong reports only the probe."""
    raw = _set(raw_of(FULL), "probe.0.components", ["ux", "zz"])
    assert errors(raw, scene_dir) == [
        "case.toml: [[probe]][0].components: unknown DOF 'zz' (expected some of ux, uy, uz, rx, ry, rz)"]


# ------------------------------------------------------------------ files and overrides
def test_missing_file_is_one_line(tmp_path):
    with pytest.raises(SceneError) as caught:
        load_scene(tmp_path / "nope.toml")
    assert caught.value.messages == [f"{tmp_path / 'nope.toml'}: file not found"]


def test_toml_syntax_error_is_one_line(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("[scene]\nname = \n")
    with pytest.raises(SceneError) as caught:
        load_scene(path)
    (message,) = caught.value.messages
    assert message.startswith("bad.toml: TOML syntax error: ") and "line 2" in message
    assert "\n" not in message


def test_overrides_scalar_vector_and_array_index():
    raw = raw_of(FULL)
    out = apply_overrides(raw, ["mesh.nx=20", "method.kind=fem", "solve.tolerance = 1e-3",
                                "load.1.force=[0,0,2]", "boundary.0.fix=['ux']",
                                "output.load_steps=true", "scene.description=two words",
                                "mesh.nx=30"])
    assert out["mesh"]["nx"] == 30                       # later overrides win
    assert out["method"]["kind"] == "fem"
    assert out["solve"]["tolerance"] == 1e-3
    assert out["load"][1]["force"] == [0, 0, 2]
    assert out["boundary"][0]["fix"] == ["ux"]
    assert out["output"]["load_steps"] is True
    assert out["scene"]["description"] == "two words"
    assert raw == raw_of(FULL), "the input must not be modified"


def test_overrides_create_keys_and_tables():
    out = apply_overrides(raw_of(TUBE_SCENE), ["element.hourglass=0.02", "mesh.new_key=1"])
    assert out["element"] == {"hourglass": 0.02}
    assert out["mesh"]["new_key"] == 1


@pytest.mark.parametrize("item, problem", [
    ("load.5.force=[0,0,1]", "index 5 out of range (load has 2 entries)"),
    ("load.first.force=[0,0,1]", "load is an array of tables; expected an index, got 'first'"),
    ("mesh.nx.value=3", "mesh.nx is not a table (it is 10)"),
    ("mesh.nx", "expected KEY=VALUE, e.g. mesh.nx=20"),
    ("mesh..nx=3", "empty key in 'mesh..nx'"),
])
def test_bad_override_paths(item, problem):
    with pytest.raises(SceneError) as caught:
        apply_overrides(raw_of(FULL), [item, "mesh.ny=2"])
    assert caught.value.messages == [f"--set {item}: {problem}"]


def test_load_scene_with_overrides(scene_dir):
    path = scene_dir / "strip.toml"
    path.write_text(FULL)
    scene = load_scene(path, ["mesh.nx=20", "method.kind=mpm", "load.1.moment=[0, 0, 1]"])
    assert scene.mesh.nx == 20 and scene.method.kind == "mpm"
    assert scene.loads[1].moment == (0.0, 0.0, 1.0)
    with pytest.raises(SceneError) as caught:
        load_scene(path, ["mesh.nxx=3", "load.9.force=[1,0,0]"])
    assert caught.value.messages == ["strip.toml: --set load.9.force=[1,0,0]: index 9 out of range "
                                     "(load has 2 entries)"]
    with pytest.raises(SceneError) as caught:
        load_scene(path, ["mesh.nxx=3", "method.kind=fm"])
    assert caught.value.messages == [
        "strip.toml: [mesh].nxx: unknown key (did you mean 'nx'?)",
        "strip.toml: [method].kind: expected one of mpm, fem, got 'fm' (did you mean 'fem'?)"]


# ------------------------------------------------------------------ fuzzing
_SCALARS = st.one_of(
    st.text(max_size=8), st.integers(min_value=-2**63, max_value=2**63 - 1),
    st.floats(allow_nan=True, allow_infinity=True), st.booleans(),
    st.sampled_from([math.nan, math.inf, -math.inf, -1, -1.5, 0, "all", "ux", "tip", "tip.uz",
                     "plate", "tube", "hemisphere", "file", "dynamic", "lobatto", "x"]))
_VALUES = st.one_of(_SCALARS, st.lists(_SCALARS, max_size=4),
                    st.dictionaries(st.text(max_size=5), _SCALARS, max_size=2))


def _mutate(raw: dict, data) -> None:
    """Delete a key, insert an unknown key, or replace a value by a random one."""
    action = data.draw(st.sampled_from(["delete", "insert", "replace"]))
    if action == "insert":
        tables = [raw] + [c[k] for c, k in locations(raw) if isinstance(c[k], dict)]
        table = data.draw(st.sampled_from(tables))
        table[data.draw(st.text(min_size=1, max_size=10))] = data.draw(_VALUES)
        return
    container, key = data.draw(st.sampled_from(locations(raw)))
    if action == "delete":
        del container[key]
    else:
        container[key] = data.draw(_VALUES)


@settings(max_examples=500, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_mutated_scenes_fail_cleanly(scene_dir, data):
    raw = copy.deepcopy(data.draw(st.sampled_from(_FUZZ_BASES)))
    for _ in range(data.draw(st.integers(1, 3))):
        _mutate(raw, data)
    try:
        scene = parse_scene(raw, scene_dir / "fuzz.toml")
    except SceneError as exc:
        assert exc.messages
        for message in exc.messages:
            assert isinstance(message, str) and "\n" not in message and "\r" not in message
            assert message.startswith("fuzz.toml: ") and len(message) > len("fuzz.toml: ")
    else:
        assert isinstance(scene, Scene)


# Curves, prescribed motion, pressure, gravity, curve/follower/line loads (issue 18; runs in
# tests/test_motion_loads.py).
MOTION_SCENE = """
[scene]
name = "motion"
units = "consistent"
[mesh]
kind = "plate"
lx = 4.0
ly = 1.0
nx = 4
ny = 1
[material]
E = 1000.0
nu = 0.3
density = 1.0
[section]
thickness = 0.1
[elementsets.left]
box = { min = [0, 0, 0], max = [2, 1, 0] }
[nodesets.clamp]
plane = { point = [0, 0, 0], normal = [1, 0, 0] }
[nodesets.tip]
plane = { point = [4, 0, 0], normal = [1, 0, 0] }
[curves.table]
points = [[0.0, 0.0], [0.5, 1.0], [1.0, 0.0]]
scale = 2.0
[curves.up]
shape = "ramp"
start = 0.1
end = 0.4
[curves.smooth]
shape = "smooth_step"
end = 0.5
[curves.one]
shape = "constant"
[[boundary]]
nodes = "clamp"
fix = "all"
[[motion]]
name = "lift"
nodes = "tip"
dofs = ["uz", "ry"]
kind = "displacement"
value = [0.2, 0.1]
curve = "smooth"
[[motion]]
name = "push"
nodes = "tip"
dofs = ["ux"]
kind = "velocity"
value = 1.0
curve = "table"
[[load]]
nodes = "tip"
force = [0.0, 1.0, 0.0]
moment = [0.0, 0.0, 0.1]
curve = "up"
follower = true
[[load]]
nodes = "tip"
force_per_length = [0.0, 0.0, 1.0]
moment_per_length = [0.0, 0.1, 0.0]
distribute = "length"
[[pressure]]
value = -0.5
elements = "left"
curve = "one"
[gravity]
acceleration = [0.0, 0.0, -9.81]
curve = "up"
[solve]
kind = "dynamic"
end_time = 1.0
"""

BODIES_SCENE = """
[scene]
name = "bodies"
units = "consistent"
[mesh]
kind = "plate"
lx = 4.0
ly = 1.0
nx = 4
ny = 1
[material]
E = 1000.0
nu = 0.3
density = 1.0
[section]
thickness = 0.1
[nodesets.clamp]
plane = { point = [0, 0, 0], normal = [1, 0, 0] }
[nodesets.tip]
plane = { point = [4, 0, 0], normal = [1, 0, 0] }
[nodesets.middle]
plane = { point = [2, 0, 0], normal = [1, 0, 0] }
[[boundary]]
nodes = "clamp"
fix = "all"
[[rigid_body]]
name = "end"
nodes = "tip"
mass = 2.0
inertia = [1.0, 2.0, 3.0, 0.1, 0.0, -0.1]
center = [4.0, 0.5, 0.0]
mass_from_nodes = true
velocity = [0.0, 0.0, 1.0]
spin = [0.0, 0.5, 0.0]
fixed = ["ux"]
[[motion]]
name = "drive"
body = "end"
dofs = ["uz"]
kind = "velocity"
value = 1.0
[[point_mass]]
name = "weights"
nodes = "middle"
mass = 0.5
inertia = 0.01
[[point_mass]]
name = "shared"
nodes = "middle"
total_mass = 1.0
[solve]
kind = "dynamic"
end_time = 1.0
"""

_FUZZ_BASES = [raw_of(text) for text in (FULL, TUBE_SCENE, HEMISPHERE_SCENE, FILE_MESH, MOTION_SCENE, BODIES_SCENE)]


# ------------------------------------------------------------------ every key is documented
PARTS_SCENE = """
[scene]
name = "parts"
units = "consistent"
[mesh]
kind = "plate"
lx = 2.0
ly = 1.0
nx = 2
ny = 1
[materials.steel]
E = 1.0
nu = 0.0
density = 1.0
model = "j2"
yield_stress = 1.0
hardening = 0.0
[sections.skin]
thickness = 0.1
points = 3
rule = "gauss"
shear_factor = 0.8
hourglass = 0.02
drilling_stiffness = 0.2
[elementsets.a]
box = { min = [0, 0, 0], max = [1, 1, 0] }
[elementsets.b]
ids = [1]
[elementsets.c]
all = true
[[part]]
name = "a"
material = "steel"
section = "skin"
elements = "a"
[[part]]
name = "b"
material = "steel"
section = "skin"
elements = "b"
[solve]
kind = "dynamic"
end_time = 1.0
"""


def _doc_sections() -> dict[str, str]:
    """docs/scenes.md by '## ' heading."""
    out, heading = {}, ""
    for line in DOCS.read_text().splitlines():
        if line.startswith("## "):
            heading = line[3:]
        out[heading] = out.get(heading, "") + line + "\n"
    return out


def _table_heading(path: str) -> str:
    """The docs heading fragment of a parser path: '[[part]][1]' -> '[[part]]',
    '[[reference.compare]][0]' -> '[reference]', '[sections.skin]' -> '[sections.NAME]',
    '[nodesets.x].plane' -> '[nodesets.NAME]', '[mesh]' -> '[mesh]'."""
    double, name, sub = re.match(r"\[(\[?)([A-Za-z_]+)(\.[A-Za-z0-9_-]+)?", path).groups()
    if double:
        return f"[{name}]" if sub else f"[[{name}]]"
    if sub and name in ("materials", "sections"):     # documented as "those of [material]"
        return f"## `[{name[:-1]}]`"
    return f"[{name}.NAME]" if sub else f"[{name}]"


# Every hardening and rate law (issue 18), one material each on a strip of five elements.
LAWS_SCENE = """
[scene]
name = "laws"
units = "kN-mm-ms-kg"
[mesh]
kind = "plate"
lx = 5.0
ly = 1.0
nx = 5
ny = 1
[materials.swift]
E = 200.0
nu = 0.3
density = 7.85e-6
model = "j2"
hardening_law = "swift"
K = 0.5
eps0 = 0.01
n = 0.2
rate_law = "cowper_symonds"
C = 0.0404
p = 5
rate_cutoff_frequency = 10.0
[materials.ludwik]
E = 200.0
nu = 0.3
density = 7.85e-6
model = "j2"
hardening_law = "ludwik"
yield_stress = 0.25
B = 0.4
n = 0.4
max_stress = 0.5
rate_law = "johnson_cook"
c = 0.02
reference_rate = 0.001
rate_measure = "plastic"
rate_filter_time = 0.05
[materials.voce]
E = 200.0
nu = 0.3
density = 7.85e-6
model = "j2"
hardening_law = "voce"
yield_stress = 0.25
Q = 0.15
b = 15.0
hardening = 0.2
[materials.curve]
E = 200.0
nu = 0.3
density = 7.85e-6
model = "j2"
hardening_law = "tabulated"
curve = [[0.0, 0.25], [0.05, 0.3], [0.2, 0.35]]
beyond_curve = "extrapolate"
[materials.file]
E = 200.0
nu = 0.3
density = 7.85e-6
model = "j2"
hardening_law = "tabulated"
curve_file = "steel.csv"
[sections.skin]
thickness = 1.0
points = 5
rule = "gauss"
""" + "".join(f"""[elementsets.{m}]
ids = [{i}]
[[part]]
name = "{m}"
material = "{m}"
section = "skin"
elements = "{m}"
""" for i, m in enumerate(("swift", "ludwik", "voce", "curve", "file"))) + """[solve]
kind = "dynamic"
end_time = 1.0
"""


def test_hardening_and_rate_laws_parse(scene_dir):
    path = scene_dir / "laws.toml"
    path.write_text(LAWS_SCENE)
    m = load_scene(path).materials
    assert (m["swift"].hardening_law, m["swift"].K, m["swift"].eps0, m["swift"].n) == ("swift", 0.5, 0.01, 0.2)
    assert (m["swift"].rate_law, m["swift"].C, m["swift"].p, m["swift"].rate_measure,
            m["swift"].rate_cutoff_frequency) == ("cowper_symonds", 0.0404, 5.0, "total", 10.0)
    assert (m["ludwik"].B, m["ludwik"].max_stress, m["ludwik"].rate_law, m["ludwik"].c,
            m["ludwik"].reference_rate, m["ludwik"].rate_measure, m["ludwik"].rate_filter_time) == (
        0.4, 0.5, "johnson_cook", 0.02, 0.001, "plastic", 0.05)
    assert (m["voce"].Q, m["voce"].b, m["voce"].hardening, m["voce"].rate_law) == (0.15, 15.0, 0.2, "none")
    assert m["curve"].curve == ((0.0, 0.25), (0.05, 0.3), (0.2, 0.35)) and m["curve"].beyond_curve == "extrapolate"
    assert m["file"].curve == ((0.0, 0.25), (0.1, 0.3)) and m["file"].curve_file == (scene_dir / "steel.csv").resolve()
    assert m["file"].beyond_curve == "flat"


J2 = {"E": 200.0, "nu": 0.3, "density": 1.0, "model": "j2", "yield_stress": 0.25}


@pytest.mark.parametrize("table, expected", [
    ({"hardening_law": "swift", "K": 0.5, "eps0": 0.01, "B": 0.1},
     ['[material].B: not used by hardening_law = "swift" (its keys: K, n, eps0, yield_stress, hardening)',
      '[material].n: missing required key for hardening_law = "swift"',
      '[material].eps0: expected exactly one of eps0 and yield_stress for hardening_law = "swift" (yield_stress '
      'sets eps0 = (yield_stress / K)^(1/n))']),
    ({"hardening_law": "voce", "Q": 0.1, "B": 0.1},
     ['[material].B: not used by hardening_law = "voce" (its keys: yield_stress, Q, b, hardening)',
      '[material].b: missing required key for hardening_law = "voce"']),
    ({"hardening_law": "ludwik", "B": 0.1, "n": 0.5, "max_stress": 0.2},
     ["[material].max_stress: expected a number above yield_stress = 0.25, got 0.2"]),
    ({"hardening_law": "tabulated", "curve": [[0.01, 0.25], [0.1, 0.3]]},
     ["[material].curve: point 1: expected plastic strain 0 (the initial yield stress), got 0.01",
      '[material].yield_stress: not used by hardening_law = "tabulated" (its keys: curve, curve_file, beyond_curve)']),
    ({"hardening_law": "tabulated", "yield_stress": None, "curve": [[0.0, 0.25], [0.1, 0.2]]},
     ["[material].curve: point 2: the yield stress falls (0.25 -> 0.2): softening curves are not supported"]),
    ({"hardening_law": "tabulated", "yield_stress": None, "curve": [[0.0, 0.25], [0.0, 0.3]]},
     ["[material].curve: point 2: expected a plastic strain above the previous point's 0, got 0"]),
    ({"hardening_law": "tabulated", "yield_stress": None, "curve": [[0.0, 0.25]], "beyond_curve": "extrapolate"},
     ['[material].beyond_curve: "extrapolate" needs a curve of at least two points']),
    ({"hardening_law": "tabulated", "yield_stress": None, "curve": [0.0, 0.25]},
     ["[material].curve: expected a list of [plastic strain, yield stress] pairs, got [0.0, 0.25]"]),
    ({"hardening_law": "tabulated", "yield_stress": None},
     ['[material].curve: expected exactly one of curve and curve_file for hardening_law = "tabulated"']),
    ({"hardening_law": "tabulated", "yield_stress": None, "curve_file": "ref.csv"},
     ["[material].curve_file: ref.csv line 2: expected two numbers (plastic strain, yield stress), got "
      "'0.05,0.20,0.026,0.663'"]),
    ({"rate_law": "cowper_symonds", "C": 0.04},
     ['[material].p: missing required key for rate_law = "cowper_symonds"']),
    ({"C": 0.04, "rate_measure": "plastic"},
     ['[material].C: not used by rate_law = "none"', '[material].rate_measure: not used by rate_law = "none"']),
    ({"rate_law": "johnson_cook", "c": 0.02, "reference_rate": 1.0, "rate_filter_time": 0.1,
      "rate_cutoff_frequency": 2.0},
     ["[material].rate_cutoff_frequency: give the rate filter either as rate_filter_time or as "
      "rate_cutoff_frequency, not both"]),
    ({"rate_law": "johnson_cook", "c": 0.02, "reference_rate": 0.0},
     ["[material].reference_rate: expected a number > 0, got 0.0"]),
    ({"model": "elastic", "yield_stress": None, "rate_law": "cowper_symonds"},
     ['[material].rate_law: only for model = "j2"']),
    ({"hardening_law": "power"},
     ["[material].hardening_law: expected one of linear, swift, ludwik, voce, tabulated, hockett_sherby, got 'power'"]),
])
def test_hardening_and_rate_key_errors(scene_dir, table, expected):
    """One line per mistake, naming the key (the CLI exits with code 2: tests/test_hardening.py)."""
    raw = raw_of(TUBE_SCENE)
    raw["material"] = {k: v for k, v in {**J2, **table}.items() if v is not None}
    assert errors(raw, scene_dir) == [f"case.toml: {line}" for line in expected]


def test_a_rate_law_needs_a_dynamic_solve(scene_dir):
    raw = raw_of(HEMISPHERE_SCENE)
    raw["material"].update(model="j2", yield_stress=1e5, rate_law="cowper_symonds", C=40.0, p=5.0)
    assert errors(raw, scene_dir) == ['case.toml: [material].rate_law: a static solve has no physical time: a rate '
                                      'law needs [solve].kind = "dynamic"']


def test_every_scene_key_is_documented(scene_dir, monkeypatch):
    """Every key the parser accepts in the scenes of this file, the bundled scenes and a parts
    scene appears as `key` in the docs/scenes.md section of its table."""
    from taichi_shell_mpm.scene import reader as scene_module
    seen: dict[str, set[str]] = {}
    read = scene_module.Reader.read

    def recording(self, path, data, spec, cls=None, required=(), extra=()):
        seen.setdefault(path, set()).update(spec, extra)
        return read(self, path, data, spec, cls, required, extra)

    monkeypatch.setattr(scene_module.Reader, "read", recording)
    scenes = [(text, scene_dir / "case.toml")
              for text in (FULL, TUBE_SCENE, HEMISPHERE_SCENE, PARTS_SCENE, LAWS_SCENE, MOTION_SCENE, BODIES_SCENE)]
    scenes += [((ROOT / "scenes" / f"{n}.toml").read_text(), ROOT / "scenes" / f"{n}.toml")
               for n in ("cantilever", "hemisphere", "square_tube", "tube_rate_dependent")]
    for text, source in scenes:
        parse_scene(raw_of(text), source)
    sections = _doc_sections()
    missing = []
    for path, keys in seen.items():
        heading = _table_heading(path)
        text = next((body for title, body in sections.items() if heading.removeprefix("## ") == title
                     or not heading.startswith("## ") and heading in title), None)
        assert text is not None, f"docs/scenes.md has no section for {heading} ({path})"
        missing += [f"{path}.{key}" for key in sorted(keys) if f"`{key}`" not in text]
    print(f"\n{len(seen)} tables, {sum(len(k) for k in seen.values())} keys checked")
    assert not missing, f"keys not documented in their docs/scenes.md section: {missing}"


def test_docs_key_tables_are_generated_from_the_declarations():
    """docs/scenes.md's key tables are the declarations' (scene/schema.py): the test fails when
    one is edited by hand or a declaration changes without `python -m taichi_shell_mpm schema
    --docs docs/scenes.md`; every declared table is in the docs once."""
    from taichi_shell_mpm.scene.schema import DOC_TABLES, generated_docs, marked_tables
    text = DOCS.read_text(encoding="utf-8")
    assert sorted(marked_tables(text)) == sorted(DOC_TABLES)
    stale = [a for a, b in zip(text.splitlines(), generated_docs(text).splitlines()) if a != b]
    assert not stale, f"stale key tables in docs/scenes.md (regenerate them): {stale[:3]}"


def _schema_validator():
    import jsonschema

    from taichi_shell_mpm.scene.schema import scene_schema
    schema = scene_schema()
    jsonschema.Draft7Validator.check_schema(schema)
    return jsonschema.Draft7Validator(schema)


def test_every_valid_scene_passes_the_json_schema(scene_dir):
    """The JSON Schema (`python -m taichi_shell_mpm schema`) accepts every bundled scene and
    every scene of this file that the parser accepts."""
    validator = _schema_validator()
    texts = {n: (ROOT / "scenes" / f"{n}.toml").read_text() for n in
             ("cantilever", "hemisphere", "hinged_roof", "rollup", "slit_annular_plate", "square_tube",
              "tube_rate_dependent")}
    texts.update(FULL=FULL, TUBE=TUBE_SCENE, HEMISPHERE=HEMISPHERE_SCENE, PARTS=PARTS_SCENE, LAWS=LAWS_SCENE,
                 MOTION=MOTION_SCENE, BODIES=BODIES_SCENE)
    checked = 0
    for name, text in texts.items():
        raw = raw_of(text)
        source = ROOT / "scenes" / f"{name}.toml" if name.islower() else scene_dir / "case.toml"
        parse_scene(raw, source)            # the parser accepts it
        problems = [f"{'.'.join(map(str, e.path))}: {e.message}" for e in validator.iter_errors(raw)]
        assert not problems, (name, problems[:3])
        checked += 1
    print(f"\n{checked} scenes valid against the schema")


@pytest.mark.parametrize("change, where", [
    (lambda raw: raw["material"].update(nu_typo=0.3), "material"),
    (lambda raw: raw["material"].update(nu=0.5), "material"),
    (lambda raw: raw["solve"].pop("kind"), "solve"),
    (lambda raw: raw["method"].update(kind="sph"), "method.kind"),
    (lambda raw: raw["nodesets"]["clamp"].update(nearest="here"), "nodesets.clamp"),
    (lambda raw: raw.update(gravityy={"acceleration": [0, 0, -9.81]}), ""),
])
def test_the_json_schema_refuses_what_the_parser_refuses(change, where):
    """A typo, a value out of range, a missing required key, an unknown choice: the schema (what
    an editor marks as the user types) refuses them, at the table the parser names."""
    raw = raw_of((ROOT / "scenes" / "cantilever.toml").read_text())
    change(raw)
    errors = list(_schema_validator().iter_errors(raw))
    assert errors and any(".".join(map(str, e.path)).startswith(where) for e in errors), \
        [(list(e.path), e.message) for e in errors]


def test_schema_command_prints_the_json_schema(capsys):
    """`python -m taichi_shell_mpm schema` prints the schema: valid JSON, a valid draft 7 schema."""
    import jsonschema

    from taichi_shell_mpm.cli import main
    assert main(["schema"]) == 0
    schema = json.loads(capsys.readouterr().out)
    jsonschema.Draft7Validator.check_schema(schema)
    assert {"scene", "mesh", "material", "tool", "solve"} <= set(schema["properties"])


@pytest.mark.parametrize("material, solve, expected", [
    ({"model": "elastic", "yield_stress": None, "failure_strain": 0.2},
     {}, ['[material].failure_strain: only for model = "j2" (the equivalent plastic strain); failure_min_dt '
          'erodes elements of any model']),
    ({"failure_points": 2}, {}, ["[material].failure_points: only with failure_strain"]),
    ({"failure_strain": 0.0}, {}, ["[material].failure_strain: expected a number > 0, got 0.0"]),
    ({"failure_strain": 0.3, "failure_points": 11}, {},
     ["[material].failure_points: expected an integer in [1, 10], got 11"]),
    ({}, {"mass_scaling": "conventional"},
     ['[solve].target_dt: missing required key for mass_scaling = "conventional"']),
    ({}, {"target_dt": 1e-4, "added_mass_limit": 2.0},
     ['[solve].target_dt: only with mass_scaling = "selective" or "conventional"',
      '[solve].added_mass_limit: only with mass_scaling = "conventional"']),
    ({}, {"mass_scaling": "conventional", "target_dt": -1.0},
     ['[solve].target_dt: expected a number > 0 or "auto", got -1.0']),
    ({}, {"mass_scaling": "conventional", "target_dt": 1e-4, "added_mass_limit": -5.0},
     ["[solve].added_mass_limit: expected a number >= 0, got -5.0"]),
    ({}, {"mass_scaling": "selective", "target_dt": 1e-4},
     ['[solve].mass_scaling: "selective" needs [method].kind = "fem" (in mpm the grid solves with lumped masses: '
      'use "conventional"; docs/mass_scaling.md)']),
])
def test_erosion_and_mass_scaling_key_errors(scene_dir, material, solve, expected):
    """[material] failure keys and [solve] mass scaling keys: one line per mistake."""
    raw = raw_of(TUBE_SCENE)
    raw["material"] = {k: v for k, v in {**J2, **material}.items() if v is not None}
    raw["solve"].update(solve)
    assert errors(raw, scene_dir) == [f"case.toml: {line}" for line in expected]


def test_erosion_and_mass_scaling_parse(scene_dir):
    raw = raw_of(TUBE_SCENE)
    raw["material"] = {**J2, "failure_strain": 0.3, "failure_points": 2, "failure_min_dt": 1e-6}
    raw["solve"].update(mass_scaling="conventional", target_dt=2e-4, added_mass_limit=3.0)
    scene = parse_scene(raw, scene_dir / "case.toml")
    m, s = scene.material, scene.solve
    assert (m.failure_strain, m.failure_points, m.failure_min_dt) == (0.3, 2, 1e-6)
    assert (s.mass_scaling, s.target_dt, s.added_mass_limit) == ("conventional", 2e-4, 3.0)
    raw["method"] = {**raw.get("method", {}), "kind": "fem"}
    raw["solve"] = {**raw["solve"], "mass_scaling": "selective", "sms_tolerance": 1e-4, "sms_max_iterations": 50}
    del raw["solve"]["added_mass_limit"]
    s = parse_scene(raw, scene_dir / "case.toml").solve
    assert (s.mass_scaling, s.target_dt, s.sms_tolerance, s.sms_max_iterations) == ("selective", 2e-4, 1e-4, 50)
    raw["solve"]["target_dt"] = "auto"
    assert parse_scene(raw, scene_dir / "case.toml").solve.target_dt == "auto"


@pytest.mark.parametrize("solve, expected", [
    ({"mass_scaling": "selective"}, ['[solve].target_dt: missing required key for mass_scaling = "selective"']),
    ({"mass_scaling": "selective", "target_dt": 0.0}, ['[solve].target_dt: expected a number > 0 or "auto", got 0.0']),
    ({"mass_scaling": "selective", "target_dt": "automatic"},
     ['[solve].target_dt: expected a number > 0 or "auto", got \'automatic\'']),
    ({"mass_scaling": "selective", "target_dt": 1e-4, "added_mass_limit": 5.0},
     ['[solve].added_mass_limit: only with mass_scaling = "conventional"']),
    ({"mass_scaling": "selective", "target_dt": 1e-4, "sms_tolerance": 0.5},
     ["[solve].sms_tolerance: expected a number in (0, 0.1], got 0.5"]),
    ({"mass_scaling": "selective", "target_dt": 1e-4, "sms_max_iterations": 0},
     ["[solve].sms_max_iterations: expected an integer >= 1, got 0"]),
    ({"mass_scaling": "conventional", "target_dt": 1e-4, "sms_tolerance": 1e-3},
     ['[solve].sms_tolerance: only with mass_scaling = "selective"']),
    ({"mass_scaling": "conventional", "target_dt": 1e-4, "sms_solve": "reciprocal"},
     ['[solve].sms_solve: only with mass_scaling = "selective"']),
    ({"mass_scaling": "selective", "target_dt": 1e-4, "sms_solve": "inverse"},
     ["[solve].sms_solve: expected one of pcg, reciprocal, got 'inverse'"]),
    ({"mass_scaling": "selective", "target_dt": 1e-4, "sms_solve": "reciprocal", "sms_tolerance": 1e-3,
      "sms_max_iterations": 5},
     ['[solve].sms_tolerance: only with sms_solve = "pcg" (the reciprocal mass matrix does not iterate)',
      '[solve].sms_max_iterations: only with sms_solve = "pcg" (the reciprocal mass matrix does not iterate)']),
])
def test_selective_mass_scaling_key_errors(scene_dir, solve, expected):
    """[solve] selective mass scaling keys (fem): one line per mistake, naming the key."""
    raw = raw_of(TUBE_SCENE)
    raw["method"] = {**raw.get("method", {}), "kind": "fem"}
    raw["solve"].update(solve)
    assert errors(raw, scene_dir) == [f"case.toml: {line}" for line in expected]


def test_erosion_and_mass_scaling_need_a_dynamic_solve(scene_dir):
    raw = raw_of(HEMISPHERE_SCENE)
    raw["solve"].update(mass_scaling="conventional", target_dt=1e-3)
    assert errors(raw, scene_dir) == [
        'case.toml: [solve].mass_scaling: expected "auto", "uniform_dt" or "none" for a static solve, got '
        '"conventional" (mass scaling to a target step is for dynamic solves)']
    raw = raw_of(HEMISPHERE_SCENE)           # (a [solve] with an error is not checked against the materials)
    raw["material"].update(model="j2", yield_stress=1e5, failure_strain=0.3)
    assert errors(raw, scene_dir) == ['case.toml: [material].failure_strain: erosion needs [solve].kind = "dynamic"']


# ------------------------------------------------------------------ issue 28, item 10
def test_invalid_named_tables_do_not_cascade(scene_dir):
    """An invalid [sections.X] / [materials.X] / [elementsets.X] is reported once, by its own
    check: no second 'no [sections.X]' from the [[part]] that names it."""
    for path, value, expected in (
            ("sections.skin.thickness", -1.0, "[sections.skin].thickness: expected a number > 0, got -1.0"),
            ("materials.steel.E", 0, "[materials.steel].E: expected a number > 0, got 0"),
            ("elementsets.a.box", 3, "[elementsets.a].box: expected a table, got 3")):
        raw = _set(raw_of(PARTS_SCENE), path, value)
        raw["sections"]["other"] = {"thickness": 1.0}
        raw["materials"]["other"] = {"E": 1.0, "nu": 0.0, "density": 1.0}
        assert errors(raw, scene_dir) == ["case.toml: " + expected]


def test_newton_displacement_control_messages(scene_dir):
    raw = raw_of(FULL)
    raw["solve"].update(solver="newton", control="displacement")
    del raw["method"]
    raw["method"] = {"kind": "fem"}
    raw["element"] = {"drilling": "penalty"}
    assert errors(raw, scene_dir) == [
        'case.toml: [solve].control_nodes: missing required key for control = "displacement" (the node set whose '
        'control_dof is prescribed)',
        'case.toml: [solve].control_displacement: missing required key for control = "displacement" (the final mean '
        'value of control_dof)']
    raw["solve"].update(control_nodes="tip", control_displacement=0)
    assert errors(raw, scene_dir) == [
        'case.toml: [solve].control_displacement: expected a non-zero number for control = "displacement", got 0']


def test_arc_length_bounded_by_the_model_size():
    """arc_length = 1e30 was refused only by Newton as a 'singular tangent'; it is a scene
    error now, naming the key and the bound."""
    from taichi_shell_mpm.preflight import prepare
    scene = ROOT / "scenes" / "hinged_roof.toml"
    with pytest.raises(SceneError) as err:
        prepare(scene, ["solve.arc_length=1e30"])
    assert err.value.messages == [
        "hinged_roof.toml: [solve].arc_length: expected at most 1.06e+05 (the arc in which each of the 289 nodes "
        "moves 10 times the model's size 359), got 1e+30; 0 starts from the linear step at load factor 1 / load_steps"]
    prepare(scene, ["solve.arc_length=1e5"])


def test_setup_warnings_thick_shell_unused_keys_late_times():
    """Thickness above an element's shortest edge, grid-transfer keys in fem mode and output
    times after end_time run, with a warning naming the key."""
    from taichi_shell_mpm.cli import setup_warnings
    from taichi_shell_mpm.preflight import prepare
    scene, mesh, model = prepare(ROOT / "scenes" / "cantilever.toml", [
        "section.thickness=1e9", "method.kind=fem", "method.transfer=flip", "solve.kind=dynamic",
        "solve.end_time=1", "output.times=[0.5, 2]"])
    lines = [w for w in setup_warnings(scene, model) if "[reference]" not in w]
    print("\n".join(lines))
    assert lines == [
        'cantilever.toml: [method].transfer: not used with kind = "fem" (no grid: it is for kind = "mpm")',
        "cantilever.toml: [output].times: 2 after [solve].end_time = 1: no frame is written there",
        "cantilever.toml: [section].thickness: 1e+09 is above the shortest edge of 10 elements of part 'all' (e.g. "
        "element 0: 1): a shell element models a thin shell (t below its size); check the units or model a solid"]
    scene, mesh, model = prepare(ROOT / "scenes" / "cantilever.toml", ["section.thickness=0.99"])
    assert not any("thickness" in w or "not used" in w for w in setup_warnings(scene, model))


def test_static_solve_keeps_the_scaled_rotary_inertia(tmp_path):
    """Issue 28 item 8: rotary_inertia = "physical" is for dynamic solves.  A static solve
    (its masses the relaxation's own) assembles the scaled inertia and no rotational step
    limit, with a warning: with the physical inertia the relaxation of the 10 x 1 cantilever
    stalled at 0.70 of the load after 400 000 steps (docs/scenes.md, rotary_inertia).  A
    dynamic solve keeps m t^2 / 12."""
    import numpy as np
    from taichi_shell_mpm.model.assembly import assemble
    from taichi_shell_mpm.config import Features
    from taichi_shell_mpm.mesh import build_mesh
    from .conftest import plate_scene
    models = {}
    for kind in ("static", "dynamic"):
        for inertia in ("scaled", "physical"):
            (tmp_path / f"{kind}_{inertia}").mkdir()
            scene = plate_scene(tmp_path / f"{kind}_{inertia}", t=0.05, method="fem", solve=kind,
                                extra='[gravity]\nacceleration = [0.0, 0.0, -1.0]',
                                overrides=(f"solve.rotary_inertia={inertia}",))
            model = assemble(scene, build_mesh(scene.mesh))
            models[kind, inertia] = (model, Features.from_scene(scene, model).physical_rotary_inertia)
    static, physical_static = models["static", "scaled"][0], models["static", "physical"][0]
    assert np.array_equal(physical_static.node_inertia, static.node_inertia)
    assert not physical_static.element.rotational_frequency.any() and not models["static", "physical"][1]
    assert [n for n in physical_static.notes if "rotary_inertia" in n] == [
        'scene.toml: [solve].rotary_inertia = "physical" is for dynamic solves: a static solve keeps the scaled '
        "rotary inertia (its masses are fictitious; with the physical one the relaxation stalls, docs/scenes.md)"]
    dynamic = models["dynamic", "physical"][0]
    assert models["dynamic", "physical"][1] and dynamic.element.rotational_frequency.all()
    assert dynamic.node_inertia.sum() == pytest.approx(dynamic.node_mass.sum() * 0.05 ** 2 / 12, rel=1e-12)
