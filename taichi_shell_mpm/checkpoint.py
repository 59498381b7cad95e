"""No lost work: checkpoints and restart.

A checkpoint (``OUTDIR/checkpoint.npz``, written atomically) holds

* every persistent Taichi field of :class:`~taichi_shell_mpm.state.State` (the used entries
  of each, ``group.name``; State.arrays).  The scratch fields (``persistent=False`` in
  state.py) are left out: between two steps the grid mass, momentum and force are zero, and
  the P2G bins, gathered element loads and contact pair scratch are rewritten before they
  are read; the contact hash is rebuilt before it is read; so a fresh State is equivalent;
* the recorded history rows (probes, energies, forces), the frames listed in
  ``frames.pvd``, the step counters, the warnings given so far;
* the driver's position (static: load level and steps taken in it; dynamic: the next
  output/history event), and
* a hash of the scene (every resolved key except the scene file's own path and the
  display-only keys, :data:`DISPLAY_ONLY`) and of the mesh (node coordinates and element
  connectivity).

``run --restart DIR`` restores all of it into a freshly built Simulation of the same scene
and continues: the result is bit-for-bit that of an uninterrupted run, because the
drivers cut the run into the same batches and nothing between two batches changes the
state.

The clean stop at a batch boundary (Ctrl-C, SIGTERM, SIGHUP) and the periodic checkpoints
are run_control.py's.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path
from typing import Any

import numpy as np

from .output import atomic_write
from .scene import SceneError

CHECKPOINT_NAME = "checkpoint.npz"
FORMAT_VERSION = 4
class CheckpointError(SceneError):
    """A checkpoint that cannot be used (missing, unreadable, written for another scene)."""


# ------------------------------------------------------------------ scene identity
def _canonical(obj: Any) -> Any:
    """A plain, repr-stable view of a scene value (dataclasses -> tuples, paths resolved)."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return (type(obj).__name__,) + tuple((f.name, _canonical(getattr(obj, f.name)))
                                             for f in dataclasses.fields(obj) if f.name != "source")
    if isinstance(obj, Path):
        return str(obj.resolve())
    if isinstance(obj, (list, tuple)):
        return tuple(_canonical(v) for v in obj)
    if isinstance(obj, float):
        return float.hex(obj)
    return obj


DISPLAY_ONLY = (("solve", "progress_every"), ("info", "description"))
"""Scene keys that change what is printed, never a number of the run nor a file it writes:
``[solve].progress_every`` (seconds between progress lines) and ``[scene].description``
(free text).  A checkpoint's identity leaves them out, so a run may be continued with other
values of them (issue 28).  Every other key changes the computation or its outputs (even
``[output]``: the dynamic driver's batches end at the output times)."""


def _without_display(scene):
    """`scene` with the DISPLAY_ONLY keys at their defaults (so that the identity of a
    scene using the defaults is the one it had before these keys were left out)."""
    for table, key in DISPLAY_ONLY:
        part = getattr(scene, table)
        default = next(f.default for f in dataclasses.fields(part) if f.name == key)
        scene = dataclasses.replace(scene, **{table: dataclasses.replace(part, **{key: default})})
    return scene


