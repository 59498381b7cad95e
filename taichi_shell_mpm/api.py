"""The Python API: load a scene, run it, read its results (docs/api.md).

    import taichi_shell_mpm as tsm
    scene = tsm.load_scene("scenes/cantilever.toml", set={"solve.load_steps": 4})
    result = tsm.run(scene, out="outputs/cantilever")
    result.probes            # pandas DataFrame of probes.csv (the [data] extra)
    result.summary["steps"]

The command line (cli.py) is a thin layer over :func:`run`: the same checks, the same
messages, the same files.  Errors are exceptions: :class:`SceneError` (a mistake in the
scene, its mesh or a checkpoint: one line per problem in ``messages``), :class:`RunFailed`
(the run stopped: instability, non-convergence, a file that cannot be written; the results
so far are written), :class:`RunInterrupted` (a ``KeyboardInterrupt``: Ctrl-C, SIGTERM or
SIGHUP; the same checkpoint, frames and tables as the CLI's Ctrl-C).  Each carries the exit
code the CLI gives it.
"""
from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .checkpoint import CheckpointError
from .problems import SceneError

EXIT_SCENE, EXIT_RUNTIME = 2, 3
"""Exit codes of a mistake in the scene and of a run-time failure (the CLI's, cli.py)."""


class RunFailed(Exception):
    """The run stopped with a run-time failure (the CLI's exit code 3); `messages` are its
    lines, `result` the results written so far."""

    def __init__(self, messages: list[str], result: "Result | None" = None):
        self.messages, self.result, self.code = list(messages), result, EXIT_RUNTIME
        super().__init__("\n".join(self.messages))


class RunInterrupted(KeyboardInterrupt):
    """A run stopped by Ctrl-C, SIGTERM or SIGHUP: the results so far and (with checkpoints)
    a checkpoint to continue from are written.  `code`: the CLI's exit code (130, 143, 129)."""

    def __init__(self, messages: list[str], code: int, result: "Result | None" = None):
        self.messages, self.code, self.result = list(messages), code, result
        super().__init__("\n".join(self.messages))


def toml_value(value: Any) -> str:
    """A Python value as the TOML text of a ``--set`` value (numbers, booleans, strings, lists)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        if isinstance(value, float) and not math.isfinite(value):
            return {math.inf: "inf", -math.inf: "-inf"}.get(value, "nan")
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, Path):
        return json.dumps(str(value))
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"cannot write {type(value).__name__} {value!r} as a scene value")


def load_scene(path: str | Path, set: dict | None = None, accept_unread: bool = False):
    """Read and check a scene file (TOML or an LS-DYNA deck) with the overrides `set`
    ({"solve.end_time": 6, "method.kind": "fem"}: the CLI's ``--set``); the validated,
    frozen :class:`~taichi_shell_mpm.scene.Scene`.  Raises :class:`SceneError` with the CLI's
    lines (``messages``)."""
    from .scene import load_scene as read
    overrides = [f"{key}={toml_value(value)}" for key, value in (set or {}).items()]
    return read(Path(path), overrides, accept_unread)


# ---------------------------------------------------------------- results
class Result:
    """The results of a run in its output folder: tables as pandas DataFrames (read when first
    asked for), the summary as a dict, the frames as pyvista meshes (read one at a time)."""

    def __init__(self, out: str | Path):
        self.out = Path(out)
        self._tables: dict[str, Any] = {}

    @classmethod
    def load(cls, out: str | Path) -> "Result":
        """The results of an earlier run (a folder with summary.json, e.g. ``outputs/tube``)."""
        out = Path(out)
        if not (out / "summary.json").is_file():
            raise FileNotFoundError(f"{out}: no summary.json (not the output folder of a run)")
        return cls(out)

    @property
    def summary(self) -> dict:
        """summary.json (the final summary: steps, energies, warnings, the error if any)."""
        return json.loads((self.out / "summary.json").read_text())

    def _table(self, name: str):
        if name not in self._tables:
            from .extras import require
            require("data", "Result tables (DataFrames)")
            import pandas
            path = self.out / f"{name}.csv"
            self._tables[name] = pandas.read_csv(path) if path.is_file() else pandas.DataFrame()
        return self._tables[name]

    @property
    def probes(self):
        """probes.csv: time (or load factor) and each probe's components."""
        return self._table("probes")

    @property
    def energy(self):
        """energy.csv: kinetic, internal, ... and the balance error over time."""
        return self._table("energy")

    @property
    def force(self):
        """force.csv: support reactions, motions', tools' and bodies' forces over time."""
        return self._table("force")

    @property
    def parts(self):
        """parts.csv: each part's energies over time."""
        return self._table("parts")

    @property
    def frames(self) -> "Frames":
        """The frames of frames.pvd, each read (a pyvista mesh) when indexed."""
        return Frames(self.out)

    def __repr__(self) -> str:
        return f"Result({str(self.out)!r})"


class Frames(Sequence):
    """frames.pvd as a sequence: ``len``, ``times``, and ``frames[k]`` a pyvista mesh read
    from disk when asked for (the [render] extra)."""

    def __init__(self, out: Path):
        import xml.etree.ElementTree as ET
        self.out = Path(out)
        pvd = self.out / "frames.pvd"
        sets = list(ET.parse(pvd).getroot().iter("DataSet")) if pvd.is_file() else []
        self.times = [float(d.get("timestep")) for d in sets]
        self.files = [self.out / d.get("file") for d in sets]

    def __len__(self) -> int:
        return len(self.files)

    def __getitem__(self, k):
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(self)))]
        from .extras import require
        require("render", "Result.frames (pyvista meshes)")
        import pyvista
        return pyvista.read(self.files[k])


