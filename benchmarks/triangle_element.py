"""Which 3-node shell (issue 17 item 4): the C0 triangle of stages/triangle.py against the
alternative, a Belytschko-Tsay quad with corner 4 on corner 1 (the "degenerate quad" most
explicit codes fall back to), on Sze's cantilever strip with its quads cut into triangles:

    python -m benchmarks.triangle_element [--method fem] [--mesh 20x2 --mesh 40x4]

Each (variant, mesh) runs `scenes/cantilever.toml --set mesh.triangles=all` through the CLI
in a process of its own and prints the mean / max error of both tip components against the
Sze table (reference.py) and the hourglass energy share at the last load step.

The degenerate quad is the kernel of stages/shell.py run on the same mesh with each
triangle's -1 replaced by its first corner, which this build never does on its own, so the
variant patches it in for this measurement only: Simulation gets the repeated-corner model,
and the quad's inside-out test (two corner Jacobians <= 0, which the zero-length edge 4-1
always trips) is switched off.  The lumped masses stay the triangle's (1/3 at each corner;
statics do not depend on them).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
VARIANTS = ("c0_triangle", "degenerate_quad")


def patch_degenerate_quad() -> None:
    """Run triangles through the quad kernel as quads with corner 4 = corner 1 (see above)."""
    import numpy as np
    import taichi as ti

    from taichi_shell_mpm import simulation
    from taichi_shell_mpm.stages import shell

    @ti.func
    def never_tangled(xh, yh):
        return False

    shell.tangled = never_tangled
    original_init = simulation.Simulation.__init__

    def init(self, scene, out_dir=None, arch="cpu", quiet=False, mesh=None, model=None):
        elements = model.elements.copy()
        tri = elements[:, 3] < 0
        elements[tri, 3] = elements[tri, 0]
        original_init(self, scene, out_dir, arch, quiet, mesh, replace(model, elements=elements))

    simulation.Simulation.__init__ = init
    simulation.Simulation.element_distortion = lambda self, x: (
        np.zeros(len(self.model.elements), dtype=bool), np.full(len(self.model.elements), np.inf))


def one(variant: str, mesh: str, method: str, out: Path) -> int:
    """One run in this process (the CLI's `run`, patched for the degenerate quad)."""
    from taichi_shell_mpm.cli import main as cli
    if variant == "degenerate_quad":
        patch_degenerate_quad()
    nx, ny = mesh.split("x")
    return cli(["run", str(ROOT / "scenes" / "cantilever.toml"), "--out", str(out), "--quiet", "--overwrite",
                "--set", f"mesh.nx={nx}", "--set", f"mesh.ny={ny}", "--set", "mesh.triangles=all",
                "--set", f"method.kind={method}"])


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--method", choices=("fem", "mpm"), default="fem")
    p.add_argument("--mesh", action="append", default=[], help="NXxNY quads before the cut (default 20x2)")
    p.add_argument("--one", choices=VARIANTS, help=argparse.SUPPRESS)
    p.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    a = p.parse_args()
    meshes = a.mesh or ["20x2"]
    if a.one:
        return one(a.one, meshes[0], a.method, a.out)
    print(f"Sze cantilever, quads cut into triangles, {a.method}: error vs Sze 2004 (mean / max, %)")
    print(f"{'variant':<16s} {'mesh':>6s} {'triangles':>9s} {'W_tip':>15s} {'-U_tip':>15s} {'E_hg/E_int':>10s} "
          f"{'steps':>8s}")
    with tempfile.TemporaryDirectory(prefix="triangle_element_") as tmp:
        for mesh in meshes:
            for variant in VARIANTS:
                out = Path(tmp) / f"{variant}_{mesh}"
                proc = subprocess.run([sys.executable, "-m", "benchmarks.triangle_element", "--one", variant,
                                       "--mesh", mesh, "--method", a.method, "--out", str(out)],
                                      cwd=ROOT, capture_output=True, text=True)
                summary = out / "summary.json"
                if proc.returncode != 0 or not summary.is_file():
                    print(f"{variant:<16s} {mesh:>6s} failed (exit {proc.returncode}): "
                          f"{(proc.stderr.strip().splitlines() or ['?'])[-1]}")
                    continue
                s = json.loads(summary.read_text())
                cols = s["reference"]["columns"]
                err = {c: f"{100 * cols[c]['mean_rel_error']:.2f} / {100 * cols[c]['max_rel_error']:.2f}"
                       for c in ("W_tip", "minus_U_tip")}
                e = s["energies"]
                share = e["hourglass"] / e["internal"] if e["internal"] else float("nan")
                nx, ny = (int(v) for v in mesh.split("x"))
                print(f"{variant:<16s} {mesh:>6s} {2 * nx * ny:>9d} {err['W_tip']:>15s} {err['minus_U_tip']:>15s} "
                      f"{100 * share:>9.2f}% {s['steps']:>8d}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
