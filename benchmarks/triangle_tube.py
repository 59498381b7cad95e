"""The square tube crush with a band of triangles against the all-quad tube (issue 17 item 4):

    python -m benchmarks.triangle_tube [--end-time 6] [--set KEY=VALUE ...]

Runs scenes/square_tube.toml (5 mm mesh, mpm, contact) to --end-time ms twice through the
CLI, each in a process of its own: as it is, and with the +y face (the flat between the
fillets, all along the tube: 10 x 60 quads) cut into triangles (`mesh.triangles`, a box of
quad centroids y in [29.5, 31]).  Prints for each the crush distance, the mean crush force
over 20 mm to the end, lobes, half-wavelength, hourglass share, energy balance, steps and
run time, then the mixed tube's mean force relative to the all-quad one (the issue asks
for it within 10 %).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BAND = "mesh.triangles={min = [-31.0, 29.5, -1.0], max = [31.0, 31.0, 301.0]}"


def run(out: Path, overrides: list[str]) -> dict:
    cmd = [sys.executable, "-m", "taichi_shell_mpm", "run", str(ROOT / "scenes" / "square_tube.toml"),
           "--out", str(out), "--quiet"]
    for item in overrides:
        cmd += ["--set", item]
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    summary = out / "summary.json"
    if proc.returncode != 0 or not summary.is_file():
        raise SystemExit(f"{' '.join(cmd)} failed (exit {proc.returncode}):\n{proc.stderr[-2000:]}")
    return json.loads(summary.read_text())


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--end-time", type=float, default=6.0, help="ms (default 6)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="overrides of both runs")
    a = p.parse_args()
    common = [f"solve.end_time={a.end_time}", f"output.times=[{a.end_time}]", "output.history_interval=0.02",
              *a.set]
    force = {}
    with tempfile.TemporaryDirectory(prefix="triangle_tube_") as tmp:
        for name, extra in (("quads", []), ("mixed", [BAND])):
            s = run(Path(tmp) / name, [*common, *extra])
            c = s["crush"]
            force[name] = c["mean_crush_force"]
            window = c["mean_force_window"]
            print(f"{name:<6s} {s['elements']:>5d} elements: crush {c['crush_distance']:.1f} mm, mean force "
                  f"{c['mean_crush_force']:.3f} kN over {window[0]:.0f}-{window[1]:.1f} mm, lobes {c['lobes']}, "
                  f"H {c['half_wavelength']:.1f} mm, E_hg/E_int {100 * c['hourglass_over_internal']:.1f} %, balance "
                  f"{100 * c['energy_balance_error_max']:.2f} % of absorbed, {s['steps']} steps, run "
                  f"{s['run_seconds']:.0f} s ({s['us_per_element_step']:.2f} us/element-step)", flush=True)
    print(f"mixed / quads mean crush force: {force['mixed'] / force['quads']:.4f} "
          f"({100 * (force['mixed'] / force['quads'] - 1):+.2f} %)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
