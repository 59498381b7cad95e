"""The sweep's figures, one PNG per metric in ``OUT/plots/``, drawn with matplotlib: the
metric against each parameter (one line per combination of the other parameters' values),
and with two parameters also its response surface over them (filled contours through the
cases, each case marked with its value).

A parameter whose values are all numbers is drawn on a numeric axis, any other (``fem``,
``mpm``) at equally spaced positions labelled with its values.  Only the cases with status
``ok`` are drawn; a metric without a finite value is not drawn.
"""
from __future__ import annotations

import itertools
import math
import re
from pathlib import Path

import numpy as np

from .results import number

_FILE_SAFE = re.compile(r"[^A-Za-z0-9._-]")


def _axis(values: list[str]) -> tuple[dict[str, float], list[str] | None]:
    """Position of each value on the axis, and tick labels for a non-numeric parameter."""
    nums = [number(v) for v in values]
    if all(math.isfinite(x) for x in nums):
        return dict(zip(values, nums)), None
    return {v: float(i) for i, v in enumerate(values)}, list(values)


def plot_metric(rows: list[dict], keys: list[str], labels: dict[str, str], values: dict[str, list[str]],
                metric: str, path: Path) -> bool:
    """One figure: `metric` against each key (and the surface over two keys). Returns
    whether anything was drawn."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    ok = [r for r in rows if r.get("status") == "ok" and math.isfinite(number(r.get(metric)))]
    varying = [k for k in keys if len(values[k]) > 1]
    if not ok or not varying:
        return False
    surface = len(varying) == 2 and all(len(values[k]) >= 2 for k in varying)
    panels = len(varying) + surface
    fig, axes = plt.subplots(1, panels, figsize=(5.2 * panels, 4.2), squeeze=False)
    for ax, key in zip(axes[0], varying):
        pos, ticks = _axis(values[key])
        others = [k for k in varying if k != key]
        for n, combo in enumerate(itertools.product(*(values[k] for k in others))):
            pts = sorted((pos[r[key]], number(r[metric])) for r in ok
                         if all(r.get(k) == v for k, v in zip(others, combo)) and r.get(key) in pos)
            if not pts:
                continue
            x, y = np.array(pts).T
            label = ", ".join(f"{labels[k]}={v}" for k, v in zip(others, combo)) or None
            ax.plot(x, y, marker="o", label=label, color=f"C{n % 10}")
        if ticks:
            ax.set_xticks(range(len(ticks)), ticks)
        ax.set_xlabel(labels[key])
        ax.set_ylabel(metric)
        ax.grid(True, alpha=0.3)
        if others:
            ax.legend(fontsize=7)
    if surface:
        _surface(axes[0][-1], ok, varying, labels, values, metric, fig)
    fig.suptitle(metric, fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def _surface(ax, ok, keys, labels, values, metric, fig) -> None:
    (kx, ky) = keys
    px, tx = _axis(values[kx])
    py, ty = _axis(values[ky])
    xs, ys = sorted(set(px.values())), sorted(set(py.values()))
    z = np.full((len(ys), len(xs)), np.nan)
    for r in ok:
        if r.get(kx) in px and r.get(ky) in py:
            z[ys.index(py[r[ky]]), xs.index(px[r[kx]])] = number(r[metric])
    if np.isfinite(z).sum() >= 3 and np.nanmax(z) > np.nanmin(z):
        filled = ax.contourf(xs, ys, np.ma.masked_invalid(z), levels=12, cmap="viridis")
        fig.colorbar(filled, ax=ax, label=metric)
    for j, y in enumerate(ys):
        for i, x in enumerate(xs):
            if np.isfinite(z[j, i]):
                ax.plot(x, y, "ko", markersize=3)
                ax.annotate(f"{z[j, i]:.4g}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=8)
    for setter, ticks in ((ax.set_xticks, tx), (ax.set_yticks, ty)):
        if ticks:
            setter(range(len(ticks)), ticks)
    for set_limits, ends in ((ax.set_xlim, xs), (ax.set_ylim, ys)):     # room for the marks at the edges
        pad = 0.12 * ((ends[-1] - ends[0]) or 1.0)
        set_limits(ends[0] - pad, ends[-1] + pad)
    ax.set_xlabel(labels[kx])
    ax.set_ylabel(labels[ky])
    ax.set_title("response surface", fontsize=9)


def plot_all(rows: list[dict], keys: list[str], labels: dict[str, str], cases, metrics: list[str],
             folder: Path) -> dict[str, Path]:
    """One figure per metric column into `folder`; returns {metric: png}."""
    values = {k: list(dict.fromkeys(v for c in cases for kk, v in c.params if kk == k)) for k in keys}
    out = {}
    for metric in metrics:
        png = folder / f"{_FILE_SAFE.sub('_', metric)}.png"
        if plot_metric(rows, keys, labels, values, metric, png):
            out[metric] = png
    return out
