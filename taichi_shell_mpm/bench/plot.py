"""The figures: ``error_vs_time.png`` (error, mean and max of both components, against run
wall time), ``convergence.png`` (mean error against element size, with the observed
orders), ``tube.png`` (crush force against crush distance from each tube run's force.csv,
and the tube's wall time) and ``scaling.png`` (time per step against elements).  Drawn with
matplotlib when it imports, else with pyvista's charts (as ``render``): :func:`draw`.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .cases import STATIC_SCENES
from .fit import group_key
from .results import atomic_write, num

PLOT_FILES = {"error against run time": "error_vs_time.png", "convergence": "convergence.png",
              "square tube": "tube.png", "scaling": "scaling.png"}
"""The report's name of each figure -> its file in ``--out``."""


@dataclass
class Series:
    x: np.ndarray
    y: np.ndarray
    label: str
    color: str
    dashed: bool = False
    marker: str = "o"
    filled: bool = True
    notes: tuple = ()               # text next to each point (matplotlib only)


@dataclass
class Panel:
    title: str
    xlabel: str
    ylabel: str
    series: list
    logx: bool = True
    logy: bool = True


PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f")
MARKERS = ("o", "s", "^", "D", "v")


def _color(i: int) -> str:
    return PALETTE[i % len(PALETTE)]