# ---------------------------------------------------------------- running
def run(scene, out: str | Path | None = None, *, progress: bool = True, arch: str = "cpu",
        restart: str | Path | None = None, checkpoint_every: int = 0, overwrite: bool = False,
        hourglass_limit: float | None = None, energy_limit: float | None = None,
        mesh=None, model=None, command: str | None = None, table: bool | None = None) -> Result:
    """Run `scene` (a Scene from :func:`load_scene`, or a scene file's path) into the folder
    `out` (default outputs/<scene name>, or the `restart` folder) and return its
    :class:`Result`.  `progress`: progress lines and the final table on stdout (warnings are
    printed either way); `restart`: continue the run whose checkpoint is in that folder
    (bit-for-bit); `checkpoint_every`: a checkpoint every N steps; `overwrite`: start afresh
    in a folder that holds an unfinished run's checkpoint; the limits as the CLI's
    ``--hourglass-limit`` / ``--energy-limit``.  `mesh` and `model`: the scene's, when the
    caller has them (cli.py); `command`: how the run was started, for the line that says how
    to continue it; `table`: print the final summary table (default: with `progress`).
    Raises SceneError, RunFailed, RunInterrupted (module docstring)."""
    from .checkpoint import check_compatible, finished_run, load_checkpoint, summary_is_final
    from .output import OutputError, clear_run_files
    if isinstance(scene, (str, Path)):
        scene = load_scene(scene)
    if mesh is None or model is None:
        from .preflight import mesh_and_model
        mesh, model = mesh_and_model(scene)
    say = print if progress else (lambda *a, **k: None)
    ckpt = None
    if restart is not None:
        ckpt = load_checkpoint(Path(restart))
        check_compatible(ckpt, scene, model.points, model.elements)
        if finished_run(ckpt.path.parent, ckpt, scene):
            print(f"nothing to do: the run in {ckpt.path.parent} is finished (its checkpoint is at the end and its "
                  "summary.json records no error); its results are there.  Run without --restart to compute it "
                  "again", flush=True)
            return Result(ckpt.path.parent)
        if summary_is_final(ckpt.path.parent):
            say(f"{ckpt.path.parent}: this run had finished; its checkpoint is at step {ckpt.meta.get('step')}, "
                "so the steps after it are computed again (bit-for-bit the same)", flush=True)
    out = Path(out) if out is not None else (Path(restart) if restart is not None else Path("outputs") / scene.info.name)
    problem = _check_out_dir(out)
    if problem:
        raise SceneError(problem)
    in_place = ckpt is not None and out.resolve() == ckpt.path.parent.resolve()
    if not in_place:         # the results of an earlier run in `out` are replaced, never mixed in
        if _unfinished_checkpoint(out) and not overwrite:
            raise SceneError(f"--out {out}: holds the checkpoint of an unfinished run: continue it with "
                             f"--restart {out}, or start afresh with --overwrite (deletes its results)")
        try:
            removed = clear_run_files(out)
        except OutputError as exc:
            raise SceneError(f"--out {out}: cannot replace the results of an earlier run ({exc})") from None
        if removed:
            say(f"{out}: removed {removed} files of an earlier run (frames, tables, summary, checkpoint, "
                "pictures); other files are kept", flush=True)
    return _execute(scene, mesh, model, out, ckpt, progress, arch, checkpoint_every, hourglass_limit,
                    energy_limit, command, progress if table is None else table)


