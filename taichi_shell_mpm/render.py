"""Pictures and plots of a run's output directory (``python -m taichi_shell_mpm render``).

Reads what :mod:`taichi_shell_mpm.output` wrote (``frames.pvd`` + ``frames/*.vtu``,
``probes.csv``, ``energy.csv``, optional ``force.csv``, ``summary.json``) and writes PNGs
into ``OUTDIR/pictures/``:

``frame_NNNNN.png``
    one per chosen frame (same stem as its ``.vtu``): the deformed shell (without its
    eroded elements) coloured by
    ``plastic_strain_max`` when the frames have it, else by ``|displacement|`` (or by
    ``--field``), with a scalar bar and the time / load factor in the title.  The camera
    (isometric, +z up, fitted to the union of the frames' bounds) and the colour range are
    fixed for the whole sequence, so the pictures can be flipped through as a movie.
``sheet.png``
    the frames nearest to the ``--sheet`` times side by side, like a paper figure
    (default: 5, 10 and 15 when a dynamic run reaches t = 15, else the frames at 1/3, 2/3
    and 3/3 of the run).
``energy.png``
    the energies of ``energy.csv`` and the balance error versus time / load factor, plus
    the columns of ``force.csv`` when the run wrote one.
``load_displacement.png``
    static runs compared with a reference: one panel per compared column, load factor
    versus displacement, simulated against reference.

Only pyvista / vtk (charts included), numpy and meshio are used: no matplotlib code.

Off-screen rendering.  The vtk wheels (>= 9.4) pick an OpenGL window at run time: X when
a display answers, else EGL (Mesa's or the GPU driver's ``libEGL``), else OSMesa.  When none
works VTK kills the process with SIGSEGV, which no ``try`` catches, so a short probe renders
one window in a subprocess first; its window class is then used here directly (through
``VTK_DEFAULT_OPENGL_WINDOW``, so no failed X connection is attempted or reported).

Failures are :class:`RenderError` with a one-line message and an exit code:
:data:`EXIT_INPUT` (2) for a bad output directory or option, :data:`EXIT_RENDER` (3) when
nothing can be drawn.
"""
from __future__ import annotations

import csv
import json
import math
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field as dc_field
from pathlib import Path

import numpy as np

from .output import atomic_write

EXIT_INPUT, EXIT_RENDER = 2, 3

PLASTIC_FIELD = "plastic_strain_max"
"""Cell array preferred for colouring when the frames have it."""
FRAME_SIZE = (1024, 768)
FRAME_FREE = (0.02, 0.82, 0.03, 0.90)
"""Part of a frame picture (x0, x1, y0, y1) the shell is fitted into: title above, bar right."""
SHEET_PANEL = (560, 760)
"""Width of one sheet panel, and its height when the shell's screen extent is square."""
SHEET_HEIGHT = (420, 1000)
"""Least and most sheet height: the panel height follows the shell's screen extent."""
SHEET_FREE = (0.02, 0.98, 0.03, 0.90)
SHEET_BAR = 0.5
"""Width of the sheet's scalar-bar column, in panel widths."""
STATS_FRAMES = 200
"""Most frames read to fix the camera and the colour range (evenly sampled, plus the drawn
ones when they are few); a longer sequence may slightly overshoot them at unsampled frames."""
VIEW_DIRECTION = (1.0, -1.0, 1.0)
VIEW_UP = (0.0, 0.0, 1.0)
COLORMAP = "jet"
"""Fringe-plot colours, as in the crash-code figures the benchmarks compare with."""
PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
           "#7f7f7f", "#bcbd22", "#17becf")
PROBE_TIMEOUT_S = 120
RUNAWAY_EXTENT = 1e3
"""A frame whose shell (bounding-box diagonal) is this many times larger than in the first
drawable frame is a runaway state: not drawn (it would shrink every other frame to a dot)."""

_PROBE = """
from vtkmodules.vtkRenderingCore import vtkRenderWindow, vtkRenderer
import vtkmodules.vtkRenderingOpenGL2
w = vtkRenderWindow()
w.SetOffScreenRendering(1)
w.SetSize(8, 8)
w.AddRenderer(vtkRenderer())
w.Render()
print("WINDOW", w.GetClassName() if w.SupportsOpenGL() else "", flush=True)
"""


