"""Quasi-static problems: load control in N equal steps, each relaxed to equilibrium by
dynamic relaxation (method.md 6): FIRE by default, plain kinetic damping on request
(``[solve].relaxation``; both decided in-kernel, see :mod:`~taichi_shell_mpm.solvers.stepper`).

The load is never advanced by comparing with a reference answer (the paper did): a level
is done when the out-of-balance force falls below ``tolerance * |F_ext|`` and the kinetic
energy below 1e-8 of the external work (checked in-kernel every step, see
:class:`~taichi_shell_mpm.solvers.stepper.Stepper`).  Non-convergence within the step
budget is an error.

The driver is resumable (:mod:`taichi_shell_mpm.checkpoint`): its position is the load
level and the steps already taken in it, and it cuts each level into batches whose sizes
depend only on the scene and that count, so a restarted run takes the same batches.
"""
from __future__ import annotations

import numpy as np

from ..checkpoint import RunControl
from ..energy import balance_ratio
from ..simulation import Simulation, SimulationError
from ..state import STATUS_CONVERGED, STATUS_OK
from .stepper import FIRE_ALPHA_START

BATCH_ELEMENT_STEPS = 1_000_000   # one batch ~ 1 s at most, so a Ctrl-C is answered promptly


def load_norm(sim: Simulation, lam: float) -> float:
    f = sim.model.load_force
    m = sim.model.load_moment / sim.model.mean_edge
    return lam * float(np.sqrt(np.sum(f * f) + np.sum(m * m)))


def batch_size(sim: Simulation, cap: int) -> int:
    """Steps per batch: `cap` for small scenes, fewer for large ones (deterministic)."""
    if not sim.stepper.batched:
        return min(cap, 200)
    return int(max(10, min(cap, BATCH_ELEMENT_STEPS // max(1, len(sim.model.elements)))))


def run_static(sim: Simulation, control: RunControl | None = None) -> dict:
    control = control or RunControl()
    scene, s, stepper = sim.scene, sim.state.step, sim.stepper
    n_levels = scene.solve.load_steps
    budget = scene.solve.max_steps_per_load_step
    chunk = batch_size(sim, 20_000)
    level_steps = sim.driver_data.setdefault("level_steps", [])
    pos = control.resume or {"level": 1, "steps": 0, "started": False}
    j, steps, started = int(pos["level"]), int(pos["steps"]), bool(pos["started"])
    control.start(sim)
    reporter = sim.reporter
    reporter.start(int(s.step[None]), (j - 1) / n_levels)
    try:
        while j <= n_levels:
            lam = j / n_levels
            if not started:
                s.load_factor[None] = lam
                s.residual_target_sq[None] = (scene.solve.tolerance * load_norm(sim, lam)) ** 2
                s.velocity_keep[None] = 0.0          # start each level from rest ...
                s.restart_factor[None] = 0.5         # ... with the central-difference half step
                s.kinetic_prev[None] = 0.0
                s.fire_alpha[None], s.fire_uphill[None], s.fire_mix[None] = FIRE_ALPHA_START, 0, 0.0
                s.status[None] = STATUS_OK
                steps, started = 0, True
            while True:
                steps += stepper.advance(min(chunk, budget - steps))
                code = s.status[None]
                if code == STATUS_CONVERGED:
                    break
                sim.check_status()
                if steps >= budget:
                    ratio = np.sqrt(s.residual_sq[None] / max(s.residual_target_sq[None], 1e-300)) \
                        * scene.solve.tolerance
                    raise SimulationError(
                        f"load step {j}/{n_levels} (load factor {lam:.4g}) did not converge in {budget} steps "
                        f"at {sim.where()} (residual {ratio:.2e} of the load; raise "
                        "[solve].max_steps_per_load_step or load_steps)")
                if reporter.due():
                    target = max(s.residual_target_sq[None], 1e-300)
                    reporter.show(f"load step {j}/{n_levels} (residual/target "
                                  f"{np.sqrt(s.residual_sq[None] / target):.1e})", int(s.step[None]),
                                  s.dt[None], balance_ratio(sim.energies()),
                                  (j - 1) / n_levels)
                control.boundary(sim, {"level": j, "steps": steps, "started": True})
            sim.check_status()                       # hourglass energy of the converged level
            sim.total_steps += steps
            level_steps.append(steps)
            started = False                          # this level's steps are counted
            s.status[None] = STATUS_OK
            sim.record(lam, frame=scene.output.load_steps)
            e = sim.energies()
            sim.progress(f"load step {j:3d}/{n_levels}  lambda {lam:.3f}  steps {steps:7d}  dt {s.dt[None]:.3e}  "
                         f"W_ext {e['external_work']:.4e}  E_int {e['internal']:.4e}  E_hg {e['hourglass']:.2e}  "
                         f"[{control.run_seconds():.1f} s]")
            j, steps, started = j + 1, 0, False
            control.boundary(sim, {"level": j, "steps": 0, "started": False})
    except BaseException:
        if started:          # a failed or interrupted level: its steps were taken too (summary, us/step)
            sim.total_steps += steps
        raise
    finally:
        sim.run_seconds, sim.run_cpu_seconds = control.run_seconds(), control.run_cpu_seconds()
        reporter.close()
    return {"load_steps": n_levels, "steps_per_load_step": list(level_steps)}
