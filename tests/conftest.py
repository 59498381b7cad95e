"""Shared helpers: scene texts, scenes and simulations built in-process, runs through the
Python API (:func:`run_scene`), the element harness."""
from __future__ import annotations

import os
import textwrap
from pathlib import Path
from unittest import mock

import meshio
import numpy as np
import pytest
import taichi as ti
from hypothesis import settings

from taichi_shell_mpm.scene import load_scene
from taichi_shell_mpm.simulation import Simulation
from taichi_shell_mpm.runtime import init_taichi, kernel_cache_base
from taichi_shell_mpm.solvers.stepper import Stepper

ROOT = Path(__file__).resolve().parents[1]

# The fuzz tests (test_scene.py, test_fuzz_run.py) draw the same examples on every run by default,
# so the suite's verdict does not depend on the draw [choice]; `HYPOTHESIS_PROFILE=explore` draws
# fresh random examples (with `--hypothesis-seed=N` to replay one) to look for new failures.
settings.register_profile("repeatable", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))

# The suite runs in two processes (README: `pytest -n 2 --dist loadfile`, pytest-xdist; the tests
# of one file stay in one process, so module fixtures and a file's statistics are not split).
# Each process keeps its own offline kernel cache [choice]: two processes never write or read a
# half-written cached kernel of the other, at the price of compiling a feature set both meet twice.
if os.environ.get("PYTEST_XDIST_WORKER"):
    os.environ["TAICHI_SHELL_MPM_CACHE"] = str(kernel_cache_base() / os.environ["PYTEST_XDIST_WORKER"])

def run_scene(scene, out, *overrides: str):
    """`run SCENE --out OUT --set ...` in this process through the Python API (api.run): for
    tests whose subject is the physics, not the command line (no interpreter start, no
    import per run; the CLI's own behaviour is tested through it elsewhere).  Returns
    `returncode` (the CLI's exit code), `stderr` (its error lines) and `summary` (or None)."""
    import json
    from types import SimpleNamespace

    from taichi_shell_mpm.api import RunFailed, RunInterrupted, run
    from taichi_shell_mpm.checkpoint import CheckpointError
    from taichi_shell_mpm.scene import SceneError
    code, lines = 0, []
    try:
        run(load_scene(Path(scene), list(overrides)), out=out, progress=False)
    except (SceneError, CheckpointError) as exc:
        code, lines = 2, exc.messages
    except (RunFailed, RunInterrupted) as exc:
        code, lines = exc.code, exc.messages
    summary_file = Path(out) / "summary.json"
    summary = json.loads(summary_file.read_text()) if summary_file.is_file() else None
    return SimpleNamespace(returncode=code, stderr="".join(f"error: {' '.join(str(m).split())}\n" for m in lines),
                           stdout="", summary=summary)


PLATE = """
[scene]
name = "plate"
units = "consistent"
[mesh]
kind = "plate"
lx = {lx}
ly = {ly}
nx = {nx}
ny = {ny}
[material]
E = {E}
nu = {nu}
density = {density}
[section]
thickness = {t}
[method]
kind = "{method}"
transfer = "{transfer}"
{method_extra}
[solve]
kind = "{solve}"
end_time = {end_time}
dt_rule = "shell"
{extra}
"""


# Small valid scenes of the generated curved meshes (optional tables at their defaults), shared
# by the parser tests (test_scene.py) and the CLI fuzzing (test_fuzz_run.py).
TUBE_SCENE = """
[scene]
name = "tube"
units = "kN-mm-ms-kg"
[mesh]
kind = "tube"
width = 60
depth = 40
corner_radius = 5
length = 40
n_flat = 2
n_corner = 1
n_length = 4
[material]
E = 200
nu = 0.3
density = 7.85e-6
[section]
thickness = 1
[nodesets.front]
plane = {point = [0, 0, 0], normal = [0, 0, 1]}
[[boundary]]
nodes = "front"
fix = "all"
[[initial]]
velocity = [0, 0, -15]
[solve]
kind = "dynamic"
end_time = 0.1
"""

HEMISPHERE_SCENE = """
[scene]
name = "hemisphere"
units = "consistent"
[mesh]
kind = "hemisphere"
radius = 10
hole_deg = 18
n_around = 4
n_meridian = 3
[material]
E = 6.825e7
nu = 0.3
density = 1
[section]
thickness = 0.04
[nodesets.a]
nearest = [10, 0, 0]
[nodesets.sym_x]
plane = {point = [0, 0, 0], normal = [1, 0, 0]}
[[boundary]]
nodes = "sym_x"
symmetry = "x"
[[load]]
nodes = "a"
force = [200, 0, 0]
[solve]
kind = "static"
"""


def locations(node, found=None) -> list[tuple[object, object]]:
    """Every (container, key) pair in the nested dicts and lists of `node` (for mutating scenes)."""
    found = [] if found is None else found
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, child in items:
        found.append((node, key))
        locations(child, found)
    return found


def write_scene(tmp_path: Path, text: str, name: str = "scene.toml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def plate_scene(tmp_path: Path, *, lx=1.0, ly=1.0, nx=4, ny=4, E=1e4, nu=0.3, t=0.01, method="mpm",
                transfer="apic", method_extra="", solve="dynamic", extra="", overrides=()):
    text = PLATE.format(lx=lx, ly=ly, nx=nx, ny=ny, E=E, nu=nu, density=1.0, t=t, method=method, transfer=transfer,
                        method_extra=method_extra, solve=solve, end_time=1.0, extra=extra)
    return load_scene(write_scene(tmp_path, text), overrides)