class RenderError(Exception):
    """One-line failure with the exit code the command line returns."""

    def __init__(self, code: int, message: str):
        super().__init__(" ".join(str(message).split()))
        self.code = code


# ---------------------------------------------------------------- reading the run
@dataclass
class Table:
    """A numeric CSV: header names and an (n_rows, n_columns) float array."""
    header: list[str]
    data: np.ndarray

    def column(self, name: str) -> np.ndarray:
        return self.data[:, self.header.index(name)]


@dataclass
class Run:
    out_dir: Path
    name: str
    key: str
    """'time' (dynamic) or 'load_factor' (static): the first column of probes.csv."""
    keys: np.ndarray
    """Time / load factor of each frame, in frames.pvd order."""
    files: list[Path]
    summary: dict = dc_field(default_factory=dict)
    energy: Table | None = None
    force: Table | None = None
    warnings: list[str] = dc_field(default_factory=list)
    undrawable: dict[int, str] = dc_field(default_factory=dict)
    """Frame index -> why it is not drawn (unreadable, no cells, non-finite, runaway)."""

    @property
    def static(self) -> bool:
        return self.key == "load_factor"

    @property
    def key_label(self) -> str:
        """Short name of the key in picture titles."""
        return "load factor" if self.static else ("t" if self.key == "time" else self.key)

    @property
    def axis_label(self) -> str:
        return self.key.replace("_", " ")


def _read_table(path: Path) -> Table:
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    if not rows or not rows[0]:
        raise ValueError("empty file")
    header = [h.strip() for h in rows[0]]
    body = [r for r in rows[1:] if r]
    data = np.array([[float(v) if v.strip() else np.nan for v in r] for r in body], dtype=float)
    if body and data.shape[1] != len(header):
        raise ValueError(f"rows have {data.shape[1]} values for {len(header)} columns")
    return Table(header, data.reshape(len(body), len(header)))


def load_run(out_dir: Path) -> Run:
    """Frames index, tables and summary of ``out_dir``; RenderError(2) when it is not one."""
    out_dir = Path(out_dir)
    if not out_dir.is_dir():
        raise RenderError(EXIT_INPUT, f"{out_dir}: no such output directory")
    pvd = out_dir / "frames.pvd"
    if not pvd.is_file():
        if (out_dir / "summary.json").is_file():     # a run that stopped before its first frame
            raise RenderError(EXIT_RENDER, f"{out_dir}: nothing to draw: the run wrote no frame (see its "
                              "summary.json)")
        raise RenderError(EXIT_INPUT, f"{out_dir}: not a run output directory (no frames.pvd)")
    try:
        entries = [(float(ds.get("timestep")), out_dir / ds.get("file"))
                   for ds in ET.parse(pvd).getroot().iter("DataSet")]
    except (ET.ParseError, TypeError, ValueError) as exc:
        raise RenderError(EXIT_INPUT, f"{pvd}: cannot read the frame index ({exc})") from None
    warnings = [f"{f}: listed in frames.pvd but missing" for _, f in entries if not f.is_file()]
    entries = [(k, f) for k, f in entries if f.is_file()]
    if not entries:
        raise RenderError(EXIT_INPUT, f"{pvd}: no frame files to render")

    tables = {}
    for name in ("probes", "energy", "force"):
        path = out_dir / f"{name}.csv"
        if path.is_file():
            try:
                tables[name] = _read_table(path)
            except (OSError, ValueError) as exc:
                warnings.append(f"{path}: unreadable, skipped ({' '.join(str(exc).split())})")
    summary = {}
    if (out_dir / "summary.json").is_file():
        try:
            summary = json.loads((out_dir / "summary.json").read_text())
        except (OSError, ValueError) as exc:
            warnings.append(f"{out_dir / 'summary.json'}: unreadable, skipped ({exc})")
    key = next((tables[n].header[0] for n in ("probes", "energy") if n in tables), "time")
    return Run(out_dir=out_dir, name=str(summary.get("scene") or out_dir.resolve().name), key=key,
               keys=np.array([k for k, _ in entries]), files=[f for _, f in entries],
               summary=summary, energy=tables.get("energy"), force=tables.get("force"),
               warnings=warnings)