def _execute(scene, mesh, model, out: Path, ckpt, progress: bool, arch_requested: str, checkpoint_every: int,
             hourglass_limit, energy_limit, command, table: bool) -> Result:
    from .output import OutputError
    from .preflight import reference_note, setup_warnings
    from .progress import format_summary
    from .run_control import RunControl, exit_code, signal_name
    if not progress:           # Taichi prints a banner when imported unless told not to
        os.environ.setdefault("ENABLE_TAICHI_HEADER_PRINT", "false")
    from .runtime import init_taichi
    from .simulation import Simulation, SimulationError
    from .solvers.dynamic import run_dynamic
    from .solvers.newton import ShellEquations, run_newton
    from .solvers.static import run_static
    from .solvers.tangent import MAX_VIRTUAL_ELEMENTS, newton_is_serial, virtual_count
    sim = None
    control = RunControl(checkpoint_every, resume=ckpt.position if ckpt else None)
    try:
        threads = None
        if scene.solve.kind == "static" and scene.solve.solver == "newton":
            virtual = virtual_count(model, scene.element.triangle)
            if virtual > MAX_VIRTUAL_ELEMENTS:
                raise SceneError(f'[solve].solver: "newton" on {len(model.elements)} elements needs {virtual} '
                                 f"virtual elements for its tangent (solvers/tangent.py), more than "
                                 f'{MAX_VIRTUAL_ELEMENTS} (about 8 GB): use "relaxation" or a coarser mesh')
            if newton_is_serial(virtual):
                threads = 1         # its kernels are serial: no thread pool (solvers/tangent.newton_is_serial)
        keep = not (scene.solve.kind == "static" and scene.solve.solver == "newton")   # program.py
        arch = init_taichi(arch_requested, quiet=not progress, threads=threads, keep=keep)
        if progress:
            print("compiling kernels (a configuration's first run takes 15-70 s; later runs load them from "
                  "Taichi's offline cache) ...", flush=True)
        t0 = time.perf_counter()
        sim = Simulation(scene, out, arch, quiet=not progress, mesh=mesh, model=model, keep=keep)
        if arch != arch_requested:
            sim.arch_requested = arch_requested
        if hourglass_limit is not None:
            sim.hourglass_limit = hourglass_limit
        if energy_limit is not None:
            sim.energy_limit = energy_limit
        newton = None
        if scene.solve.kind == "static" and scene.solve.solver == "newton":
            newton = ShellEquations.compiled(sim)
        for w in (*sim.mesh.warnings, *setup_warnings(scene, model)):
            print(f"warning: {w}")
        if ckpt is not None:
            from .checkpoint import restore_checkpoint
            for w in restore_checkpoint(sim, ckpt):
                sim.warn(w)
        fallback = (f"--arch {arch_requested}: not available on this machine; Taichi fell back to {arch}, "
                    f"the run is on {arch}")
        for note in ((fallback if arch != arch_requested else None), reference_note(scene)):
            if note is not None and note not in sim.warnings:
                sim.warn(note)
        sim.progress(f"{scene.info.name}: {len(sim.model.points)} nodes, {len(sim.model.elements)} elements, "
                     f"{sim.cfg.method}, kernels ready in {time.perf_counter() - t0:.1f} s -> {sim.out_dir}"
                     + (f" (restarted at step {sim.state.step.step[None]})" if ckpt else ""))
        if scene.solve.kind == "dynamic":          # each driver runs in a run_control.RunLoop (signals too)
            extra = run_dynamic(sim, control)
        elif newton is not None:
            extra = run_newton(sim, newton, control)
        else:
            extra = run_static(sim, control)
        summary = sim.write_results(extra)
    except (SceneError, CheckpointError):
        raise
    except (SimulationError, OutputError) as exc:
        what = str(exc) if isinstance(exc, SimulationError) else (
            f"{exc}" + (f" at {sim.where()}" if sim is not None else "")
            + " (disk full, read-only or no permission?); the results that could be written are there")
        more = _finish(sim, what)
        raise RunFailed([what] + ([more] if more and not isinstance(exc, OutputError) else []),
                        Result(out) if sim is not None else None) from None
    except KeyboardInterrupt as exc:      # Ctrl-C, SIGTERM, SIGHUP (run_control.Interrupted)
        more = _finish(sim, "interrupted", interrupted=True)
        code, by = exit_code(exc), signal_name(exc)
        if sim is None:
            raise RunInterrupted([f"interrupted{by} before the run started; nothing written"], code) from None
        follow = (f"; continue with: {command or 'run'} --restart {sim.out_dir}"
                  if control.last_checkpoint is not None else "")
        raise RunInterrupted([f"interrupted{by} at {sim.where()}; results so far written to {sim.out_dir}" + follow]
                             + ([more] if more else []), code, Result(out)) from None
    except Exception as exc:  # a bug: results so far, then the exception itself
        more = _finish(sim, f"internal error: {type(exc).__name__}: {' '.join(str(exc).split())}")
        if more:
            exc.add_note(more)
        raise
    if table:
        print(format_summary(summary), flush=True)
    return Result(out)


