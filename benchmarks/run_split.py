"""Where a dynamic run's wall time goes: the steps, or the host's work between two batches of
steps (the checks, the record at each output time, the progress line) [issue 29 item 5].

    python benchmarks/run_split.py run scenes/square_tube.toml --set solve.end_time=3 \\
        --set method.kind=fem --out /tmp/split --quiet

runs the CLI with the arguments given and, at the end, prints (to stderr) the time of the run
loop (solvers/dynamic.run_dynamic), of its `Stepper.advance` calls, and the rest per batch;
where the tree has them, the medians of the parts of a batch's host work (RunLoop.guard,
.record, .progress, .boundary; Simulation.probe_values, .energies, .part_values,
.body_values).  It imports the package found first on the path, so that another checkout is
measured with `PYTHONPATH=<checkout> python <this file> run ...` (an older tree without some
of those names is timed as far as it has them; a6fbb47 has the loop and the stepper).
"""
from __future__ import annotations

import importlib
import runpy
import sys
import time

import numpy as np

TIMES: dict[str, list[float]] = {}
PARTS = {"run_control": ("RunLoop", ("guard", "record", "progress", "boundary")),
         "simulation": ("Simulation", ("probe_values", "energies", "part_values", "body_values"))}


def timed(label: str, function):
    """`function`, adding each call's wall time to TIMES[label]."""
    def call(*args, **kwargs):
        start = time.perf_counter()
        try:
            return function(*args, **kwargs)
        finally:
            TIMES.setdefault(label, []).append(time.perf_counter() - start)
    return call


def instrument() -> None:
    stepper = importlib.import_module("taichi_shell_mpm.solvers.stepper")
    stepper.Stepper.advance = timed("advance", stepper.Stepper.advance)
    dynamic = importlib.import_module("taichi_shell_mpm.solvers.dynamic")
    dynamic.run_dynamic = timed("loop", dynamic.run_dynamic)       # the CLI imports it at the call
    for module, (cls_name, methods) in PARTS.items():
        try:
            cls = getattr(importlib.import_module(f"taichi_shell_mpm.{module}"), cls_name)
        except (ImportError, AttributeError):
            continue
        for name in methods:
            if name in cls.__dict__:
                setattr(cls, name, timed(name, cls.__dict__[name]))


def report() -> None:
    if "loop" not in TIMES:
        print("run_split: no dynamic run loop was timed", file=sys.stderr)
        return
    loop, advance = sum(TIMES["loop"]), sum(TIMES.get("advance", []))
    batches = max(1, len(TIMES.get("advance", [])))
    print(f"run loop {loop:.3f} s: steps (Stepper.advance, {batches} calls) {advance:.3f} s, between batches "
          f"{loop - advance:.3f} s ({1e3 * (loop - advance) / batches:.2f} ms per batch)", file=sys.stderr)
    for label, values in TIMES.items():
        if label not in ("loop", "advance"):
            ms = 1e3 * np.array(values[1:] or values)      # (the first: kernels loaded then)
            print(f"  {label:14s} {len(values):6d} calls, median {np.median(ms):.3f} ms, mean {ms.mean():.3f} ms",
                  file=sys.stderr)


def main() -> int:
    instrument()
    sys.argv = ["taichi_shell_mpm", *sys.argv[1:]]
    try:
        runpy.run_module("taichi_shell_mpm", run_name="__main__")
    except SystemExit as stop:
        report()
        return int(stop.code or 0)
    report()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
