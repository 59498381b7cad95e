"""No lost work (issue 5.4): ``run --checkpoint-every N`` and ``run --restart DIR`` continue a
run bit-for-bit as if it had never stopped.

Each scene is run three ways, in-process through the CLI: (a) uninterrupted with periodic
checkpoints, (b) stopped part-way exactly as a Ctrl-C stops it (a stop request honoured at
the next batch boundary, here in the middle of a load level / between output times), then
(c) restarted from (b)'s checkpoint into a new directory and (d) restarted in place from
(a)'s last periodic checkpoint.
probes.csv, energy.csv, force.csv and frames.pvd must be byte-for-byte those of (a), and
the final frame's node positions exactly equal.  Batches are made small (monkeypatched
BATCH_ELEMENT_STEPS, the same in every run) so that the stop falls inside a batch sequence.
"""
from __future__ import annotations

import filecmp
import json
import shutil
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np

from taichi_shell_mpm import run_control
from taichi_shell_mpm.solvers import static

from .conftest import ROOT, write_scene
from .test_sweep import env
from .test_reliability import cli_run

TABLES = ("probes.csv", "energy.csv", "force.csv", "frames.pvd")
COMPILE_TIMEOUT = 600     # a run that compiles the tube's kernels on a cold cache (CI) takes minutes

CANTILEVER = [str(ROOT / "scenes" / "cantilever.toml"), "--set", "mesh.nx=4", "--set", "solve.load_steps=4"]

FLAP = """
[scene]
name = "flap"
units = "consistent"
[mesh]
kind = "plate"
lx = 1.0
ly = 1.0
nx = 4
ny = 4
[material]
E = 1e4
nu = 0.3
density = 1.0
[section]
thickness = 0.02
[method]
kind = "mpm"
cell_size = 0.125
[nodesets.edge]
plane = {point = [0, 0, 0], normal = [1, 0, 0]}
[nodesets.tip]
plane = {point = [1, 0, 0], normal = [1, 0, 0]}
[[boundary]]
nodes = "edge"
fix = "all"
[[load]]
nodes = "tip"
force = [0.0, 0.0, 2e-3]
[[initial]]
velocity = [0.0, 0.05, 0.2]
[[probe]]
name = "tip"
nodes = "tip"
components = ["ux", "uz", "ry"]
[solve]
kind = "dynamic"
end_time = 2.0
[output]
times = [0.5, 1.0, 1.5]
history_interval = 0.1
"""


def last_frame_points(out: Path) -> np.ndarray:
    files = [d.get("file") for d in ET.parse(out / "frames.pvd").getroot().iter("DataSet")]
    return meshio.read(out / files[-1]).points


def assert_same_run(a: Path, b: Path) -> None:
    for name in TABLES:
        assert filecmp.cmp(a / name, b / name, shallow=False), f"{name} differs between {a.name} and {b.name}"
    pa, pb = last_frame_points(a), last_frame_points(b)
    assert np.array_equal(pa, pb), np.abs(pa - pb).max()
    sa, sb = (json.loads((d / "summary.json").read_text()) for d in (a, b))
    assert sa["steps"] == sb["steps"] and sa["energies"] == sb["energies"]


def position_of(out: Path) -> dict:
    with np.load(out / "checkpoint.npz") as data:
        return json.loads(data["meta"].tobytes())["position"]


def restart_roundtrip(tmp_path, monkeypatch, scene_args, stop_step, every, batch_element_steps):
    monkeypatch.setattr(static, "BATCH_ELEMENT_STEPS", batch_element_steps)
    a, b, d = tmp_path / "a", tmp_path / "b", tmp_path / "d"       # d: restarted in place
    r = cli_run("run", *scene_args, "--out", str(a), "--quiet", "--checkpoint-every", str(every),
                timeout=COMPILE_TIMEOUT)
    assert r.code == 0, r.err
    steps = json.loads((a / "summary.json").read_text())["steps"]
    monkeypatch.setattr(run_control, "stop_hook", lambda sim: sim.state.step.step[None] >= stop_step)
    r = cli_run("run", *scene_args, "--out", str(b), "--quiet", timeout=COMPILE_TIMEOUT)
    monkeypatch.setattr(run_control, "stop_hook", None)
    assert r.code == 130, r.err
    assert r.err.startswith("error: interrupted at") and "--restart" in r.err, r.err
    stopped = position_of(b)
    summary_b = json.loads((b / "summary.json").read_text())
    assert summary_b["error"] == "interrupted"
    shutil.copytree(a, d)
    periodic = position_of(d)
    c = tmp_path / "c"           # continue into another directory: the frames so far are copied
    r = cli_run("run", *scene_args, "--restart", str(b), "--out", str(c), "--quiet", timeout=COMPILE_TIMEOUT)
    assert r.code == 0, r.err
    assert_same_run(a, c)
    r = cli_run("run", *scene_args, "--restart", str(d), "--quiet", timeout=COMPILE_TIMEOUT)
    assert r.code == 0, r.err
    assert_same_run(a, d)
    print(f"\n{steps} steps; stopped at {stopped} and restarted, and restarted from the periodic "
          f"checkpoint at {periodic}: tables byte-identical, final positions identical")
    return stopped, periodic


