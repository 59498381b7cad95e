"""The loop every driver runs in, and a run's control at its batch boundaries: periodic
checkpoints and a clean stop on Ctrl-C, SIGTERM or SIGHUP (the checkpoint itself:
checkpoint.py).

:class:`RunLoop` is the one object the static, dynamic and Newton drivers (solvers/) run in:
it starts and ends the run's clock and progress display, catches the stop signals, and gives
the driver its guards (the simulation's status checks), progress lines, recording and batch
boundaries (checkpoint, clean stop), so that a driver holds only its stepping logic.

:class:`RunControl` is what the drivers call at every batch boundary: it writes the
periodic checkpoint (``--checkpoint-every N``: at the first boundary at or after each
multiple of N steps) and turns a Ctrl-C into a clean stop there (checkpoint, then
``KeyboardInterrupt``); a second Ctrl-C interrupts at once.

SIGTERM (``timeout``, a batch scheduler's wall-time limit, ``kill``) and SIGHUP (the
terminal closed) are stops like a Ctrl-C (issue 28): the same clean stop at the next batch
boundary, raised as :class:`Interrupted`, a ``KeyboardInterrupt`` that carries the signal,
so every ``except KeyboardInterrupt`` on the way out (cli.py, executor.py, sweep/) writes
the results so far and the command exits with 128 + the signal's number (130 SIGINT,
129 SIGHUP, 143 SIGTERM), the shell's convention for a process ended by a signal.  A signal
the process was started with ignored (``nohup`` ignores SIGHUP, a shell's background job
SIGINT) stays ignored.
"""
from __future__ import annotations

import contextlib
import signal
import threading
import time
from pathlib import Path
from typing import Any, Callable

from .checkpoint import save_checkpoint
from .energy import balance_ratio

stop_hook: Callable[[Any], bool] | None = None
"""Tests and embedding code: called with the Simulation at every batch boundary; returning
True stops the run there exactly as a Ctrl-C does."""


STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))
"""The signals that stop a run cleanly (SIGHUP does not exist on Windows)."""


class Interrupted(KeyboardInterrupt):
    """A stop by `signum` (one of STOP_SIGNALS), handled wherever a Ctrl-C is."""

    def __init__(self, signum: int = signal.SIGINT):
        self.signum = int(signum)
        super().__init__(signal.Signals(self.signum).name)


def exit_code(exc: KeyboardInterrupt) -> int:
    """The exit status of a command stopped by `exc`: 128 + the signal (a plain
    KeyboardInterrupt is Python's own Ctrl-C: SIGINT, 130)."""
    return 128 + getattr(exc, "signum", int(signal.SIGINT))


def signal_name(exc: KeyboardInterrupt) -> str:
    """' (SIGTERM)' / ' (SIGHUP)' for a stop by those signals, '' for a Ctrl-C."""
    signum = getattr(exc, "signum", int(signal.SIGINT))
    return "" if signum == signal.SIGINT else f" ({signal.Signals(signum).name})"


@contextlib.contextmanager
def _handlers(handler, signals=STOP_SIGNALS, only_default=False):
    """`handler` for each of `signals` (only those at their default action with
    `only_default`; never one that is ignored or handled outside Python), in the main thread
    only; the previous handlers back afterwards.  Yields {signal: previous handler} of those
    replaced."""
    if threading.current_thread() is not threading.main_thread():
        yield {}
        return
    previous = {}
    try:
        for signum in signals:
            now = signal.getsignal(signum)
            if now is signal.SIG_DFL or (callable(now) and not only_default):
                previous[signum] = signal.signal(signum, handler)
        yield previous
    finally:
        for signum, old in previous.items():
            signal.signal(signum, old)


def _raise_interrupted(signum, frame):
    raise Interrupted(signum)


def stop_on_signals():
    """SIGTERM and SIGHUP raise :class:`Interrupted` as Python's own handler raises
    KeyboardInterrupt on SIGINT (cli.main: around the whole command, e.g. while the kernels
    compile).  Their default action would end the process at once, with nothing written and
    no checkpoint."""
    return _handlers(_raise_interrupted, [s for s in STOP_SIGNALS if s != signal.SIGINT], only_default=True)


