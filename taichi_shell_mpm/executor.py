"""Running the cases of a study (``sweep``, ``bench``): one after the other in this process,
or in parallel on Dask (dask.distributed), on a local cluster or on an existing one.

:class:`Executor` takes :class:`Task` objects (a module-level function and its arguments, so
that Dask can send it to a worker by name) and calls ``on_done(Outcome)`` in this process as
each one finishes, in the order they finish.  Between them it prints a status line: cases
done / running / failed, elapsed time and an estimate of the time left at the rate so far
(elapsed x cases left / cases done).

Back ends [choice, issue 21: we do not write our own job pool]:

* ``workers=None``: in this process, in the given order (``bench``'s default: its timings
  need a quiet machine, and a case already is a subprocess).
* ``workers=N``: a ``distributed.LocalCluster`` of N worker processes with one thread each,
  so each runs one case at a time; a case may use ``case_threads`` = cores / N CPU threads.
* ``scheduler="tcp://host:8786"``: the cluster whose scheduler is there (SLURM through
  dask-jobqueue, a cloud cluster, ``dask scheduler`` + ``dask worker`` by hand); its workers
  need this package installed and the scene files and output folder on a shared filesystem.

A case is tried once: a worker that dies under a case (a crash of the native code, memory)
fails that case (``distributed.scheduler.allowed-failures`` = 0 on the local cluster) and the
study goes on.  Ctrl-C (KeyboardInterrupt in :meth:`Executor.run`) cancels the cases not
finished and closes the local cluster, which stops the worker processes and their cases;
cases already started on an external cluster run to their end, their results unused.
"""
from __future__ import annotations

import logging
import os
import sys
import time
from dataclasses import dataclass
from typing import Any, Callable

from .progress import format_seconds

STATUS_EVERY = 30.0          # s: a status line at least this often while cases run
POLL = 0.2                   # s between looks at the futures (keeps Ctrl-C prompt)
CONNECT_TIMEOUT = "10s"      # to reach the scheduler of --scheduler


@dataclass(frozen=True)
class Task:
    key: str                 # the case's name: unique in a study
    function: Callable       # a module-level function (Dask pickles it by reference)
    args: tuple = ()


@dataclass
class Outcome:
    task: Task
    value: Any = None        # what the function returned
    error: str | None = None  # set when the function raised or its worker died: one line


def _one_line(text: object) -> str:
    return " ".join(str(text).split())


def address_problem(address: str) -> str | None:
    """Why `address` is no Dask scheduler address (parsed as ``distributed`` parses it:
    ``[scheme://]host:port`` for tcp, tls, ws and wss, the scheme's own form for the
    others), or None.  Checked before anything is written: a malformed address is a mistake
    in the command line, not a cluster that cannot be reached."""
    from distributed.comm.addressing import parse_address, parse_host_port
    try:
        scheme, location = parse_address(address)
        if scheme in ("tcp", "tls", "ws", "wss"):
            host, _ = parse_host_port(location)
            if not host or any(c.isspace() for c in host):
                raise ValueError(f"no host name in {address!r}")
    except ValueError as exc:
        return f"not a scheduler address ({' '.join(str(exc).split())}); expected e.g. tcp://host:8786"
    return None


def refuse_early(address: str, timeout: float = 2.0) -> None:
    """Raise ConnectionRefusedError at once when nothing listens at a tcp:// scheduler address
    (a host that answers with a refusal), where Dask's Client retries until CONNECT_TIMEOUT:
    a study pointed at the wrong port fails in milliseconds instead of 10 s.  A host that does
    not answer within `timeout`, or another scheme, is left to Dask."""
    import socket

    from distributed.comm.addressing import parse_address, parse_host_port
    scheme, location = parse_address(address)
    if scheme != "tcp":
        return
    host, port = parse_host_port(location)
    try:
        socket.create_connection((host, port), timeout=timeout).close()
    except ConnectionRefusedError:
        raise ConnectionRefusedError(f"nothing listens at {host}:{port} (connection refused)") from None
    except OSError:           # no answer in time, no route, a name not resolved: Dask says what
        return


