"""Explicit dynamics to an end time (method.md 2).  Frames at the listed output times and
the end time (hit exactly: the step before an output time is shortened) or every N steps;
histories (probes, energies, forces) also every ``[output].history_interval``."""
import time

import numpy as np

from ..simulation import Simulation


def run_dynamic(sim: Simulation) -> dict:
    scene, s, stepper = sim.scene, sim.state, sim.stepper
    out, end = scene.output, scene.solve.end_time
    every = out.every_steps
    chunk = every if every > 0 else (5_000 if stepper.batched else 100)
    frame_times = {t for t in out.times if 0.0 < t <= end} | {end}
    events = set(frame_times)
    if out.history_interval > 0:
        events |= {float(t) for t in np.arange(out.history_interval, end, out.history_interval)}
    t_start = time.perf_counter()
    last_print = t_start
    sim.record(0.0, frame=True)
    for target in sorted(events):
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
                sim.progress(f"t {s.time[None]:.5g}/{end:g}  step {s.step[None]}  "
                             f"dt {s.dt_stable[None]:.3e}  KE {e['kinetic']:.4e}  E_int {e['internal']:.4e}  "
                             f"balance {e['balance_error']:.2e}  [{now - t_start:.0f} s]")
        if every == 0:
            sim.record(s.time[None], frame=target in frame_times)
    sim.run_seconds = time.perf_counter() - t_start
    return {}
