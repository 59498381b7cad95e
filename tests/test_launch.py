"""The three launches give one answer, here on the CPU: the reduced tube of
tests/test_crush.py (mpm, J2, self-contact search, rigid body, walls) for 0.3 ms.
``threads`` (parallel loops, no atomics) must reproduce ``batched`` (one serial kernel):
the same trajectory and the same energies to the bit (the energies are summed per element
and node, energy.py); ``gpu`` (atomic scatters, run here on the CPU's threads) to round-off."""
from __future__ import annotations

import json

import numpy as np

from taichi_shell_mpm import simulation

from .conftest import ROOT
from .test_crush import SHORT
from .test_reliability import cli_run


def run(tmp_path, name: str) -> tuple[dict, np.ndarray]:
    args = ["run", str(ROOT / "scenes" / "square_tube.toml"), "--out", str(tmp_path / name), "--quiet"]
    for item in [*SHORT[:5], "solve.end_time=0.3", "output.times=[]", "output.history_interval=0.05"]:
        args += ["--set", item]
    r = cli_run(*args, timeout=600)       # compiles the tube kernels (twice: serial and parallel)
    assert r.code == 0, r.err
    summary = json.loads((tmp_path / name / "summary.json").read_text())
    energy = np.loadtxt(tmp_path / name / "energy.csv", delimiter=",", skiprows=1)
    return summary, energy


def test_launches_match(tmp_path, monkeypatch):
    runs = {}
    for launch in ("batched", "threads", "gpu"):
        monkeypatch.setattr(simulation, "FORCE_LAUNCH", launch)
        runs[launch] = run(tmp_path, launch)
        assert runs[launch][0]["launch"] == launch
    serial, e_serial = runs["batched"]
    scale = np.abs(e_serial).max(axis=0) + 1e-300
    # threads: the trajectory and the energies are exact (per-entity accumulators summed on the
    # host in a fixed order; before issue 16 they were per-thread reductions, 1e-12)
    for launch, tolerance in (("threads", 0.0), ("gpu", 1e-8)):
        summary, energy = runs[launch]
        assert summary["steps"] == serial["steps"]
        worst = float((np.abs(energy - e_serial) / scale).max())
        crush = summary["crush"]["crush_distance"]
        print(f"\n{launch}: {summary['steps']} steps; largest energy-history difference {worst:.2e} of each "
              f"column's scale; crush {crush:.9f} vs {serial['crush']['crush_distance']:.9f} mm (batched)")
        assert worst <= tolerance
        if launch == "threads":
            assert crush == serial["crush"]["crush_distance"]
        else:
            assert abs(crush - serial["crush"]["crush_distance"]) <= 1e-9
