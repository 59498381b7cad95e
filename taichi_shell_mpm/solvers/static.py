"""Quasi-static problems: load control in N equal steps, each relaxed to equilibrium by
dynamic relaxation (method.md 6): FIRE by default, plain kinetic damping on request
(``[solve].relaxation``; both decided in-kernel, see :mod:`~taichi_shell_mpm.solvers.stepper`).

The load is never advanced by comparing with a reference answer (the paper did): a level
is done when the out-of-balance force falls below ``tolerance * |F_ext|`` and the kinetic
energy below 1e-8 of the external work (checked in-kernel every step, see
:class:`~taichi_shell_mpm.solvers.stepper.Stepper`).  Non-convergence within the step
budget is an error.  A level whose displacement increment is far larger than its
neighbours' is reported as a jump to a remote branch (solvers/path.JumpMonitor, issue 19).
Under displacement control (``[[motion]]``, kind = "displacement":
u = value x f(lambda), f(lambda) = lambda without a curve) the forces on the prescribed
DOFs count in the scale: the residual must fall below ``tolerance * sqrt(|F_ext|^2 + |R|^2)``,
R the prescribed DOFs' reactions (moments over the mean edge, as in the residual), and the
kinetic energy below 1e-8 of the loads' and the motions' work.

Displacement control ramps [choice, measured]: the prescribed DOFs move from the last level's
value to this level's at most RAMP_STEP x the shortest element edge per step, and the
relaxation's restarts (FIRE or kinetic damping) wait until they arrive; then the level
relaxes as a load level does.  A jump in one step, like a load's, wrecks the incremental
(corotational, hypo-elastic) element update: the 10 x 1 cantilever (fem, PL^2/EI = 1, 5
levels, tip u_z prescribed to the load-controlled run's deflection) came back with a tip
reaction 3.8 % short of P.  Ramped at 1e-2 / 3e-3 / 1e-3 / 3e-4 of the edge per step it was
0.12 / 0.014 / 0.0016 / 0.0004 % short, and the motion's work (with the kinetic energy the
relaxation takes out after the ramp) 66 / 13 / 2.9 / 1.05 x the strain energy; 3e-4 took
25 000 steps against 16 300 at 1e-3.  Restarts during the ramp (tried first) dumped and
re-accelerated the shell every few steps: 107 x the strain energy went through the
relaxation at 1e-3.

The driver is resumable (:mod:`taichi_shell_mpm.checkpoint`): its position is the load
level and the steps already taken in it, and it cuts each level into batches whose sizes
depend only on the scene and that count, so a restarted run takes the same batches.
"""
from __future__ import annotations

import numpy as np

from ..curves import evaluate
from ..loading import reference_loads
from ..run_control import RunControl, RunLoop
from ..simulation import Simulation, SimulationError
from ..state import STATUS_CONVERGED, STATUS_OK
from .path import JumpMonitor
from .stepper import FIRE_ALPHA_START

BATCH_ELEMENT_STEPS = 1_000_000   # one batch ~ 1 s at most, so a Ctrl-C is answered promptly
RAMP_STEP = 3e-4    # displacement control: a prescribed DOF's move per step / shortest edge (module docstring)


def load_norm(sim: Simulation, lam: float) -> float:
    """|F_ext| at load factor lam (every load, in the reference configuration; moments over
    the mean edge).  Plain loads only: lam |F_ext(1)|, the bits of the runs before issue 18."""
    if not sim.model.loading.loads:
        f, m = sim.model.load_force, sim.model.load_moment / sim.model.mean_edge
        return lam * float(np.sqrt(np.sum(f * f) + np.sum(m * m)))
    f, m = reference_loads(sim.model, lam)
    m = m / sim.model.mean_edge
    return float(np.sqrt(np.sum(f * f) + np.sum(m * m)))


def motion_ramp(sim: Simulation, lam_start: float, lam: float) -> float:
    """The largest change of the motions' argument per step in the level from lam_start to lam:
    no prescribed DOF moves more than RAMP_STEP x the shortest element edge per step (a
    rotation: times the mean edge)."""
    specs = sim.model.loading.curves.specs
    largest = 0.0
    for m in sim.model.loading.motions:
        change = lam - lam_start if m.curve < 0 else evaluate(specs[m.curve], lam) - evaluate(specs[m.curve], lam_start)
        arm = np.where(np.arange(6) < 3, 1.0, sim.model.mean_edge)
        largest = max(largest, abs(change) * float(np.max(np.abs(m.value) * arm)))
    return (lam - lam_start) / max(1, int(np.ceil(largest / (RAMP_STEP * sim.model.min_edge))))


