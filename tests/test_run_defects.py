"""Run-time and output defects (issue 16, items 8-15 and 18), through the command line.

Each test runs the public CLI in-process (:func:`tests.test_reliability.cli_run`) on a tiny
scene (the 4-element cantilever with 2 load levels, or the 2x2 FE plate of the guard tests,
whose kernels the rest of the suite compiles too) and checks the exit code, the one-line
messages and what is left in the output directory.
"""
from __future__ import annotations

import errno
import json
import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from taichi_shell_mpm import output
from taichi_shell_mpm.progress import format_seconds

from .conftest import ROOT, write_scene
from .test_reliability import CLAMP, assert_clean_output, assert_output_directory_valid, cli_run, plate

CANTILEVER = str(ROOT / "scenes" / "cantilever.toml")
SMALL = ["--set", "mesh.nx=4", "--set", "solve.load_steps=2"]


def summary_of(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


def frame_keys(out: Path) -> list[float]:
    return [float(d.get("timestep")) for d in ET.parse(out / "frames.pvd").getroot().iter("DataSet")]


# ------------------------------------------------------------------ 8, 9: the reference table
def test_dynamic_run_skips_the_static_reference(tmp_path):
    """Item 8: a dynamic run of a scene whose reference is keyed by load level ended in an
    internal error (max of an empty array); now the comparison is skipped with a warning."""
    out = tmp_path / "dyn"
    # in fem: the kernels of the write-failure tests' dynamic plate below (the same Features)
    args = [CANTILEVER, *SMALL, "--set", "solve.kind=dynamic", "--set", "solve.end_time=0.002",
            "--set", "method.kind=fem"]
    r = cli_run("validate", *args)
    assert r.code == 0 and "warning: cantilever.toml: [reference] (cantilever_end_shear.csv) is keyed by load " \
                           "level ('P_over_Pmax'), which only a static solve records" in r.out, r.out + r.err
    r = cli_run("run", *args, "--out", str(out), "--quiet")
    print(r.out, r.err)
    assert r.code == 0, r.err
    assert_clean_output(r)
    assert r.out.count("warning: cantilever.toml: [reference]") == 1
    summary = summary_of(out)
    assert "comparison is skipped" in summary["reference"]["skipped"] and "columns" not in summary["reference"]
    assert any("comparison is skipped" in w for w in summary["warnings"])


def test_reference_with_a_bad_cell_fails_validation(tmp_path):
    """Item 9: a non-numeric cell passed `validate` and crashed the run at its end (exit 1)."""
    shutil.copy(CANTILEVER, tmp_path / "c.toml")
    (tmp_path / "data").mkdir()
    rows = (ROOT / "scenes" / "data" / "cantilever_end_shear.csv").read_text().splitlines()
    rows[3] = ",".join(rows[3].split(",")[:-1] + ["0.6x"])           # W_tip of the third data row
    (tmp_path / "data" / "cantilever_end_shear.csv").write_text("\n".join(rows) + "\n")
    for command in ("validate", "run"):
        r = cli_run(command, str(tmp_path / "c.toml"), *(["--out", str(tmp_path / "o")] if command == "run" else []))
        print(r.err)
        assert r.code == 2
        assert_clean_output(r)
        assert r.err == ("error: c.toml: [reference].file: cantilever_end_shear.csv line 4, column 'W_tip': "
                         "expected a finite number, got '0.6x'\n")
    assert not (tmp_path / "o").exists()


# ------------------------------------------------------------------ 10, 15: a failed run's frames and summary
def test_static_failure_keeps_the_last_converged_frame_and_counts_its_steps(tmp_path, monkeypatch):
    """Items 10 and 15: a run-time failure in load level 2 leaves the frame of level 1 as the
    last one (the failing state was written, labelled with the failing load factor), and the
    summary counts every step taken, those of the failed level too (it said 0 steps and
    93 551 us per element-step after a failure in the first level)."""
    from taichi_shell_mpm.simulation import Simulation, SimulationError
    original = Simulation.check_status

    def failing(sim):
        if sim.state.step.load_factor[None] == 1.0:
            raise SimulationError(f"a test failure at {sim.where()}")
        original(sim)

    monkeypatch.setattr(Simulation, "check_status", failing)
    out = tmp_path / "fail2"
    r = cli_run("run", CANTILEVER, *SMALL, "--out", str(out), "--quiet")
    print(r.err)
    assert r.code == 3 and r.err.startswith("error: a test failure at load factor 1, ")
    assert_clean_output(r)
    assert assert_output_directory_valid(out) == [0.5]
    summary = summary_of(out)
    step = int(r.err.split("step ")[-1])
    assert summary["steps"] == step        # before: only the steps of level 1
    assert len((out / "probes.csv").read_text().splitlines()) == 2      # header, level 1
    assert summary["us_per_element_step"] == pytest.approx(1e6 * summary["run_seconds"] / (4 * step))


def test_static_non_convergence_in_the_first_level(tmp_path):
    """Items 8, 10, 15: 100 steps of level 1 and no convergence: steps 100 in the summary, the
    undeformed shell at load factor 0 as the only frame (no frame of the unconverged state
    labelled 0.5), the reference compared with nothing: a warning, not a crash."""
    out = tmp_path / "nc"
    r = cli_run("run", CANTILEVER, *SMALL, "--set", "solve.max_steps_per_load_step=100", "--out", str(out),
                "--quiet")
    print(r.out, r.err)
    assert r.code == 3 and "did not converge in 100 steps" in r.err and len(r.err.splitlines()) == 1
    assert_clean_output(r)
    assert assert_output_directory_valid(out) == [0.0]
    summary = summary_of(out)
    assert summary["steps"] == 100
    assert summary["us_per_element_step"] == pytest.approx(1e6 * summary["run_seconds"] / 400)
    assert summary["reference"]["matched"] == 0 and summary["reference"]["columns"]["W_tip"]["mean_rel_error"] is None
    assert "none of its 20 load levels was reached" in r.out


# ------------------------------------------------------------------ 11: a write failure
def _failing_writes(monkeypatch, fail_from: int, fail_to: int) -> list[Path]:
    """atomic_write raises OSError(ENOSPC) on calls fail_from..fail_to (1-based)."""
    calls: list[Path] = []
    real = output.atomic_write

    def atomic_write(path, write):
        calls.append(Path(path))
        if fail_from <= len(calls) <= fail_to:
            raise output.OutputError(path, OSError(errno.ENOSPC, os.strerror(errno.ENOSPC)))
        real(path, write)

    monkeypatch.setattr(output, "atomic_write", atomic_write)
    return calls


FLAP = CLAMP + "[output]\ntimes = [0.1, 0.2]\n[[initial]]\nvelocity = [0, 0, 0.1]\n"


@pytest.mark.parametrize("disk", ["full", "once"])
def test_write_failure_is_a_run_time_failure(tmp_path, monkeypatch, disk):
    """Item 11: a write failure (disk full) was reported as a bug (exit 1) and the tables and
    summary were lost.  Now exit 3, one line naming the file; the frames already written stay
    valid; with the disk full nothing more can be written, after a single failure the tables and
    summary are."""
    scene = plate(tmp_path, "disk", end=0.3, extra=FLAP)
    out = tmp_path / disk
    calls = _failing_writes(monkeypatch, 3, 10 ** 6 if disk == "full" else 3)   # 3: the frame at t = 0.1
    r = cli_run("run", str(scene), "--out", str(out), "--quiet", "--hourglass-limit", "0")
    print(r.err)
    assert r.code == 3
    assert_clean_output(r)
    assert len(r.err.splitlines()) == 1
    assert r.err.startswith(f"error: cannot write {out / 'frames' / 'frame_00001.vtu'}: No space left on device "
                            "at t=0.1, step ")
    assert calls[2].name == "frame_00001.vtu"
    assert frame_keys(out) == [0.0] and not list(out.glob("**/.*"))
    if disk == "full":
        assert not (out / "summary.json").exists() and not (out / "probes.csv").exists()
    else:
        assert_output_directory_valid(out)
        summary = summary_of(out)
        assert summary["error"] == r.err[len("error: "):].strip()
        # the history at t = 0.1 was recorded before its frame could not be written
        assert (out / "probes.csv").read_text().splitlines() == ["time", "0", "0.1"]


# ------------------------------------------------------------------ 13, 18: arch, banner, file modes
def test_quiet_cuda_request_without_gpu_subprocess(tmp_path):
    """Items 13 and 18: `--arch cuda` where Taichi falls back to the CPU said `cuda` in the
    summary; `--quiet` printed Taichi's banner; outputs were written with mode 0600 whatever
    the umask.  In a fresh process (Taichi's banner is printed when it is imported)."""
    out = tmp_path / "q"
    proc = subprocess.run([sys.executable, "-m", "taichi_shell_mpm", "run", CANTILEVER, *SMALL, "--out", str(out),
                           "--quiet", "--arch", "cuda"], capture_output=True, text=True, timeout=600, cwd=ROOT,
                          preexec_fn=lambda: os.umask(0o027))
    print(proc.stdout, proc.stderr)
    assert proc.returncode == 0, proc.stderr
    assert "[Taichi]" not in proc.stdout + proc.stderr and proc.stderr == ""
    summary = summary_of(out)
    if summary["arch"] == "cuda":             # a machine with a GPU: nothing fell back
        assert "arch_requested" not in summary
    else:
        assert summary["arch"] == "cpu" and summary["arch_requested"] == "cuda"
        assert proc.stdout.startswith("warning: --arch cuda: not available on this machine; Taichi fell back to "
                                      "cpu, the run is on cpu\n")
        assert summary["launch"] == "batched"          # the CPU's launch, not the GPU's
    for path in [out / "summary.json", out / "probes.csv", out / "frames.pvd", *out.glob("frames/*.vtu")]:
        assert path.stat().st_mode & 0o777 == 0o640, path


def test_cuda_fallback_compiles_as_a_cpu_run():
    """A `--arch cuda` run that Taichi moved to the CPU compiles its kernels as a CPU run does
    (Taichi's IR optimizations as runtime.ir_optimization says, off by default): the same
    kernels and offline-cache keys as `--arch cpu`.  Before, the GPU's setting stayed on: the
    4-element cantilever compiled 19.7 s instead of 2.8 s on a cold cache, into cache entries
    of its own (the subprocess test above took 23 s)."""
    import taichi as ti

    from taichi_shell_mpm.runtime import init_taichi, ir_optimization
    arch = init_taichi("cuda", quiet=True)
    cfg = ti.lang.impl.current_cfg()
    print(arch, cfg.arch, cfg.advanced_optimization)
    if arch == "cpu":
        assert cfg.advanced_optimization == ir_optimization()
    else:
        assert cfg.advanced_optimization


def test_atomic_write_follows_the_umask(tmp_path):
    old = os.umask(0o002)
    try:
        output._FILE_MODE = None
        output.write_text(tmp_path / "a.txt", "x")
        assert (tmp_path / "a.txt").stat().st_mode & 0o777 == 0o664
    finally:
        os.umask(old)
        output._FILE_MODE = None


# ------------------------------------------------------------------ 14: output directories
def test_empty_out_is_refused(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for args in (["run", CANTILEVER, "--out", ""], ["run", CANTILEVER, "--restart", " "], ["render", ""]):
        r = cli_run(*args)
        print(r.err)
        assert r.code == 2 and "expected a directory, got an empty string" in r.err
    assert list(tmp_path.iterdir()) == []


def test_reused_output_directory(tmp_path):
    """Item 14: a new run into the directory of an earlier one removes that run's frames,
    tables, summary, checkpoint and pictures (nothing else); a directory holding the
    checkpoint of an interrupted run is refused unless --overwrite; `--restart` of a finished
    run says that there is nothing to do instead of recomputing it."""
    out = tmp_path / "reused"
    (out / "frames").mkdir(parents=True)
    (out / "pictures").mkdir()
    stale = [out / "frames" / "frame_00007.vtu", out / "pictures" / "frame_00007.png", out / "pictures" / "sheet.png",
             out / "checkpoint.npz", out / "summary.json", out / ".probes.csv.x1y2.csv"]
    for path in stale:
        path.write_text("{}")
    (out / "notes.txt").write_text("mine")
    (out / "frames" / "mine.vtu").write_text("mine")
    r = cli_run("run", CANTILEVER, *SMALL, "--out", str(out))
    assert r.code == 0, r.err
    assert f"{out}: removed 6 files of an earlier run" in r.out
    assert not any(p.exists() for p in stale if p.name != "summary.json")
    assert (out / "notes.txt").read_text() == "mine" and (out / "frames" / "mine.vtu").exists()
    assert frame_keys(out) == [0.5, 1.0] and sorted(p.name for p in (out / "frames").glob("frame_*")) == [
        "frame_00000.vtu", "frame_00001.vtu"]

    # a finished run with its checkpoint at the end: nothing to do
    r = cli_run("run", CANTILEVER, *SMALL, "--out", str(out), "--quiet", "--checkpoint-every", "1")
    assert r.code == 0, r.err
    before = {p: p.stat().st_mtime_ns for p in out.rglob("*")}
    r = cli_run("run", CANTILEVER, *SMALL, "--restart", str(out))
    print(r.out)
    assert r.code == 0 and r.err == ""
    assert r.out.startswith(f"nothing to do: the run in {out} is finished")
    assert {p: p.stat().st_mtime_ns for p in out.rglob("*")} == before

    # an interrupted run's checkpoint is not thrown away by a run without --restart
    summary = summary_of(out)
    summary["error"] = "interrupted"
    (out / "summary.json").write_text(json.dumps(summary))
    r = cli_run("run", CANTILEVER, *SMALL, "--out", str(out), "--quiet")
    print(r.err)
    assert r.code == 2 and r.err == (f"error: --out {out}: holds the checkpoint of an unfinished run: continue it "
                                     f"with --restart {out}, or start afresh with --overwrite (deletes its results)\n")
    assert (out / "checkpoint.npz").is_file()
    r = cli_run("run", CANTILEVER, *SMALL, "--out", str(out), "--quiet", "--overwrite")
    assert r.code == 0, r.err
    assert not (out / "checkpoint.npz").exists() and "error" not in summary_of(out)


# ------------------------------------------------------------------ 18: messages
def test_restart_messages(tmp_path):
    """Item 18: `--restart DIR` of a directory without a checkpoint said 'no such directory'."""
    (tmp_path / "empty").mkdir()
    (tmp_path / "file").write_text("x")
    expected = {
        "nowhere": "no such directory (give the output directory of an interrupted run;",
        "empty": "no checkpoint.npz in this directory (a run writes one with --checkpoint-every N, and when "
                 "stopped by Ctrl-C; a run without one cannot be continued: run it again without --restart)",
        "file": "not a directory (give the output directory of an interrupted run)"}
    for name, words in expected.items():
        r = cli_run("run", CANTILEVER, "--restart", str(tmp_path / name))
        print(r.err)
        assert r.code == 2 and len(r.err.splitlines()) == 1
        assert r.err.startswith(f"error: --restart {tmp_path / name}: {words}")


def test_run_help_describes_the_scene():
    r = cli_run("run", "--help")
    text = " ".join(r.out.split())
    assert r.code == 0
    assert "scene file (TOML)" in text and "docs/scenes.md" in text and "--overwrite" in text


def test_eta_is_bounded():
    assert format_seconds(1e300) == "> 999 d" and format_seconds(3 * 86400 + 5) == "3.0 d"
    assert format_seconds(3725) == "1:02:05" and format_seconds(float("inf")) == "--"


def test_compiling_message_before_the_build(tmp_path):
    """Item 18: nothing was printed during the kernel compile; --quiet prints nothing of it."""
    loud = cli_run("run", CANTILEVER, *SMALL, "--out", str(tmp_path / "l"), "--set", "solve.progress_every=100")
    assert loud.code == 0, loud.err
    lines = loud.out.splitlines()
    compiling = next(i for i, line in enumerate(lines) if line.startswith("compiling kernels ("))
    ready = next(i for i, line in enumerate(lines) if "kernels ready in" in line)
    assert compiling < ready
    quiet = cli_run("run", CANTILEVER, *SMALL, "--out", str(tmp_path / "q"), "--quiet")
    assert quiet.code == 0 and "compiling" not in quiet.out


def test_merge_nodes_key_through_validate(tmp_path):
    """Item 17 through the CLI: a slit mesh validates with a warning; merge_nodes joins it."""
    import meshio
    points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [1, 0, 0], [2, 0, 0], [2, 1, 0], [1, 1, 0]],
                      dtype=float)
    meshio.write(tmp_path / "slit.vtu", meshio.Mesh(points, [("quad", np.array([[0, 1, 2, 3], [4, 5, 6, 7]]))]))
    text = (ROOT / "scenes" / "cantilever.toml").read_text()
    text = text[:text.index("[mesh]")] + '[mesh]\nkind = "file"\npath = "slit.vtu"\n' + \
        text[text.index("[material]"):text.index("[method]")] + '[method]\nkind = "fem"\n' + \
        text[text.index("[nodesets.clamp]"):text.index("[[probe]]")] + "[solve]\nkind = \"static\"\n"
    scene = write_scene(tmp_path, text, "slit.toml")
    r = cli_run("validate", str(scene), "--set", "nodesets.tip.plane.point=[2,0,0]")
    print(r.out, r.err)
    assert r.code == 0
    assert "warning: " + str(tmp_path / "slit.vtu") + ": 2 pairs of coincident nodes kept distinct" in r.out
    assert "(8 nodes, 2 elements" in r.out and "coincident nodes move together" not in r.out      # fem
    r = cli_run("validate", str(scene), "--set", "nodesets.tip.plane.point=[2,0,0]", "--set", "method.kind=mpm")
    assert r.code == 0 and ('warning: slit.toml: [method].kind = "mpm": the 2 pairs of coincident nodes move '
                            "together") in r.out
    r = cli_run("validate", str(scene), "--set", "nodesets.tip.plane.point=[2,0,0]", "--set", "mesh.merge_nodes=true")
    assert r.code == 0 and "merged 2 coincident nodes" in r.out and "(6 nodes, 2 elements" in r.out
    # issue 28 item 8d: the first square clamped whole, its face of the slit too: the other face
    # is free, follows the grid and the slit opens, so no "move together" warning in mpm
    clamped = write_scene(tmp_path, text.replace("plane = { point = [0.0, 0.0, 0.0], normal = [1.0, 0.0, 0.0] }",
                                                 "ids = [0, 1, 2, 3]"), "clamped.toml")
    r = cli_run("validate", str(clamped), "--set", "nodesets.tip.plane.point=[2,0,0]", "--set", "method.kind=mpm")
    print(r.out, r.err)
    assert r.code == 0 and "2 pairs of coincident nodes kept distinct" in r.out
    assert "move together" not in r.out
