"""The ``sweep`` subcommand: its options (:func:`add_arguments`, wired into
``python -m taichi_shell_mpm sweep`` by the package's cli.py) and the study itself
(:func:`main`): plan the cases, check each one's scene, run the rest on Dask, record each
row as it comes back, then the table and the plots.
"""
from __future__ import annotations

import argparse
import os
import shlex
import sys
import time
from pathlib import Path

from ..executor import Executor, Task, address_problem
from ..run_control import exit_code, signal_name
from ..tables import positive_int
from .cases import SweepError, plan, short_keys
from .metrics import default_metrics, parse_metrics
from .plot import plot_all
from .results import case_row, fmt, metric_columns, read_study, retabulate, write_csv, write_markdown
from .task import run_case

EXIT_SCENE, EXIT_FAILED = 2, 3      # interrupted: 128 + the signal (run_control.exit_code)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", type=Path, help="scene file (TOML, docs/scenes.md; or an LS-DYNA deck, docs/decks.md)")
    p.add_argument("--param", action="append", default=[], metavar="KEY=V1,V2,...",
                   help="a scene key (as --set addresses it) and its values; several --param make a "
                        "cartesian product, e.g. --param section.thickness=0.8,1.0,1.2")
    p.add_argument("--cases", type=Path, default=None, metavar="FILE",
                   help="CSV of cases: a header of scene keys (and optionally 'case', the names), one row "
                        "per case; combined with --param, each row with each combination")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene key in every case, e.g. solve.end_time=6")
    p.add_argument("--out", type=Path, default=None,
                   help="directory of sweep.csv, sweep.md, plots/ and cases/CASE/ (default "
                        "outputs/sweep_<scene name>)")
    p.add_argument("--metrics", action="append", default=[], metavar="PATH,...",
                   help="summary.json values to tabulate, e.g. crush.mean_crush_force,energies.internal "
                        "(* for every key; default: by the scene, docs/sweep.md)")
    p.add_argument("--workers", type=positive_int, default=None, metavar="N",
                   help="worker processes of the local Dask cluster, one case at a time each "
                        "(default: one per core)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on the existing Dask cluster whose scheduler is at ADDRESS "
                        "(e.g. tcp://host:8786) instead of a local one")
    p.add_argument("--resume", action="store_true",
                   help="skip the cases that already have an ok row in OUT/sweep.csv")
    p.add_argument("--list", action="store_true", help="list the cases and exit")
    p.add_argument("--arch", choices=["cpu", "cuda", "vulkan"], default="cpu")
    p.add_argument("--accept-unread", action="store_true",
                   help="an LS-DYNA deck: run its cases although some keywords that change the physics are not read")


def command_line(args: argparse.Namespace) -> str:
    """The sweep command as typed, rebuilt from the parsed options (without --resume)."""
    words = ["python", "-m", "taichi_shell_mpm", "sweep", str(args.scene)]
    for p in args.param:
        words += ["--param", p]
    if args.cases is not None:
        words += ["--cases", str(args.cases)]
    for o in args.overrides:
        words += ["--set", o]
    for m in args.metrics:
        words += ["--metrics", m]
    for flag in ("out", "workers", "scheduler"):
        if getattr(args, flag) is not None:
            words += ["--" + flag, str(getattr(args, flag))]
    if args.arch != "cpu":
        words += ["--arch", args.arch]
    if args.accept_unread:
        words += ["--accept-unread"]
    return shlex.join(words)


def _fail(code: int, lines) -> int:
    sys.stdout.flush()
    for line in lines:
        print(f"error: {' '.join(str(line).split())}", file=sys.stderr, flush=True)
    return code


def _check(scene_file: Path, overrides: list[str], accept_unread: bool = False):
    """The scene with `overrides`, or the SceneError's lines."""
    from ..scene import SceneError, load_scene
    try:
        return load_scene(scene_file, overrides, accept_unread), None
    except SceneError as exc:
        return None, exc.messages