# ---------------------------------------------------------------- choosing frames
def _times(spec: str, option: str, words: str) -> list[float]:
    try:
        values = [float(v) for v in spec.replace(";", ",").split(",") if v.strip()]
    except ValueError:
        values = []
    if not values or not all(math.isfinite(v) for v in values):
        raise RenderError(EXIT_INPUT, f"{option} {spec!r}: expected {words} or comma-separated "
                          "times / load factors, e.g. 5,10,15")
    return values


def nearest_frames(keys: np.ndarray, times: list[float]) -> list[int]:
    """Index of the frame nearest to each time, in the order given, without repeats."""
    chosen = []
    for t in times:
        i = int(np.argmin(np.abs(keys - t)))
        if i not in chosen:
            chosen.append(i)
    return chosen


def choose_frames(run: Run, spec: str) -> list[int]:
    spec = spec.strip().lower()
    if spec == "all":
        return list(range(len(run.files)))
    if spec == "last":
        return [len(run.files) - 1]
    if spec == "none":
        return []
    return sorted(nearest_frames(run.keys, _times(spec, "--frames", "'all', 'last', 'none'")))


def sheet_times(run: Run) -> list[float]:
    """5, 10, 15 for a dynamic run that reaches 15; else 1/3, 2/3, 3/3 of the last key."""
    end = float(run.keys[-1])
    if not run.static and end >= 15.0 * (1.0 - 1e-6):
        return [5.0, 10.0, 15.0]
    start = min(float(run.keys[0]), 0.0)
    return [start + (end - start) * k / 3.0 for k in (1, 2, 3)]


def choose_sheet(run: Run, spec: str | None) -> list[int]:
    if spec is not None and spec.strip().lower() == "none":
        return []
    times = sheet_times(run) if spec is None else _times(spec, "--sheet", "'none'")
    return sorted(nearest_frames(run.keys, times))


# ---------------------------------------------------------------- frames -> meshes
class Undrawable(Exception):
    """A frame that cannot be drawn; the message says why."""


ERODED_FIELD = "eroded"
"""Cell array (output.py, runs with erosion) that is non-zero for an eroded element."""


def _without_eroded(m):
    """The meshio mesh `m` without its eroded cells (``eroded`` != 0) and the nodes only they
    used: an eroded element carries no force and its nodes may fly anywhere, so drawn it is a
    line stretched across the picture, and its nodes would set the camera's bounds."""
    import meshio
    if not any(ERODED_FIELD in m.cell_data and np.any(m.cell_data[ERODED_FIELD][k])
               for k in range(len(m.cells))):
        return m
    keep = [np.asarray(m.cell_data[ERODED_FIELD][k]) == 0 for k in range(len(m.cells))]
    cells = [(block.type, block.data[kept]) for block, kept in zip(m.cells, keep)]
    used = np.unique(np.concatenate([c.ravel() for _, c in cells])) if any(len(c) for _, c in cells) else \
        np.zeros(0, dtype=np.int64)
    index = np.full(len(m.points), -1)
    index[used] = np.arange(len(used))
    return meshio.Mesh(m.points[used], [(kind, index[c]) for kind, c in cells if len(c)],
                       point_data={k: np.asarray(v)[used] for k, v in m.point_data.items()},
                       cell_data={k: [np.asarray(v[b])[kept] for b, kept in enumerate(keep) if kept.any()]
                                  for k, v in m.cell_data.items()})


def _read_frame(path: Path):
    """The frame as a pyvista mesh without its eroded elements (:func:`_without_eroded`), or
    :class:`Undrawable` (unreadable or truncated file, no cells, every element eroded,
    non-finite node coordinates)."""
    import contextlib
    import io

    import meshio
    import pyvista as pv
    printed = io.StringIO()
    try:
        with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(printed):
            m = meshio.read(path)
    except SystemExit:       # meshio prints why it cannot read the file, then exits
        raise Undrawable(f"cannot read it ({' '.join(printed.getvalue().split()) or 'unreadable'})") from None
    except Exception as exc:  # meshio raises many types for a damaged file
        raise Undrawable(f"cannot read it ({' '.join(str(exc).split()) or type(exc).__name__})") from None
    if not sum(len(c.data) for c in m.cells):
        raise Undrawable("it has no cells")
    m = _without_eroded(m)
    if not sum(len(c.data) for c in m.cells):
        raise Undrawable("every element has eroded")
    points = np.asarray(m.points, dtype=float)
    if not points.size or not np.isfinite(points).all():
        raise Undrawable("its node coordinates are not all finite")
    try:
        return pv.from_meshio(m)
    except Exception as exc:
        raise Undrawable(f"cannot convert it ({' '.join(str(exc).split()) or type(exc).__name__})") from None


