"""Reduced crush (issue 3): the paper's tube section and material, 80 mm long, crushed for
2.5 ms (about 37 mm) through the CLI.  Asserts the energy balance against the absorbed
energy, the hourglass share, contact penetration and that folds form."""
from __future__ import annotations

import json
import subprocess
import sys

from .conftest import ROOT

SHORT = ["mesh.length=80", "mesh.n_length=16", "nodesets.rear.plane.point=[0,0,80]", "wall.1.point=[0,0,80]",
         "method.grid_max=[50,50,90]", "solve.end_time=2.5", "output.times=[1.0,2.0]",
         "output.history_interval=0.02"]


def test_reduced_crush(tmp_path):
    args = [sys.executable, "-m", "taichi_shell_mpm", "run", str(ROOT / "scenes" / "square_tube.toml"),
            "--out", str(tmp_path), "--quiet"]
    for item in SHORT:
        args += ["--set", item]
    proc = subprocess.run(args, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-2000:]
    summary = json.loads((tmp_path / "summary.json").read_text())
    c = summary["crush"]
    print(f"\ncrush {c['crush_distance']:.1f} mm, peak {c['peak_support_force']:.1f} kN, mean "
          f"{c['mean_crush_force']:.2f} kN over {c['mean_force_window']}, half-waves {c['half_waves']}, "
          f"balance {100 * c['energy_balance_error_max']:.2f}% of absorbed, hourglass/internal "
          f"{100 * c['hourglass_over_internal']:.1f}%, penetration {100 * c['max_penetration_over_thickness']:.1f}% t, "
          f"{summary['steps']} steps, run {summary['run_seconds']:.0f} s, {summary['us_per_element_step']:.2f} us/el-step")
    assert c["crush_distance"] > 30
    assert c["energy_balance_error_max"] <= 0.05
    assert c["hourglass_over_internal"] <= 0.10
    assert c["max_penetration_over_thickness"] <= 0.5
    assert c["half_waves"] >= 2
    assert 2.0 < c["mean_crush_force"] < 30.0
