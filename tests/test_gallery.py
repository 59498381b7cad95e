"""Issue 32: the gallery scenes (docs/gallery.md) run through the CLI, shortened."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from .test_reliability import assert_clean_output, cli_run

SCENES = Path(__file__).resolve().parents[1] / "scenes"


@pytest.mark.parametrize("scene,settings", [
    ("sphere_drop.toml", ("solve.end_time=1.5",)),                 # the sphere reaches the plate at 0.6 ms
    ("burst_cylinder.toml", ("solve.end_time=0.3", "output.times=[]")),
    ("laminated_roof.toml", ("solve.control_displacement=-3.0",)),
], ids=["sphere_drop", "burst_cylinder", "laminated_roof"])
def test_gallery_scene_runs(tmp_path, scene, settings):
    out = tmp_path / "out"
    args = [a for s in settings for a in ("--set", s)]
    r = cli_run("run", str(SCENES / scene), "--out", str(out), "--quiet", *args)
    assert_clean_output(r)
    assert r.code == 0, r.err
    summary = json.loads((out / "summary.json").read_text())
    energy = np.genfromtxt(out / "energy.csv", delimiter=",", names=True)
    print(f"\n{scene}: {summary['steps']} steps, internal {energy['internal'][-1]:.4g}, "
          f"balance error {energy['balance_error'][-1]:.3g}")
    assert summary["steps"] > 0 and not summary.get("error")
    if scene == "sphere_drop.toml":        # the sphere has struck: the plate holds energy
        assert energy["internal"][-1] > 1.0 and abs(energy["balance_error"][-1]) < 1e-3 * energy["kinetic"][0]