def frame_mesh(run: Run, i: int):
    """Frame `i` of `run` as a pyvista mesh, or None when it cannot be drawn (the reason is
    kept in ``run.undrawable`` and given once as a warning)."""
    if i in run.undrawable:
        return None
    try:
        return _read_frame(run.files[i])
    except Undrawable as exc:
        run.undrawable[i] = str(exc)
        run.warnings.append(f"{run.files[i]}: not drawn: {exc}")
        return None


def _nothing_to_draw(run: Run) -> RenderError:
    why = next(iter(run.undrawable.values()), "no frame")
    return RenderError(EXIT_RENDER, f"{run.out_dir}: nothing to draw: no frame can be drawn "
                       f"({len(run.undrawable)} of {len(run.files)} frames read are not drawable; e.g. {why})")


def _arrays(mesh) -> dict[str, str]:
    """name -> 'point' | 'cell' for every data array of a frame."""
    names = {n: "cell" for n in mesh.cell_data.keys()}
    names.update({n: "point" for n in mesh.point_data.keys()})
    return names


@dataclass(frozen=True)
class Field:
    """The scalar a picture is coloured by: an array, or one component / the magnitude of it."""
    array: str
    where: str
    component: int | None
    label: str

    def values(self, mesh) -> np.ndarray:
        data = mesh.point_data[self.array] if self.where == "point" else mesh.cell_data[self.array]
        data = np.asarray(data, dtype=float)
        if data.ndim == 1:
            return data
        if self.component is not None:
            return data[:, self.component]
        return np.linalg.norm(data, axis=1)


def choose_field(mesh, name: str | None) -> Field:
    """``--field NAME`` or ``NAME:K`` (component K = 0, 1, 2 or x, y, z); default
    plastic_strain_max if present, else |displacement|."""
    arrays = _arrays(mesh)
    if name is None:
        name = PLASTIC_FIELD if PLASTIC_FIELD in arrays else "displacement"
        if name not in arrays:
            name = next(iter(arrays), None)
            if name is None:
                return Field("", "none", None, "")
    array, _, comp = name.partition(":")
    if array not in arrays:
        raise RenderError(EXIT_INPUT, f"--field {name!r}: no such array in the frames; have "
                          + ", ".join(sorted(arrays)))
    where = arrays[array]
    data = mesh.point_data[array] if where == "point" else mesh.cell_data[array]
    width = 1 if np.ndim(data) == 1 else np.shape(data)[1]
    if not comp:
        return Field(array, where, None, array if width == 1 else f"{array} magnitude")
    k = {"x": 0, "y": 1, "z": 2}.get(comp.lower(), comp)
    try:
        k = int(k)
    except ValueError:
        k = -1
    if not 0 <= k < width:
        raise RenderError(EXIT_INPUT, f"--field {name!r}: component must be 0..{width - 1}"
                          + (" or x, y, z" if width == 3 else ""))
    return Field(array, where, k, f"{array}[{k}]")


def _view_axes() -> np.ndarray:
    """Rows: screen right, screen up, towards the camera (unit vectors)."""
    d = np.asarray(VIEW_DIRECTION, dtype=float)
    d /= np.linalg.norm(d)
    right = np.cross(-d, VIEW_UP)
    right /= np.linalg.norm(right)
    return np.array([right, np.cross(right, -d), d])


@dataclass
class Stats:
    bounds: np.ndarray
    """xmin, xmax, ymin, ymax, zmin, zmax over the frames read."""
    extent: np.ndarray
    """(3, 2) min and max of the nodes' coordinates along the :func:`_view_axes`."""
    clim: tuple[float, float]


