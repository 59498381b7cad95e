"""`sweep`: parameter studies on Dask (taichi_shell_mpm/sweep/, executor.py; issue 21).

Through the public CLI, on a short cantilever (4 load steps instead of 20, so a case runs in
about a second once its kernels are in the offline cache):

* a 4-case study (2 meshes x 2 hourglass coefficients) on a 2-worker local cluster: the
  table is complete, and each case's results (summary.json figures, probes.csv, energy.csv)
  are those of the same run done directly with ``run``, to the last digit (statics run the
  serial batched launch, so a run is the same whatever process it is in);
* a study from a cases CSV with a bad value (exit 2, found before the cluster starts) and a
  case that does not converge (exit 3, in its worker): both recorded, the good case done;
* ``--resume`` after a case's row and folder were lost runs that case only;
* ``--scheduler`` against a scheduler and a worker this test starts on localhost;
* Ctrl-C (SIGINT to the process group, as a terminal sends it) stops the study with exit
  130, no traceback, and a ``--resume`` command to continue; SIGTERM the same with exit 143.
The rest are in-process checks of the case planning, the metric paths and the plots.
"""
from __future__ import annotations

import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from taichi_shell_mpm.sweep import SweepError, lookup, plan, split_values

CHECKOUT = Path(__file__).resolve().parents[1]
SCENE = CHECKOUT / "scenes" / "cantilever.toml"
SHORT = ["--set", "solve.load_steps=4"]
GRID = ["--param", "mesh.nx=4,8", "--param", "element.hourglass=0.05,0.1"]
CASES = ["nx=4__hourglass=0.05", "nx=4__hourglass=0.1", "nx=8__hourglass=0.05", "nx=8__hourglass=0.1"]


def env() -> dict:
    """The environment of a child process: this checkout's package first, no Taichi banner (the
    tests read the sweep's first lines; a run with --quiet in this process turned it off for the
    children, so whether it showed depended on the order of the tests)."""
    return dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(CHECKOUT), os.environ.get("PYTHONPATH")])),
                ENABLE_TAICHI_HEADER_PRINT="false")


def sweep(*args: str, cwd: Path, timeout: float = 900) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "taichi_shell_mpm", "sweep", str(SCENE), *args], capture_output=True,
                          text=True, timeout=timeout, cwd=cwd, env=env())


def read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def same_results(a: Path, b: Path) -> None:
    """Two run folders hold the same results: summary.json's figures (not its timings,
    paths or launch) and the probe and energy tables, exactly."""
    sa, sb = (json.loads((d / "summary.json").read_text()) for d in (a, b))
    for key in ("steps", "energies", "reference", "steps_per_load_step", "elements", "nodes"):
        assert sa[key] == sb[key], key
    for name in ("probes.csv", "energy.csv"):
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    work = tmp_path_factory.mktemp("sweep")
    out = work / "out"
    t0 = time.perf_counter()
    proc = sweep(*GRID, *SHORT, "--workers", "2", "--out", str(out), cwd=work)
    print(f"\n4-case sweep on 2 workers: {time.perf_counter() - t0:.1f} s\n{proc.stdout}")
    return work, out, proc


def test_study_on_a_local_cluster_matches_direct_runs(study, tmp_path):
    from taichi_shell_mpm.cli import main
    _, out, proc = study
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "local Dask cluster of 2 worker process(es)" in proc.stdout
    rows = read_csv(out / "sweep.csv")
    assert [r["case"] for r in rows] == CASES
    workers = set()
    for r in rows:
        assert r["status"] == "ok" and r["exit_code"] == "0", r
        nx, hg = r["mesh.nx"], r["element.hourglass"]
        assert r["case"] == f"nx={nx}__hourglass={hg}"
        for col in ("reference.columns.W_tip.mean_rel_error", "reference.columns.minus_U_tip.max_rel_error",
                    "reference.columns.W_tip.simulated.-1", "steps", "compile_s", "run_s", "wall_s"):
            assert float(r[col]) > 0, col
        workers.add(r["worker"])
        direct = tmp_path / r["case"]
        assert main(["run", str(SCENE), "--quiet", "--out", str(direct), *SHORT, "--set", f"mesh.nx={nx}",
                     "--set", f"element.hourglass={hg}"]) == 0
        same_results(out / "cases" / r["case"], direct)
        summary = json.loads((direct / "summary.json").read_text())
        assert float(r["reference.columns.W_tip.mean_rel_error"]) == pytest.approx(
            summary["reference"]["columns"]["W_tip"]["mean_rel_error"], rel=1e-9)
    assert len(workers) == 2                       # both workers ran cases
    table = (out / "sweep.md").read_text()
    assert all(f"| {c} |" in table for c in CASES) and "4 ok, 0 failed, 0 not run" in table
    pngs = sorted(p.name for p in (out / "plots").glob("*.png"))
    assert "reference.columns.W_tip.mean_rel_error.png" in pngs and len(pngs) == 6
    assert all((out / "plots" / p).stat().st_size > 5000 for p in pngs)


