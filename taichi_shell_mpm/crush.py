"""Crush post-processing (benchmarks.md 3.2, 3.4), for scenes with a ``[crush]`` table
(scene.Crush): crush distance, peak and mean crush force, folds and fold half-wavelength,
energy-balance and hourglass ratios, deepest contact penetration.

Definitions (also in docs/crush.md), with e = ``[crush].axis`` (unit, the direction in which
the crushing body moves) and the body ``[crush].body``:
* crush distance delta(t) = the body's displacement along e;
* crush force F = -R . e, R the support reaction on the shell (clamped nodes and fixed
  walls, stages/bodies.py);
* mean crush force = the work of F over delta in ``[crush].window`` / the window's length.
  The work comes from the support impulse accumulated every step (``support_impulse_*`` in
  force.csv): over each history interval, the impulse increment times the interval's mean
  crush speed.  [issue 16: before, |R| sampled every 0.01 ms was integrated, which
  rectified and aliased the force's oscillation.]
* folds (``[crush].folds``): along the centre line of each flat face of a prismatic tube
  along e (reference coordinates), the lateral displacement w(Z) of the final state has
  alternating extrema (hysteresis: a new extremum must differ from the last by more than
  2t).  Each extremum is the outermost (or innermost) hinge of one lobe: a lobe folds a
  wall length 2H, and in the symmetric mode consecutive lobes of a face alternate outward /
  inward, so consecutive extrema are one lobe = 2H apart (benchmarks.md 3.2).  Lobes =
  folds = the number of extrema (median over the four faces); H = half their mean spacing.
* energy balance error = |E_err| / (E_int + E_hg + E_drill + E_contact + E_wall), the
  energy the shell absorbed (the kinetic energy of the mass would hide errors), largest
  over the recorded history after the first 1/30 of the run.
* specific energy absorption SEA = absorbed energy / crushed mass, the crushed mass being
  the shell's mass per unit length along e (its mass / its extent along e, a prismatic
  tube) times the crush distance; the energy absorbed is that of the energy balance error
  above, at the end of the run.
* the ratios to ``[crush].mean_force_reference`` and ``half_wavelength_reference``.  A
  reference may name a closed-form mean force of a tube mesh (MEAN_FORCE_FORMULAS),
  evaluated with the run's yield stress sigma0 and thickness t (one value each over the
  shell) and C = (width + depth) / 2; the SEA's reference of each is P_ref / (mass per unit
  length), the SEA of a crush at the constant force P_ref.
"""
from __future__ import annotations

import numpy as np

from .energy import ENERGY_COLUMNS
from .model.materials import COL

MEAN_FORCE_FORMULAS = {"wierzbicki_abramowicz": 38.12 / 4, "abramowicz_jones": 52.22 / 4}
"""k of P_m = k sigma0 t^(5/3) C^(1/3) = 4k M0 (C/t)^(1/3), M0 = sigma0 t^2 / 4 (benchmarks.md
3.2): Wierzbicki & Abramowicz (1983), superfolding element, symmetric mode, P_m = 38.12 M0
(C/t)^(1/3); Abramowicz & Jones (1984), with the effective crushing distance 0.73 x 2H,
52.22 M0 (C/t)^(1/3).  Rigid-perfectly plastic, no strain-rate terms."""

def crush_work(time: np.ndarray, crush: np.ndarray, impulse: np.ndarray) -> np.ndarray:
    """Cumulative work of the crush force at each history row: sum over the intervals of the
    impulse increment times the interval's mean crush speed (crush increment / duration)."""
    d_time = np.diff(time)
    speed = np.divide(np.diff(crush), d_time, out=np.zeros_like(d_time), where=d_time > 0)
    return np.concatenate([[0.0], np.cumsum(np.diff(impulse) * speed)])


def mean_force(crush: np.ndarray, work: np.ndarray, window: tuple[float, float]) -> tuple[float, float]:
    """Mean crush force over the crush distances `window`: the work between the first times
    the crush reaches its ends (linear in each interval) / the distance; the window is cut
    to the distance reached.  Returns (mean force, distance covered)."""
    lo, hi = window
    hi = min(hi, float(crush.max()))
    if hi <= lo:
        return float("nan"), 0.0

    def work_at(distance):
        k = int(np.argmax(crush >= distance))          # first row at or past it
        if k == 0:
            return float(work[0])
        f = (distance - crush[k - 1]) / (crush[k] - crush[k - 1])
        return float(work[k - 1] + f * (work[k] - work[k - 1]))
    return (work_at(hi) - work_at(lo)) / (hi - lo), hi - lo


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