class _Study:
    """The table of a study (its rows in the planned order) and its files, rewritten after
    every case; the plots with ``final``."""

    def __init__(self, out: Path, keys: list[str], cases, title: str, command: str):
        self.out, self.keys, self.cases, self.title, self.command = out, keys, cases, title, command
        self.csv, self.md = out / "sweep.csv", out / "sweep.md"
        self.table: dict[str, dict] = {}
        self.where = "not started"
        self.plots: dict[str, Path] = {}

    def rows(self) -> list[dict]:
        return [self.table[c.name] for c in self.cases if c.name in self.table]

    def record(self, final: bool = False) -> None:
        rows = self.rows()
        write_csv(self.csv, rows, self.keys)
        if final:
            self.plots = plot_all(rows, self.keys, short_keys(self.keys), self.cases, metric_columns(rows, self.keys),
                                  self.out / "plots")
        write_markdown(self.md, rows, self.keys, self.cases, self.title, self.command, self.where, self.plots)


def main(args: argparse.Namespace, run) -> int:
    """The study; `run` is the ``run`` command's entry point (``cli.main``), which each case
    calls in its worker (task.py)."""
    if args.scheduler is not None and args.workers is not None:
        return _fail(EXIT_SCENE, ["--workers and --scheduler: give one (--workers starts a local cluster, "
                                  "--scheduler uses an existing one)"])
    problem = address_problem(args.scheduler) if args.scheduler is not None else None
    if problem:
        return _fail(EXIT_SCENE, [f"--scheduler {args.scheduler}: {problem}"])
    try:
        keys, cases = plan(args.param, args.cases)
        metrics = parse_metrics(args.metrics)
    except SweepError as exc:
        return _fail(EXIT_SCENE, exc.messages)
    except ValueError as exc:
        return _fail(EXIT_SCENE, [str(exc)])
    scene, problems = _check(args.scene, args.overrides, args.accept_unread)
    if problems:
        return _fail(EXIT_SCENE, problems)
    metrics = metrics or default_metrics(scene)
    if args.list:
        for c in cases:
            print(f"{c.name:50s} {' '.join('--set ' + shlex.quote(o) for o in c.overrides)}")
        return 0
    out = args.out if args.out is not None else Path("outputs") / f"sweep_{scene.info.name}"
    study = _Study(out, keys, cases, f"{scene.info.name} ({args.scene})", command_line(args))
    try:                            # --resume: the ok rows stay, their metrics read again from their summary.json
        previous = read_study(study.csv, keys, cases) if args.resume else []
    except SweepError as exc:
        return _fail(EXIT_SCENE, exc.messages)
    try:
        (out / "cases").mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        return _fail(EXIT_SCENE, [f"--out {out}: cannot create the directory ({exc.strerror or exc})"])
    for r in previous:
        if r.get("status") == "ok":
            summary = _summary(out / "cases" / r["case"])
            study.table[r["case"]] = retabulate(r, keys, summary, metrics) if summary else r
    todo, failed_before = [], []
    for case in cases:
        if case.name in study.table:
            continue
        _, lines = _check(args.scene, [*args.overrides, *case.overrides], args.accept_unread)
        if lines:
            failed_before.append((case, lines))
        else:
            todo.append(case)
    if failed_before and not todo and not study.table:
        return _fail(EXIT_SCENE, [f"case {c.name}: {line}" for c, lines in failed_before for line in lines])
    for case, lines in failed_before:
        study.table[case.name] = case_row(case, keys, None, metrics, error="; ".join(lines), exit_code=EXIT_SCENE)
    skipped = len(cases) - len(todo) - len(failed_before)
    print(f"sweep: {len(todo)} case(s) to run of {len(cases)}" + (f" ({skipped} done before)" if skipped else "")
          + (f", {len(failed_before)} with a scene error" if failed_before else "") + f"; results in {study.csv}",
          flush=True)
    for case, lines in failed_before:
        print(f"  {case.name}: failed (exit {EXIT_SCENE}): {lines[0]}", flush=True)
    if not todo:                    # everything done before (--resume): the table and plots again
        study.where = "no case left to run"
        study.record(final=True)
        print(f"sweep: nothing to run; wrote {study.csv}, {study.md}", flush=True)
        return EXIT_FAILED if failed_before else 0
    study.record()
    return _execute(study, todo, metrics, args, run)


