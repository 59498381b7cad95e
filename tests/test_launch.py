"""The parallel launch (one kernel per step, loops over threads; what larger CPU meshes and
GPUs run) gives the answer of the batched one (one serial kernel for many steps), here on
the CPU: the reduced tube of tests/test_crush.py (mpm, J2, self-contact search, rigid
body, walls) for 0.3 ms."""
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


def test_parallel_launch_matches_batched(tmp_path, monkeypatch):
    monkeypatch.setattr(simulation, "PARALLEL_ON_CPU", False)
    serial, e_serial = run(tmp_path, "batched")
    monkeypatch.setattr(simulation, "PARALLEL_ON_CPU", True)
    parallel, e_parallel = run(tmp_path, "parallel")
    assert serial["launch"] == "batched" and parallel["launch"] == "threads"
    assert serial["steps"] == parallel["steps"]
    scale = np.abs(e_serial).max(axis=0) + 1e-300
    worst = float((np.abs(e_parallel - e_serial) / scale).max())
    print(f"\n{serial['steps']} steps; largest energy-history difference {worst:.2e} of each column's scale; "
          f"crush {serial['crush']['crush_distance']:.6f} vs {parallel['crush']['crush_distance']:.6f} mm")
    assert worst < 1e-8
    assert abs(serial["crush"]["crush_distance"] - parallel["crush"]["crush_distance"]) < 1e-9
