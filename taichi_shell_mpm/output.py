"""Output, separated from the physics: VTU frames + a PVD index, CSV tables, summary.json.

Every file is written atomically (temporary file in the same directory, then rename), and
``frames.pvd`` is rewritten after each frame, so an interrupted run leaves a directory
ParaView opens with every frame written so far.
"""
from __future__ import annotations

import csv
import json
import os
import tempfile
from pathlib import Path

import meshio
import numpy as np


def atomic_write(path: Path, write) -> None:
    """Call write(tmp_path) then rename onto `path`."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        write(Path(tmp))
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
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

    def __init__(self, out_dir: Path, quads: np.ndarray):
        self.out_dir = Path(out_dir)
        self.frames_dir = self.out_dir / "frames"
        self.frames_dir.mkdir(parents=True, exist_ok=True)
        self.quads = np.asarray(quads, dtype=np.int64)
        self.entries: list[tuple[float, str]] = []

    def write(self, key: float, points: np.ndarray, point_data: dict, cell_data: dict) -> Path:
        name = f"frame_{len(self.entries):05d}.vtu"
        mesh = meshio.Mesh(points, [("quad", self.quads)], point_data=point_data,
                           cell_data={k: [v] for k, v in cell_data.items()})
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
