"""Fuzzing the public CLI (issue 5.7): generated malformed or random scenes and meshes go
through ``validate`` (>= 500 examples), and a sample of valid ones through ``run`` with tiny
step counts.  Every one either passes or exits with clear one-line errors: never a
traceback, never a hang.

* validate: scenes derived from five small bases (plate fem/static, plate mpm/dynamic with
  a rigid body, wall and contact, tube, hemisphere, imported mesh) by 0-3 structural
  mutations (delete a key, add an unknown key, replace a value by a random one) and numeric
  perturbations (scale a number by 0, -1, 1e-9, 1e9 ...), some raw-text damage (truncated
  or random TOML), and random meshes written with meshio (jittered quads, shuffled corners
  giving bow-ties, duplicate nodes, triangles, NaN coordinates, out-of-range ids, 2-D
  points, garbage files).  Exit code 0 or 2; on 2 every stderr line is ``error: ...``.
* run: three fixed shapes (element and node counts, material, method: compile-time
  constants of the kernels, so each compiles once and is loaded from Taichi's offline
  cache afterwards) with random loads, supports, initial velocities, node sets, end times
  and step budgets.  Exit code 0, 2 or 3 within the time limit.
"""
from __future__ import annotations

import collections
import contextlib
import copy
import io
import json
import math
import tempfile
import tomllib
from pathlib import Path

import meshio
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from .conftest import HEMISPHERE_SCENE, TUBE_SCENE, locations
from .test_reliability import assert_clean_output, cli_run

VALIDATE_EXAMPLES = 500
RUN_EXAMPLES = 20

# ------------------------------------------------------------------ TOML writing
def _key(k) -> str:
    return json.dumps(str(k))


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + "}"
    return json.dumps(str(v))


def _is_table_array(v) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def dump_toml(doc: dict) -> str:
    lines: list[str] = []

    def table(d: dict, path: list) -> None:
        for k, v in d.items():
            if not isinstance(v, dict) and not _is_table_array(v):
                lines.append(f"{_key(k)} = {_value(v)}")
        for k, v in d.items():
            name = ".".join(_key(p) for p in path + [k])
            if isinstance(v, dict):
                lines.append(f"[{name}]")
                table(v, path + [k])
            elif _is_table_array(v):
                for item in v:
                    lines.append(f"[[{name}]]")
                    table(item, path + [k])

    table(doc, [])
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------ bases
PLATE_STATIC = """
[scene]
name = "plate"
units = "consistent"
[mesh]
kind = "plate"
lx = 3.0
ly = 1.0
nx = 3
ny = 2
[material]
E = 1e4
nu = 0.3
density = 1.0
[section]
thickness = 0.05
[method]
kind = "fem"
[nodesets.edge]
plane = {point = [0, 0, 0], normal = [1, 0, 0]}
[nodesets.tip]
box = {min = [3, 0, -1], max = [3, 1, 1]}
[nodesets.one]
ids = [5]
[[boundary]]
nodes = "edge"
fix = "all"
[[load]]
nodes = "tip"
force = [0, 0, 0.01]
[[probe]]
name = "tip"
nodes = "tip"
components = ["uz"]
[solve]
kind = "static"
load_steps = 1
max_steps_per_load_step = 300
"""

PLATE_DYNAMIC = """
[scene]
name = "ram"
units = "consistent"
[mesh]
kind = "plate"
lx = 1.0
ly = 1.0
nx = 2
ny = 2
[material]
E = 1e4
nu = 0.3
density = 1.0
model = "j2"
yield_stress = 10.0
[section]
thickness = 0.05
[method]
kind = "mpm"
cell_size = 0.25
grid_min = [-1, -1, -1]
grid_max = [2, 2, 2]
[nodesets.edge]
plane = {point = [0, 0, 0], normal = [1, 0, 0]}
[nodesets.far]
plane = {point = [1, 0, 0], normal = [1, 0, 0]}
[[boundary]]
nodes = "edge"
symmetry = "x"
[[rigid_body]]
name = "ram"
nodes = "far"
mass = 1.0
direction = [1, 0, 0]
[[wall]]
point = [1.5, 0, 0]
normal = [-1, 0, 0]
moves_with = "ram"
[contact]
stiffness = 0.1
[[initial]]
velocity = [-1, 0, 0]
[solve]
kind = "dynamic"
end_time = 0.01
[output]
times = [0.005]
history_interval = 0.002
"""

