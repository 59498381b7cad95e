"""Explicit dynamics to an end time (method.md 2).  Frames at the listed output times and
the end time (hit exactly: the step before an output time is shortened) or every N steps;
histories (probes, energies, forces) also every ``[output].history_interval``.

The driver is resumable (:mod:`taichi_shell_mpm.checkpoint`): its position is the index of
the next output/history event and whether its time limit is already set; batches have a
fixed size, so a restarted run takes the same batches.
"""

from ..checkpoint import event_times
from ..energy import balance_ratio
from ..run_control import RunControl
from ..simulation import Simulation
from ..stages.timestep import landing_step
from .static import batch_size


def events_of(sim: Simulation) -> tuple[list[float], set[float]]:
    """Sorted event times (frames and history records) and the frame times among them."""
    return event_times(sim.scene)


def run_dynamic(sim: Simulation, control: RunControl | None = None) -> dict:
    control = control or RunControl()
    scene, s, stepper = sim.scene, sim.state.step, sim.stepper
    out, end = scene.output, scene.solve.end_time
    every = out.every_steps
    chunk = every if every > 0 else batch_size(sim, 5_000)
    events, frame_times = events_of(sim)
    control.start(sim)
    reporter = sim.reporter
    reporter.start(int(s.step[None]), s.time[None] / end if end > 0 else None)
    if control.resume is None:
        s.load_factor[None] = 1.0            # dead loads act in full (they are load-stepped only in statics)
        sim.record(0.0, frame=True)
        pos = {"event": 0, "started": False}
    else:
        pos = control.resume
    i, started = int(pos["event"]), bool(pos["started"])
    try:
        while i < len(events):
            target = events[i]
            if not started:
                s.time_limit[None] = target
                s.dt[None] = landing_step(target - s.time[None], s.dt_stable[None])
                started = True
            while s.dt[None] > 0.0:
                sim.total_steps += stepper.advance(chunk)
                sim.check_status()
                if every > 0:
                    sim.record(s.time[None], frame=True)
                if reporter.due():
                    reporter.show(f"t {s.time[None]:.5g}/{end:g}", int(s.step[None]), s.dt_stable[None],
                                  balance_ratio(sim.energies()),
                                  s.time[None] / end if end > 0 else None)
                control.boundary(sim, {"event": i, "started": True})
            if every == 0:
                sim.record(s.time[None], frame=target in frame_times)
            i, started = i + 1, False
            control.boundary(sim, {"event": i, "started": False})
    finally:
        sim.run_seconds, sim.run_cpu_seconds = control.run_seconds(), control.run_cpu_seconds()
        reporter.close()
    return {}
