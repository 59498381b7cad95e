"""Explicit dynamics to an end time (method.md 2).  Frames at the listed output times and
the end time (hit exactly: the step before an output time is shortened) or every N steps;
histories (probes, energies, forces) also every ``[output].history_interval``.

The driver is resumable (:mod:`taichi_shell_mpm.checkpoint`): its position is the index of
the next output/history event and whether its time limit is already set; batches have a
fixed size, so a restarted run takes the same batches.
"""

from ..checkpoint import event_times
from ..run_control import RunControl, RunLoop
from ..simulation import Simulation
from ..stages.timestep import landing_step
from .static import batch_size


def events_of(sim: Simulation) -> tuple[list[float], set[float]]:
    """Sorted event times (frames and history records) and the frame times among them."""
    return event_times(sim.scene)


def run_dynamic(sim: Simulation, control: RunControl | None = None) -> dict:
    scene, s, stepper = sim.scene, sim.state.step, sim.stepper
    out, end = scene.output, scene.solve.end_time
    every = out.every_steps
    chunk = every if every > 0 else batch_size(sim, 5_000)
    events, frame_times = events_of(sim)
    with RunLoop(sim, control, s.time[None] / end if end > 0 else None) as loop:
        if loop.resume is None:
            s.load_factor[None] = 1.0            # dead loads act in full (they are load-stepped only in statics)
            loop.record(0.0, frame=True)
            pos = {"event": 0, "started": False}
        else:
            pos = loop.resume
        i, started = int(pos["event"]), bool(pos["started"])
        while i < len(events):
            target = events[i]
            if not started:
                s.time_limit[None] = target
                s.dt[None] = landing_step(target - s.time[None], s.dt_stable[None])
                started = True
            recorded = False
            while s.dt[None] > 0.0:
                sim.total_steps += stepper.advance(chunk)
                with sim.state.reads_cached():      # the checks and the record read this state once
                    loop.guard()
                    if every > 0:
                        loop.record(s.time[None], frame=True)
                    loop.progress(lambda: (f"t {s.time[None]:.5g}/{end:g}", s.dt_stable[None],
                                           s.time[None] / end if end > 0 else None))
                    loop.boundary({"event": i, "started": True})
                    if every == 0 and s.dt[None] <= 0.0:        # landed on the event
                        loop.record(s.time[None], frame=target in frame_times)
                        recorded = True
            if every == 0 and not recorded:         # (a run restarted on the event itself)
                loop.record(s.time[None], frame=target in frame_times)
            i, started = i + 1, False
            loop.boundary({"event": i, "started": False})
    return {}