FILE_MESH = """
[scene]
name = "imported"
units = "m-kg-s"
[mesh]
kind = "file"
path = "mesh.vtu"
[material]
E = 2e11
nu = 0.3
density = 7850
[section]
thickness = 0.001
[nodesets.left]
box = {min = [-0.1, -1, -1], max = [0.1, 10, 1]}
[[boundary]]
nodes = "left"
fix = ["ux", "uy", "uz"]
[[load]]
nodes = "all"
force = [0, 0, -1]
[solve]
kind = "static"
"""

BASES = {name: tomllib.loads(text) for name, text in
         (("plate", PLATE_STATIC), ("ram", PLATE_DYNAMIC), ("tube", TUBE_SCENE), ("hemisphere", HEMISPHERE_SCENE),
          ("file", FILE_MESH))}
BASES["tube"]["mesh"]["trigger_amplitude"] = 0.5            # the tube's optional keys, to mutate too
BASES["tube"]["section"].update(points=5, rule="gauss")

# ------------------------------------------------------------------ strategies
_SCALARS = st.one_of(
    st.text(max_size=6), st.integers(min_value=-2**63, max_value=2**63 - 1),
    st.floats(allow_nan=True, allow_infinity=True), st.booleans(),
    st.sampled_from([math.nan, math.inf, -1, 0, 1, 2, 0.5, 1e9, "all", "ux", "tip", "edge", "far", "ram",
                     "plate", "file", "dynamic", "static", "mpm", "fem", "x", "j2"]))
_VALUES = st.one_of(_SCALARS, st.lists(_SCALARS, max_size=4),
                    st.lists(st.floats(-5, 5), min_size=3, max_size=3),
                    st.dictionaries(st.text(max_size=5), _SCALARS, max_size=2))


def _mutate(raw: dict, data) -> str:
    action = data.draw(st.sampled_from(["delete", "insert", "replace", "scale", "scale"]))
    places = locations(raw)
    if action == "insert" or not places:
        tables = [raw] + [c[k] for c, k in places if isinstance(c[k], dict)]
        table = data.draw(st.sampled_from(tables))
        table[data.draw(st.text(min_size=1, max_size=10))] = data.draw(_VALUES)
        return "insert"
    if action == "scale":
        numbers = [(c, k) for c, k in places if isinstance(c[k], (int, float)) and not isinstance(c[k], bool)]
        if numbers:
            container, key = data.draw(st.sampled_from(numbers))
            factor = data.draw(st.sampled_from([0, -1, 1e-9, 1e-3, 0.5, 2, 3, 10, 1e9]))
            value = container[key] * factor
            container[key] = int(value) if isinstance(container[key], int) and abs(value) < 2**62 else float(value)
            return "scale"
    container, key = data.draw(st.sampled_from(places))
    if action == "delete":
        del container[key]
    else:
        container[key] = data.draw(_VALUES)
    return action


