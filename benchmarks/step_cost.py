"""µs per element-step of two checkouts (or two sets of overrides) in one sitting, alternated:

    python benchmarks/step_cost.py --tree ../before --tree . --repeats 3
    python benchmarks/step_cost.py --case tube --set-b material.hardening_law=swift ...

Each case runs A, B, A, B, ... (``--repeats`` pairs), every run in a fresh process on a
kernel cache warmed by a first run of its own (not counted), and reads
``us_per_element_step`` from summary.json.  Prints each run, then per case the median and
the minimum of A and of B and their ratios B/A.  A shared machine is noisy: trust ratios within one sitting
only, and the median and the minimum over the runs (the minimum: the run least disturbed).
``--cpu`` reads ``cpu_us_per_element_step`` instead: the process's CPU time (all threads) per
element-step, which counts the work and not the waiting for a core (on a machine loaded by
other jobs the wall time of a run varied by 2x between identical runs).

Cases (short runs; the step is what is measured):

* tube: scenes/square_tube.toml to 0.5 ms (j2, contact, rigid body, walls, mpm);
* hemisphere: scenes/hemisphere.toml, its first load step of 20 (static, elastic, mpm).
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CASES = {
    "tube": ("scenes/square_tube.toml", ["solve.end_time=0.5", "output.times=[]", "output.history_interval=0.05"]),
    "hemisphere": ("scenes/hemisphere.toml", ["solve.load_steps=20", "solve.max_steps_per_load_step=20000"]),
}


def run(tree: Path, scene: str, overrides: list[str], out: Path) -> dict:
    shutil.rmtree(out, ignore_errors=True)      # (not --overwrite: older trees lack it)
    cmd = [sys.executable, "-m", "taichi_shell_mpm", "run", str(tree / scene), "--out", str(out), "--quiet"]
    for item in overrides:
        cmd += ["--set", item]
    env = dict(os.environ, PYTHONPATH=str(tree))
    proc = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True)
    summary = out / "summary.json"
    if not summary.is_file():
        raise SystemExit(f"{' '.join(cmd)} failed:\n{proc.stderr[-2000:]}")
    return json.loads(summary.read_text())


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tree", type=Path, action="append", default=[],
                   help="checkout A, then B (default: this checkout for both)")
    p.add_argument("--case", action="append", choices=list(CASES), default=[])
    p.add_argument("--set-a", action="append", default=[], metavar="KEY=VALUE", help="overrides of A only")
    p.add_argument("--set-b", action="append", default=[], metavar="KEY=VALUE", help="overrides of B only")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--cpu", action="store_true", help="CPU time per element-step instead of wall time")
    a = p.parse_args()
    trees = [t.resolve() for t in (a.tree or [ROOT])]
    trees = (trees * 2)[:2]
    cases = a.case or list(CASES)
    key, unit = ("cpu_us_per_element_step", "CPU us") if a.cpu else ("us_per_element_step", "us")
    with tempfile.TemporaryDirectory(prefix="step_cost_") as tmp:
        for case in cases:
            scene, overrides = CASES[case]
            runs = {"A": (trees[0], overrides + a.set_a), "B": (trees[1], overrides + a.set_b)}
            for label, (tree, sets) in runs.items():          # warm the caches
                run(tree, scene, sets, Path(tmp) / label)
            values = {"A": [], "B": []}
            for i in range(a.repeats):
                for label, (tree, sets) in runs.items():
                    s = run(tree, scene, sets, Path(tmp) / label)
                    values[label].append(s[key])
                    print(f"{case:<11} {label} {i + 1}: {s[key]:.3f} {unit}/element-step "
                          f"({s['steps']} steps, {s['elements']} elements)", flush=True)
            ma, mb = statistics.median(values["A"]), statistics.median(values["B"])
            la, lb = min(values["A"]), min(values["B"])
            print(f"{case:<11} median A {ma:.3f}  B {mb:.3f}  B/A {mb / ma:.3f};  min A {la:.3f}  B {lb:.3f}  "
                  f"B/A {lb / la:.3f}   (A = {runs['A'][0]} "
                  f"{' '.join(a.set_a)}; B = {runs['B'][0]} {' '.join(a.set_b)})", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
