"""Running one case: a subprocess ``python -m taichi_shell_mpm run SCENE --quiet --out
OUT/runs/CASE --set ...`` (the cases compile different kernels; a fresh process keeps memory
and the Taichi runtime clean), or, for a ``kratos`` case, :func:`peer_child` in a Python
subprocess; its console log ``bench.log`` (first line: the command), its wall time, the
peak resident memory of the child (``os.wait4``), and its results.csv row read from the
run's ``summary.json``.  :func:`pending`: the cases still to run (``--resume``).
"""
from __future__ import annotations

import datetime
import json
import os
import shlex
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

from .cases import ROOT, Case
from .results import COMPONENT_LABEL, TUBE_KEYS


def _peer_command(case: Case, run_dir: Path) -> list[str]:
    code = ("import sys; from taichi_shell_mpm.bench import peer_child; "
            "sys.exit(peer_child(sys.argv[1], sys.argv[2], sys.argv[3:]))")
    return [sys.executable, "-c", code, str(case.scene_file), str(run_dir), *case.overrides]


def case_command(case: Case, run_dir: Path, arch: str = "cpu") -> list[str]:
    if case.mode == "kratos":
        return _peer_command(case, run_dir)
    cmd = [sys.executable, "-m", "taichi_shell_mpm", "run", str(case.scene_file), "--quiet", "--out", str(run_dir)]
    if arch != "cpu":
        cmd += ["--arch", arch]
    for o in case.overrides:
        cmd += ["--set", o]
    return cmd


def peer_child(scene_file: str, out_dir: str, overrides: list[str]) -> int:
    """Child process of a ``kratos`` case: solve the scene with Kratos, write summary.json in
    the shape of ours (compile_seconds = model set-up, run_seconds = Newton solve, steps =
    Newton iterations, reference = errors)."""
    from ..preflight import prepare
    from ..output import write_json
    from ..peers import kratos
    scene, mesh, model = prepare(Path(scene_file), overrides)
    result = kratos.solve_static(scene, mesh, model)
    n = int(result["elements"])
    its = int(result["newton_iterations"])
    summary = {"scene": scene.info.name, "method": "kratos", "element": result.get("element"),
               "kratos_version": result.get("kratos_version"), "elements": n, "nodes": int(result["nodes"]),
               "steps": its, "compile_seconds": float(result["setup_seconds"]),
               "run_seconds": float(result["solve_seconds"]),
               "us_per_element_step": 1e6 * float(result["solve_seconds"]) / max(1, its * n),
               "iterations_per_step": result.get("iterations_per_step")}
    if scene.reference is not None:
        summary["reference"] = kratos.compare(scene, result)
    write_json(Path(out_dir) / "summary.json", summary)
    print(f"kratos: {its} Newton iterations, set-up {summary['compile_seconds']:.2f} s, "
          f"solve {summary['run_seconds']:.2f} s")
    return 0


def _last_error(log: Path) -> str:
    try:
        lines = [ln.strip() for ln in log.read_text(errors="replace").splitlines() if ln.strip()]
    except OSError:
        return ""
    errors = [ln for ln in lines if ln.startswith("error:")]
    return (errors or lines or [""])[-1][:300]


def row_from_summary(case: Case, summary: dict) -> dict:
    row = {"case": case.name, "scene": case.scene, "mesh": case.mesh, "mode": case.mode,
           "cell_ratio": case.ratio, "cell_size": summary.get("cell_size"), "element_size": case.element_size,
           "overrides": " ".join(case.overrides)}
    for key, src in (("elements", "elements"), ("steps", "steps"), ("compile_s", "compile_seconds"),
                     ("run_s", "run_seconds"), ("us_per_element_step", "us_per_element_step")):
        row[key] = summary.get(src)
    ref = summary.get("reference") or {}
    cols = list((ref.get("columns") or {}).items())
    for k, (name, col) in enumerate(cols[:2], start=1):
        row[f"comp{k}"] = COMPONENT_LABEL.get(name, name)
        row[f"err{k}_mean"] = col.get("mean_rel_error")
        row[f"err{k}_max"] = col.get("max_rel_error")
    if ref:
        row["rows_compared"] = int(ref.get("rows", 0)) - len(ref.get("missing_levels") or [])
    crush = summary.get("crush") or {}
    for key, src in TUBE_KEYS.items():
        if src in crush:
            row[key] = crush[src]
    return row


def run_case(case: Case, out: Path, arch: str, machine: str, echo=print) -> dict:
    """Run one case in a subprocess; return its results.csv row (status ok or failed)."""
    run_dir = out / "runs" / case.name
    if run_dir.exists():
        shutil.rmtree(run_dir)
    run_dir.mkdir(parents=True)
    cmd = case_command(case, run_dir, arch)
    log = run_dir / "bench.log"
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    t0 = time.perf_counter()
    with open(log, "w") as fh:
        fh.write("$ " + shlex.join(cmd) + "\n")
        fh.flush()
        proc = subprocess.Popen(cmd, stdout=fh, stderr=subprocess.STDOUT, env=env, cwd=ROOT)
        try:
            _, status, usage = os.wait4(proc.pid, 0)
        except KeyboardInterrupt as exc:   # a terminal's Ctrl-C (or a job's SIGTERM) reaches the child too:
            try:                           # let it write its results
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:   # it did not get the signal (e.g. `kill -INT` of this process)
                proc.send_signal(getattr(exc, "signum", signal.SIGINT))
                proc.wait()
            raise
        proc.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - t0
    summary = {}
    try:
        summary = json.loads((run_dir / "summary.json").read_text())
    except (OSError, ValueError):
        pass
    row = row_from_summary(case, summary)
    row.update(wall_s=wall, peak_mem_MB=usage.ru_maxrss / 1024.0,   # Linux: kilobytes
               date=datetime.datetime.now().isoformat(timespec="seconds"), machine=machine)
    if proc.returncode == 0 and summary and not summary.get("error"):
        row["status"] = "ok"
    else:
        why = summary.get("error") or _last_error(log) or "no summary.json"
        row["status"] = f"failed (exit {proc.returncode}): {why}"
    return row


def pending(selected: list[Case], rows: list[dict], resume: bool) -> list[Case]:
    """The selected cases to run: all of them, or with `resume` those without an ``ok`` row
    in `rows` (results.csv)."""
    done = {r["case"] for r in rows if r.get("status") == "ok"}
    return [c for c in selected if not (resume and c.name in done)]
