"""Reliability (issue 5.3, 5.5, 5.1): run-time guards, Ctrl-C, progress and summary, and
``validate``/``run`` reporting every scene problem at once.

Each guard has a scene built to trigger it (a 2x2 or 1x1 plate, explicit FE unless the grid
is the point).  For each: exit code 3, exactly one stderr line naming the time, the step,
the element or node and a likely cause; frames.pvd is well-formed XML, every frame it lists
is readable by meshio and finite; probes.csv, energy.csv and summary.json (with "error")
are written.  All runs are in-process through :func:`taichi_shell_mpm.cli.main`.
"""
from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import signal
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import meshio
import numpy as np
import pytest

from taichi_shell_mpm import run_control
from taichi_shell_mpm.cli import main
from taichi_shell_mpm.progress import Progress, format_summary

from .conftest import HEMISPHERE_SCENE, ROOT, write_scene


# ------------------------------------------------------------------ helpers (also used by the other new tests)
@dataclass
class CliResult:
    code: int
    out: str
    err: str


class Hang(Exception):
    pass


def cli_run(*args: str, timeout: int = 600) -> CliResult:
    """`python -m taichi_shell_mpm ARGS` in-process: exit code, stdout, stderr; raises Hang
    after `timeout` seconds."""
    out, err = io.StringIO(), io.StringIO()

    def alarm(signum, frame):
        raise Hang(f"{' '.join(args)} did not return within {timeout} s")

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(timeout)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main(list(args))
            except SystemExit as exc:          # argparse
                code = exc.code
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    return CliResult(code, out.getvalue(), err.getvalue())


def assert_clean_output(r: CliResult) -> None:
    """No traceback anywhere, and every stderr line is an 'error: ' line."""
    assert "Traceback" not in r.out + r.err, r.out + r.err
    for line in r.err.splitlines():
        assert line.startswith("error: "), line


def assert_output_directory_valid(out: Path) -> list[float]:
    """frames.pvd parses, each listed frame reads with meshio and is finite; returns the keys."""
    root = ET.parse(out / "frames.pvd").getroot()
    keys = []
    for ds in root.iter("DataSet"):
        mesh = meshio.read(out / ds.get("file"))
        assert np.isfinite(mesh.points).all()
        for name, data in mesh.point_data.items():
            assert np.isfinite(data).all(), name
        keys.append(float(ds.get("timestep")))
    assert keys and keys == sorted(keys)
    assert not list(out.glob("**/.*.vtu")) and not list(out.glob(".*")), "temporary files left"
    for name in ("probes.csv", "energy.csv", "force.csv"):
        with open(out / name) as fh:
            rows = list(csv.reader(fh))
        assert len(rows) >= 1
    return keys


PLATE = """
[scene]
name = "guard"
units = "consistent"
[mesh]
kind = "plate"
lx = 1.0
ly = 1.0
nx = {nx}
ny = {nx}
[material]
E = 1e4
nu = 0.3
density = 1.0
[section]
thickness = 0.05
[method]
kind = "{method}"
{method_extra}
[solve]
kind = "{solve}"
end_time = {end}
dt_safety = {safety}
load_steps = 2
{extra}
"""
CLAMP = """
[nodesets.edge]
plane = {point = [0, 0, 0], normal = [1, 0, 0]}
[[boundary]]
nodes = "edge"
fix = "all"
"""
CENTRE = """
[nodesets.centre]
nearest = [0.5, 0.5, 0]
"""


def plate(tmp_path, name, *, nx=2, method="fem", method_extra="", solve="dynamic", end=1.0, safety=0.9, extra=""):
    return write_scene(tmp_path, PLATE.format(nx=nx, method=method, method_extra=method_extra, solve=solve,
                                              end=end, safety=safety, extra=extra), f"{name}.toml")


