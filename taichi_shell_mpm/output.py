"""Output, separated from the physics: VTU frames + a PVD index, CSV tables, summary.json.

Every file is written atomically (temporary file in the same directory, then rename), and
``frames.pvd`` is rewritten after each frame, so an interrupted run leaves a directory
ParaView opens with every frame written so far.
"""
from __future__ import annotations

import contextlib
import csv
import json
import os
import tempfile
from pathlib import Path

import meshio
import numpy as np


class OutputError(OSError):
    """A file of the results could not be written (disk full, read-only filesystem, no
    permission ...): a run-time failure, not a bug.  ``str()`` is one line naming the file."""

    def __init__(self, path: Path, exc: OSError):
        super().__init__(exc.errno, exc.strerror or str(exc), str(path))
        self.path = Path(path)
        self.reason = exc.strerror or " ".join(str(exc).split()) or type(exc).__name__

    def __str__(self) -> str:
        return f"cannot write {self.path}: {self.reason}"


_FILE_MODE: int | None = None


def file_mode() -> int:
    """Mode of a new file under the user's umask (0o666 & ~umask), as open() would create it;
    mkstemp's temporary files are 0600, so the renamed result gets this mode instead."""
    global _FILE_MODE
    if _FILE_MODE is None:
        umask = os.umask(0o022)
        os.umask(umask)
        _FILE_MODE = 0o666 & ~umask
    return _FILE_MODE


def atomic_write(path: Path, write) -> None:
    """Call write(tmp_path) then rename onto `path` (mode 0o666 & ~umask).  An OSError on
    the way (disk full, read-only filesystem, ...) is raised as :class:`OutputError` naming
    `path`; the temporary file is removed and an earlier `path` stays as it was."""
    path = Path(path)
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
        os.close(fd)
        write(Path(tmp))
        os.chmod(tmp, file_mode())
        os.replace(tmp, path)
    except BaseException as exc:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        if isinstance(exc, OSError) and not isinstance(exc, OutputError):
            raise OutputError(path, exc) from exc
        raise


def write_text(path: Path, text: str) -> None:
    atomic_write(path, lambda p: p.write_text(text))


def write_csv(path: Path, header: list[str], rows) -> None:
    def write(p: Path):
        with open(p, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(header)
            for row in rows:
                w.writerow([f"{v:.10g}" if isinstance(v, (float, np.floating)) else v for v in row])
    atomic_write(path, write)


def write_json(path: Path, obj) -> None:
    write_text(path, json.dumps(obj, indent=2, default=_json_default) + "\n")


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(type(o))


class FrameWriter:
    """``frames/frame_00000.vtu`` ... plus ``frames.pvd`` (timestep = time or load factor)."""

    def __init__(self, out_dir: Path, elements: np.ndarray):
        self.out_dir = Path(out_dir)
        self.frames_dir = self.out_dir / "frames"
        try:
            self.frames_dir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(self.frames_dir, exc) from exc
        self.elements = np.asarray(elements, dtype=np.int64)
        self.triangles = self.elements[:, 3] < 0
        self.entries: list[tuple[float, str]] = []

    def write(self, key: float, points: np.ndarray, point_data: dict, cell_data: dict) -> Path:
        name = f"frame_{len(self.entries):05d}.vtu"
        if self.triangles.any():     # a quad block (if any) and a triangle block; cell data split alike
            blocks = [(kind, rows) for kind, rows in (("quad", ~self.triangles), ("triangle", self.triangles))
                      if rows.any()]
            cells = [(kind, self.elements[rows][:, :4 if kind == "quad" else 3]) for kind, rows in blocks]
            data = {k: [v[rows] for _, rows in blocks] for k, v in cell_data.items()}
        else:
            cells, data = [("quad", self.elements)], {k: [v] for k, v in cell_data.items()}
        mesh = meshio.Mesh(points, cells, point_data=point_data, cell_data=data)
        path = self.frames_dir / name
        atomic_write(path, lambda p: meshio.write(p, mesh, file_format="vtu"))
        self.entries.append((float(key), f"frames/{name}"))
        self._write_pvd()
        return path

    def _write_pvd(self) -> None:
        lines = ['<?xml version="1.0"?>',
                 '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
                 "  <Collection>"]
        lines += [f'    <DataSet timestep="{k:.10g}" group="" part="0" file="{f}"/>' for k, f in self.entries]
        lines += ["  </Collection>", "</VTKFile>", ""]
        write_text(self.out_dir / "frames.pvd", "\n".join(lines))


# ------------------------------------------------------------------ a reused output directory
RUN_FILES = ("frames.pvd", "probes.csv", "energy.csv", "force.csv", "summary.json", "checkpoint.npz")
"""What a run writes at the top of its output directory (besides frames/ and pictures/)."""
PICTURE_FILES = ("frame_*.png", "sheet.png", "energy.png", "load_displacement.png")
"""What ``render`` writes into ``pictures/``."""


def run_files(out_dir: Path) -> list[Path]:
    """The files of an earlier run (and of its rendering) in `out_dir`: RUN_FILES,
    ``frames/frame_*.vtu``, the PICTURE_FILES in ``pictures/``, and the temporary files of
    an interrupted atomic write of any of them.  Nothing else."""
    out_dir = Path(out_dir)
    found = [out_dir / name for name in RUN_FILES]
    found += [p for name in RUN_FILES for p in out_dir.glob(f".{name}.*")]
    for folder, patterns in (("frames", ("frame_*.vtu",)), ("pictures", PICTURE_FILES)):
        for pattern in patterns:
            found += list((out_dir / folder).glob(pattern)) + list((out_dir / folder).glob(f".{pattern}.*"))
    return sorted({p for p in found if p.is_file() or p.is_symlink()})


def clear_run_files(out_dir: Path) -> int:
    """Delete :func:`run_files` of `out_dir` (and frames/, pictures/ if that empties them);
    returns how many files were deleted; raises OutputError if one cannot be."""
    files = run_files(out_dir)
    for path in files:
        try:
            path.unlink()
        except FileNotFoundError:
            pass
        except OSError as exc:
            raise OutputError(path, exc) from exc
    for folder in ("frames", "pictures"):
        with contextlib.suppress(OSError):
            (Path(out_dir) / folder).rmdir()          # only when empty
    return len(files)
