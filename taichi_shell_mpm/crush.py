"""Crush post-processing (benchmarks.md 3.2, 3.4): peak and mean crush force, folds and fold
half-wavelength, energy-balance and hourglass ratios, deepest contact penetration.

Definitions (also in docs/crush.md):
* crush distance delta(t) = minus the displacement of the first rigid body along its
  direction (the ram moves towards the support);
* mean crush force = work of the support force (clamped nodes and fixed walls,
  stages/bodies.py) over delta in [20, 200] mm / 180 mm
  (first peak excluded), trapezoidal in the recorded history;
* folds: along the centre line of each flat face (reference coordinates), the lateral
  displacement w(Z) of the final state has alternating extrema (hysteresis: a new extremum
  must differ from the last by more than 2t).  Each extremum is the outermost (or innermost)
  hinge of one lobe: a lobe folds a wall length 2H (hinges at Z0, Z0 + H, Z0 + 2H, the
  middle one displaced by about H), and in the symmetric mode consecutive lobes of a face
  alternate outward / inward, so consecutive extrema are one lobe = 2H apart
  (benchmarks.md 3.2: "each [lobe] consuming 2H of tube").  Lobes = folds = the number of
  extrema (median over the four faces); H = half their mean spacing in Z.  (Until
  2026-11-23 the code called each extremum a half-wave and reported the spacing itself as
  H, twice the half-wavelength; the 15 ms profile, extrema +-12..17 mm about 35 mm apart,
  shows one extremum per lobe.)
* energy balance error = |E_kin + E_int + E_hg + E_contact + E_wall - E_kin0 - W_ext| /
  (E_int + E_hg + E_contact + E_wall), the energy the tube absorbed (the 56 kJ of the
  mass would hide errors), largest over the recorded history after 0.5 ms.
"""
from __future__ import annotations

import numpy as np

WINDOW = (20.0, 200.0)


def mean_force(crush: np.ndarray, force: np.ndarray, window=WINDOW) -> tuple[float, float]:
    """Mean of `force` over crush distance in `window` (work / distance); the window is cut
    to the distance actually reached. Returns (mean force, distance covered)."""
    lo, hi = window
    hi = min(hi, float(crush.max()))
    if hi <= lo:
        return float("nan"), 0.0
    grid = np.linspace(lo, hi, 2000)
    order = np.argsort(crush)
    f = np.interp(grid, crush[order], force[order])
    return float(np.trapezoid(f, grid) / (hi - lo)), hi - lo


def lobe_peaks(z_ref: np.ndarray, lateral: np.ndarray, threshold: float) -> np.ndarray:
    """Reference positions of the alternating interior extrema of lateral(z) (hysteresis
    threshold).  The ends of the line are supports, not lobe hinges: a line that starts by
    rising (falling) has no extremum at its first point."""
    order = np.argsort(z_ref)
    z, w = z_ref[order], lateral[order]
    extrema = []
    direction, hi, lo = 0, 0, 0
    for i in range(1, len(w)):
        hi = i if w[i] > w[hi] else hi
        lo = i if w[i] < w[lo] else lo
        if direction >= 0 and w[hi] - w[i] > threshold:      # passed a maximum
            if hi > 0:
                extrema.append(hi)
            direction, lo = -1, i
        elif direction <= 0 and w[i] - w[lo] > threshold:    # passed a minimum
            if lo > 0:
                extrema.append(lo)
            direction, hi = 1, i
    return z[extrema]


def fold_geometry(points: np.ndarray, positions: np.ndarray, thickness: float) -> dict:
    """Lobes and fold half-wavelength on the centre lines of the four flat faces of a tube
    along z (module docstring)."""
    centre = points[:, :2].mean(axis=0)
    rel = points[:, :2] - centre
    half_x, half_y = np.abs(rel[:, 0]).max(), np.abs(rel[:, 1]).max()
    tol = 1e-6 * max(half_x, half_y)
    spacings, counts = [], []
    for axis, half in ((0, half_x), (1, half_y)):
        other = 1 - axis
        for sign in (1.0, -1.0):
            line = (np.abs(rel[:, other]) < tol) & (sign * rel[:, axis] > 0.8 * half)   # trigger moved some
            if line.sum() < 4:
                continue
            lateral = sign * (positions[line, axis] - points[line, axis])
            z = lobe_peaks(points[line, 2], lateral, 2.0 * thickness)
            counts.append(len(z))
            if len(z) > 1:
                spacings.append(np.diff(z).mean())
    if not counts:
        return {"lobes": 0, "folds": 0, "half_wavelength": None}
    n = int(np.median(counts))
    return {"lobes": n, "folds": n,
            "half_wavelength": 0.5 * float(np.mean(spacings)) if spacings else None}


def crush_summary(sim) -> dict:
    """The crush figures of a run with a rigid body (see the module docstring)."""
    rows = np.array(sim.history.force_rows)
    energy = np.array(sim.history.energy_rows)
    t = rows[:, 0]
    support = rows[:, 3]                               # support_z
    nb = len(sim.model.rigid_bodies)
    crush = -rows[:, 4]
    ram_force = rows[:, 4 + nb]
    mean, covered = mean_force(crush, np.abs(support))
    cols = ["key", *sim_energy_columns()]
    e = {name: energy[:, i] for i, name in enumerate(cols)}
    absorbed = e["internal"] + e["hourglass"] + e["drilling"] + e["contact"] + e["wall"]
    late = (energy[:, 0] >= 0.5) & (absorbed > 0)
    balance = np.abs(e["balance_error"][late]) / absorbed[late] if late.any() else np.array([np.nan])
    folds = fold_geometry(sim.model.points, sim.state.position.to_numpy(), sim.cfg.thickness)
    final_internal = e["internal"][-1]
    s = sim.state
    return {"crush": {
        "crush_distance": float(crush[-1]), "peak_support_force": float(np.abs(support).max()),
        "peak_ram_force": float(np.abs(ram_force).max()),
        "mean_crush_force": mean, "mean_force_window": [WINDOW[0], WINDOW[0] + covered],
        "mean_force_over_7.46kN": mean / 7.46, "mean_force_over_10.22kN": mean / 10.22,
        **folds,
        "half_wavelength_over_15.1mm": folds["half_wavelength"] / 15.1 if folds["half_wavelength"] else None,
        "energy_balance_error_max": float(balance.max()),
        "hourglass_over_internal": float(e["hourglass"][-1] / final_internal) if final_internal > 0 else None,
        "drilling_over_internal": float(e["drilling"][-1] / final_internal) if final_internal > 0 else None,
        "absorbed_energy": float(absorbed[-1]),
        "max_penetration_over_thickness": float(s.max_penetration[None]) if s.contact else None,
        "ram_velocity_final": float(s.body_velocity[0]) if nb else None,
    }}


def sim_energy_columns():
    from .simulation import ENERGY_COLUMNS
    return ENERGY_COLUMNS