@st.composite
def meshes(draw):
    """(points, cells) of a random, often broken, surface mesh, or None for a garbage file."""
    if draw(st.integers(0, 19)) == 0:
        return None
    nx, ny = draw(st.integers(1, 4)), draw(st.integers(1, 3))
    jitter = draw(st.sampled_from([0.0, 0.0, 0.1, 0.4, 0.9]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    x, y = np.meshgrid(np.linspace(0, nx, nx + 1), np.linspace(0, ny, ny + 1))
    points = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    points[:, :2] += jitter * rng.uniform(-0.5, 0.5, (len(points), 2))
    points[:, 2] += draw(st.sampled_from([0.0, 0.0, 0.05, 0.5])) * rng.standard_normal(len(points))
    quads = np.array([[j * (nx + 1) + i, j * (nx + 1) + i + 1, (j + 1) * (nx + 1) + i + 1, (j + 1) * (nx + 1) + i]
                      for j in range(ny) for i in range(nx)], dtype=np.int64)
    triangles = np.empty((0, 3), dtype=np.int64)
    for damage in draw(st.lists(st.sampled_from(["bowtie", "reverse", "duplicate", "triangles", "nan",
                                                 "out_of_range", "flat2d", "only_triangles", "unused",
                                                 "repeat_node", "collapse", "huge"]), max_size=3)):
        e = int(rng.integers(len(quads)))
        if damage == "bowtie":
            quads[e] = quads[e][[0, 2, 1, 3]]
        elif damage == "reverse":
            quads[e] = quads[e][::-1]
        elif damage == "duplicate":
            points = np.vstack([points, points[min(quads[e][0], len(points) - 1)]])
            quads[e][0] = len(points) - 1
        elif damage in ("triangles", "only_triangles"):
            triangles = np.vstack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
            if damage == "only_triangles":
                quads = np.empty((0, 4), dtype=np.int64)
                break
        elif damage == "nan":
            points[min(quads[e][1], len(points) - 1), 0] = np.nan
        elif damage == "out_of_range":
            quads[e][2] = len(points) + 5
        elif damage == "flat2d":
            points = points[:, :2]
        elif damage == "unused":
            points = np.vstack([points, [[50.0, 50.0, 0.0][: points.shape[1]]]])
        elif damage == "repeat_node":
            quads[e][3] = quads[e][0]
        elif damage == "collapse":
            ids = np.minimum(quads[e], len(points) - 1)      # an earlier out_of_range may be here
            points[ids] = points[ids[0]]
        elif damage == "huge":
            points *= 1e200
    cells = [(kind, data) for kind, data in (("quad", quads), ("triangle", triangles)) if len(data)]
    return points, cells


def write_mesh(path: Path, mesh) -> str:
    if mesh is None:
        path.write_bytes(b"\x00garbage, not a mesh\xff" * 3)
        return "garbage"
    points, cells = mesh
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            meshio.write(path, meshio.Mesh(points, cells), file_format="vtu")
    except Exception:           # meshio itself refuses some broken arrays: a garbage file then
        path.write_bytes(b"<VTKFile broken")
        return "unwritable"
    return "mesh"


# ------------------------------------------------------------------ validate: >= 500 examples
STATS = collections.Counter()
VALID = []


@pytest.fixture(scope="module")
def workdir():
    with tempfile.TemporaryDirectory(prefix="fuzz_run_") as d:
        yield Path(d)


@settings(max_examples=VALIDATE_EXAMPLES, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_validate_never_crashes(workdir, data):
    STATS["examples"] += 1
    folder = workdir / f"v{STATS['examples']}"
    folder.mkdir()
    base = data.draw(st.sampled_from(sorted(BASES)))
    raw = copy.deepcopy(BASES[base])
    if base == "file":
        STATS["mesh:" + write_mesh(folder / "mesh.vtu", data.draw(meshes()))] += 1
    for _ in range(data.draw(st.integers(0, 3))):
        STATS["mutation:" + _mutate(raw, data)] += 1
    text = dump_toml(raw)
    damage = data.draw(st.sampled_from(["none"] * 8 + ["truncate", "random"]))
    if damage == "truncate":
        text = text[: data.draw(st.integers(0, len(text)))]
    elif damage == "random":
        text = data.draw(st.text(max_size=200))
    path = folder / "scene.toml"
    path.write_text(text)
    overrides = data.draw(st.lists(st.sampled_from(["mesh.nx=2", "solve.kind=dynamic", "method.kind=mpm",
                                                    "load.0.force=[0,0,0]", "bogus", "method.cell_size=-1",
                                                    "boundary.0.fix=all", "solve.end_time=1e-3"]), max_size=2))
    args = ["validate", str(path)] + [a for o in overrides for a in ("--set", o)]
    r = cli_run(*args, timeout=60)
    STATS[f"exit {r.code}"] += 1
    STATS["validated"] += 1
    assert r.code in (0, 2), (r.code, r.out, r.err, text)
    assert_clean_output(r)
    if r.code == 2:
        assert r.err.strip(), "exit 2 without a message"
    else:
        assert ": ok (" in r.out
        VALID.append((base, overrides))


def test_validate_fuzz_statistics():
    if not STATS:
        pytest.skip("the validate fuzz test did not run in this session")
    print("\n" + ", ".join(f"{k}: {v}" for k, v in sorted(STATS.items())))
    assert STATS["validated"] >= VALIDATE_EXAMPLES
    assert STATS["exit 0"] > 0 and STATS["exit 2"] > 0
    print(f"valid bases: {collections.Counter(b for b, _ in VALID)}")


# ------------------------------------------------------------------ run: a sample of valid scenes
RUN_SHAPES = {
    "plate-static-fem": PLATE_STATIC,
    "plate-dynamic-mpm": PLATE_STATIC.replace('kind = "fem"', 'kind = "mpm"\ncell_size = 0.25')
                                     .replace('kind = "static"', 'kind = "dynamic"\nend_time = 0.01'),
    "file-dynamic-fem": FILE_MESH.replace('kind = "static"', 'kind = "dynamic"\nend_time = 1e-6')
                                 .replace("[[load]]", "[[initial]]\nvelocity = [0, 0, 1]\n[[load]]"),
}
RUN_STATS = collections.Counter()


def _vector(magnitude):
    """A vector of the given magnitude scale, not zero unless the magnitude is."""
    return st.lists(st.sampled_from([0.0, 1.0, -1.0, 0.3]), min_size=3, max_size=3).map(
        lambda v: [magnitude * x for x in (v if any(v) else [0.0, 0.0, 1.0])])


@settings(max_examples=RUN_EXAMPLES, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_run_valid_scenes_with_tiny_step_counts(workdir, data):
    RUN_STATS["examples"] += 1
    folder = workdir / f"r{RUN_STATS['examples']}"
    folder.mkdir()
    shape = data.draw(st.permutations(sorted(RUN_SHAPES)))[0]     # less biased than sampled_from
    raw = tomllib.loads(RUN_SHAPES[shape])
    if shape.startswith("file"):
        write_mesh(folder / "mesh.vtu", _FILE_MESH)
    magnitude = data.draw(st.sampled_from([1e-6, 1e-2, 1.0, 1e3, 1e8, 1e300]))
    raw["load"][0]["force"] = data.draw(_vector(magnitude))
    raw["load"][0]["nodes"] = data.draw(st.sampled_from(["all", "tip", "one"] if "tip" in raw.get("nodesets", {})
                                                        else ["all", "left"]))
    raw["boundary"][0]["fix"] = data.draw(st.lists(st.sampled_from(["ux", "uy", "uz", "rx", "ry", "rz"]),
                                                   min_size=1, max_size=6, unique=True))
    if "nodesets" in raw and "one" in raw["nodesets"]:
        raw["nodesets"]["one"]["ids"] = data.draw(st.lists(st.integers(0, 11), min_size=1, max_size=3))
    if raw["solve"]["kind"] == "dynamic":
        raw["solve"]["end_time"] = data.draw(st.sampled_from([1e-7, 1e-4, 1e-3, 0.01]))
        raw["initial"] = [{"velocity": data.draw(_vector(data.draw(st.sampled_from([0.0, 0.1, 10.0, 1e4]))))}]
    else:
        raw["solve"]["load_steps"] = data.draw(st.integers(1, 2))
        raw["solve"]["max_steps_per_load_step"] = data.draw(st.sampled_from([1, 50, 300]))
    path = folder / "scene.toml"
    path.write_text(dump_toml(raw))
    r = cli_run("validate", str(path), timeout=60)
    assert r.code in (0, 2)
    assert_clean_output(r)
    if r.code == 2:
        RUN_STATS["invalid"] += 1
        print(r.err.strip())
        return
    r = cli_run("run", str(path), "--out", str(folder / "out"), "--quiet", timeout=600)
    RUN_STATS[f"{shape} exit {r.code}"] += 1
    assert r.code in (0, 2, 3), (r.code, r.err)
    assert_clean_output(r)
    if r.code == 3:
        assert len(r.err.splitlines()) == 1
        assert json.loads((folder / "out" / "summary.json").read_text())["error"]


def test_run_fuzz_statistics():
    if not RUN_STATS:
        pytest.skip("the run fuzz test did not run in this session")
    print("\n" + ", ".join(f"{k}: {v}" for k, v in sorted(RUN_STATS.items())))
    assert RUN_STATS["examples"] >= RUN_EXAMPLES
    assert sum(v for k, v in RUN_STATS.items() if " exit " in k) >= RUN_EXAMPLES // 2


def _file_mesh():
    """A fixed, valid but irregular 3x2 quad mesh (the 'file' run shape)."""
    x, y = np.meshgrid(np.linspace(0, 3, 4), np.linspace(0, 1, 3))
    points = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    points[[5, 6], 0] += [0.2, -0.15]
    quads = np.array([[j * 4 + i, j * 4 + i + 1, (j + 1) * 4 + i + 1, (j + 1) * 4 + i]
                      for j in range(2) for i in range(3)])
    return points, [("quad", quads)]


_FILE_MESH = _file_mesh()
