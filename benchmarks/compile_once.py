"""Compile targets of issue 17 (kernels compiled once per feature set), from summary.json
``compile_seconds``, each command in a fresh process, with an empty kernel cache at the start:

    python benchmarks/compile_once.py                 # this checkout
    python benchmarks/compile_once.py --tree ../old   # another checkout of the package (before/after)

Sequences (the second command of each is the target; the first fills the cache):

* cantilever: ``run scenes/cantilever.toml``, then the same with ``--set mesh.nx=13 --set
  material.E=2.0e6`` (target <= 3 s);
* tube: ``run scenes/square_tube.toml`` (cut to 0.05 ms: the kernels are the same as a full
  run's), then another mesh density, 6 mm elements instead of 5 (n_flat 10 -> 12 is 4.17 mm;
  see CASES) (target <= 5 s), then also another cell size.

The cache folder is this package's (``TAICHI_SHELL_MPM_CACHE``) and Taichi's own
(``TI_OFFLINE_CACHE_FILE_PATH``, what builds before issue 17 used), both pointed to a new
temporary folder, so runs of earlier results do not count.  Prints a table of wall seconds
(``compile_seconds``) and the process's CPU seconds over the same span (``compile_cpu_seconds``,
all threads; for builds that lack it, the run's whole CPU time from the operating system, an
upper bound): on a shared machine the wall time grows with the load, the CPU time much less.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TUBE_SHORT = ["solve.end_time=0.05", "output.times=[]", "output.history_interval=0.05"]
CASES = {
    "cantilever": [("first run", "scenes/cantilever.toml", []),
                   ("nx=13, E=2.0e6 (target <= 3 s)", "scenes/cantilever.toml", ["mesh.nx=13", "material.E=2.0e6"])],
    "tube": [("first run (0.05 ms)", "scenes/square_tube.toml", TUBE_SHORT),
             ("n_flat=12, n_length=72 (target <= 5 s)", "scenes/square_tube.toml",
              TUBE_SHORT + ["mesh.n_flat=12", "mesh.n_length=72"]),
             ("n_flat=8, n_length=48, cell 3.0", "scenes/square_tube.toml",
              TUBE_SHORT + ["mesh.n_flat=8", "mesh.n_length=48", "method.cell_size=3.0"])],
}


def run(tree: Path, scene: str, overrides: list[str], out: Path, env: dict) -> dict:
    cmd = [sys.executable, "-m", "taichi_shell_mpm", "run", str(tree / scene), "--out", str(out), "--quiet",
           "--overwrite"]
    for item in overrides:
        cmd += ["--set", item]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{proc.stderr[-2000:]}")
    summary = json.loads((out / "summary.json").read_text())
    summary.setdefault("compile_cpu_seconds", after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    return summary


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tree", type=Path, default=ROOT, help="checkout of the package to run (default: this one)")
    p.add_argument("--cases", nargs="*", default=list(CASES), choices=list(CASES))
    a = p.parse_args()
    tree = a.tree.resolve()
    with tempfile.TemporaryDirectory(prefix="compile_once_") as tmp:
        env = dict(os.environ, TAICHI_SHELL_MPM_CACHE=str(Path(tmp) / "cache"),
                   TI_OFFLINE_CACHE_FILE_PATH=str(Path(tmp) / "ticache"), PYTHONPATH=str(tree))
        print(f"tree {tree}")
        print(f"{'case':<12} {'command':<42} {'compile s':>9} {'cpu s':>7} {'elements':>8}")
        for case in a.cases:
            for label, scene, overrides in CASES[case]:
                s = run(tree, scene, overrides, Path(tmp) / "out", env)
                print(f"{case:<12} {label:<42} {s['compile_seconds']:>9.1f} {s['compile_cpu_seconds']:>7.1f} {s['elements']:>8}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