def sequence_stats(run: Run, indices: list[int], fld: Field) -> Stats:
    """Union bounds and value range over an even sample of the run plus ``indices``."""
    n = len(run.files)
    sample = set(np.linspace(0, n - 1, min(n, STATS_FRAMES)).round().astype(int).tolist())
    if len(indices) <= STATS_FRAMES:
        sample |= set(indices)
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    axes = _view_axes()
    ext_lo, ext_hi = np.full(3, np.inf), np.full(3, -np.inf)
    vmin, vmax = np.inf, -np.inf
    read = {}
    for i in sorted(sample):
        mesh = frame_mesh(run, i)
        if mesh is not None:
            p = np.asarray(mesh.points, dtype=float)
            read[i] = (mesh, p, float(np.linalg.norm(np.ptp(p, axis=0))))
    if not read:
        raise _nothing_to_draw(run)
    first = read[min(read)][2]            # the sample always holds frame 0: the start of the run
    for i, (mesh, p, diagonal) in read.items():
        if diagonal > RUNAWAY_EXTENT * first:
            run.undrawable[i] = f"a runaway state ({diagonal / first:.3g} times the size of the first frame)"
            run.warnings.append(f"{run.files[i]}: not drawn: {run.undrawable[i]}")
            continue
        lo, hi = np.minimum(lo, p.min(axis=0)), np.maximum(hi, p.max(axis=0))
        q = p @ axes.T
        ext_lo, ext_hi = np.minimum(ext_lo, q.min(axis=0)), np.maximum(ext_hi, q.max(axis=0))
        if fld.where != "none":
            v = fld.values(mesh)
            v = v[np.isfinite(v)]
            if v.size:
                vmin, vmax = min(vmin, float(v.min())), max(vmax, float(v.max()))
    if not np.isfinite(lo).all():
        raise _nothing_to_draw(run)
    if not np.isfinite([vmin, vmax]).all():
        vmin, vmax = 0.0, 1.0
    if fld.array in (PLASTIC_FIELD, "displacement") and fld.component is None:
        vmin = min(vmin, 0.0)
    if vmax <= vmin:
        vmax = vmin + max(1.0, abs(vmin)) * 1e-6 if vmin else 1.0
    return Stats(np.column_stack([lo, hi]).ravel(), np.column_stack([ext_lo, ext_hi]),
                 (vmin, vmax))


# ---------------------------------------------------------------- drawing
def ensure_offscreen() -> str:
    """Probe off-screen OpenGL in a subprocess; return the window class that works.

    Sets ``VTK_DEFAULT_OPENGL_WINDOW`` (unless the user did) so this process opens that
    class directly.  RenderError(3) when no window class works.
    """
    try:
        proc = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True,
                              timeout=PROBE_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        raise RenderError(EXIT_RENDER, "off-screen rendering probe timed out") from None
    except OSError as exc:
        raise RenderError(EXIT_RENDER, f"cannot start the off-screen rendering probe ({exc})") from None
    window = ""
    for line in proc.stdout.splitlines():
        if line.startswith("WINDOW"):
            window = line[len("WINDOW"):].strip()
    if proc.returncode != 0 or not window:
        how = (f"killed by signal {-proc.returncode}" if proc.returncode < 0
               else f"exit {proc.returncode}" if proc.returncode else "no OpenGL support")
        # last stderr line, without VTK's colour codes and log prefix
        detail = [re.sub(r"\x1b\[[0-9;]*m", "", ln).split("| ", 1)[-1].strip()
                  for ln in proc.stderr.splitlines()]
        detail = [ln for ln in detail if ln]
        raise RenderError(EXIT_RENDER, "off-screen rendering unavailable: no OpenGL window "
                          f"could be opened (tried X, EGL, OSMesa; probe {how}"
                          + (f": {detail[-1][-200:]}" if detail else "") + "); install Mesa's "
                          "libEGL (e.g. apt install libegl1) or run under xvfb-run")
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", window)
    return window


def _quiet_vtk() -> None:
    """VTK's own warnings (already handled, or noise) stay off the one-line contract."""
    from vtkmodules.vtkCommonCore import vtkLogger, vtkObject
    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_ERROR)
    vtkObject.GlobalWarningDisplayOff()


def _plotter(shape=(1, 1), window_size=FRAME_SIZE, **kw):
    import pyvista as pv
    return pv.Plotter(off_screen=True, shape=shape, window_size=list(window_size),
                      theme=pv.themes.DocumentTheme(), border=False, **kw)