GUARDS = {
    # name: (scene keywords, words the message must contain)
    "inverted": (dict(safety=1.0, extra=CLAMP + CENTRE + '[[load]]\nnodes = "centre"\nforce = [-1000, 0, 0]\n'),
                 ["element", "turned inside out", "time step too large"]),
    "runaway": (dict(extra=CLAMP + '[[initial]]\nvelocity = [0, 0, 1e5]\n'),
                ["node", "non-finite or runaway velocity", "instability"]),
    "nan": (dict(extra=CLAMP + CENTRE + '[[load]]\nnodes = "centre"\nforce = [0, 0, 1e300]\n'),
            ["node", "non-finite or runaway velocity"]),
    "dt_collapse": (dict(nx=1, end=5.0, extra='[nodesets.a]\nids = [0]\n[nodesets.b]\nids = [3]\n'
                         '[[load]]\nnodes = "a"\nforce = [100, 100, 0]\n[[load]]\nnodes = "b"\nforce = [-100, -100, 0]\n'),
                    ["time step collapsed", "element 0", "crushed or badly distorted"]),
    "left_grid": (dict(method="mpm", method_extra="cell_size = 0.25\ngrid_min = [-0.1, -0.1, -0.1]\n"
                                                  "grid_max = [1.1, 1.1, 0.1]",
                       extra='[[initial]]\nvelocity = [0, 0, 10]\n'),
                  ["node", "left the background grid", "grid_min/grid_max"]),
    "hourglass": (dict(nx=1, solve="static", extra='[nodesets.a]\nids = [0, 3]\n[nodesets.b]\nids = [1, 2]\n'
                       '[[load]]\nnodes = "a"\nforce = [0, 0, 1e-3]\n[[load]]\nnodes = "b"\nforce = [0, 0, -1e-3]\n'),
                  ["hourglass and drilling energy", "zero-energy modes", "[element].hourglass", "load factor"]),
}


@pytest.mark.parametrize("guard", list(GUARDS))
def test_guard_stops_cleanly(tmp_path, guard):
    kwargs, words = GUARDS[guard]
    scene = plate(tmp_path, guard, **kwargs)
    out = tmp_path / "out"
    # the collapsing element's energy balance fails (42 % at step 2) before its step collapses:
    # this case is about the time-step guard, the balance guard has tests/test_energy.py
    more = ("--energy-limit", "0") if guard == "dt_collapse" else ()
    r = cli_run("run", str(scene), "--out", str(out), "--quiet", *more)
    print(f"\n{guard}: exit {r.code}: {r.err.strip()}")
    assert r.code == 3
    assert_clean_output(r)
    lines = r.err.splitlines()
    assert len(lines) == 1
    message = lines[0][len("error: "):]
    for word in words + ["t=", "step "]:
        assert word in message, (word, message)
    keys = assert_output_directory_valid(out)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["error"] == message
    print(f"  frames {keys}; summary error recorded; {len(keys)} finite frames readable")
    # the failing state (finite or not) is no frame: the last good one stays last (issue 16.10: a
    # finite failing state was written as the last frame); a static run that fails in its first
    # level ("hourglass") gets the undeformed shell at load factor 0 as its only frame
    assert keys == [0.0]
    if guard == "hourglass":
        mesh = meshio.read(out / "frames" / "frame_00000.vtu")
        assert not np.any(mesh.point_data["displacement"])


