"""Issue 32: the Python API (api.py) -- load_scene with overrides, run -> Result (DataFrames,
summary, lazy frames), Result.load, Simulation.advance with arrays, an interrupted run from
Python continued bit-for-bit, README's code blocks, and a lean install (no extras)."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import taichi_shell_mpm as tsm
from taichi_shell_mpm import run_control

from .test_reliability import cli_run

ROOT = Path(__file__).resolve().parents[1]
CANTILEVER = ROOT / "scenes" / "cantilever.toml"
FEM = {"method.kind": "fem", "solve.load_steps": 2}

DRIFT = """
[scene]
name = "drift"
units = "consistent"
[mesh]
kind = "plate"
lx = 2.0
ly = 1.0
nx = 2
ny = 1
[material]
E = 1.0e4
nu = 0.3
density = 1.0
[section]
thickness = 0.05
[method]
kind = "fem"
[[initial]]
velocity = [0.5, -0.25, 1.0]
[[probe]]
name = "corner"
nodes = "all"
components = ["ux", "uz"]
[solve]
kind = "dynamic"
end_time = 0.4
[output]
history_interval = 0.1
"""


def test_load_scene_takes_overrides_and_raises_the_clis_lines(tmp_path):
    scene = tsm.load_scene(CANTILEVER, set={"method.kind": "fem", "mesh.nx": 4, "solve.tolerance": 1e-5})
    assert (scene.method.kind, scene.mesh.nx, scene.solve.tolerance) == ("fem", 4, 1e-5)
    with pytest.raises(tsm.SceneError) as e:
        tsm.load_scene(CANTILEVER, set={"material.nu": 0.5})
    r = cli_run("validate", str(CANTILEVER), "--set", "material.nu=0.5")
    assert r.code == 2
    assert [f"error: {m}" for m in e.value.messages] == r.err.splitlines()
    assert tsm.api.toml_value([1, 2.5, "a", True]) == '[1, 2.5, "a", true]'


def test_run_returns_the_results_as_tables(tmp_path):
    out = tmp_path / "cantilever"
    result = tsm.run(tsm.load_scene(CANTILEVER, set=FEM), out=out, progress=False)
    assert result.summary["steps"] > 0 and not result.summary.get("error")
    probes = result.probes
    text = (out / "probes.csv").read_text().splitlines()
    assert list(probes.columns) == text[0].split(",") and len(probes) == len(text) - 1
    np.testing.assert_array_equal(probes.to_numpy(), np.genfromtxt(out / "probes.csv", delimiter=",", skip_header=1))
    assert "balance_error" in result.energy.columns and len(result.force) == len(probes)
    frames = result.frames
    assert frames.times == [0.5, 1.0]                  # a frame at the end of each load step
    mesh = frames[-1]
    assert mesh.n_points == 22 and "displacement" in mesh.point_data
    again = tsm.Result.load(out)
    assert again.summary == result.summary
    with pytest.raises(FileNotFoundError):
        tsm.Result.load(tmp_path)


def test_simulation_steps_from_python(tmp_path):
    """A free plate drifting at v: positions x0 + v t to round-off at each advance(until=t)
    (the last step of each advance lands on t); then finish() writes the run's tables."""
    path = tmp_path / "drift.toml"
    path.write_text(DRIFT)
    sim = tsm.Simulation(tsm.load_scene(path), out=tmp_path / "drift")
    x0 = sim.positions
    v = np.array([0.5, -0.25, 1.0])
    for t in (0.05, 0.13, 0.2):
        assert sim.advance(until=t) == pytest.approx(t, abs=0.0)
        error = np.abs(sim.positions - (x0 + v * t)).max()
        print(f"t {t}: drift error {error:.2e}")
        assert error < 1e-12
        np.testing.assert_allclose(sim.velocities, np.tile(v, (len(x0), 1)), rtol=0, atol=1e-12)
    assert sim.stresses.shape[:1] == (2,) and np.abs(sim.stresses).max() < 1e-6
    assert set(sim.energies()) >= {"kinetic", "internal"}
    result = sim.finish()
    assert len(result.probes) == 4 and result.probes["time"].iloc[-1] == pytest.approx(0.2, abs=0.0)