def scene_hash(scene, points: np.ndarray, quads: np.ndarray) -> str:
    """SHA-256 of the resolved scene (not its file's location, nor its DISPLAY_ONLY keys)
    and the mesh arrays: a checkpoint's identity."""
    h = hashlib.sha256()
    h.update(repr(_canonical(_without_display(scene))).encode())
    h.update(np.ascontiguousarray(points, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(quads, dtype=np.int64).tobytes())
    return h.hexdigest()


def _rows(rows: list, width: int) -> np.ndarray:
    return np.array(rows, dtype=np.float64).reshape(len(rows), width)


# ------------------------------------------------------------------ save / load
def save_checkpoint(sim, position: dict, path: Path | None = None) -> Path:
    """Write the checkpoint of `sim` at driver `position` (atomically)."""
    path = Path(path) if path is not None else sim.out_dir / CHECKPOINT_NAME
    arrays = {f"field.{name}": a for name, a in sim.state.arrays().items()}
    h = sim.history
    ncols = len(h.probe_header)
    arrays["history.probe"] = _rows(h.probe_rows, ncols)
    arrays["history.energy"] = _rows(h.energy_rows, len(h.energy_rows[0]) if h.energy_rows else 0)
    arrays["history.force"] = _rows(h.force_rows, len(h.force_rows[0]) if h.force_rows else 0)
    arrays["history.parts"] = _rows(h.part_rows, len(h.part_rows[0]) if h.part_rows else 0)
    arrays.update({f"driver.{name}": a for name, a in sim.driver_arrays.items()})
    meta = {
        "version": FORMAT_VERSION,
        "scene_hash": scene_hash(sim.scene, sim.model.points, sim.model.elements),
        "scene": sim.scene.info.name, "arch": sim.arch,
        "launch": sim.cfg.launch,
        "position": position,
        "total_steps": int(sim.total_steps), "run_seconds": float(sim.run_seconds),
        "run_cpu_seconds": float(sim.run_cpu_seconds),
        "step": int(sim.state.step.step[None]),
        "frames": [[float(k), f] for k, f in (sim.frames.entries if sim.frames else [])],
        "warnings": list(sim.warnings), "hourglass_warned": bool(sim.hourglass_warned),
        "overflow_warned": bool(sim.overflow_warned),
        "balance_warned": bool(sim.balance_warned),
        "driver": sim.driver_data,
    }
    arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)

    def write(p: Path):
        with open(p, "wb") as fh:
            np.savez(fh, **arrays)
    atomic_write(path, write)
    return path


@dataclasses.dataclass
class Checkpoint:
    path: Path
    meta: dict
    arrays: dict

    @property
    def position(self) -> dict:
        return self.meta["position"]


def load_checkpoint(directory: Path) -> Checkpoint:
    """Read ``directory/checkpoint.npz`` (raises :class:`CheckpointError`)."""
    directory = Path(directory)
    path = directory / CHECKPOINT_NAME if directory.suffix != ".npz" else directory
    if not path.is_file():
        how = ("a run writes one with --checkpoint-every N, and when stopped by Ctrl-C; a run without "
               "one cannot be continued: run it again without --restart")
        if not directory.exists():
            raise CheckpointError(f"--restart {directory}: no such directory (give the output directory of "
                                  f"an interrupted run; {how})")
        if not directory.is_dir() and path != directory:
            raise CheckpointError(f"--restart {directory}: not a directory (give the output directory of "
                                  "an interrupted run)")
        raise CheckpointError(f"--restart {directory}: no {CHECKPOINT_NAME} in this directory ({how})")
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
        meta = json.loads(arrays.pop("meta").tobytes().decode())
    except Exception as exc:  # zip/npz/json errors of a damaged file
        reason = "not a checkpoint file" if "pickle" in str(exc) else " ".join(str(exc).split())
        raise CheckpointError(f"{path}: cannot read the checkpoint ({reason or type(exc).__name__})") from None
    if meta.get("version") != FORMAT_VERSION:
        raise CheckpointError(f"{path}: checkpoint format {meta.get('version')} is not {FORMAT_VERSION}")
    return Checkpoint(path, meta, arrays)


def event_times(scene) -> tuple[list[float], set[float]]:
    """The dynamic driver's schedule (solvers/dynamic.py): sorted event times (frames and
    history records) and the frame times among them; its checkpoint position counts them."""
    out, end = scene.output, scene.solve.end_time
    frame_times = {t for t in out.times if 0.0 < t <= end} | {end}
    if out.frame_interval > 0:
        frame_times |= {float(t) for t in np.arange(out.frame_interval, end, out.frame_interval)}
    events = set(frame_times)
    if out.history_interval > 0:
        events |= {float(t) for t in np.arange(out.history_interval, end, out.history_interval)}
    return sorted(events), frame_times


def at_end(ckpt: Checkpoint, scene) -> bool:
    """True when `ckpt` was written after the driver's last step and record (nothing left
    to compute; a restart would only rewrite the results)."""
    pos = ckpt.position
    if scene.solve.kind == "static":
        return int(pos.get("level", 0)) > scene.solve.load_steps
    return int(pos.get("event", 0)) >= len(event_times(scene)[0])