@pytest.mark.parametrize("guard, status", [("inverted", "STATUS_INVERTED"), ("dt_collapse", "STATUS_DT_COLLAPSE")])
def test_kernel_flags_the_guard_itself(tmp_path, guard, status):
    """The in-kernel check (not only the host's refinement in check_status) catches the problem,
    and a later check of the same step does not overwrite it: an element folding over is flagged
    by its corner Jacobians (its BT area is >= 0 by construction), the time-step collapse only
    when nothing was flagged before."""
    from taichi_shell_mpm import state as state_module
    from taichi_shell_mpm.scene import load_scene
    from taichi_shell_mpm.simulation import Simulation, SimulationError
    from taichi_shell_mpm.runtime import init_taichi
    from taichi_shell_mpm.solvers.dynamic import run_dynamic
    kwargs, _ = GUARDS[guard]
    init_taichi("cpu")
    sim = Simulation(load_scene(plate(tmp_path, guard, **kwargs)), tmp_path / "out", quiet=True)
    if guard == "dt_collapse":
        sim.energy_limit = 0          # its balance fails first (see test_guard_stops_cleanly)
    raw = []
    host_check = sim.check_status

    def record():
        if sim.state.step.status[None] != state_module.STATUS_OK and not raw:
            raw.append((sim.state.step.status[None], sim.state.step.status_index[None], sim.state.step.step[None]))
        host_check()

    sim.check_status = record
    with pytest.raises(SimulationError) as caught:
        run_dynamic(sim, run_control.RunControl(0))
    print(f"\n{guard}: kernel status/index/step {raw}; {caught.value}")
    assert raw and raw[0][0] == getattr(state_module, status)
    if guard == "inverted":
        assert f"element {raw[0][1]} turned inside out" in str(caught.value)


def test_hourglass_warning_then_stop(tmp_path, capsys):
    """E_hg/E_int above 10%: one warning; above 20%: SimulationError; not before E_int matters."""
    from taichi_shell_mpm.scene import load_scene
    from taichi_shell_mpm.simulation import Simulation, SimulationError
    from taichi_shell_mpm.runtime import init_taichi
    init_taichi("cpu")
    sim = Simulation(load_scene(plate(tmp_path, "hg", extra=CLAMP)), tmp_path / "out", quiet=True)
    s = sim.state
    s.step.external_work[None] = 1.0
    s.step.internal_energy[None], s.step.hourglass_energy[None] = 1e-7, 1e-7       # E_int not yet meaningful
    sim.check_status()
    s.step.internal_energy[None], s.step.hourglass_energy[None] = 1.0, 0.05
    sim.check_status()
    assert not sim.warnings
    s.step.hourglass_energy[None] = 0.15
    sim.check_status()
    sim.check_status()
    assert len(sim.warnings) == 1 and "15% of the internal energy" in sim.warnings[0]
    s.step.hourglass_energy[None] = 0.25
    with pytest.raises(SimulationError, match="hourglass and drilling energy is 25% of the internal energy"):
        sim.check_status()
    printed = capsys.readouterr().out
    print(printed)
    assert printed.count("warning: hourglass and drilling energy") == 1


def test_ctrl_c_stops_cleanly(tmp_path, monkeypatch):
    """A real SIGINT mid-run: stop at the next batch boundary, checkpoint, last frame, exit 130."""
    scene = plate(tmp_path, "flap", method="mpm", method_extra="cell_size = 0.25", end=3.0,
                  extra=CLAMP + "[output]\ntimes = [0.5, 1.0, 1.5, 2.0, 2.5]\n[[initial]]\nvelocity = [0, 0, 0.1]\n")
    sent = []

    def press_ctrl_c(sim):
        if sim.state.step.time[None] > 1.2 and not sent:
            sent.append(sim.state.step.step[None])
            os.kill(os.getpid(), signal.SIGINT)
        return False

    from taichi_shell_mpm.solvers import static
    monkeypatch.setattr(static, "BATCH_ELEMENT_STEPS", 400)     # 100-step batches
    monkeypatch.setattr(run_control, "stop_hook", press_ctrl_c)
    # Python's own Ctrl-C handler, as in a terminal: a suite started in the background from a
    # non-interactive shell inherits SIGINT ignored, which the run rightly leaves alone
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    out = tmp_path / "out"
    # the 2x2 flap hourglasses (E_hg/E_int 20 % at t = 1.39 with the kirchhoff w-rate): not
    # what this test is about, so no hourglass stop
    try:
        r = cli_run("run", str(scene), "--out", str(out), "--quiet", "--hourglass-limit", "0")
    finally:
        signal.signal(signal.SIGINT, previous)
    print(f"\nSIGINT at step {sent}: exit {r.code}: {r.err.strip()}")
    assert r.code == 130 and sent
    assert_clean_output(r)
    assert len(r.err.splitlines()) == 1 and "--restart" in r.err
    keys = assert_output_directory_valid(out)
    assert keys[:3] == [0.0, 0.5, 1.0] and 1.2 < keys[-1] <= 1.5, keys
    assert json.loads((out / "summary.json").read_text())["error"] == "interrupted"
    assert (out / "checkpoint.npz").is_file()


