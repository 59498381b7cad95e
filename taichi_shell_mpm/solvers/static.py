"""Quasi-static problems: load control in N equal steps, each relaxed to equilibrium by
dynamic relaxation with kinetic damping (method.md 6).

The load is never advanced by comparing with a reference answer (the paper did): a level
is done when the out-of-balance force falls below ``tolerance * |F_ext|`` and the kinetic
energy below 1e-8 of the external work (checked in-kernel every step, see
:class:`~taichi_shell_mpm.solvers.stepper.Stepper`).  Non-convergence within the step
budget is an error.
"""
from __future__ import annotations

import time

import numpy as np

from ..simulation import Simulation, SimulationError
from ..state import STATUS_CONVERGED, STATUS_OK


def load_norm(sim: Simulation, lam: float) -> float:
    f = sim.model.load_force
    m = sim.model.load_moment / sim.cfg.length_ref
    return lam * float(np.sqrt(np.sum(f * f) + np.sum(m * m)))


def run_static(sim: Simulation) -> dict:
    scene, s, stepper = sim.scene, sim.state, sim.stepper
    n_levels = scene.solve.load_steps
    budget = scene.solve.max_steps_per_load_step
    chunk = 20_000 if stepper.batched else 200
    level_steps = []
    t_start = time.perf_counter()
    last_print = t_start
    for j in range(1, n_levels + 1):
        lam = j / n_levels
        s.load_factor[None] = lam
        s.residual_target_sq[None] = (scene.solve.tolerance * load_norm(sim, lam)) ** 2
        s.velocity_keep[None] = 0.0          # start each level from rest ...
        s.restart_factor[None] = 0.5         # ... with the central-difference half step
        s.kinetic_prev[None] = 0.0
        s.status[None] = STATUS_OK
        steps = 0
        while True:
            steps += stepper.advance(min(chunk, budget - steps))
            code = s.status[None]
            if code == STATUS_CONVERGED:
                break
            sim.check_status()
            if steps >= budget:
                ratio = np.sqrt(s.residual_sq[None] / max(s.residual_target_sq[None], 1e-300)) * scene.solve.tolerance
                raise SimulationError(
                    f"load step {j}/{n_levels} (load factor {lam:.4g}) did not converge in {budget} steps "
                    f"(residual {ratio:.2e} of the load; raise [solve].max_steps_per_load_step or load_steps)")
            now = time.perf_counter()
            if now - last_print > scene.solve.progress_every:
                last_print = now
                sim.progress(f"  load step {j}/{n_levels}  steps {steps}  dt {s.dt[None]:.3e}  "
                             f"residual/target {np.sqrt(s.residual_sq[None] / s.residual_target_sq[None]):.2e}")
        sim.total_steps += steps
        level_steps.append(steps)
        s.status[None] = STATUS_OK
        sim.record(lam, frame=scene.output.load_steps)
        e = sim.energies()
        sim.progress(f"load step {j:3d}/{n_levels}  lambda {lam:.3f}  steps {steps:7d}  dt {s.dt[None]:.3e}  "
                     f"W_ext {e['external_work']:.4e}  E_int {e['internal']:.4e}  E_hg {e['hourglass']:.2e}  "
                     f"[{time.perf_counter() - t_start:.1f} s]")
    sim.run_seconds = time.perf_counter() - t_start
    return {"load_steps": n_levels, "steps_per_load_step": level_steps}