def test_static_restart_is_bit_for_bit(tmp_path, monkeypatch):
    # 4 elements, 2000-step batches: the stop falls inside a load level (which one depends on
    # how fast the relaxation converges), so the restart resumes a level half done
    stopped, periodic = restart_roundtrip(tmp_path, monkeypatch, CANTILEVER, stop_step=7000, every=5000,
                                          batch_element_steps=8000)
    assert stopped["started"] and 0 < stopped["steps"]
    # a level resumed half done measures its increment from the last converged level, not from
    # where it stopped: no false "jumped to a remote branch" warning (issue 28 item 12)
    warnings = {d: json.loads((tmp_path / d / "summary.json").read_text())["warnings"] for d in "acd"}
    print(warnings)
    assert warnings["c"] == warnings["a"] == warnings["d"]
    assert not any("jumped" in w for w in warnings["c"])


def test_dynamic_restart_is_bit_for_bit(tmp_path, monkeypatch):
    scene = write_scene(tmp_path, FLAP, "flap.toml")
    # 16 elements, 250-step batches
    stopped, periodic = restart_roundtrip(tmp_path, monkeypatch, [str(scene)], stop_step=1100, every=700,
                                          batch_element_steps=4000)
    assert stopped["event"] > 0


def test_a_restarted_run_gives_its_warnings_once(tmp_path, monkeypatch):
    """A warning given once per run (here the energy balance warning: --energy-limit 1e-3
    warns above 2e-4 of the energy absorbed, which the flap passes at t ~ 1.7, max 5.4e-4)
    before the stop is not given again, at another time, after the restart: summary.json's
    warnings are those of the uninterrupted run."""
    scene = write_scene(tmp_path, FLAP, "flap.toml")
    restart_roundtrip(tmp_path, monkeypatch, [str(scene), "--energy-limit", "1e-3"], stop_step=1900, every=700,
                      batch_element_steps=4000)
    warnings = {d: json.loads((tmp_path / d / "summary.json").read_text())["warnings"] for d in "acd"}
    print(warnings)
    assert warnings["c"] == warnings["a"] == warnings["d"]          # none repeated after the restart, none lost
    assert sum("energy balance error" in w for w in warnings["c"]) == 1


def test_restart_refuses_a_missing_or_foreign_checkpoint(tmp_path):
    r = cli_run("run", *CANTILEVER, "--restart", str(tmp_path / "nowhere"))
    print(r.err)
    assert r.code == 2 and r.err.startswith("error: --restart") and "Traceback" not in r.err
    out = tmp_path / "run"
    r = cli_run("run", *CANTILEVER, "--set", "solve.load_steps=1", "--out", str(out), "--quiet",
                "--checkpoint-every", "1000")
    assert r.code == 0 and (out / "checkpoint.npz").is_file()
    r = cli_run("run", *CANTILEVER, "--set", "solve.load_steps=1", "--set", "material.E=1.3e6",
                "--restart", str(out))
    print(r.err)
    assert r.code == 2 and "checkpoint was written for a different scene" in r.err
    # display-only keys (checkpoint.DISPLAY_ONLY) are no part of the identity: accepted (and the
    # run is finished, so there is nothing to do)
    r = cli_run("run", *CANTILEVER, "--set", "solve.load_steps=1", "--set", "solve.progress_every=30",
                "--set", "scene.description=another text", "--restart", str(out))
    print(r.out, r.err)
    assert r.code == 0 and "nothing to do" in r.out, r.err
    (out / "checkpoint.npz").write_bytes(b"not a checkpoint")
    r = cli_run("run", *CANTILEVER, "--set", "solve.load_steps=1", "--restart", str(out))
    print(r.err)
    assert r.code == 2 and "cannot read the checkpoint" in r.err and len(r.err.splitlines()) == 1