def _set_camera(plotter, stats: Stats, aspect: float,
                free: tuple[float, float, float, float] = (0.0, 1.0, 0.0, 1.0)) -> None:
    """Fixed perspective view from VIEW_DIRECTION (VIEW_UP up) that fits every node of the
    sampled frames into the ``free`` part (x0, x1, y0, y1, fractions) of a viewport of
    width/height ``aspect``; it depends on the sequence, never on the frame drawn.

    The nodes' extents along the screen axes give the size; the distance adds the depth
    half-extent, so that nodes nearer than the focal plane (which look larger) still fit.
    """
    axes = _view_axes()
    mid = stats.extent.mean(axis=1)
    half = np.maximum(0.5 * (stats.extent[:, 1] - stats.extent[:, 0]), 1e-12)
    centre = axes.T @ mid
    x0, x1, y0, y1 = free
    view_angle = 30.0
    tan = math.tan(math.radians(view_angle / 2.0))
    # the visible half-height at unit distance is tan; the free part is a fraction of it
    dist = 1.04 * max(half[1] / ((y1 - y0) * tan), half[0] / ((x1 - x0) * tan * aspect)) + half[2]
    plotter.camera_position = [tuple(centre + dist * axes[2]), tuple(centre), tuple(axes[1])]
    camera = plotter.camera
    camera.view_angle = view_angle
    # shift the picture so that the centre sits at the centre of the free part
    camera.SetWindowCenter(-(x0 + x1 - 1.0), -(y0 + y1 - 1.0))
    plotter.renderer.ResetCameraClippingRange(*stats.bounds)


def _add_frame(plotter, mesh, fld: Field, stats: Stats):
    """Draw one frame; return its mapper (for a scalar bar) or None when uncoloured."""
    kw = dict(show_edges=True, edge_color="#404040", line_width=0.5, lighting=True)
    if fld.where == "none":
        plotter.add_mesh(mesh, color="#b0c4de", **kw)
        return None
    mesh[fld.label] = fld.values(mesh)
    actor = plotter.add_mesh(mesh, scalars=fld.label, preference=fld.where, clim=stats.clim,
                             cmap=COLORMAP, show_scalar_bar=False, **kw)
    return actor.mapper


def _add_bar(plotter, fld: Field, mapper, **where) -> None:
    if mapper is None:
        return
    plotter.add_scalar_bar(title=fld.label, mapper=mapper, n_labels=5, fmt="%.3g",
                           vertical=True, title_font_size=16, label_font_size=14,
                           color="black", **where)


def _key_text(run: Run, key: float) -> str:
    return f"{run.key_label} = {key:.4g}"


def _save(plotter, path: Path) -> Path:
    """Write the plotter's picture to `path` atomically (a blank picture is not written)."""
    def write(tmp: Path) -> None:
        img = plotter.screenshot(str(tmp), return_img=True)
        if img is None or np.asarray(img).size == 0 or np.ptp(np.asarray(img)) == 0:
            raise RenderError(EXIT_RENDER, f"{path}: rendering produced a blank image")
    try:
        atomic_write(path, write)
    finally:
        plotter.close()
    return path


def render_frames(run: Run, indices: list[int], fld: Field, stats: Stats, pictures: Path) -> list[Path]:
    written = []
    for i in indices:
        mesh = frame_mesh(run, i)
        if mesh is None:
            continue
        p = _plotter()
        mapper = _add_frame(p, mesh, fld, stats)
        _add_bar(p, fld, mapper, position_x=0.86, position_y=0.12, height=0.72, width=0.06)
        p.add_text(f"{run.name}   {_key_text(run, run.keys[i])}", position="upper_edge",
                   font_size=14, color="black")
        _set_camera(p, stats, FRAME_SIZE[0] / FRAME_SIZE[1], free=FRAME_FREE)
        written.append(_save(p, pictures / f"{run.files[i].stem}.png"))
    return written