def _execute(study: _Study, todo, metrics: list[str], args: argparse.Namespace, run) -> int:
    """Run the cases `todo` on the executor, each row recorded as it comes back."""
    start = time.perf_counter()
    executor = Executor(workers=None if args.scheduler else (args.workers or os.cpu_count() or 1),
                        scheduler=args.scheduler, label="sweep")
    try:
        executor.start()
    except OSError as exc:          # no scheduler at --scheduler, a port or process that cannot be had
        return _fail(EXIT_SCENE, [f"{'--scheduler ' + args.scheduler if args.scheduler else 'local cluster'}: "
                                  f"cannot start ({type(exc).__name__}: {exc})"])
    except KeyboardInterrupt as exc:      # Ctrl-C, SIGTERM, SIGHUP (run_control.Interrupted)
        return _fail(exit_code(exc), [f"interrupted{signal_name(exc)} while the cluster started; nothing run"])
    scene_file = str(args.scene.resolve())
    by_name = {c.name: c for c in todo}

    def on_done(outcome) -> bool:
        case = by_name[outcome.task.key]
        row = case_row(case, study.keys, outcome.value, metrics, error=outcome.error)
        study.table[case.name] = row
        study.record()
        print(_case_line(row, metrics), flush=True)
        return row["status"] == "ok"

    try:
        with executor as ex:
            study.where = ex.describe()
            print(f"sweep: {study.where}", flush=True)
            ex.run([Task(c.name, run_case, (run, scene_file, (*args.overrides, *c.overrides),
                                            str((study.out / "cases" / c.name).resolve()), args.arch, ex.case_threads,
                                            ("--accept-unread",) if args.accept_unread else ()))
                    for c in todo], on_done)
    except KeyboardInterrupt as exc:      # Ctrl-C, SIGTERM, SIGHUP: the cluster is closed, its cases stop
        study.record(final=True)
        return _fail(exit_code(exc), [f"interrupted{signal_name(exc)}; the finished cases are in {study.csv}; "
                                      f"continue with: {study.command} --resume"])
    except OSError as exc:          # output.OutputError: sweep.csv / sweep.md / a plot could not be written
        return _fail(EXIT_FAILED, [f"{exc} (disk full, read-only or no permission?)"])
    study.record(final=True)
    rows = study.rows()
    failures = sum(1 for r in rows if r.get("status") != "ok")
    print(f"sweep: done in {time.perf_counter() - start:.0f} s; {len(rows) - failures} ok, {failures} failed; "
          f"wrote {study.csv}, {study.md}" + (f" and {len(study.plots)} plot(s) in {study.out / 'plots'}"
                                              if study.plots else ""), flush=True)
    return EXIT_FAILED if failures else 0


def _summary(folder: Path) -> dict | None:
    import json
    try:
        summary = json.loads((folder / "summary.json").read_text())
    except (OSError, ValueError):
        return None
    return summary if isinstance(summary, dict) else None


def _case_line(row: dict, metrics: list[str]) -> str:
    head = f"  {row['case']}: {row['status']}"
    if row["status"] != "ok":
        code = row.get("exit_code")
        return head + (f" (exit {code})" if code not in (None, "") else "") + f": {row.get('message')}"
    shown = [c for c in row if any(c == m or c.startswith(m.split("*")[0]) for m in metrics)][:3]
    return (head + f", wall {fmt(row.get('wall_s'))} s (compile {fmt(row.get('compile_s'))} s, run "
            f"{fmt(row.get('run_s'))} s)" + "".join(f", {c} {fmt(row[c])}" for c in shown))
