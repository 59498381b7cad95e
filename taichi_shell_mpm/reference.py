"""Comparison of recorded probes with a reference table (e.g. Sze, Liu & Lo 2004).

Relative error of row i: e_i = |sim_i - ref_i| / max(|ref_i|, floor * max_j |ref_j|)
(issue 2: the floor keeps the 3-decimal rounding of tiny first-row values from dominating).

The table's rows are keyed by load level (its ``load_column``), which static runs record as
the load factor of each converged load step; a dynamic run records times instead, so the
comparison is skipped there (:func:`skip_reason`).

A path with limit points (``[reference].along = "path"``, issue 19: the load factor goes up
and down, so a load level is no key) is compared point by point in the plane of the compared
value x and the load factor lam, each scaled by the table's largest magnitude X, Lam:
e_i = the distance from the row (x_i / X, lam_i / Lam) to the simulated path, the polyline
through the origin (the unloaded state) and the converged points in order
(:func:`compare_along_path`).  A row whose x lies beyond the path's range was not reached
(``missing_levels``).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:        # annotations only: scene/reference.py imports this module to check reference tables
    from .scene import Reference

MAX_CELL_PROBLEMS = 5
"""Most bad cells of a reference table reported one by one (then one line counts the rest)."""


def _name(text: str) -> str:
    return " ".join(str(text).split())


def read_rows(path: Path) -> tuple[list[str], list[tuple[int, list[str]]]]:
    """Header names (whitespace collapsed, as the scene checks them) and the non-blank data
    rows with their line numbers (the header is line 1)."""
    with open(path, newline="", encoding="utf-8-sig") as fh:
        rows = list(csv.reader(fh))
    header = [_name(h) for h in rows[0]] if rows else []
    body = [(i + 2, r) for i, r in enumerate(rows[1:]) if any(c.strip() for c in r)]
    return header, body


def table_problems(path: Path, columns: list[str]) -> list[str]:
    """One line per cell of `columns` in the CSV `path` that is not a finite number (at
    most MAX_CELL_PROBLEMS, then a count), or a line saying that it has no data row."""
    header, body = read_rows(path)
    if not body:
        return [f"{path.name} has a header but no data rows"]
    index = {name: header.index(name) for name in dict.fromkeys(columns) if name in header}
    problems = []
    for line, row in body:
        for name, k in index.items():
            cell = row[k] if k < len(row) else None
            try:
                ok = cell is not None and math.isfinite(float(cell))
            except ValueError:
                ok = False
            if not ok:
                got = "nothing (the row is short)" if cell is None else repr(cell.strip())
                problems.append(f"{path.name} line {line}, column {name!r}: expected a finite number, got {got}")
    if len(problems) > MAX_CELL_PROBLEMS:
        problems = problems[:MAX_CELL_PROBLEMS] + [f"{path.name}: ... and {len(problems) - MAX_CELL_PROBLEMS} "
                                                   "more cells that are not finite numbers"]
    return problems


def read_reference(ref: Reference) -> dict[str, np.ndarray]:
    """The load column and the compared columns of the table, as float arrays (the scene's
    validation checked that every one of their cells is a finite number)."""
    header, body = read_rows(ref.file)
    names = dict.fromkeys([ref.load_column, *(c.column for c in ref.compare)])
    return {k: np.array([float(row[header.index(k)]) for _, row in body]) for k in names}


def relative_errors(sim: np.ndarray, ref: np.ndarray, floor: float) -> np.ndarray:
    return np.abs(sim - ref) / np.maximum(np.abs(ref), floor * np.max(np.abs(ref)))


def skip_reason(ref: Reference, solve_kind: str) -> str | None:
    """Why the comparison cannot be made for a run of `solve_kind`, or None."""
    if solve_kind != "static":
        return (f"[reference] ({ref.file.name}) is keyed by load level ('{ref.load_column}'), which only a "
                f"static solve records; this {solve_kind} run records times: the comparison is skipped")
    return None


def _segment_distance(px: np.ndarray, py: np.ndarray, x: float, y: float) -> tuple[float, float, float]:
    """Distance from (x, y) to the polyline (px, py) and the nearest point on it."""
    ax, ay, bx, by = px[:-1], py[:-1], px[1:], py[1:]
    dx, dy = bx - ax, by - ay
    length = dx * dx + dy * dy
    t = np.clip(np.where(length > 0, ((x - ax) * dx + (y - ay) * dy) / np.where(length > 0, length, 1.0), 0.0),
                0.0, 1.0)
    cx, cy = ax + t * dx, ay + t * dy
    dist = np.hypot(cx - x, cy - y)
    k = int(np.argmin(dist))
    return float(dist[k]), float(cx[k]), float(cy[k])


def compare_along_path(ref: Reference, header: list[str], data: np.ndarray, table: dict) -> dict:
    """:func:`compare_with_reference` for ``along = "path"`` (module docstring): per column
    the errors, ``simulated`` (the nearest point's x, None for a row not reached) and
    ``path`` (the simulated x and load factors, for the plot)."""
    levels = table[ref.load_column]
    lam_scale = max(float(np.max(np.abs(levels))), 1e-300)
    result = {"file": str(ref.file), "along": "path", "rows": len(levels), "load_levels": levels.tolist(),
              "columns": {}}
    reached = np.ones(len(levels), dtype=bool)
    for comp in ref.compare:
        x = data[:, header.index(comp.probe)] * comp.scale
        xr = table[comp.column]
        x_scale = max(float(np.max(np.abs(xr))), 1e-300)
        px = np.concatenate([[0.0], x]) / x_scale
        py = np.concatenate([[0.0], data[:, 0]]) / lam_scale
        inside = (xr / x_scale >= px.min() - 1e-12) & (xr / x_scale <= px.max() + 1e-12) if len(x) else xr != xr
        reached &= inside
        errors, nearest = [], []
        for xi, li, ok in zip(xr / x_scale, levels / lam_scale, inside):
            if ok:
                dist, cx, _ = _segment_distance(px, py, xi, li)
                errors.append(dist)
                nearest.append(cx * x_scale)
            else:
                nearest.append(None)
        err = np.array(errors)
        result["columns"][comp.column] = {
            "probe": comp.probe, "mean_rel_error": float(err.mean()) if len(err) else None,
            "max_rel_error": float(err.max()) if len(err) else None, "simulated": nearest,
            "reference": xr.tolist(), "path": {"x": x.tolist(), "load_factor": data[:, 0].tolist()}}
    result["matched"] = int(reached.sum())
    result["missing_levels"] = [float(lv) for lv, ok in zip(levels, reached) if not ok]
    return result


def compare_with_reference(ref: Reference, header: list[str], rows: list[list[float]]) -> dict:
    """Per compared column: mean and max relative error over the reference rows, the rows'
    values side by side, and the reference rows that had no matching load level.  When no
    row matches (a run cut short before the first reference level), the errors are None and
    ``matched`` is 0.  ``along = "path"``: :func:`compare_along_path`."""
    table = read_reference(ref)
    data = np.array(rows, dtype=float).reshape(len(rows), len(header))
    if ref.along == "path":
        return compare_along_path(ref, header, data, table)
    keys = data[:, 0]
    levels = table[ref.load_column]
    match = [int(np.argmin(np.abs(keys - lv))) if len(keys) and np.min(np.abs(keys - lv)) < 1e-9 * max(1, abs(lv))
             else -1 for lv in levels]
    missing = [float(lv) for lv, i in zip(levels, match) if i < 0]
    ok = np.array([i >= 0 for i in match], dtype=bool)
    result = {"file": str(ref.file), "rows": len(levels), "matched": int(ok.sum()), "missing_levels": missing,
              "columns": {}}
    for comp in ref.compare:
        col = header.index(comp.probe)
        sim = np.array([data[i, col] * comp.scale if i >= 0 else np.nan for i in match])
        err = relative_errors(sim[ok], table[comp.column][ok], ref.floor) if ok.any() else np.empty(0)
        result["columns"][comp.column] = {
            "probe": comp.probe, "mean_rel_error": float(err.mean()) if len(err) else None,
            "max_rel_error": float(err.max()) if len(err) else None,
            "simulated": sim.tolist(), "reference": table[comp.column].tolist()}
    return result


def reference_summary(scene, header: list[str], rows: list[list[float]]) -> tuple[dict | None, str | None]:
    """summary.json's ``reference`` entry for a run of `scene` that recorded `rows`, and a
    warning line if any: skipped for a dynamic run (the table is keyed by load level), noted
    when no row matched (a run stopped before its first reference level)."""
    ref = scene.reference
    if ref is None:
        return None, None
    name = scene.source.name
    reason = skip_reason(ref, scene.solve.kind)
    if reason is not None:
        return {"file": str(ref.file), "skipped": reason}, f"{name}: {reason}"
    result = compare_with_reference(ref, header, rows)
    if result["matched"] == 0:
        return result, (f"{name}: [reference] ({ref.file.name}): none of its {result['rows']} load levels was "
                        "reached by a converged load step: no errors computed")
    return result, None