class Executor:
    """Context manager: ``with Executor(workers=2) as ex: ex.run(tasks, on_done)`` (entering
    calls :meth:`start`, leaving closes the client and the local cluster)."""

    def __init__(self, workers: int | None = None, scheduler: str | None = None, label: str = "study",
                 stream=None):
        self.workers = workers
        self.scheduler = scheduler
        self.label = label
        self.stream = stream if stream is not None else sys.stdout
        self.cluster = None
        self.client = None
        self.slots = 1                       # cases that run at once
        self.case_threads: int | None = None  # CPU threads a case may use (local cluster), None = all
        self.dashboard: str | None = None

    # ------------------------------------------------------------------ set-up
    def start(self) -> "Executor":
        """Start the local cluster or connect to the scheduler (nothing in this process's
        mode, or when started already).  Raises OSError when that fails."""
        if (self.scheduler is None and self.workers is None) or self.client is not None:
            return self
        import dask
        from distributed import Client, LocalCluster
        dask.config.set({"distributed.scheduler.allowed-failures": 0})
        try:
            if self.scheduler is not None:
                refuse_early(self.scheduler)
                self.client = Client(self.scheduler, timeout=CONNECT_TIMEOUT)
            else:
                cores = os.cpu_count() or 1
                self.case_threads = max(1, cores // self.workers)
                self.cluster = LocalCluster(n_workers=self.workers, threads_per_worker=1, processes=True,
                                            dashboard_address=":0", silence_logs=logging.ERROR)
                self.client = Client(self.cluster)
        except BaseException:
            self.__exit__(None, None, None)
            raise
        self.slots = self._threads()
        if "dashboard" in self.client.scheduler_info().get("services", {}) and _have_bokeh():
            self.dashboard = self.client.dashboard_link
        return self

    def __enter__(self) -> "Executor":
        return self.start()

    def __exit__(self, kind=None, *exc) -> None:
        if kind is not None:      # Ctrl-C, a lost scheduler: the cluster's own complaints while it stops are noise
            logging.getLogger("distributed").setLevel(logging.CRITICAL + 1)
        for thing in (self.client, self.cluster):
            if thing is not None:
                try:
                    thing.close()
                except Exception:   # closing after Ctrl-C or a lost connection: nothing left to save
                    pass
        self.client = self.cluster = None

    def describe(self) -> str:
        """One line: where the cases run."""
        if self.client is None:
            return "in this process, one after the other"
        where = (f"Dask cluster at {self.scheduler}" if self.scheduler is not None
                 else f"local Dask cluster of {self.workers} worker process(es), {self.case_threads} CPU "
                      f"thread(s) per case")
        return f"{where}, {self.slots} case(s) at a time" + (f"; dashboard {self.dashboard}" if self.dashboard
                                                              else "")

    # ------------------------------------------------------------------ running
    def run(self, tasks: list[Task], on_done: Callable[[Outcome], bool]) -> None:
        """Run `tasks`; ``on_done(outcome)`` (in this process) returns whether the case
        succeeded.  KeyboardInterrupt cancels what is left and propagates.

        On Dask, only as many tasks as the cluster has threads are submitted at a time, the
        next one as one finishes: a worker then holds only the case it runs, so a worker
        that dies fails that case alone (the scheduler would count every task assigned to
        it as suspect), and the status line's running count is exact."""
        status = _Status(self, len(tasks))
        if self.client is None:
            for task in tasks:
                status.start(task.key)
                if status.done:
                    status.show()
                try:
                    outcome = Outcome(task, value=task.function(*task.args))
                except KeyboardInterrupt:
                    raise
                except Exception as exc:
                    outcome = Outcome(task, error=_describe(exc))
                status.finish(task.key, on_done(outcome))
            status.show()
            return
        from distributed import as_completed
        waiting, futures, queue = list(tasks), {}, as_completed()

        def submit() -> None:
            while waiting and len(futures) < self.slots:
                task = waiting.pop(0)
                future = self.client.submit(task.function, *task.args, key=f"{self.label}-{task.key}", pure=False)
                futures[future] = task
                queue.add(future)
                status.start(task.key)
        try:
            submit()
            while futures:
                if not queue.has_ready():
                    time.sleep(POLL)
                    status.heartbeat()
                    continue
                for future in queue.next_batch(block=False):
                    task = futures.pop(future)
                    try:
                        outcome = Outcome(task, value=future.result())
                    except KeyboardInterrupt:
                        raise
                    except Exception as exc:      # raised in the task, or its worker died (KilledWorker)
                        outcome = Outcome(task, error=_describe(exc))
                    future.release()
                    status.finish(task.key, on_done(outcome))
                self.slots = self._threads()      # an existing cluster may have grown or shrunk
                submit()
                status.show()
        except BaseException:
            self.client.cancel(list(futures), force=True)
            raise

    def _threads(self) -> int:
        """Threads of the cluster's workers (at least 1: with none, a case waits for one)."""
        return max(1, sum(self.client.nthreads().values()))


def _describe(exc: Exception) -> str:
    """One line for a task that raised, or whose worker died."""
    if type(exc).__name__ == "KilledWorker":
        return "its worker died while running it (KilledWorker: a crash or out of memory; see the worker's log)"
    return f"{type(exc).__name__}: {_one_line(exc)}"


def _have_bokeh() -> bool:
    """The Dask dashboard needs bokeh (optional: ``pip install bokeh``)."""
    try:
        import bokeh  # noqa: F401
    except ImportError:
        return False
    return True


class _Status:
    """The status line: done / running / failed, elapsed, ETA = (what the running cases
    still need at the mean wall time of the finished ones, plus that mean for each case not
    started) / the cases that run at once."""

    def __init__(self, executor: Executor, total: int):
        self.ex = executor
        self.total = total
        self.done = self.failed = 0
        self.t0 = self.last = time.perf_counter()
        self.started: dict[str, float] = {}      # running cases: key -> start time
        self.walls: list[float] = []

    def start(self, key: str) -> None:
        self.started[key] = time.perf_counter()

    def line(self) -> str:
        now = time.perf_counter()
        queued = self.total - self.done - len(self.started)
        eta = None
        if self.walls:
            mean = sum(self.walls) / len(self.walls)
            eta = (sum(max(mean - (now - t), 0.0) for t in self.started.values()) + queued * mean) / self.ex.slots
        return (f"{self.ex.label}: {self.done}/{self.total} done, {len(self.started)} running, {self.failed} "
                f"failed; elapsed {format_seconds(now - self.t0)}, ETA {format_seconds(eta)}")

    def finish(self, key: str, ok: bool) -> None:
        self.done += 1
        self.failed += not ok
        self.walls.append(time.perf_counter() - self.started.pop(key))

    def heartbeat(self) -> None:
        if time.perf_counter() - self.last >= STATUS_EVERY:
            self.show()

    def show(self) -> None:
        self.last = time.perf_counter()
        print(self.line(), file=self.ex.stream, flush=True)