def target_sq(sim: Simulation) -> float:
    """The residual's squared target of this step (with displacement control, the
    prescribed DOFs' reactions count: stepper.Stepper.end)."""
    s = sim.state.step
    return s.residual_target_sq[None] + s.tolerance_sq[None] * s.constraint_sq[None]


def batch_size(sim: Simulation, cap: int) -> int:
    """Steps per batch: `cap` for small scenes, fewer for large ones (deterministic)."""
    if not sim.stepper.batched:
        return min(cap, 200)
    return int(max(10, min(cap, BATCH_ELEMENT_STEPS // max(1, len(sim.model.elements)))))


def run_static(sim: Simulation, control: RunControl | None = None) -> dict:
    scene, s, stepper = sim.scene, sim.state.step, sim.stepper
    n_levels = scene.solve.load_steps
    budget = scene.solve.max_steps_per_load_step
    chunk = batch_size(sim, 20_000)
    s.tolerance_sq[None] = scene.solve.tolerance ** 2
    level_steps = sim.driver_data.setdefault("level_steps", [])
    pos = (control.resume if control is not None else None) or {"level": 1, "steps": 0, "started": False}
    j, steps, started = int(pos["level"]), int(pos["steps"]), bool(pos["started"])
    jumps = JumpMonitor(sim.warn)            # a jump to a remote branch between two levels (issue 19)
    jumps.replay(sim.driver_data.get("level_increments", []))
    # the positions of the last converged level: a restart in the middle of a level measures
    # that level's increment from them, not from where it stopped (a false jump otherwise)
    previous = sim.driver_arrays.get("level_start")
    if previous is None or not started:
        previous = sim.state.fetch("nodes.position")
    sim.driver_arrays["level_start"] = previous
    with RunLoop(sim, control, (j - 1) / n_levels) as loop:
        try:
            while j <= n_levels:
                lam = j / n_levels
                if not started:
                    s.load_factor[None] = lam
                    s.residual_target_sq[None] = (scene.solve.tolerance * load_norm(sim, lam)) ** 2
                    s.motion_ramp[None] = motion_ramp(sim, (j - 1) / n_levels, lam)
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
                    loop.guard()
                    if steps >= budget:
                        ratio = np.sqrt(s.residual_sq[None] / max(target_sq(sim), 1e-300)) * scene.solve.tolerance
                        raise SimulationError(
                            f"load step {j}/{n_levels} (load factor {lam:.4g}) did not converge in {budget} steps "
                            f"at {sim.where()} (residual {ratio:.2e} of the load; raise "
                            "[solve].max_steps_per_load_step or load_steps)")
                    loop.progress(lambda: (f"load step {j}/{n_levels} (residual/target "
                                           f"{np.sqrt(s.residual_sq[None] / max(target_sq(sim), 1e-300)):.1e})",
                                           s.dt[None], (j - 1) / n_levels))
                    loop.boundary({"level": j, "steps": steps, "started": True})
                loop.guard()                             # hourglass energy of the converged level
                sim.total_steps += steps
                level_steps.append(steps)
                started = False                          # this level's steps are counted
                s.status[None] = STATUS_OK
                loop.record(lam, frame=scene.output.load_steps)
                position = sim.state.fetch("nodes.position")
                size = float(np.linalg.norm(position - previous))
                previous = sim.driver_arrays["level_start"] = position
                jumps.add(lam, size)
                sim.driver_data.setdefault("level_increments", []).append((lam, size))
                e = sim.energies()
                loop.note(f"load step {j:3d}/{n_levels}  lambda {lam:.3f}  steps {steps:7d}  dt {s.dt[None]:.3e}  "
                          f"W_ext {e['external_work']:.4e}  E_int {e['internal']:.4e}  E_hg {e['hourglass']:.2e}")
                j, steps, started = j + 1, 0, False
                loop.boundary({"level": j, "steps": 0, "started": False})
            jumps.finish()
        except BaseException:
            if started:          # a failed or interrupted level: its steps were taken too (summary, us/step)
                sim.total_steps += steps
            raise
    return {"load_steps": n_levels, "steps_per_load_step": list(level_steps)}