def fold_geometry(points: np.ndarray, positions: np.ndarray, thickness: float,
                  axis=(0.0, 0.0, -1.0)) -> dict:
    """Lobes and fold half-wavelength on the centre lines of the four flat faces of a tube
    crushed along `axis` (module docstring); Z runs from the support towards the ram."""
    e3 = -np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    e1 = np.cross(e3, [1.0, 0.0, 0.0] if abs(e3[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    if abs(e3[2]) > 0.9:                 # a tube along z keeps the x and y axes as its face normals
        e1 = np.array([1.0, 0.0, 0.0]) - e3[0] * e3
        e1 /= np.linalg.norm(e1)
    frame = np.array([e1, np.cross(e3, e1), e3])
    points, positions = points @ frame.T, positions @ frame.T
    centre = points[:, :2].mean(axis=0)
    rel = points[:, :2] - centre
    half_x, half_y = np.abs(rel[:, 0]).max(), np.abs(rel[:, 1]).max()
    tol = 1e-6 * max(half_x, half_y)
    spacings, counts = [], []
    for ax, half in ((0, half_x), (1, half_y)):
        other = 1 - ax
        for sign in (1.0, -1.0):
            line = (np.abs(rel[:, other]) < tol) & (sign * rel[:, ax] > 0.8 * half)   # trigger moved some
            if line.sum() < 4:
                continue
            lateral = sign * (positions[line, ax] - points[line, ax])
            z = lobe_peaks(points[line, 2], lateral, 2.0 * thickness)
            counts.append(len(z))
            if len(z) > 1:
                spacings.append(np.diff(z).mean())
    if not counts:
        return {"lobes": 0, "folds": 0, "half_wavelength": None}
    n = int(np.median(counts))
    return {"lobes": n, "folds": n,
            "half_wavelength": 0.5 * float(np.mean(spacings)) if spacings else None}


def reference_forces(sim) -> list[float | None]:
    """The values of ``[crush].mean_force_reference``: numbers as given, formulas evaluated
    (None when the shell has more than one thickness or yield stress, or a layered part)."""
    model, mesh = sim.model, sim.scene.mesh
    thickness = model.element.thickness
    index = {name: i for i, name in enumerate(model.materials.names)}
    yield_stress = np.array([model.materials.rows[index[p.material], COL["yield_stress"]] if p.material in index
                             else np.nan for p in model.parts])
    out = []
    for ref in sim.scene.crush.mean_force_reference:
        if not isinstance(ref, str):
            out.append(float(ref))
        elif np.ptp(thickness) > 0 or not np.ptp(yield_stress) == 0 or not yield_stress[0] > 0:
            out.append(None)
        else:
            size = 0.5 * (mesh.width + mesh.depth)
            out.append(MEAN_FORCE_FORMULAS[ref] * float(yield_stress[0]) * float(thickness[0]) ** (5 / 3)
                       * size ** (1 / 3))
    return out


def mass_per_length(sim, axis: np.ndarray) -> float:
    """The shell's mass over its extent along `axis` (a prismatic tube's mass per unit length)."""
    extent = float(np.ptp(sim.model.points @ axis))
    return float(sim.model.corner_mass.sum()) / extent if extent > 0 else float("nan")


def crush_summary(sim) -> dict:
    """The crush figures of a run with a [crush] table (see the module docstring)."""
    spec = sim.scene.crush
    names = [b.name for b in sim.model.rigid_bodies]
    b = names.index(spec.body) if spec.body is not None else 0
    body = sim.model.rigid_bodies[b]
    axis = np.asarray(spec.axis, dtype=float) / np.linalg.norm(spec.axis)
    rows = np.array(sim.history.force_rows)
    energy = np.array(sim.history.energy_rows)
    t = rows[:, 0]
    support = -rows[:, 1:4] @ axis                    # crush force: the reaction against the motion
    impulse = -rows[:, 4:7] @ axis
    header = sim.force_header()
    if body.direction is not None:      # a ram: its displacement and force along its direction
        crush = rows[:, header.index(f"{body.name}.displacement")] * float(np.dot(body.direction, axis))
        body_force = rows[:, header.index(f"{body.name}.force")]
    else:
        crush = rows[:, [header.index(f"{body.name}.u{c}") for c in "xyz"]] @ axis
        body_force = rows[:, [header.index(f"{body.name}.force_{c}") for c in "xyz"]] @ axis
    work = crush_work(t, crush, impulse)
    mean, covered = mean_force(crush, work, spec.window)
    e = {name: energy[:, i] for i, name in enumerate(["key", *ENERGY_COLUMNS])}
    absorbed = e["internal"] + e["hourglass"] + e["drilling"] + e["eroded"] + e["contact"] + e["wall"]
    late = (energy[:, 0] >= energy[-1, 0] / 30.0) & (absorbed > 0)
    balance = np.abs(e["balance_error"][late]) / absorbed[late] if late.any() else np.array([np.nan])
    final_internal = e["internal"][-1]
    s = sim.state
    references = reference_forces(sim)
    per_length = mass_per_length(sim, axis)
    crushed_mass = per_length * float(crush[-1])
    sea = float(absorbed[-1]) / crushed_mass if crushed_mass > 0 else None
    out = {
        "crush_distance": float(crush[-1]), "peak_support_force": float(np.abs(support).max()),
        "peak_ram_force": float(np.abs(body_force).max()),
        "mean_crush_force": mean, "mean_force_window": [spec.window[0], spec.window[0] + covered],
        "mean_force_reference": references,
        "mean_force_over_reference": [mean / r if r else None for r in references],
        "energy_balance_error_max": float(balance.max()),
        "hourglass_over_internal": float(e["hourglass"][-1] / final_internal) if final_internal > 0 else None,
        "drilling_over_internal": float(e["drilling"][-1] / final_internal) if final_internal > 0 else None,
        "absorbed_energy": float(absorbed[-1]),
        "crushed_mass": crushed_mass,
        "specific_energy_absorption": sea,
        "specific_energy_absorption_over_reference": [sea * per_length / r if (r and sea is not None) else None
                                                      for r in references],
        "max_penetration_over_thickness": float(s.contact.max_penetration[None]) if s.contact is not None else None,
        "ram_velocity_final": float(s.bodies.velocity[b].to_numpy()
                                    @ (np.asarray(body.direction) if body.direction is not None else axis)),
    }
    if spec.folds:
        folds = fold_geometry(sim.model.points, sim.state.fetch("nodes.position"),
                              float(sim.model.element.thickness.max()), axis)
        out.update(folds)
        if spec.half_wavelength_reference is not None:
            out["half_wavelength_over_reference"] = (folds["half_wavelength"] / spec.half_wavelength_reference
                                                     if folds["half_wavelength"] else None)
    return {"crush": out}
