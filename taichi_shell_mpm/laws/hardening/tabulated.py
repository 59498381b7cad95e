"""Tabulated hardening: sigma_y linear between the points of a curve (``hardening_law =
"tabulated"``; an LS-DYNA *MAT_024 LCSS or *MAT_037 HLCID curve)."""
from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

from ...keys import Check, Invalid, Key, choice, curve_points, hardening_curve, keys, one_line, show

NAME = "tabulated"
DOC = "`tabulated` linear between the points of `curve` or `curve_file`, beyond the last as `beyond_curve` says"


def read_curve_file(r, value: Any) -> tuple[Path, tuple[tuple[float, float], ...]]:
    """A CSV file of (plastic strain, yield stress) rows, relative to the scene file (an
    optional header row; blank lines and lines starting with '#' are skipped): its path
    and points (keys.curve_points).  `r`: the scene reader (its `file` check)."""
    path = r.file(value)
    try:
        with path.open(newline="", encoding="utf-8-sig") as f:
            rows = [(i, row) for i, row in enumerate(csv.reader(f), 1)
                    if row and "".join(row).strip() and not row[0].lstrip().startswith("#")]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise Invalid(f"cannot read {path.name} ({one_line(exc)})")

    def number(text: str) -> float | None:
        try:
            x = float(text)
        except ValueError:
            return None
        return x if math.isfinite(x) else None
    if rows and any(number(cell) is None for cell in rows[0][1]):
        rows = rows[1:]                           # the header
    points, lines = [], []
    for line, row in rows:
        cells = [number(cell) for cell in row]
        if len(cells) != 2 or None in cells:
            raise Invalid(f"{path.name} line {line}: expected two numbers (plastic strain, yield stress), "
                          f"got {show(','.join(row))}")
        points.append((cells[0], cells[1]))
        lines.append(line)
    return path, curve_points(points, lambda i: f"{path.name} line {lines[i]}")


curve_file = Check(None, "string", "an existing file", {"type": "string"}, context=read_curve_file)
"""The CSV file of a tabulated hardening curve (read_curve_file)."""

KEYS = keys(
    Key("curve", hardening_curve, "`tabulated`: the points, e.g. `[[0.0, 0.25], [0.05, 0.31], [0.2, 0.38]]`",
        default=(), default_text="–"),
    Key("curve_file", curve_file, "`tabulated`: a CSV file of `ε̄ᵖ, σ_y` rows (relative to the scene file; an "
                                  "optional header row; blank lines and lines starting with `#` skipped); exactly "
                                  "one of `curve` and `curve_file`", default=None, default_text="–"),
    Key("beyond_curve", choice("flat", "extrapolate"), "beyond the last point: its stress, or the last segment's "
                                                       "line (needs two points)", default="flat"))
REQUIRED: tuple[str, ...] = ()
OPTIONAL = ("curve", "curve_file", "beyond_curve")
BLOCK = ("curve_start", "curve_points", "curve_extrapolate")


def rules(r, path: str, data: dict, values: dict) -> None:
    """Exactly one of curve and curve_file (the file's points become the curve); extrapolation
    needs two points."""
    if ("curve" in data) == ("curve_file" in data):
        r.error(f"{path}.curve", "expected exactly one of curve and curve_file for hardening_law = \"tabulated\"")
    if "curve_file" in data and "curve_file" in values:
        values["curve_file"], values["curve"] = values["curve_file"]
    if values.get("beyond_curve") == "extrapolate" and 0 < len(values.get("curve", ())) < 2:
        r.error(f"{path}.beyond_curve", "\"extrapolate\" needs a curve of at least two points")


def block(spec, curve_start: int) -> list[float]:
    """The curve's first point in the curve table, its point count, extrapolated (1) or flat."""
    return [curve_start, len(spec.curve), float(spec.beyond_curve == "extrapolate")]


def kernel(offset: int, col: dict):
    import taichi as ti
    START, POINTS, EXTRAPOLATE = offset, offset + 1, offset + 2

    @ti.data_oriented
    class TabulatedHardening:
        """sigma_y linear between the points of the material's curve (state.sections.curve_strain
        / curve_stress from curve_start, curve_points of them; the first at ebar = 0), found by
        bisection; beyond the last point its stress (flat) or the last segment's line
        (curve_extrapolate = 1).  At a point the slope is the next segment's."""
        law = NAME

        def __init__(self, state=None):
            self.s = state

        @ti.func
        def flow_stress(self, row, ebar):
            strain, stress = ti.static(self.s.sections.curve_strain, self.s.sections.curve_stress)
            first = ti.cast(row[START], ti.i32)
            last = first + ti.cast(row[POINTS], ti.i32) - 1
            sy, slope = stress[last], 0.0
            if ebar < strain[last]:
                lo, hi = first, last                     # strain[lo] <= ebar < strain[hi]
                while hi - lo > 1:
                    mid = (lo + hi) // 2
                    if strain[mid] <= ebar:
                        lo = mid
                    else:
                        hi = mid
                slope = (stress[hi] - stress[lo]) / (strain[hi] - strain[lo])
                sy = stress[lo] + slope * (ebar - strain[lo])
            elif row[EXTRAPOLATE] > 0.0:
                slope = (stress[last] - stress[last - 1]) / (strain[last] - strain[last - 1])
                sy = stress[last] + slope * (ebar - strain[last])
            return sy, slope

    return TabulatedHardening
