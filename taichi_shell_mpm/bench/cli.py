"""The ``bench`` subcommand: its options (:func:`add_arguments`, wired into
``python -m taichi_shell_mpm bench`` by the package's cli.py), where its files go
(:func:`default_out`, :func:`default_report`) and the sitting itself (:func:`main`):
plan, select, run the cases (one after the other, or ``--workers N`` at a time on a local
Dask cluster, :mod:`taichi_shell_mpm.executor`), record each row and regenerate the report
after every case.
"""
from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

from ..executor import Executor, Task
from ..run_control import exit_code, signal_name
from ..tables import positive_int
from .cases import peers_available, plan, select
from .machine import machine_info, machine_tag
from .report import error_pair, fmt, regenerate
from .results import read_results, replace_row
from .run import pending, row_from_summary, run_case


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--quick", action="store_true",
                   help="small subset, under 3 minutes: cantilever 5x1 (mpm) and 10x1 (mpm, fem), quarter "
                        "hemisphere 8x8 with 10 load steps (mpm, fem); mpm at h = l/2")
    p.add_argument("--out", type=Path, default=None,
                   help="directory of results.csv, plots and runs/ (default outputs/bench, "
                        "outputs/bench_quick with --quick)")
    p.add_argument("--report", type=Path, default=None,
                   help="report file (default BENCHMARKS.md in the working directory for the study into "
                        "the default folder or ./bench; OUT/BENCHMARKS.md with --quick or another --out)")
    p.add_argument("--resume", action="store_true", help="skip cases that already have an ok row in results.csv")
    p.add_argument("--cases", action="append", default=[], metavar="PATTERN",
                   help="run only the cases whose name matches this shell pattern (repeatable), "
                        "e.g. 'cantilever*' or '*_fem'")
    p.add_argument("--list", action="store_true", help="list the planned cases and exit")
    p.add_argument("--report-only", action="store_true", help="regenerate report and plots from results.csv")
    p.add_argument("--arch", choices=["cpu", "cuda", "vulkan"], default="cpu")
    p.add_argument("--workers", type=positive_int, default=None, metavar="N",
                   help="run N cases at a time on a local Dask cluster (default: one after the other in "
                        "this process; cases that share the cores time slower, and the report says so)")


def command_line(args: argparse.Namespace) -> str:
    """The bench command as typed, rebuilt from the parsed options."""
    words = ["python", "-m", "taichi_shell_mpm", "bench"]
    for flag in ("quick", "resume", "report_only"):
        if getattr(args, flag, False):
            words.append("--" + flag.replace("_", "-"))
    for flag in ("out", "report"):
        if getattr(args, flag, None) is not None:
            words += ["--" + flag, str(getattr(args, flag))]
    for pat in args.cases:
        words += ["--cases", pat]
    if args.arch != "cpu":
        words += ["--arch", args.arch]
    if getattr(args, "workers", None):
        words += ["--workers", str(args.workers)]
    return shlex.join(words)


def default_out(quick: bool) -> Path:
    return Path("outputs") / ("bench_quick" if quick else "bench")


def default_report(out: Path, quick: bool) -> Path:
    """The committed report (BENCHMARKS.md in the working directory) only for the full study
    into the default folder or ./bench; anything else (--quick, a study into a scratch
    folder) keeps its report beside its results, so it cannot overwrite the committed one."""
    if not quick and out.resolve() in (default_out(False).resolve(), Path("bench").resolve()):
        return Path("BENCHMARKS.md")
    return out / "BENCHMARKS.md"


def main(args: argparse.Namespace) -> int:
    peers = peers_available()
    planned = plan(args.quick, peers)
    out = args.out or default_out(args.quick)
    report = args.report or default_report(out, args.quick)
    selected = select(planned, args.cases)
    if args.list:
        for c in planned:
            print(f"{c.name:36s} {'*' if c in selected else ' '} {c.scene_file.name} {' '.join(c.overrides)}")
        return 0
    if args.cases and not selected:
        print(f"error: --cases {' '.join(args.cases)}: no planned case matches (see --list)", file=sys.stderr)
        return 2
    try:
        out.mkdir(parents=True, exist_ok=True)
        report.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        print(f"error: cannot create {exc.filename}: {exc.strerror}", file=sys.stderr)
        return 2
    info = machine_info()
    workers = getattr(args, "workers", None)
    tag = machine_tag(info, args.arch, workers)
    command = command_line(args)
    results = out / "results.csv"
    todo = [] if args.report_only else pending(selected, read_results(results), args.resume)
    print(f"bench: {len(todo)} case(s) to run of {len(planned)} planned; results in {results}, report {report}",
          flush=True)
    if todo and workers:
        print(f"bench: {workers} cases at a time (--workers {workers}): they share the machine, so their timings "
              "are not those of a quiet machine (the machine column and the report say so)", flush=True)
    failures = 0
    start = time.perf_counter()
    by_name = {c.name: c for c in todo}

    def on_done(outcome) -> bool:
        nonlocal failures
        case = by_name[outcome.task.key]
        row = outcome.value if outcome.error is None else dict(
            row_from_summary(case, {}), status=f"failed: {outcome.error}", machine=tag)
        replace_row(results, row)
        ok = row["status"] == "ok"
        failures += not ok
        errs = (f"errors {error_pair(row, 1)} | {error_pair(row, 2)} %" if row.get("comp1")
                else f"mean force {fmt(float(row.get('mean_force') or 'nan'))} kN")
        print(f"{case.name}: {'ok' if ok else row['status']}: wall {float(row.get('wall_s') or 'nan'):.1f} s "
              f"(compile {fmt(float(row.get('compile_s') or 'nan'))} s, run {fmt(float(row.get('run_s') or 'nan'))} "
              f"s), {errs}", flush=True)
        regenerate(out, report, planned, command, info, args.arch, peers, args.quick)
        return ok

    try:
        with Executor(workers=workers, label="bench") as ex:
            if workers:
                print(f"bench: {ex.describe()}", flush=True)
            ex.run([Task(c.name, run_case, (c, out.resolve(), args.arch, tag)) for c in todo], on_done)
    except KeyboardInterrupt as exc:      # Ctrl-C, SIGTERM, SIGHUP (run_control.Interrupted)
        regenerate(out, report, planned, command, info, args.arch, peers, args.quick)
        print(f"\ninterrupted{signal_name(exc)}; continue with: {command} --resume", file=sys.stderr)
        return exit_code(exc)
    regenerate(out, report, planned, command, info, args.arch, peers, args.quick)
    print(f"bench: done in {time.perf_counter() - start:.0f} s; {failures} failed; wrote {results}, {report}",
          flush=True)
    return 3 if failures else 0
