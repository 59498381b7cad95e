"""One case of a sweep, in a Dask worker: a normal ``run`` of the scene with the case's
``--set`` overrides into the case's own folder, in the worker's process.

The worker imports Taichi once and keeps it; a case reuses the worker's Taichi program,
fields and kernels when it differs from the case before only in values (program.py), and
otherwise starts Taichi's runtime afresh and loads its kernels from the offline cache that
every process of this build of the package shares (``runtime.kernel_cache_dir``), so a study
compiles each feature set once [issue 21].
The console output of the case (its warnings, the final summary, the ``error:`` line) goes
to ``run.log`` in its folder, from the file descriptors down, so that Taichi's own messages
land there too.

The run command itself is passed in as `run` (``taichi_shell_mpm.cli.main``, which Dask
sends by name): the sweep package does not import cli.py, which imports it (no import
cycles, tests/test_architecture.py).
"""
from __future__ import annotations

import contextlib
import json
import os
import shlex
import socket
import sys
import time
from pathlib import Path

THREADS_ENV = "TAICHI_SHELL_MPM_THREADS"     # read by runtime.cpu_threads


@contextlib.contextmanager
def _output_to(path: Path):
    """stdout and stderr (Python's and the file descriptors 1 and 2) appended to `path`."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    try:
        with open(path, "a") as fh, contextlib.redirect_stdout(fh), contextlib.redirect_stderr(fh):
            os.dup2(fh.fileno(), 1)
            os.dup2(fh.fileno(), 2)
            try:
                yield
            finally:
                fh.flush()
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        os.close(saved[0])
        os.close(saved[1])


def last_error(log: Path) -> str:
    """The last ``error:`` line of a run's console log (else its last line), without the prefix."""
    try:
        lines = [ln.strip() for ln in log.read_text(errors="replace").splitlines() if ln.strip()]
    except OSError:
        return ""
    errors = [ln for ln in lines if ln.startswith("error:")]
    line = (errors or lines or [""])[-1]
    return line.removeprefix("error:").strip()[:300]


def run_case(run, scene: str, overrides: tuple[str, ...], out_dir: str, arch: str = "cpu",
             threads: int | None = None, flags: tuple[str, ...] = ()) -> dict:
    """Run one case (`flags`: more options of ``run``, e.g. --accept-unread); returns exit_code,
    message (the error, else ""), wall_s, the run's summary (None without summary.json), the
    worker (host:pid) and the log's path."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    log = out / "run.log"
    argv = ["run", scene, "--quiet", "--overwrite", "--out", str(out)]
    if arch != "cpu":
        argv += ["--arch", arch]
    argv += list(flags)
    for o in overrides:
        argv += ["--set", o]
    if threads is not None:
        os.environ[THREADS_ENV] = str(threads)
    log.write_text("$ python -m taichi_shell_mpm " + shlex.join(argv) + "\n")
    t0 = time.perf_counter()
    with _output_to(log):
        try:
            code = run(argv)
        except SystemExit as exc:          # argparse's own exit on a bad option
            code = exc.code if isinstance(exc.code, int) else 2
    wall = time.perf_counter() - t0
    try:
        summary = json.loads((out / "summary.json").read_text())
    except (OSError, ValueError):
        summary = None
    message = ""
    if code != 0 or summary is None or (isinstance(summary, dict) and summary.get("error")):
        message = (summary or {}).get("error") or last_error(log) or "no summary.json"
    return {"exit_code": code, "message": message, "wall_s": wall, "summary": summary,
            "worker": f"{socket.gethostname()}:{os.getpid()}", "log": str(log)}