def test_an_interrupted_run_continues_bit_for_bit(tmp_path, monkeypatch):
    """KeyboardInterrupt inside run(): RunInterrupted (a KeyboardInterrupt, the CLI's code 130),
    the results so far and a checkpoint; run(restart=...) gives the uninterrupted run's tables."""
    path = tmp_path / "drift.toml"
    path.write_text(DRIFT.replace("[[initial]]", "[nodesets.left]\nplane = {point = [0, 0, 0], normal = [1, 0, 0]}\n"
                                  "[[boundary]]\nnodes = \"left\"\nfix = \"all\"\n[[initial]]"))
    scene = tsm.load_scene(path)
    whole = tsm.run(scene, out=tmp_path / "whole", progress=False)
    monkeypatch.setattr(run_control, "stop_hook", lambda sim: sim.state.step.step[None] >= 40)
    with pytest.raises(KeyboardInterrupt) as e:
        tsm.run(scene, out=tmp_path / "half", progress=False, checkpoint_every=10)
    monkeypatch.setattr(run_control, "stop_hook", None)
    assert isinstance(e.value, tsm.RunInterrupted) and e.value.code == 130
    assert "--restart" in e.value.messages[0] and (tmp_path / "half" / "checkpoint.npz").is_file()
    assert e.value.result.summary["error"] == "interrupted"
    rest = tsm.run(scene, restart=tmp_path / "half", progress=False)
    for table in ("energy.csv", "probes.csv", "force.csv"):
        assert (whole.out / table).read_bytes() == (rest.out / table).read_bytes(), table


def test_readme_code_blocks_run(tmp_path, monkeypatch):
    """Every ```python block of README.md runs as written (from a folder holding scenes/)."""
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)
    assert blocks, "README.md has no python code block"
    (tmp_path / "scenes").symlink_to(ROOT / "scenes")
    monkeypatch.chdir(tmp_path)
    for block in blocks:
        exec(compile(block, "README.md", "exec"), {})


BLOCKED = ("pyvista", "vtk", "matplotlib", "dask", "distributed", "pandas")


def lean(*argv: str, cwd: Path) -> subprocess.CompletedProcess:
    """The CLI in a process where the extras' modules cannot be imported (a core install)."""
    code = ("import sys\nfor m in %r: sys.modules[m] = None\nfrom taichi_shell_mpm.cli import main\n"
            "sys.exit(main(%r))" % (BLOCKED, list(argv)))
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=cwd, timeout=900,
                          env=dict(os.environ, PYTHONPATH=str(ROOT), ENABLE_TAICHI_HEADER_PRINT="false"))


def test_a_core_install_runs_scenes_and_names_the_extra_a_command_needs(tmp_path):
    out = tmp_path / "lean"
    r = lean("run", str(CANTILEVER), "--set", "method.kind=fem", "--set", "solve.load_steps=2", "--out", str(out),
             "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    for argv, extra in ((("render", str(out)), "render"), (("sweep", str(CANTILEVER), "--list"), "sweep")):
        r = lean(*argv, cwd=tmp_path)
        assert r.returncode == 2, r.stderr
        assert r.stderr.splitlines() == [r.stderr.splitlines()[0]] and f'pip install "taichi_shell_mpm[{extra}]"' \
            in r.stderr, r.stderr
    code = ("import sys\nsys.modules['pandas'] = None\nimport taichi_shell_mpm as tsm\n"
            f"tsm.Result.load({str(out)!r}).energy")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=dict(os.environ, PYTHONPATH=str(ROOT)))
    assert r.returncode == 1 and r.stderr.strip().splitlines()[-1].startswith("taichi_shell_mpm.extras.MissingExtra: "
                                                                            "Result tables (DataFrames) needs pandas")