# ------------------------------------------------------------------ progress and summary
def test_progress_plain_lines_when_not_a_terminal():
    stream = io.StringIO()
    p = Progress(every=0.0, stream=stream)
    assert not p.tty
    p.start(0, 0.0)
    for i in range(1, 4):
        p.show(f"t {i}/4", 100 * i, 1e-3, 1e-5, i / 4)
    p.line("load step 1/4 done")
    text = stream.getvalue()
    print(text)
    assert "\r" not in text and len(text.splitlines()) == 4
    assert "steps/s" in text and "ETA" in text and "balance 1.0e-05" in text


def test_progress_live_line_on_a_terminal():
    stream = io.StringIO()
    p = Progress(every=2.0, stream=stream, tty=True)
    assert p.every < 1.0            # the live line refreshes faster than the plain lines
    p.start(0, 0.0)
    p.show("load step 1/20", 1000, 1e-4, 2e-6, 0.05)
    p.show("load step 2/20", 2000, 1e-4, 2e-6, 0.10)
    assert "\n" not in stream.getvalue() and stream.getvalue().count("\r") == 2
    p.warn("something")
    p.close()
    text = stream.getvalue()
    print(repr(text))
    assert text.endswith("warning: something\n")
    quiet = io.StringIO()
    q = Progress(quiet=True, stream=quiet, tty=True)
    q.show("x", 1, 1.0, 0.0, 0.5)
    q.line("y")
    assert quiet.getvalue() == ""


def test_summary_table_handles_everything():
    summary = {"scene": "s", "steps": 1234567, "load_steps": 20, "elements": 10, "nodes": 22, "method": "mpm",
               "launch": "batched", "arch": "cpu", "compile_seconds": 3.2, "run_seconds": 1.5,
               "us_per_element_step": 1.2,
               "energies": {"kinetic": 1.0, "internal": None, "hourglass": float("nan"), "external_work": 2.0,
                            "damped": 0.0, "balance_error": 1e-6},
               "reference": {"missing_levels": [], "columns": {"W": {"mean_rel_error": 0.01, "max_rel_error": None}}},
               "crush": {"crush_distance": 200.0, "peak_support_force": 30.0, "mean_crush_force": 8.0,
                         "mean_force_window": [20, 200], "folds": 3, "lobes": 3, "half_wavelength": None,
                         "energy_balance_error_max": 0.01, "hourglass_over_internal": 0.02},
               "error": "interrupted"}
    table = format_summary(summary)
    print(table)
    assert "1 234 567 in 20 load steps" in table and "mean crush force" in table and "1.00 %" in table
    table.encode("ascii")