def render_sheet(run: Run, indices: list[int], fld: Field, stats: Stats, pictures: Path) -> Path:
    """The frames side by side, same camera and colours, one scalar bar in a last column."""
    n = len(indices)
    bar = fld.where != "none"
    weights = [1.0] * n + ([SHEET_BAR] if bar else [])
    # panel height follows the shape of the sequence's screen extent (tall tube, flat strip)
    x0, x1, y0, y1 = SHEET_FREE
    half = np.maximum(0.5 * np.diff(stats.extent, axis=1).ravel(), 1e-12)
    height = SHEET_PANEL[0] * (half[1] / (y1 - y0)) / (half[0] / (x1 - x0))
    height = int(np.clip(height, *SHEET_HEIGHT))
    aspect = SHEET_PANEL[0] / height
    width = int(SHEET_PANEL[0] * sum(weights))
    p = _plotter(shape=(1, len(weights)), window_size=(width, height), col_weights=weights)
    mapper = None
    for j, i in enumerate(indices):
        p.subplot(0, j)
        mesh = frame_mesh(run, i)
        if mesh is not None:
            mapper = _add_frame(p, mesh, fld, stats)
        p.add_text(_key_text(run, run.keys[i]), position="upper_edge", font_size=14,
                   color="black")
        _set_camera(p, stats, aspect, free=SHEET_FREE)
    if bar:
        p.subplot(0, n)
        _add_bar(p, fld, mapper, position_x=0.4, position_y=0.12, height=0.72, width=0.2)
    return _save(p, pictures / "sheet.png")


def _chart(title: str, x_label: str, y_label: str):
    import pyvista as pv
    from vtkmodules.vtkChartsCore import vtkChartLegend
    chart = pv.Chart2D(x_label=x_label, y_label=y_label)
    chart.title = title
    chart.legend_visible = True
    chart.legend.SetHorizontalAlignment(vtkChartLegend.LEFT)
    chart.legend.SetVerticalAlignment(vtkChartLegend.TOP)
    return chart


def _legend_room(chart, n_series: int) -> None:
    """Raise the top of the y range so that the legend (top left) covers no data."""
    lo, hi = np.inf, -np.inf
    for plot in chart.plots():
        y = np.asarray(plot.y, dtype=float)
        if y.size:
            lo, hi = min(lo, float(y.min())), max(hi, float(y.max()))
    if np.isfinite([lo, hi]).all():
        span = hi - lo if hi > lo else max(abs(hi), 1.0)
        chart.y_range = [lo, hi + span * (0.1 + 0.07 * n_series)]


def _series(chart, x: np.ndarray, y: np.ndarray, k: int, label: str, *, line=True,
            markers=False, color=None, style="-") -> bool:
    ok = np.isfinite(x) & np.isfinite(y)
    if not ok.any():
        return False
    color = color or PALETTE[k % len(PALETTE)]
    if line and ok.sum() > 1:
        chart.line(x[ok], y[ok], color=color, width=2.0, style=style,
                   label="" if markers else label)
    if markers or ok.sum() == 1:
        chart.scatter(x[ok], y[ok], color=color, size=9, style="o" if k % 2 == 0 else "s",
                      label=label)
    return True


def render_energy(run: Run, pictures: Path) -> Path | None:
    """Energies, balance error (and force.csv columns) versus the run's key."""
    panels = []
    if run.energy is not None and len(run.energy.data):
        e = run.energy
        x = e.data[:, 0]
        names = [h for h in e.header[1:] if h != "balance_error"]
        chart = _chart("Energies", run.axis_label, "energy")
        drawn = sum([_series(chart, x, e.column(h), k, h) for k, h in enumerate(names)])
        if drawn:
            _legend_room(chart, drawn)
            panels.append(chart)
        if "balance_error" in e.header:
            chart = _chart("Energy balance error", run.axis_label, "balance error")
            if _series(chart, x, e.column("balance_error"), 1, "balance_error"):
                panels.append(chart)
    if run.force is not None and len(run.force.data):
        f = run.force
        chart = _chart("Forces", f.header[0].replace("_", " "), "force")
        drawn = sum([_series(chart, f.data[:, 0], f.data[:, c], c - 1, f.header[c])
                     for c in range(1, len(f.header))])
        if drawn:
            _legend_room(chart, drawn)
            panels.append(chart)
    if not panels:
        return None
    p = _plotter(shape=(len(panels), 1), window_size=(1100, 380 * len(panels)))
    for j, chart in enumerate(panels):
        p.subplot(j, 0)
        p.add_chart(chart)
    return _save(p, pictures / "energy.png")