def test_resume_runs_only_the_missing_case(study, tmp_path):
    _, out, proc = study
    assert proc.returncode == 0
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    lost = CASES[2]
    rows = [r for r in read_csv(copy / "sweep.csv") if r["case"] != lost]
    with open(copy / "sweep.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    shutil.rmtree(copy / "cases" / lost)
    kept = {c: (copy / "cases" / c / "summary.json").stat().st_mtime_ns for c in CASES if c != lost}
    again = sweep(*GRID, *SHORT, "--workers", "1", "--out", str(copy), "--resume", cwd=tmp_path)
    print(again.stdout)
    assert again.returncode == 0, again.stdout[-3000:] + again.stderr[-3000:]
    assert "1 case(s) to run of 4 (3 done before)" in again.stdout
    assert [r["case"] for r in read_csv(copy / "sweep.csv")] == CASES
    assert {c: (copy / "cases" / c / "summary.json").stat().st_mtime_ns for c in kept} == kept
    same_results(copy / "cases" / lost, out / "cases" / lost)


def test_failing_cases_are_recorded_and_the_others_finish(tmp_path):
    cases = tmp_path / "cases.csv"
    cases.write_text("case,section.thickness,solve.max_steps_per_load_step\n"
                     "good,0.1,\n"
                     "bad_value,-0.1,\n"
                     "no_convergence,,50\n")
    out = tmp_path / "out"
    proc = sweep("--cases", str(cases), *SHORT, "--workers", "2", "--out", str(out), cwd=tmp_path)
    print(proc.stdout, proc.stderr)
    assert proc.returncode == 3, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr
    rows = {r["case"]: r for r in read_csv(out / "sweep.csv")}
    assert list(rows) == ["good", "bad_value", "no_convergence"]
    assert rows["good"]["status"] == "ok"
    assert float(rows["good"]["reference.columns.W_tip.mean_rel_error"]) > 0
    assert rows["bad_value"]["status"] == "failed" and rows["bad_value"]["exit_code"] == "2"
    assert "[section].thickness" in rows["bad_value"]["message"] and "-0.1" in rows["bad_value"]["message"]
    assert rows["no_convergence"]["status"] == "failed" and rows["no_convergence"]["exit_code"] == "3"
    assert "did not converge in 50 steps" in rows["no_convergence"]["message"]
    table = (out / "sweep.md").read_text()
    assert "1 ok, 2 failed" in table and "failed (exit 3)" in table and "did not converge" in table


def test_study_on_an_existing_scheduler(tmp_path):
    """`--scheduler ADDRESS`: a scheduler and one worker started here, on localhost."""
    file = tmp_path / "scheduler.json"
    dask = [sys.executable, "-m"]
    procs = [subprocess.Popen(dask + ["distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0",
                                      "--no-dashboard", "--scheduler-file", str(file)],
                              env=env(), cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        for _ in range(600):
            if file.exists() and file.stat().st_size:
                break
            time.sleep(0.1)
        address = json.loads(file.read_text())["address"]
        procs.append(subprocess.Popen(dask + ["distributed.cli.dask_worker", "--scheduler-file", str(file),
                                              "--nthreads", "1", "--nworkers", "1", "--no-dashboard"],
                                      env=env(), cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        out = tmp_path / "out"
        proc = sweep("--param", "element.hourglass=0.05,0.1", "--set", "mesh.nx=4", *SHORT, "--scheduler", address,
                     "--out", str(out), cwd=tmp_path)
        print(proc.stdout, proc.stderr)
        assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
        assert f"Dask cluster at {address}, 1 case(s) at a time" in proc.stdout
        rows = read_csv(out / "sweep.csv")
        assert [r["status"] for r in rows] == ["ok", "ok"] and len({r["worker"] for r in rows}) == 1
    finally:
        for p in reversed(procs):
            p.terminate()
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
    bad = sweep("--param", "mesh.nx=4,8", "--scheduler", "tcp://127.0.0.1:9", "--out", str(tmp_path / "none"),
                cwd=tmp_path, timeout=600)
    assert bad.returncode == 2 and bad.stderr.startswith("error: --scheduler tcp://127.0.0.1:9: cannot start"), \
        bad.stderr
    assert "Traceback" not in bad.stderr


def _interruptible() -> None:
    """In the child before exec: SIGINT at its default, so that Python installs its Ctrl-C
    handler.  A test run started in the background by a non-interactive shell (``pytest ... &``)
    ignores SIGINT, and an ignored signal stays ignored across exec: the sweep, its workers and
    its cases then ran to the end through the SIGINT (measured: every test process had SIG_IGN)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.parametrize("signum, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)], ids=["SIGINT", "SIGTERM"])
def test_ctrl_c_stops_the_study_cleanly(tmp_path, signum, code):
    """SIGINT to the process group (a terminal's Ctrl-C) while two full cantilever cases run;
    SIGTERM (`timeout`, a batch job's wall-time limit) stops it the same way."""
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "taichi_shell_mpm", "sweep", str(SCENE), "--param",
                             "element.hourglass=0.05,0.1", "--set", "mesh.nx=40", "--workers", "2", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path, env=env(),
                            start_new_session=True, preexec_fn=_interruptible)
    first = proc.stdout.readline() + proc.stdout.readline()      # "N case(s) to run", then the cluster line
    # wait until both cases run (each writes its run.log first)
    deadline = time.perf_counter() + 300
    while len(list((out / "cases").glob("*/run.log"))) < 2 and time.perf_counter() < deadline \
            and proc.poll() is None:
        time.sleep(0.1)
    time.sleep(1)
    t0 = time.perf_counter()
    os.killpg(proc.pid, signum)
    stdout, stderr = proc.communicate(timeout=600)
    print(first + stdout, stderr, f"stopped {time.perf_counter() - t0:.1f} s after {signal.Signals(signum).name}")
    assert "local Dask cluster" in first
    assert proc.returncode == code
    assert "Traceback" not in stderr and "interrupted" in stderr and "--resume" in stderr
    assert [r["status"] for r in read_csv(out / "sweep.csv")] == []    # nothing finished, nothing recorded


# ------------------------------------------------------------------ in-process
def test_executor_records_a_worker_that_dies():
    """A case whose worker process dies (here: os._exit) is a failure with its reason; the
    next case runs on the worker the nanny restarts."""
    import operator

    from taichi_shell_mpm.executor import Executor, Task
    seen = {}

    def on_done(outcome) -> bool:
        seen[outcome.task.key] = outcome
        return outcome.error is None

    with Executor(workers=1, label="test") as ex:
        ex.run([Task("dies", os._exit, (1,)), Task("adds", operator.add, (1, 2))], on_done)
    print({k: (o.value, o.error) for k, o in seen.items()})
    assert "KilledWorker" in seen["dies"].error and seen["adds"].value == 3


def test_values_split_outside_brackets_and_quotes():
    assert split_values("0.8, 1.0,1.2") == ["0.8", "1.0", "1.2"]
    assert split_values("[0,0,1],[0, 1, 0]") == ["[0,0,1]", "[0, 1, 0]"]
    assert split_values("'a,b',fem") == ["'a,b'", "fem"]


def test_plan_names_and_errors(tmp_path):
    keys, cases = plan(["section.thickness=0.8,1.0", "material.yield_stress=0.2,0.3"])
    assert keys == ["section.thickness", "material.yield_stress"]
    assert [c.name for c in cases] == ["thickness=0.8__yield_stress=0.2", "thickness=0.8__yield_stress=0.3",
                                       "thickness=1.0__yield_stress=0.2", "thickness=1.0__yield_stress=0.3"]
    assert cases[1].overrides == ("section.thickness=0.8", "material.yield_stress=0.3")
    _, cases = plan(["load.0.force=[0,0,1],[0,0,2]"])
    assert len({c.name for c in cases}) == 2 and all("-" in c.name for c in cases)   # hashed: brackets
    _, cases = plan(["a.x=1", "b.x=2"])
    assert cases[0].name == "a.x=1__b.x=2"                  # "x" alone would not tell them apart
    for bad, message in ((["section.thickness"], "expected KEY=V1,V2"), (["=1,2"], "expected a scene key"),
                         (["a=1,,2"], "empty value"), (["a=1,1"], "a value is given twice"), (["a.x=1,2", "a.x=3"], "--param a.x: given twice in --param"),
                         ([], "nothing to sweep")):
        with pytest.raises(SweepError, match=message):
            plan(bad)
    file = tmp_path / "c.csv"
    file.write_text("section.thickness,mesh.nx\n0.1,4\n0.2\n")
    with pytest.raises(SweepError, match="row 3 has 1 cells"):
        plan([], file)


def sweep_here(capsys, *args: str) -> tuple[int, str]:
    """The sweep command in this process (argument errors: nothing runs): exit code, stderr."""
    from taichi_shell_mpm.cli import main
    code = main(["sweep", str(SCENE), *args])
    return code, capsys.readouterr().err


def test_a_malformed_scheduler_address_is_a_command_line_error(capsys, tmp_path):
    code, err = sweep_here(capsys, "--param", "mesh.nx=4,8", "--scheduler", "not an address", "--out", str(tmp_path))
    print(err)
    assert code == 2 and len(err.splitlines()) == 1
    assert err.startswith("error: --scheduler not an address: not a scheduler address") and "tcp://host:8786" in err
    assert not (tmp_path / "sweep.csv").exists()


def test_resume_refuses_a_table_it_would_lose(capsys, tmp_path):
    """--resume on a sweep.csv that is not UTF-8, not a sweep table, or from other --param
    values: exit 2, one line naming the difference, the file untouched."""
    from taichi_shell_mpm.sweep import case_row, write_csv
    table = tmp_path / "sweep.csv"
    keys, cases = plan(["mesh.nx=4,16"])
    write_csv(table, [case_row(c, keys, None, [], error="x", exit_code=3) for c in cases], keys)
    foreign_values = table.read_bytes()
    for content, expected in ((b"case,nx\n\xff\xfe4,8\n", "not a UTF-8 CSV file"),
                              (b"time,force\n0,1\n", "its first columns are time, force, this study's are case, "
                                                        "mesh.nx"),
                              (foreign_values, "1 of its 2 rows are not cases of this study (first: 'nx=16'")):
        table.write_bytes(content)
        code, err = sweep_here(capsys, "--param", "mesh.nx=4,8", "--resume", "--out", str(tmp_path))
        print(err)
        assert code == 2 and len(err.splitlines()) == 1 and expected in err, err
        assert table.read_bytes() == content
    assert not (tmp_path / "cases").exists()


def test_metric_paths():
    summary = {"crush": {"mean_crush_force": 8.9, "mean_force_over_reference": [1.2, 0.87]},
               "reference": {"columns": {"W": {"mean_rel_error": 0.1, "simulated": [1, 2, 3]}}}}
    assert lookup(summary, "crush.mean_crush_force") == [("crush.mean_crush_force", 8.9)]
    assert lookup(summary, "crush.mean_force_over_reference.*") == [("crush.mean_force_over_reference.0", 1.2),
                                                                    ("crush.mean_force_over_reference.1", 0.87)]
    assert lookup(summary, "reference.columns.*.simulated.-1") == [("reference.columns.W.simulated.-1", 3)]
    assert lookup(summary, "crush.nothing") == []