def test_quiet_prints_only_the_summary_and_plain_progress_otherwise(tmp_path):
    # in fem: the kernels of the "hourglass" guard's static plate above (the same Features), so
    # no compile of its own
    args = ["run", str(ROOT / "scenes" / "cantilever.toml"), "--set", "mesh.nx=4", "--set", "solve.load_steps=2",
            "--set", "method.kind=fem"]
    quiet = cli_run(*args, "--out", str(tmp_path / "q"), "--quiet")
    assert quiet.code == 0
    assert_clean_output(quiet)
    lines = [line for line in quiet.out.splitlines() if not line.startswith("[Taichi]")]
    print("\n".join(lines))
    assert lines[0] == "summary: cantilever" and "us / element-step" in quiet.out
    assert "load step   1/2" not in quiet.out and "kernels ready" not in quiet.out
    loud = cli_run(*args, "--set", "solve.progress_every=0.0", "--out", str(tmp_path / "l"))
    assert loud.code == 0
    print(loud.out)
    assert "kernels ready" in loud.out and "load step   2/2" in loud.out and "\r" not in loud.out
    assert "summary: cantilever" in loud.out


# ------------------------------------------------------------------ every problem at once
def test_validate_and_run_report_all_assembly_problems(tmp_path):
    scene = plate(tmp_path, "many", method="mpm", method_extra="grid_min = [0.2, 0, -1]\ngrid_max = [1, 1, 1]",
                  extra=CLAMP + """
[nodesets.far]
plane = {point = [5, 0, 0], normal = [1, 0, 0]}
[nodesets.nothing]
box = {min = [3, 3, 3], max = [4, 4, 4]}
[[load]]
nodes = "edge"
force = [0, 0, 1]
[[load]]
nodes = "far"
force = [0, 0, 1]
[[probe]]
name = "p"
nodes = "nothing"
[nodesets.off]
nearest = [0.5, 0.5, 3]
[[probe]]
name = "q"
nodes = "off"
""")
    for command in ("validate", "run"):
        r = cli_run(command, str(scene), *(["--out", str(tmp_path / "o")] if command == "run" else []))
        print(f"\n{command}: exit {r.code}\n{r.err}")
        assert r.code == 2
        assert_clean_output(r)
        lines = r.err.splitlines()
        assert all(line.startswith("error: many.toml: ") for line in lines)
        text = r.err
        assert "nodeset 'far'" in text and "nodeset 'nothing'" in text
        assert "every node of the set has all translations fixed" in text
        assert "grid box does not cover the mesh" in text
        assert "nodeset 'off' (nearest point=[0.5,0.5,3]): the point lies outside the mesh" in text
        assert len(lines) == 5
    assert not (tmp_path / "o").exists()


def test_scene_and_mesh_problems_are_reported_together(tmp_path):
    """A mistake in [material] does not hide one in the mesh: both lines, exit 2."""
    scene = write_scene(tmp_path, HEMISPHERE_SCENE, "hemi.toml")
    for command in ("validate", "run"):
        r = cli_run(command, str(scene), "--set", "material.E=0", "--set", "mesh.quarter=false",
                    "--set", "mesh.n_around=2", *(["--out", str(tmp_path / "o")] if command == "run" else []))
        print(r.err)
        assert r.code == 2
        assert_clean_output(r)
        assert r.err.splitlines() == [
            "error: hemi.toml: [material].E: expected a number > 0, got 0",
            "error: hemi.toml: [mesh] hemisphere: a full hemisphere needs n_around >= 3, got 2"]


def test_load_partly_on_fixed_nodes_warns(tmp_path):
    """A load spread over a set that includes clamped nodes: validate warns with the share lost."""
    scene = plate(tmp_path, "partly", extra=CLAMP + '[[load]]\nnodes = "all"\nforce = [0, 0, 1]\ndistribute = "equal"\n')
    r = cli_run("validate", str(scene))
    print(r.out)
    assert r.code == 0 and r.err == ""
    assert ("warning: partly.toml: [[load]][0] on 'all': 3 of 9 nodes have all translations fixed; "
            "the 33.3% of the force spread onto them does nothing") in r.out


def test_unwritable_output_directory(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    r = cli_run("run", str(ROOT / "scenes" / "cantilever.toml"), "--out", str(blocker / "sub"))
    print(r.err)
    assert r.code == 2 and r.err.startswith("error: --out") and len(r.err.splitlines()) == 1