def _check_out_dir(out: Path) -> str | None:
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        return f"--out {out}: cannot create the output directory ({exc.strerror or exc})"
    if not os.access(out, os.W_OK | os.X_OK):
        return f"--out {out}: the output directory is not writable"
    return None


def _unfinished_checkpoint(out: Path) -> bool:
    """`out` holds the checkpoint of a run that can still be continued: no summary.json, or
    one saying it was interrupted."""
    if not (out / "checkpoint.npz").is_file():
        return False
    try:
        summary = json.loads((out / "summary.json").read_text())
    except (OSError, ValueError):
        return True
    return not isinstance(summary, dict) or summary.get("error") == "interrupted"


def _state_is_a_result(sim) -> bool:
    """After an interrupt: the current state may be written as the last frame.  A dynamic
    state at a batch boundary is one; a static one only once its load level has converged
    (mid-level it is not the equilibrium at the level's load factor)."""
    if sim.scene.solve.kind != "static":
        return True
    rows = sim.history.probe_rows
    return bool(rows) and rows[-1][0] == float(sim.state.step.load_factor[None])


def _undeformed_frame(sim) -> None:
    """A static run stopped before its first converged load level has no frame: write the
    undeformed shell at load factor 0 (the equilibrium before any load) as its last good
    frame, so that frames.pvd opens.  Nothing when the scene writes no frames."""
    import numpy as np

    from .output import FrameWriter
    if sim.scene.solve.kind != "static" or not sim.scene.output.load_steps or sim.frames is not None:
        return
    zero = np.zeros_like(sim.model.points)
    cells = {k: (v if k == "thickness" else np.zeros_like(v)) for k, v in sim.element_results().items()}
    frames = FrameWriter(sim.out_dir, sim.model.elements)
    frames.write(0.0, sim.model.points, {"displacement": zero, "velocity": zero, "rotation": zero}, cells)
    sim.frames = frames


def _finish(sim, message: str, interrupted: bool = False) -> str | None:
    """After a failure or an interrupt: tables and summary with the error, and (interrupt
    only) the current state as the last frame.  After a failure the last frame written stays
    the last one: the failing state (runaway, inside out, not converged) is not a result.
    Returns a line saying what could not be written, or None."""
    from .run_control import deferred_interrupt
    if sim is None:
        return None
    try:
        with deferred_interrupt():
            try:
                if interrupted and _state_is_a_result(sim):
                    sim.final_frame()
                _undeformed_frame(sim)
            finally:
                sim.write_results({"error": message})
    except KeyboardInterrupt:
        return "interrupted again while writing the results"
    except Exception as exc:  # keep the one-line report of the original failure
        from .output import OutputError
        if isinstance(exc, OutputError):
            return f"while writing the results: {exc}"
        return f"could not write all results: {type(exc).__name__}: {' '.join(str(exc).split())}"
    return None