def test_sigterm_stops_like_ctrl_c_and_the_run_continues(tmp_path):
    """`timeout` or a batch scheduler's wall-time limit sends SIGTERM: the run (a subprocess
    of the CLI; 100 load levels of the 4-element cantilever, ~300 000 steps) stops at the
    next batch boundary as on Ctrl-C: exit 143, checkpoint, probes.csv and summary.json of
    the converged levels, the restart command; --restart then finishes it."""
    out = tmp_path / "run"
    args = [*CANTILEVER, "--set", "solve.load_steps=100"]
    proc = subprocess.Popen([sys.executable, "-m", "taichi_shell_mpm", "run", *args, "--out", str(out), "--quiet"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env())
    deadline = time.perf_counter() + COMPILE_TIMEOUT
    while len(list((out / "frames").glob("frame_*.vtu"))) < 2 and proc.poll() is None \
            and time.perf_counter() < deadline:        # two load levels converged
        time.sleep(0.02)
    proc.send_signal(signal.SIGTERM)
    t0 = time.perf_counter()
    _, err = proc.communicate(timeout=120)
    levels = len((out / "probes.csv").read_text().splitlines()) - 1
    print(err, f"stopped {time.perf_counter() - t0:.2f} s after SIGTERM with {levels} load levels recorded")
    assert proc.returncode == 143, err
    assert len(err.splitlines()) == 1 and err.startswith("error: interrupted (SIGTERM) at load factor"), err
    assert f"--restart {out}" in err and "Traceback" not in err
    assert (out / "checkpoint.npz").is_file() and 2 <= levels < 100
    assert json.loads((out / "summary.json").read_text())["error"] == "interrupted"
    before = (out / "probes.csv").read_text().splitlines()
    r = cli_run("run", *args, "--restart", str(out), "--quiet", timeout=COMPILE_TIMEOUT)
    assert r.code == 0, r.err
    after = (out / "probes.csv").read_text().splitlines()
    assert len(after) == 101 and after[:len(before)] == before


def test_checkpoint_arrays_are_the_fields_read_one_by_one(tmp_path):
    """State.arrays reads a checkpoint's fields a batch of a dtype per kernel and State.restore
    writes them back so (issue 32: one kernel per field cost ~7 ms each in every run): the
    arrays are those State.read gives field by field (dtype, shape and bytes), and a restore
    of changed arrays, then of the first ones, reads back exactly."""
    from taichi_shell_mpm.scene import load_scene

    from .conftest import simulation
    sim = simulation(load_scene(write_scene(tmp_path, FLAP, "flap.toml")), tmp_path)
    assert sim.stepper.advance(20) == 20
    s = sim.state
    arrays = s.arrays()
    fields = {f"{g}.{n}": (f, size) for g, group in s.groups().items() for n, (f, size) in group.fields(True).items()}
    assert arrays.keys() == fields.keys()
    kinds = {}          # one field of each kind (dtype, dimensions, components: a kernel each to read one by one)
    for key, (f, size) in fields.items():
        kinds.setdefault((f.dtype, len(f.shape), getattr(f, "n", 0), getattr(f, "m", 0)), key)
    one_by_one = {key: np.asarray(s.read(*fields[key]) if fields[key][1] is not None else fields[key][0].to_numpy())
                  for key in kinds.values()}
    print(f"\n{len(arrays)} arrays, {sum(a.size for a in arrays.values())} numbers; {len(kinds)} kinds compared")
    for key, a in one_by_one.items():
        b = arrays[key]
        assert (b.dtype, b.shape, b.tobytes()) == (a.dtype, a.shape, a.tobytes()), key
    changed = {k: a + 1 if a.dtype.kind == "f" else a for k, a in arrays.items()}
    s.restore(changed)
    assert all(np.array_equal(s.arrays()[k], changed[k]) for k in arrays)
    s.restore(arrays)
    back = s.arrays()
    assert all(back[k].tobytes() == arrays[k].tobytes() for k in arrays)