def simulation(scene, tmp_path: Path) -> Simulation:
    init_taichi("cpu")
    return Simulation(scene, tmp_path / "out", quiet=True)


def unwarmed_simulation(scene, tmp_path: Path) -> Simulation:
    """A Simulation whose full step is not compiled (Simulation.__init__ compiles it with
    Stepper.compile, which tests driving one stage alone never need and which would triple
    their cold time)."""
    with mock.patch.object(Stepper, "compile", lambda self: None):
        return simulation(scene, tmp_path)


@pytest.fixture
def make_simulation(tmp_path):
    def make(scene):
        return simulation(scene, tmp_path)
    return make


# ------------------------------------------------------------------ one element, its stage alone
ELEMENT = """
[scene]
name = "element"
units = "consistent"
[mesh]
kind = "file"
path = "element.vtu"
[material]
E = {E}
nu = {nu}
density = 1.0
{material}
[section]
thickness = {t}
{section}
[element]
{element}
[method]
kind = "fem"
[solve]
kind = "dynamic"
end_time = 1.0
{solve}
"""


def element_simulation(tmp_path: Path, corners, *, E: float, nu: float, t: float, material: str = "",
                       section: str = "", element: str = "", solve: str = "", quads=None,
                       triangles=None) -> Simulation:
    """A Simulation of the single quad `corners` (4x3, explicit FE) for driving the element stage
    (S7) alone; `material`, `section`, `element` and `solve` are extra TOML lines of those tables
    (:func:`unwarmed_simulation`: the full step is not compiled).  With `quads` (m x 4 node
    ids) and/or `triangles` (k x 3), `corners` are the nodes of a patch of those elements
    instead (elements numbered quads first)."""
    cells = []
    if quads is not None or triangles is None:
        cells.append(("quad", np.array([[0, 1, 2, 3]]) if quads is None else np.asarray(quads)))
    if triangles is not None:
        cells.append(("triangle", np.asarray(triangles)))
    meshio.write(tmp_path / "element.vtu", meshio.Mesh(np.asarray(corners, dtype=float), cells))
    scene = load_scene(write_scene(tmp_path, ELEMENT.format(E=E, nu=nu, t=t, material=material,
                                                            section=section, element=element,
                                                            solve=solve)))
    return unwarmed_simulation(scene, tmp_path)


def element_stage(sim: Simulation, end, velocity, omega, dt: float, steps: int = 1):
    """Element updates (stage S7) of every element from zero stress: the nodes arrive at `end`
    having moved with `velocity`, with nodal angular velocity `omega`; the stage runs `steps`
    times with these rates (stresses, plastic strains, hourglass resultants, drilling moments
    and nodal forces accumulate; the energy accumulators are not reset).  The element loop runs
    serially (the stage's plain scatter-adds of the batched launch).  Returns (stress per
    element and point, nodal internal forces, nodal internal moments, hourglass resultant per
    element, drilling corner moments per element or None)."""
    s = sim.state
    s.put("nodes.position", np.asarray(end, dtype=float))
    s.put("nodes.grid_velocity", np.asarray(velocity, dtype=float))
    s.put("nodes.omega", np.asarray(omega, dtype=float))
    for path in ("points.stress", "points.plastic_strain", "elements.hourglass_resultant", "elements.drilling_moment",
                 "nodes.force_int", "nodes.moment_int"):
        if path in s.arrays_index():
            s.put(path, np.zeros_like(s.fetch(path)))
    s.step.dt[None] = dt
    run = sim.__dict__.get("_element_stage_kernel")
    if run is None:             # one kernel per simulation: a test calling this often compiles it once

        @ti.kernel
        def run():
            for _ in range(1):          # the outermost loop is the parallel one: keep the element loop serial
                sim.stepper.shell.element_pass()

        sim._element_stage_kernel = run
    for _ in range(steps):
        run()
    return (s.fetch("points.stress"), s.fetch("nodes.force_int"), s.fetch("nodes.moment_int"),
            s.fetch("elements.hourglass_resultant"),
            s.fetch("elements.drilling_moment") if "elements.drilling_moment" in s.arrays_index() else None)


def element_pass(sim: Simulation, end, velocity, omega, dt: float, steps: int = 1):
    """:func:`element_stage` of the single quad: returns (stress of element 0 per point, nodal
    internal forces, nodal internal moments, hourglass resultant of element 0)."""
    stress, force, moment, hourglass, _ = element_stage(sim, end, velocity, omega, dt, steps)
    return stress[0], force, moment, hourglass[0]


def pytest_collection_modifyitems(config, items):
    """The whole feature-pair matrix (tests/test_matrix.py, marker `matrix`: a compile per
    pair, about an hour) runs only when asked for with `-m matrix`; the suite runs its CI subset."""
    if "matrix" in (config.option.markexpr or ""):
        return
    kept = [item for item in items if item.get_closest_marker("matrix") is None]
    if len(kept) < len(items):
        config.hook.pytest_deselected(items=[item for item in items if item.get_closest_marker("matrix")])
        items[:] = kept
