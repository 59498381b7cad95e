"""Time functions ([curves.NAME], scene.Curve): the tables the step evaluates
(stages/loads.ExternalLoads.curve) and their numpy twin :func:`evaluate`.

A curve f is read at an argument s (the time in a dynamic run, the load factor in a static
one) in three orders: f(s) itself, F(s) = int_0^s f and G(s) = int_0^s F.  Prescribed
motion needs the integrals [choice]: a velocity curve moves its nodes by
(F(t^(n+1)) - F(t^n)) / dt over a step, so positions follow value x F(t) to round-off
even where a step straddles a corner of the curve (the mid-step value f(t^(n+1/2)) is off
by O(dt^2) there, every time); an acceleration curve likewise through G.

Storage.  A table curve (``points``, ``file``, ``constant`` = one point, ``ramp`` = two) is
rows (t_i, f_i, k_i, I_i, J_i): the point, the slope k_i up to the next point (0 after the
last: flat beyond the ends), and the integrals I_i = int_(t_0)^(t_i) f, J_i = int_(t_0)^(t_i) I
from the first point, so that on [t_i, t_i+1], with tau = s - t_i,
    f = f_i + k_i tau,  I = I_i + f_i tau + k_i tau^2 / 2,  J = J_i + I_i tau + f_i tau^2 / 2 + k_i tau^3 / 6,
and before t_0 the flat start, f = f_0, I = f_0 tau, J = f_0 tau^2 / 2 (tau = s - t_0 < 0).
F(s) = I(s) - I(0) and G(s) = J(s) - J(0) - I(0) s; the origin (I(0), J(0)) is stored per
curve.  A ``smooth_step`` from a to b (L = b - a, x = (s - a) / L clipped to [0, 1]) is the
quintic P(x) = 10 x^3 - 15 x^4 + 6 x^5 [choice: zero slope *and* curvature at both ends,
so a displacement that follows it has a continuous acceleration and its inertial
reaction no jump where it starts and stops; the cubic 3 x^2 - 2 x^3 has an acceleration
step of 6/L^2 at each end], with I = L P1(x) (+ (s - b) after b), P1 = 5/2 x^4 - 3 x^5 + x^6, and
J = L^2 P2(x) (+ L/2 (s - b) + (s - b)^2 / 2 after b), P2 = x^5/2 - x^6/2 + x^7/7, both from a.
Every value is multiplied by the curve's ``scale``.
"""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

TABLE, SMOOTH_STEP = 0, 1          # state.loads.curve_kind
COLUMNS = 5                        # t, f, k, I, J


class CurveFileError(ValueError):
    """A curve file that cannot be read as two columns t, f (one-line message)."""


def read_table(path: Path) -> tuple[tuple[float, float], ...]:
    """The (t, f) rows of a two-column CSV file; a first row that is not two numbers is a
    header, empty rows and rows starting with '#' are skipped."""
    rows = []
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            for number, row in enumerate(csv.reader(fh), start=1):
                cells = [c.strip() for c in row]
                if not any(cells) or cells[0].startswith("#"):
                    continue
                try:
                    values = [float(c) for c in cells]
                except ValueError:
                    values = None
                if values is None or len(values) != 2 or not all(np.isfinite(values)):
                    if not rows and number == 1:
                        continue                      # a header row
                    raise CurveFileError(f"{path.name} line {number}: expected two finite numbers t, f, "
                                         f"got {','.join(cells)[:60]!r}")
                rows.append((values[0], values[1]))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise CurveFileError(f"cannot read {path.name} ({' '.join(str(exc).split())})") from None
    if not rows:
        raise CurveFileError(f"{path.name}: no rows t, f")
    return tuple(rows)


def points_of(curve) -> np.ndarray:
    """(r, 2) points (t, f) of a table curve, unscaled (scene.Curve)."""
    if curve.kind == "constant":
        return np.array([[0.0, 1.0]])
    if curve.kind == "ramp":
        return np.array([[curve.start, 0.0], [curve.end, 1.0]])
    return np.asarray(curve.points, dtype=float)


def table_rows(points: np.ndarray) -> np.ndarray:
    """(r, COLUMNS) rows t, f, k, I, J of the piecewise-linear curve through `points`."""
    t, f = points[:, 0], points[:, 1]
    h = np.diff(t)
    k = np.append(np.diff(f) / h, 0.0)
    integral = np.zeros(len(t))
    second = np.zeros(len(t))
    for i in range(len(t) - 1):
        integral[i + 1] = integral[i] + f[i] * h[i] + 0.5 * k[i] * h[i] ** 2
        second[i + 1] = second[i] + integral[i] * h[i] + 0.5 * f[i] * h[i] ** 2 + k[i] * h[i] ** 3 / 6.0
    return np.stack([t, f, k, integral, second], axis=1)


def _table_anchored(rows: np.ndarray, s: float) -> tuple[float, float, float]:
    """f(s), I(s), J(s) of a table from its first point (module docstring)."""
    if s < rows[0, 0]:
        tau, f0 = s - rows[0, 0], rows[0, 1]
        return f0, f0 * tau, 0.5 * f0 * tau * tau
    i = int(np.searchsorted(rows[:, 0], s, side="right")) - 1
    t, f, k, integral, second = rows[i]
    tau = s - t
    return (f + k * tau, integral + f * tau + 0.5 * k * tau * tau,
            second + integral * tau + 0.5 * f * tau * tau + k * tau ** 3 / 6.0)


def _smooth_anchored(start: float, end: float, s: float) -> tuple[float, float, float]:
    """f(s), I(s), J(s) of the quintic smooth step from `start` (module docstring)."""
    length = end - start
    x = min(max((s - start) / length, 0.0), 1.0)
    after = max(s - end, 0.0)
    f = x ** 3 * (10.0 - 15.0 * x + 6.0 * x * x)
    integral = length * x ** 4 * (2.5 - 3.0 * x + x * x) + after
    second = length * length * x ** 5 * (0.5 - 0.5 * x + x * x / 7.0) + 0.5 * length * after + 0.5 * after * after
    return f, integral, second


def anchored(curve, s: float) -> tuple[float, float, float]:
    """Unscaled f(s) and the integrals from the curve's own anchor (scene.Curve)."""
    if curve.kind == "smooth_step":
        return _smooth_anchored(curve.start, curve.end, s)
    return _table_anchored(table_rows(points_of(curve)), s)


def origin(curve) -> tuple[float, float]:
    """(I(0), J(0)): the anchored integrals at 0 that F and G subtract."""
    _, integral, second = anchored(curve, 0.0)
    return integral, second


def evaluate(curve, s: float, order: int = 0) -> float:
    """f(s) (order 0), F(s) = int_0^s f (1) or G(s) = int_0^s F (2) of scene.Curve `curve`."""
    f, integral, second = anchored(curve, s)
    i0, j0 = origin(curve)
    value = (f, integral - i0, second - j0 - i0 * s)[order]
    return curve.scale * value