def _reference_levels(run: Run, ref: dict) -> tuple[np.ndarray, str]:
    """Load factor of each reference row, and where it came from.

    Prefers ``load_levels`` from the summary; else the column of the reference file whose
    values are, exactly where a simulated value exists, load factors of probes.csv (the rule
    reference.py matched rows by); else rows assumed evenly spaced up to 1.
    """
    n = int(ref.get("rows") or max(len(c.get("reference", [])) for c in ref["columns"].values()))
    if "load_levels" in ref and len(ref["load_levels"]) == n:
        return np.asarray(ref["load_levels"], dtype=float), "summary"
    path = Path(str(ref.get("file", "")))
    col = next(iter(ref["columns"].values()))
    have = np.isfinite(np.asarray(col.get("simulated", []), dtype=float))
    try:
        table = _read_table(path)
        probes = _read_table(run.out_dir / "probes.csv").data[:, 0]
    except (OSError, ValueError, IndexError):
        table = None
    if table is not None and len(table.data) == n and len(have) == n and have.any():
        for name in table.header:
            levels = table.column(name)
            gap = np.array([np.min(np.abs(probes - lv)) if len(probes) else np.inf for lv in levels])
            hit = gap < 1e-9 * np.maximum(1.0, np.abs(levels))
            if np.array_equal(hit, have):
                return levels, name
    return np.arange(1, n + 1) / n, "evenly spaced rows"


def render_load_displacement(run: Run, pictures: Path) -> Path | None:
    ref = run.summary.get("reference")
    if not run.static or not isinstance(ref, dict) or not ref.get("columns"):
        return None
    levels, _ = _reference_levels(run, ref)
    charts = []
    for name, col in ref["columns"].items():
        sim = np.asarray([np.nan if v is None else v for v in col.get("simulated", [])], dtype=float)
        refv = np.asarray([np.nan if v is None else v for v in col.get("reference", [])], dtype=float)
        err = col.get("mean_rel_error"), col.get("max_rel_error")
        title = name + (f"   (error mean {100 * err[0]:.2f}%, max {100 * err[1]:.2f}%)"
                        if None not in err else "")
        chart = _chart(title, f"{name}  ({col.get('probe', '?')})", "load factor")
        _series(chart, refv, levels[:len(refv)], 0, "reference", line=True, markers=True,
                color="#000000", style="--")
        if "path" in col:           # along the path (limit points): the converged points in order
            x = np.concatenate([[0.0], np.asarray(col["path"]["x"], dtype=float)])
            lam = np.concatenate([[0.0], np.asarray(col["path"]["load_factor"], dtype=float)])
            _series(chart, x, lam, 1, "simulated path", line=True, markers=True, color=PALETTE[1])
        else:
            _series(chart, sim, levels[:len(sim)], 1, "simulated", line=True, markers=True,
                    color=PALETTE[1])
        charts.append(chart)
    p = _plotter(shape=(1, len(charts)), window_size=(640 * len(charts), 520))
    for j, chart in enumerate(charts):
        p.subplot(0, j)
        p.add_chart(chart)
    return _save(p, pictures / "load_displacement.png")


# ---------------------------------------------------------------- entry point
def render(out_dir: Path, frames: str = "all", field: str | None = None,
           sheet: str | None = None) -> tuple[list[Path], list[str]]:
    """Write the pictures of ``out_dir`` into ``out_dir/pictures``.

    Returns the files written and warning lines; raises :class:`RenderError` (one line).
    """
    run = load_run(Path(out_dir))
    indices = choose_frames(run, frames)
    sheet_indices = choose_sheet(run, sheet)
    last = next((m for m in (frame_mesh(run, i) for i in reversed(range(len(run.files)))) if m is not None),
                None)
    if last is None:
        raise _nothing_to_draw(run)
    fld = choose_field(last, field)
    ensure_offscreen()
    pictures = run.out_dir / "pictures"
    try:
        pictures.mkdir(exist_ok=True)
    except OSError as exc:
        raise RenderError(EXIT_INPUT, f"{pictures}: cannot create ({exc.strerror})") from None
    try:
        _quiet_vtk()
        stats = sequence_stats(run, sorted(set(indices) | set(sheet_indices)), fld)
        written = render_frames(run, indices, fld, stats, pictures)
        sheet_indices = [i for i in sheet_indices if i not in run.undrawable]
        if sheet_indices:
            written.append(render_sheet(run, sheet_indices, fld, stats, pictures))
        for plot in (render_energy, render_load_displacement):
            path = plot(run, pictures)
            if path is not None:
                written.append(path)
    except RenderError:
        raise
    except Exception as exc:  # VTK / pyvista failures of any type: one line, exit 3
        raise RenderError(EXIT_RENDER, f"rendering failed: {type(exc).__name__}: {exc}") from None
    return written, run.warnings