def _plot_matplotlib(panels: list[Panel], path: Path, ncols: int) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import LogFormatter
    nrows = math.ceil(len(panels) / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(6.4 * ncols, 4.6 * nrows), squeeze=False)
    for ax in axes.ravel()[len(panels):]:
        ax.set_visible(False)
    for ax, p in zip(axes.ravel(), panels):
        for s in p.series:
            ok = np.isfinite(s.x) & np.isfinite(s.y)
            if p.logx:
                ok &= s.x > 0
            if p.logy:
                ok &= s.y > 0
            if not ok.any():
                continue
            ax.plot(s.x[ok], s.y[ok], linestyle="--" if s.dashed else "-", marker=s.marker or None,
                    color=s.color, markerfacecolor=s.color if s.filled else "white", label=s.label,
                    linewidth=1.5, markersize=7 if s.filled else 5)
            for x, y, note in zip(s.x[ok], s.y[ok], np.asarray(s.notes, dtype=object)[ok] if s.notes else ()):
                ax.annotate(str(note), (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7,
                            color=s.color)
        for axis, log in ((ax.xaxis, p.logx), (ax.yaxis, p.logy)):
            if log:
                (ax.set_xscale if axis is ax.xaxis else ax.set_yscale)("log")
                axis.set_major_formatter(LogFormatter(labelOnlyBase=False))
                axis.set_minor_formatter(LogFormatter(labelOnlyBase=False, minor_thresholds=(2, 0.5)))
        ax.set_title(p.title, fontsize=10)
        ax.set_xlabel(p.xlabel)
        ax.set_ylabel(p.ylabel)
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    fig.tight_layout()
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    plt.close(fig)


def _plot_pyvista(panels: list[Panel], path: Path, ncols: int) -> None:
    from .. import render
    render.ensure_offscreen()
    render._quiet_vtk()
    nrows = math.ceil(len(panels) / ncols)
    p = render._plotter(shape=(nrows, ncols), window_size=(640 * ncols, 460 * nrows))
    for i, panel in enumerate(panels):
        chart = render._chart(panel.title, panel.xlabel, panel.ylabel)
        for s in panel.series:
            ok = np.isfinite(s.x) & np.isfinite(s.y) & ((s.x > 0) if panel.logx else True) \
                & ((s.y > 0) if panel.logy else True)
            if not ok.any():
                continue
            chart.line(s.x[ok], s.y[ok], color=s.color, width=2.0, style="--" if s.dashed else "-",
                       label="" if s.marker else s.label)
            if s.marker:
                chart.scatter(s.x[ok], s.y[ok], color=s.color, size=8, style="o" if s.filled else "s",
                              label=s.label)
        chart.x_axis.log_scale = panel.logx
        chart.y_axis.log_scale = panel.logy
        p.subplot(i // ncols, i % ncols)
        p.add_chart(chart)
    render._save(p, path)


def have_matplotlib() -> bool:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def draw(panels: list[Panel], path: Path, ncols: int = 2) -> Path | None:
    """Draw the panels into the PNG `path` (matplotlib if it imports, else pyvista's charts)."""
    if not panels:
        return None
    (_plot_matplotlib if have_matplotlib() else _plot_pyvista)(panels, path, ncols)
    return path


def _static_rows(rows: list[dict], scene: str) -> dict[str, list[dict]]:
    groups: dict[str, list[dict]] = {}
    for r in rows:
        if r["scene"] == scene and r.get("status") == "ok":
            groups.setdefault(group_key(r), []).append(r)
    return {k: sorted(v, key=lambda r: num(r, "elements")) for k, v in sorted(groups.items())}


def _error_panels(rows: list[dict], x_key: str, x_label: str, title: str, mean_label=None,
                  notes: bool = False) -> list[Panel]:
    """One panel per static scene and reference component: mean (solid) and max (dashed)
    error of each series against the column `x_key`; `mean_label(scene, series, k)` adds to
    the mean curve's label, `notes` writes the mesh beside each mean point."""
    panels = []
    for scene in STATIC_SCENES:
        groups = _static_rows(rows, scene)
        if not groups:
            continue
        first = next(iter(groups.values()))[0]
        for k in (1, 2):
            series = []
            for i, (label, rs) in enumerate(groups.items()):
                x = np.array([num(r, x_key) for r in rs])
                extra = mean_label(scene, label, k) if mean_label else ""
                for stat, dashed, filled in (("mean", False, True), ("max", True, False)):
                    e = 100 * np.array([num(r, f"err{k}_{stat}") for r in rs])
                    mean = stat == "mean"
                    series.append(Series(x, e, f"{label} {stat}" + (extra if mean else ""), _color(i), dashed,
                                         MARKERS[i % len(MARKERS)], filled,
                                         tuple(r["mesh"] for r in rs) if notes and mean else ()))
            panels.append(Panel(f"{scene}: {first.get(f'comp{k}', f'component {k}')} {title}", x_label,
                                "relative error (%)", series))
    return panels


def plot_error_vs_time(rows: list[dict], path: Path) -> Path | None:
    return draw(_error_panels(rows, "run_s", "run wall time (s)",
                              "error vs run time (points: meshes, coarse to fine)", notes=True), path)


def plot_convergence(rows: list[dict], orders: list[dict], path: Path) -> Path | None:
    order_of = {(o["scene"], o["series"]): o for o in orders}

    def slope(scene: str, series: str, k: int) -> str:
        o = order_of.get((scene, series), {}).get(f"order{k}", float("nan"))
        return f", p = {o:.2f}" if math.isfinite(o) else ""
    return draw(_error_panels(rows, "element_size", "element size l", "error vs element size", slope), path)


def _force_curve(run_dir: Path) -> tuple[np.ndarray, np.ndarray] | None:
    path = run_dir / "force.csv"
    try:
        with open(path, newline="") as fh:
            data = list(csv.reader(fh))
        header, body = data[0], np.array(data[1:], dtype=float)
        disp = next(i for i, h in enumerate(header) if h.endswith(".displacement"))
        return -body[:, disp], np.abs(body[:, header.index("support_z")])
    except (OSError, ValueError, IndexError, StopIteration):
        return None


def plot_tube(rows: list[dict], out: Path, path: Path) -> Path | None:
    tubes = [r for r in rows if r["scene"] == "tube" and r.get("status") == "ok"]
    if not tubes:
        return None
    tubes.sort(key=lambda r: num(r, "elements"))
    curves = []
    for i, r in enumerate(tubes):
        c = _force_curve(out / "runs" / r["case"])
        if c is not None:
            mean = num(r, "mean_force")
            curves.append(Series(c[0], c[1], r["case"] + (f" (mean {mean:.2f} kN)" if math.isfinite(mean)
                                                         else " (crush < 20 mm: no mean)"), _color(i), marker=""))
    ref = []
    if curves:
        xmax = max(float(np.nanmax(s.x)) for s in curves)
        for value, name, color in ((7.46, "Wierzbicki-Abramowicz 7.46 kN", "#000000"),
                                   (10.22, "Abramowicz-Jones 10.22 kN", "#7f7f7f")):
            ref.append(Series(np.array([0.0, xmax]), np.array([value, value]), name, color, dashed=True,
                              marker=""))
    panels = [Panel("square tube: support force vs crush distance", "crush distance (mm)", "force (kN)",
                    curves + ref, logx=False, logy=False)]
    n = np.array([num(r, "elements") for r in tubes])
    panels.append(Panel("square tube: wall time vs elements", "elements", "wall time (s)",
                        [Series(n, np.array([num(r, "run_s") for r in tubes]), "run", _color(0)),
                         Series(n, np.array([num(r, "compile_s") for r in tubes]), "compile", _color(1),
                                dashed=True, filled=False)]))
    return draw(panels, path)


def plot_scaling(rows: list[dict], path: Path) -> Path | None:
    rs = sorted((r for r in rows if r["scene"] == "scaling" and r.get("status") == "ok"),
                key=lambda r: num(r, "elements"))
    if not rs:
        return None
    n = np.array([num(r, "elements") for r in rs])
    per_step = 1e3 * np.array([num(r, "run_s") / num(r, "steps") for r in rs])
    series = [Series(n, per_step, "time per step", _color(0))]
    if len(n) > 1:      # the line through the largest case, slope 1
        series.append(Series(n, per_step[-1] * n / n[-1], "linear (through the largest)", "#7f7f7f",
                             dashed=True, marker=""))
    us = np.array([num(r, "us_per_element_step") for r in rs])
    panels = [Panel("tube (mpm, J2, contact): time per step vs elements", "elements", "ms per step", series),
              Panel("µs per element-step vs elements", "elements", "µs / element-step",
                    [Series(n, us, "µs / element-step", _color(1))], logy=False)]
    return draw(panels, path)


def plot_all(rows: list[dict], orders: list[dict], out: Path) -> dict[str, Path | None]:
    """Every figure into `out` (PLOT_FILES); a figure with nothing to show, or one that could
    not be drawn (a warning is printed: a plot must not lose the measurements), is None."""
    plots: dict[str, Path | None] = {}
    for name, fn in (("error against run time", lambda p: plot_error_vs_time(rows, p)),
                     ("convergence", lambda p: plot_convergence(rows, orders, p)),
                     ("square tube", lambda p: plot_tube(rows, out, p)),
                     ("scaling", lambda p: plot_scaling(rows, p))):
        target = out / PLOT_FILES[name]
        try:
            plots[name] = fn(target)
        except Exception as exc:          # a plot must not lose the measurements
            print(f"warning: could not draw {target.name}: {type(exc).__name__}: {exc}", flush=True)
            plots[name] = None
    return plots