def summary_is_final(directory: Path) -> bool:
    """`directory` holds the summary.json of a run that ended without error."""
    try:
        summary = json.loads((Path(directory) / "summary.json").read_text())
    except (OSError, ValueError):
        return False
    return isinstance(summary, dict) and not summary.get("error")


def finished_run(directory: Path, ckpt: Checkpoint, scene) -> bool:
    """The run in `directory` is finished: its checkpoint is at the end and its summary.json
    records no error."""
    return at_end(ckpt, scene) and summary_is_final(directory)


def check_compatible(ckpt: Checkpoint, scene, points, quads) -> None:
    """Raise :class:`CheckpointError` if `ckpt` was written for another scene or mesh."""
    if ckpt.meta["scene_hash"] != scene_hash(scene, points, quads):
        raise CheckpointError(f"{ckpt.path}: checkpoint was written for a different scene "
                              f"(scene '{ckpt.meta.get('scene')}' with other keys or another mesh); "
                              "restart with the same scene file and --set options")


def restore_checkpoint(sim, ckpt: Checkpoint) -> list[str]:
    """Load `ckpt` into the freshly built `sim`; returns warning lines (e.g. another arch)."""
    from .output import FrameWriter
    warnings = []
    fields = set(sim.state.arrays())
    saved = {k[len("field."):] for k in ckpt.arrays if k.startswith("field.")}
    if saved != fields:
        raise CheckpointError(f"{ckpt.path}: checkpoint fields {sorted(saved ^ fields)} do not match "
                              "this build of the solver")
    sim.state.restore({name: ckpt.arrays[f"field.{name}"] for name in fields})
    h = sim.history
    h.probe_rows = ckpt.arrays["history.probe"].tolist()
    h.energy_rows = ckpt.arrays["history.energy"].tolist()
    h.force_rows = ckpt.arrays["history.force"].tolist()
    h.part_rows = ckpt.arrays["history.parts"].tolist()
    m = ckpt.meta
    sim.total_steps = int(m["total_steps"])
    sim.run_seconds = float(m["run_seconds"])
    sim.run_cpu_seconds = float(m.get("run_cpu_seconds", 0.0))
    sim.warnings = list(m["warnings"])
    sim.hourglass_warned = bool(m["hourglass_warned"])
    sim.overflow_warned = bool(m["overflow_warned"])
    sim.balance_warned = bool(m["balance_warned"])     # warned once per run, not per session
    sim.driver_data = m["driver"]
    sim.driver_arrays = {k[len("driver."):]: a for k, a in ckpt.arrays.items() if k.startswith("driver.")}
    entries = [(float(k), str(f)) for k, f in m["frames"]]
    source = ckpt.path.parent
    if entries and source.resolve() != sim.out_dir.resolve():      # continuing into another directory
        import shutil
        (sim.out_dir / "frames").mkdir(parents=True, exist_ok=True)
        for _, f in entries:
            if (source / f).is_file():
                shutil.copyfile(source / f, sim.out_dir / f)
    if entries:
        sim.frames = FrameWriter(sim.out_dir, sim.model.elements)
        sim.frames.entries = entries
        sim.frames._write_pvd()
    elif (sim.out_dir / "frames.pvd").is_file():      # it lists only frames written after the checkpoint
        (sim.out_dir / "frames.pvd").unlink()
    frames_dir = sim.out_dir / "frames"
    if frames_dir.is_dir():                       # frames written after the checkpoint: redone
        keep = {Path(f).name for _, f in entries}
        for stale in frames_dir.glob("frame_*.vtu"):
            if stale.name not in keep:
                stale.unlink()
    launch = sim.cfg.launch
    if m["arch"] != sim.arch or m["launch"] != launch:
        warnings.append(f"checkpoint was written on {m['arch']} ({m['launch']} launch), continuing on "
                        f"{sim.arch} ({launch}): the result will not be bit-for-bit that of one run")
    return warnings
