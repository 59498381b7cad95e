"""Explicit dynamics to an end time (method.md 2), with outputs at listed times (hit
exactly: the step before an output time is shortened) or every N steps."""
from __future__ import annotations

import time

from ..simulation import Simulation


def output_times(sim: Simulation) -> list[float]:
    out = sim.scene.output
    end = sim.scene.solve.end_time
    times = sorted({t for t in out.times if 0.0 < t <= end} | {end})
    return times


def run_dynamic(sim: Simulation) -> dict:
    scene, s, stepper = sim.scene, sim.state, sim.stepper
    every = scene.output.every_steps
    chunk = every if every > 0 else (5_000 if stepper.batched else 100)
    t_start = time.perf_counter()
    last_print = t_start
    sim.record(0.0, frame=True)
    for target in output_times(sim):
        s.time_limit[None] = target
        s.dt[None] = min(s.dt_stable[None], target - s.time[None])
        while s.dt[None] > 0.0:
            sim.total_steps += stepper.advance(chunk)
            sim.check_status()
            if every > 0:
                sim.record(s.time[None], frame=True)
            now = time.perf_counter()
            if now - last_print > scene.solve.progress_every:
                last_print = now
                e = sim.energies()
                sim.progress(f"t {s.time[None]:.5g}/{scene.solve.end_time:g}  step {s.step[None]}  "
                             f"dt {s.dt_stable[None]:.3e}  KE {e['kinetic']:.4e}  E_int {e['internal']:.4e}  "
                             f"balance {e['balance_error']:.2e}")
        if every == 0:
            sim.record(s.time[None], frame=True)
    sim.run_seconds = time.perf_counter() - t_start
    return {}