# ---------------------------------------------------------------- stepping from Python
class Simulation:
    """A dynamic scene stepped from Python (scripting, control loops):

        sim = tsm.Simulation(scene)
        while sim.time < 2.0:
            sim.advance(until=sim.time + 0.1)
            print(sim.time, sim.positions[tip].mean(axis=0))
        result = sim.finish()        # the tables and summary, as run() writes them

    `advance` steps to a time exactly (the last step shortened, as the run's frames are hit)
    with the run's checks after every batch (a runaway raises RunFailed).  The arrays are
    copies read from the device: `positions`, `velocities` (nodes, (n, 3)), `rotations` (the
    nodes' rotation vectors), `stresses` (each element's through-thickness points' in-plane
    stresses in its local frame, (m, points, 5): xx, yy, xy, yz, zx) and `element_results`
    (membrane forces, moments, von Mises, plastic strain: as the frames hold them).
    `checkpoint()` writes a checkpoint that `run(scene, restart=out)` continues bit-for-bit."""

    def __init__(self, scene, out: str | Path | None = None, arch: str = "cpu", progress: bool = False):
        from .preflight import mesh_and_model
        from .runtime import init_taichi
        from .simulation import Simulation as Core
        if isinstance(scene, (str, Path)):
            scene = load_scene(scene)
        if scene.solve.kind != "dynamic":
            raise SceneError(f"{scene.source.name}: [solve].kind = {scene.solve.kind!r}: Simulation steps dynamic "
                             "scenes (run() solves static ones)")
        mesh, model = mesh_and_model(scene)
        if not progress:
            os.environ.setdefault("ENABLE_TAICHI_HEADER_PRINT", "false")
        arch = init_taichi(arch, quiet=not progress, keep=True)
        self.scene = scene
        self._core = Core(scene, out, arch, quiet=not progress, mesh=mesh, model=model, keep=True)
        from . import program
        self._generation = program.generation
        self.core.state.step.load_factor[None] = 1.0          # as the dynamic driver: dead loads in full
        self.core.record(0.0, frame=True)
        self._events = 0

    @property
    def core(self):
        """The simulation.Simulation underneath (its state lives while no later run or
        Simulation of this process has started: Taichi holds one at a time, program.py)."""
        from . import program
        if self._generation != program.generation:
            raise RuntimeError("this Simulation is stale: a later run or Simulation in this process has taken "
                               "over Taichi's state (one at a time); create it again to continue")
        return self._core

    @property
    def time(self) -> float:
        return float(self.core.state.step.time[None])

    @property
    def step(self) -> int:
        return int(self.core.state.step.step[None])

    def advance(self, until: float) -> float:
        """Step to the time `until` (recording histories there); returns the time reached."""
        from .simulation import SimulationError
        from .solvers.static import batch_size
        from .stages.timestep import landing_step
        s = self.core.state.step
        if until <= self.time:
            return self.time
        s.time_limit[None] = until
        s.dt[None] = landing_step(until - s.time[None], s.dt_stable[None])
        chunk = batch_size(self.core, 5_000)
        try:
            while s.dt[None] > 0.0:
                self.core.total_steps += self.core.stepper.advance(chunk)
                self.core.check_status()
        except SimulationError as exc:
            more = _finish(self.core, str(exc))
            raise RunFailed([str(exc)] + ([more] if more else []), Result(self.core.out_dir)) from None
        self.core.record(self.time, frame=False)
        return self.time

    @property
    def positions(self):
        return self.core.state.fetch("nodes.position")

    @property
    def velocities(self):
        return self.core.state.fetch("nodes.velocity")

    @property
    def rotations(self):
        return self.core.displacements()[1]

    @property
    def stresses(self):
        return self.core.state.fetch("points.stress")

    @property
    def element_results(self) -> dict:
        return self.core.element_results()

    def energies(self) -> dict:
        """The energy totals now (kinetic, internal, ..., balance error)."""
        return self.core.energies()

    def frame(self) -> None:
        """Write a frame of the state now (frames.pvd)."""
        self.core.write_frame(self.time)

    def checkpoint(self) -> Path:
        """A checkpoint in the output folder; ``run(scene, restart=<out>)`` continues it."""
        from .checkpoint import save_checkpoint, event_times
        events = event_times(self.scene)[0]
        done = sum(1 for t in events if t <= self.time)
        return save_checkpoint(self.core, {"event": done, "started": False})

    def finish(self) -> Result:
        """The final frame, tables and summary.json; the :class:`Result`."""
        self.core.write_frame(self.time)
        self.core.write_results({})
        return Result(self.core.out_dir)


__all__ = ["Frames", "Result", "RunFailed", "RunInterrupted", "SceneError", "Simulation", "load_scene", "run",
           "toml_value"]
