"""Wall time of a run on a fresh kernel cache with extra ``ti.init`` options (docs/performance.md,
"Cold compile"): what a feature set's first run pays for compiling.

    python benchmarks/cold_compile.py scenes/cantilever.toml
    python benchmarks/cold_compile.py scenes/square_tube.toml --options '{"advanced_optimization": true}' \\
        -- --set solve.end_time=0.5 --set 'output.times=[]'

Each run is a fresh process with an empty cache folder ($TAICHI_SHELL_MPM_CACHE in a temporary
folder); --options is a JSON object merged into every ``ti.init`` call of the run.  Everything
after ``--`` goes to ``taichi_shell_mpm run``.  Prints the wall time and the summary's
compile_seconds; compare options within one sitting.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CHILD = """
import json, os, sys
import taichi as ti
options = json.loads(os.environ["COLD_COMPILE_OPTIONS"])
init = ti.init
ti.init = lambda *a, **k: init(*a, **{**k, **options})
from taichi_shell_mpm.cli import main
sys.exit(main(sys.argv[1:]))
"""


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scene", type=Path)
    p.add_argument("--options", default="{}", help="JSON object of extra ti.init options")
    p.add_argument("rest", nargs="*", help="after --: arguments of `taichi_shell_mpm run`")
    a = p.parse_args()
    json.loads(a.options)
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "TAICHI_SHELL_MPM_CACHE": str(Path(tmp) / "cache"), "COLD_COMPILE_OPTIONS": a.options}
        out = Path(tmp) / "out"
        start = time.perf_counter()
        r = subprocess.run([sys.executable, "-c", CHILD, "run", str(a.scene), "--out", str(out), "--quiet",
                            *a.rest], env=env, capture_output=True, text=True)
        wall = time.perf_counter() - start
        if r.returncode != 0:
            sys.exit(f"run failed ({r.returncode}): {r.stderr.strip()[-500:]}")
        summary = json.loads((out / "summary.json").read_text())
    print(f"{a.scene} options {a.options}: wall {wall:.1f} s, compile {summary['compile_seconds']:.1f} s, "
          f"run {summary['run_seconds']:.1f} s")


if __name__ == "__main__":
    main()