# ------------------------------------------------------------------ the run loop
class RunLoop:
    """A driver's run (module docstring)::

        with RunLoop(sim, control, fraction) as loop:      # fraction: how far the run is (None: unknown)
            position = loop.resume or {...}
            ...                                              # the driver's steps
            loop.guard()                                     # the simulation's status checks
            loop.progress(lambda: (label, dt, fraction))    # the live line, when due
            loop.boundary(position)                          # checkpoint / clean stop
            loop.record(lam, frame=True)
            loop.note("load step 3/10 ...")                  # a progress line with the run time

    On leaving, the run time (wall and CPU, all sessions) is stored in the simulation and the
    progress display closed, however the driver ended."""

    def __init__(self, sim, control: RunControl | None = None, fraction: float | None = None):
        self.sim = sim
        self.control = control or RunControl()
        self.fraction = fraction
        self._signals = None

    @property
    def resume(self) -> dict | None:
        """The checkpoint's position of a restarted run, else None."""
        return self.control.resume

    def __enter__(self) -> RunLoop:
        self._signals = self.control.catch_interrupts()
        self._signals.__enter__()
        self.control.start(self.sim)
        self.sim.reporter.start(int(self.sim.state.step.step[None]), self.fraction)
        return self

    def __exit__(self, *exc) -> bool:
        try:
            self.sim.run_seconds, self.sim.run_cpu_seconds = self.control.run_seconds(), self.control.run_cpu_seconds()
            self.sim.reporter.close()
        finally:
            self._signals.__exit__(*exc)
        return False

    def guard(self) -> None:
        """The simulation's checks after a batch (a stopped status raises SimulationError)."""
        self.sim.check_status()

    def progress(self, line: Callable[[], tuple[str, float, float | None]]) -> None:
        """The live progress line, when it is due: line() gives its label, dt and how far the
        run is (read only then), with the step and the energy balance."""
        reporter = self.sim.reporter
        if reporter.due():
            label, dt, fraction = line()
            reporter.show(label, int(self.sim.state.step.step[None]), dt, balance_ratio(self.sim.energies()),
                          fraction)

    def boundary(self, position: dict) -> None:
        """A safe point between batches: periodic checkpoint, and a requested stop (RunControl)."""
        self.control.boundary(self.sim, position)

    def record(self, key: float, frame: bool) -> None:
        """Histories (and a frame) at the load factor or time `key`."""
        self.sim.record(key, frame)

    def note(self, text: str) -> None:
        """A progress line, with the run time so far."""
        self.sim.progress(f"{text}  [{self.control.run_seconds():.1f} s]")


# ------------------------------------------------------------------ run control
class RunControl:
    """What the drivers call between batches: periodic checkpoints and clean stops."""

    def __init__(self, checkpoint_every: int = 0, resume: dict | None = None):
        self.checkpoint_every = int(checkpoint_every or 0)
        self.resume = resume
        self.stop_requested = False
        self.stop_signal = int(signal.SIGINT)     # the signal of a requested stop
        self.checkpoints_written = 0
        self.last_checkpoint: Path | None = None
        self._seconds0 = self._cpu_seconds0 = 0.0
        self._t0, self._cpu0 = time.perf_counter(), time.process_time()
        self._overhead = self._cpu_overhead = 0.0

    def start(self, sim) -> None:
        """The driver starts (or resumes): run time counts from here, on top of the saved one."""
        self._seconds0, self._cpu_seconds0 = sim.run_seconds, sim.run_cpu_seconds
        self._t0, self._cpu0 = time.perf_counter(), time.process_time()
        self._overhead = self._cpu_overhead = 0.0

    def run_seconds(self) -> float:
        """Wall time of the driver so far, all sessions, without the checkpoint writing."""
        return self._seconds0 + time.perf_counter() - self._t0 - self._overhead

    def run_cpu_seconds(self) -> float:
        """The process's CPU time (all threads) over the same span: on a shared machine it
        counts the work, not the waiting (benchmarks/step_cost.py --cpu)."""
        return self._cpu_seconds0 + time.process_time() - self._cpu0 - self._cpu_overhead

    def boundary(self, sim, position: dict) -> None:
        """A safe point between batches: the state and `position` say how to continue."""
        step = int(sim.state.step.step[None])
        every = self.checkpoint_every
        if every > 0 and step // every > sim.driver_data.get("checkpoint_step", 0) // every:
            self.write(sim, position, step)
        if self.stop_requested or (stop_hook is not None and stop_hook(sim)):
            self.write(sim, position, step)
            raise Interrupted(self.stop_signal)

    def write(self, sim, position: dict, step: int) -> None:
        t0, cpu0 = time.perf_counter(), time.process_time()
        sim.driver_data["checkpoint_step"] = step
        sim.run_seconds, sim.run_cpu_seconds = self.run_seconds(), self.run_cpu_seconds()
        with deferred_interrupt():
            self.last_checkpoint = save_checkpoint(sim, position)
        self.checkpoints_written += 1
        self._overhead += time.perf_counter() - t0
        self._cpu_overhead += time.process_time() - cpu0

    @contextlib.contextmanager
    def catch_interrupts(self):
        """First Ctrl-C, SIGTERM or SIGHUP: stop at the next batch boundary; second: stop at once."""
        def handler(signum, frame):
            if self.stop_requested:
                raise Interrupted(signum)
            self.stop_requested, self.stop_signal = True, int(signum)

        with _handlers(handler):
            yield


@contextlib.contextmanager
def deferred_interrupt():
    """Hold a Ctrl-C, SIGTERM or SIGHUP until the block is done (a file being written is
    finished first), then act on the first one as the handler before would have."""
    received = []
    try:
        with _handlers(lambda signum, frame: received.append(signum)) as previous:
            yield
    finally:
        if received:
            signum = received[0]
            handler = previous[signum]
            if callable(handler):      # Python's KeyboardInterrupt, RunControl's stop request, ...
                handler(signum, None)
            else:                      # SIG_DFL: the signal would have ended the process
                raise Interrupted(signum)
