"""The spot-welded top-hat section (issue 31, item 4): writes scenes/top_hat.k, a plain
LS-DYNA keyword deck, and reads a run of it back (mean crush force, folds, welds, balance).

    python benchmarks/top_hat.py --write                 # scenes/top_hat.k
    python -m taichi_shell_mpm run scenes/top_hat.k --set method.kind=fem --out outputs/top_hat
    python benchmarks/top_hat.py --read outputs/top_hat
    python benchmarks/top_hat.py --theory                # the closed cell's closed forms at sigma_y

Geometry (mid-surfaces; mm): a hat of web 60 x sides 60 with two 20 mm flanges, closed by a
100 mm plate 1.5 mm below the flanges, both 1.5 mm mild steel, 200 mm long along z; spot
welds joining the flanges' centre lines to the plate every 30 mm; clamped at z = 0; a rigid
plate (*MAT_RIGID) 2 mm above the top driven down at 10 mm/ms by
*BOUNDARY_PRESCRIBED_MOTION_RIGID for 10 ms (100 mm of crush); single-surface contact.
Elements 5 mm: 2 560 shells and the impactor's 16.  Units mm, ms, kg, kN, GPa.  A trigger
(0.3 mm inward on the web over its top 15 mm) starts the folding at the loaded end.
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

from taichi_shell_mpm.crush import MEAN_FORCE_FORMULAS, lobe_peaks

ROOT = Path(__file__).resolve().parents[1]
SIZE = 5.0               # element edge, mm
LENGTH, WEB, DEPTH, FLANGE, GAP = 200.0, 60.0, 60.0, 20.0, 1.5
T, RHO, E, NU, SIGY, ETAN = 1.5, 7.85e-6, 210.0, 0.3, 0.30, 0.60
SPEED, END = 10.0, 10.0  # mm/ms, ms
PITCH = 30.0
SN, SS = 8.0, 10.0       # kN: spot weld strengths (normal, shear)
TRIGGER, TRIGGER_LENGTH = 0.3, 15.0
CELL = 0.5 * (WEB + DEPTH)  # mm: C of the closed cell (web x sides) in the closed forms


def hat_profile() -> list[tuple[float, float]]:
    """(x, y) of the hat's cross-section nodes, flange tip to flange tip."""
    pts = []
    x0 = -(WEB / 2 + FLANGE)
    for k in range(int(FLANGE / SIZE)):                        # left flange at y = GAP
        pts.append((x0 + k * SIZE, GAP))
    for k in range(int(DEPTH / SIZE)):                         # left side up
        pts.append((-WEB / 2, GAP + k * SIZE))
    for k in range(int(WEB / SIZE)):                           # web
        pts.append((-WEB / 2 + k * SIZE, GAP + DEPTH))
    for k in range(int(DEPTH / SIZE)):                         # right side down
        pts.append((WEB / 2, GAP + DEPTH - k * SIZE))
    for k in range(int(FLANGE / SIZE) + 1):                    # right flange
        pts.append((WEB / 2 + k * SIZE, GAP))
    return pts


def write_deck(path: Path) -> None:
    rows = int(LENGTH / SIZE)
    lines = ["*KEYWORD", "*TITLE", "spot-welded top-hat section crushed by a rigid plate (benchmarks/top_hat.py)",
             "$ units: mm, ms, kg, kN, GPa"]
    nodes, shells = [], []
    nid = 0

    def node(x, y, z):
        nonlocal nid
        nid += 1
        nodes.append((nid, x, y, z))
        return nid

    hat = hat_profile()
    hat_ids = []
    for j in range(rows + 1):
        z = j * SIZE
        row = []
        for x, y in hat:
            dy = 0.0
            if abs(x) < WEB / 2 - 1e-9 and abs(y - (GAP + DEPTH)) < 1e-9 and z > LENGTH - TRIGGER_LENGTH:
                dy = -TRIGGER * math.sin(math.pi * (x + WEB / 2) / WEB) * math.sin(
                    math.pi * (z - (LENGTH - TRIGGER_LENGTH)) / TRIGGER_LENGTH)
            row.append(node(x, y + dy, z))
        hat_ids.append(row)
    plate_x = [-(WEB / 2 + FLANGE) + k * SIZE for k in range(int((WEB + 2 * FLANGE) / SIZE) + 1)]
    plate_ids = [[node(x, 0.0, j * SIZE) for x in plate_x] for j in range(rows + 1)]
    eid = 0
    for ids, pid in ((hat_ids, 1), (plate_ids, 2)):
        for j in range(rows):
            for i in range(len(ids[0]) - 1):
                eid += 1
                # hat: normals outward (away from the plate); plate: towards -y
                a, b, c, d = ids[j][i], ids[j][i + 1], ids[j + 1][i + 1], ids[j + 1][i]
                shells.append((eid, pid, a, b, c, d) if pid == 1 else (eid, pid, a, d, c, b))
    # the impactor: a 4 x 4 rigid plate 1 mm above the top, covering the section
    top = LENGTH + 2.0            # 2 mm above the top: beyond the 1.5 mm contact thickness
    xs, ys = np.linspace(-55.0, 55.0, 5), np.linspace(-10.0, 70.0, 5)
    imp = [[node(float(x), float(y), top) for x in xs] for y in ys]
    for j in range(4):
        for i in range(4):
            eid += 1
            shells.append((eid, 3, imp[j][i], imp[j][i + 1], imp[j + 1][i + 1], imp[j + 1][i]))
    lines += ["*NODE"] + [f"{n:8d}{x:16.6f}{y:16.6f}{z:16.6f}" for n, x, y, z in nodes]
    lines += ["*ELEMENT_SHELL"] + [f"{e:8d}{p:8d}{a:8d}{b:8d}{c:8d}{d:8d}" for e, p, a, b, c, d in shells]
    lines += ["*PART", "hat", f"{1:10d}{1:10d}{1:10d}", "*PART", "plate", f"{2:10d}{1:10d}{1:10d}",
              "*PART", "impactor", f"{3:10d}{1:10d}{2:10d}",
              "*SECTION_SHELL", f"{1:10d}{2:10d}{0.833:10.3f}{5:10d}", "".join(f"{T:10.3f}" for _ in range(4)),
              "*MAT_PIECEWISE_LINEAR_PLASTICITY_TITLE", "mild steel",
              f"{1:10d}{RHO:10.3e}{E:10.1f}{NU:10.2f}{SIGY:10.3f}{ETAN:10.3f}", "", "", "",
              "*MAT_RIGID_TITLE", "impactor", f"{2:10d}{RHO:10.3e}{E:10.1f}{NU:10.2f}",
              f"{1.0:10.1f}{4:10d}{7:10d}", "",      # CMO = 1: x, y (CON1 = 4) and every rotation (CON2 = 7) held
              ]
    # the clamped end
    bottom = sorted(hat_ids[0] + plate_ids[0])
    lines += ["*SET_NODE_LIST_TITLE", "clamped end", f"{1:10d}"]
    lines += ["".join(f"{n:10d}" for n in bottom[k:k + 8]) for k in range(0, len(bottom), 8)]
    lines += ["*BOUNDARY_SPC_SET", f"{1:10d}{0:10d}" + "".join(f"{1:10d}" for _ in range(6))]
    lines += ["*DEFINE_CURVE_TITLE", "constant", f"{1:10d}", f"{0.0:20.4f}{1.0:20.4f}", f"{1000.0:20.4f}{1.0:20.4f}"]
    lines += ["*BOUNDARY_PRESCRIBED_MOTION_RIGID", f"{3:10d}{3:10d}{0:10d}{1:10d}{-SPEED:10.3f}"]
    # spot welds: flange centre lines (x = +-40) to the plate below, every PITCH mm
    welds = []
    flange_col = {-(WEB / 2 + FLANGE / 2): None, WEB / 2 + FLANGE / 2: None}
    for x in flange_col:
        i_hat = next(i for i, (hx, hy) in enumerate(hat) if abs(hx - x) < 1e-9 and abs(hy - GAP) < 1e-9)
        i_plate = next(i for i, px in enumerate(plate_x) if abs(px - x) < 1e-9)
        for j in range(int(PITCH / SIZE) // 2, rows + 1, int(PITCH / SIZE)):
            welds.append((hat_ids[j][i_hat], plate_ids[j][i_plate]))
    lines += ["*CONSTRAINED_SPOTWELD"] + [f"{a:10d}{b:10d}{SN:10.3f}{SS:10.3f}{2.0:10.1f}{2.0:10.1f}" for a, b in welds]
    lines += ["*CONTACT_AUTOMATIC_SINGLE_SURFACE", f"{0:10d}{0:10d}{5:10d}{0:10d}",
              f"{0.2:10.3f}{0.2:10.3f}{0.0:10.1f}{0.0:10.1f}{10.0:10.1f}", f"{1.0:10.1f}{1.0:10.1f}"]
    lines += ["*CONTROL_TERMINATION", f"{END:10.3f}", "*CONTROL_TIMESTEP", f"{0.0:10.1f}{0.9:10.2f}",
              "*CONTROL_HOURGLASS", f"{4:10d}{0.05:10.3f}",
              "*DATABASE_BINARY_D3PLOT", f"{1.0:10.3f}", "*DATABASE_GLSTAT", f"{0.01:10.3f}",
              "*DATABASE_RCFORC", f"{0.01:10.3f}", "*END"]
    path.write_text("\n".join(lines) + "\n")
    print(f"wrote {path}: {len(nodes)} nodes, {len(shells)} shells, {len(welds)} spot welds")


def closed_cell_mean_force(sigma0: float = SIGY) -> dict:
    """The published closed-form mean force of the section's closed cell, the web x sides
    square of C = 60 mm, t = 1.5 mm, at the flow stress sigma0 (crush.MEAN_FORCE_FORMULAS, as
    the tube's benchmark: Wierzbicki & Abramowicz 1983, Abramowicz & Jones 1984 with the
    effective crushing distance; rigid-perfectly plastic, no strain rate).  The flanges (two
    sheets welded, 2 x 20 mm) are not in it: White, Jones & Abramowicz's top-hat theory (1999),
    which counts them, is not in the sources this project can read."""
    return {name: k * sigma0 * T ** (5.0 / 3.0) * CELL ** (1.0 / 3.0) for name, k in MEAN_FORCE_FORMULAS.items()}


def last_frame(out: Path):
    """The run's last frame (frames.pvd's last entry) as a meshio mesh."""
    import xml.etree.ElementTree as ET

    import meshio
    files = [d.get("file") for d in ET.parse(out / "frames.pvd").getroot().iter("DataSet")]
    return meshio.read(out / files[-1])


def mean_flow_stress(last, plastic_work: float) -> float:
    """The run's dissipation-weighted mean flow stress, the sigma0 a rigid-perfectly plastic
    theory stands for: its plastic work over the integral of the equivalent plastic strain
    (the last frame's through-thickness mean of each element times its volume)."""
    x = (last.points - last.point_data["displacement"])[last.cells[0].data]
    area = 0.5 * np.linalg.norm(np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1]), axis=1)
    strain_volume = float(np.sum(last.cell_data["plastic_strain_mean"][0] * area * last.cell_data["thickness"][0]))
    return plastic_work / strain_volume if strain_volume > 0.0 else float("nan")


def read_run(out: Path) -> dict:
    """Mean crush force over 10-90 mm (the support impulse's work over the crush distance)
    and its ratio to the closed cell's closed forms at sigma_y and at the run's own mean flow
    stress, the energy balance, the welds that failed; folds counted on the web's centre line."""
    force = np.genfromtxt(out / "force.csv", delimiter=",", names=True)
    energy = np.genfromtxt(out / "energy.csv", delimiter=",", names=True)
    summary = json.loads((out / "summary.json").read_text())
    crush = np.maximum(-force["part_3uz"] - 2.0, 0.0)    # the impactor's travel past first touch (2 mm gap)
    support = np.abs(force["support_z"])                  # the clamped end's reaction along the axis
    window = (crush >= 10.0) & (crush <= 90.0)
    mean = float(np.trapezoid(support[window], crush[window]) / np.ptp(crush[window])) if window.sum() > 1 \
        else float("nan")
    balance = float(abs(energy["balance_error"][-1]) / max(abs(energy["motion_work"][-1]), 1e-300))
    welds = summary.get("spotwelds", [])
    last = last_frame(out)
    lobes, half_wave = web_folds(last, float(crush[-1]))
    theory = closed_cell_mean_force()
    flow = mean_flow_stress(last, float(energy["plastic_work"][-1]))
    at_flow = closed_cell_mean_force(flow)
    return {"mean_force_kN": mean, "closed_cell_theory_kN": theory,
            "mean_over_theory": {name: mean / value for name, value in theory.items()},
            "mean_flow_stress_GPa": flow, "closed_cell_theory_at_flow_stress_kN": at_flow,
            "mean_over_theory_at_flow_stress": {name: mean / value for name, value in at_flow.items()},
            "crush_mm": float(crush[-1]), "peak_kN": float(support.max()), "balance_over_work": balance,
            "welds": welds, "web_lobes": lobes, "half_wavelength_mm": half_wave,
            "half_wavelength_theory_mm": half_wavelength_theory(), "steps": summary.get("steps"),
            "run_seconds": summary.get("run_seconds")}


def web_folds(last, crush: float) -> tuple[int, float]:
    """Lobes and fold half-wavelength H on the web's centre line in the last frame, as the
    tube's crush measures count them (crush.lobe_peaks; docs/crush.md): the alternating
    interior extrema of its out-of-plane displacement (hysteresis 2t) over the crushed length
    (1.2 x the crush from the loaded end: below it the section bends, as a column, without
    folding); each extremum is one lobe, and H is half their mean spacing (a lobe folds 2H of
    wall)."""
    x0 = last.points - last.point_data["displacement"]
    line = np.nonzero((np.abs(x0[:, 0]) < 1e-6) & (x0[:, 1] > GAP + DEPTH - TRIGGER - 1e-6))[0]
    folded = line[x0[line, 2] > LENGTH - 1.2 * crush]
    peaks = lobe_peaks(x0[folded, 2], last.point_data["displacement"][folded, 1], 2.0 * T)
    return len(peaks), (0.5 * float(np.diff(peaks).mean()) if len(peaks) > 1 else float("nan"))


def half_wavelength_theory() -> float:
    """H = 0.983 C^(2/3) t^(1/3) of the closed cell (Wierzbicki & Abramowicz 1983, symmetric
    mode; the tube benchmark's reference, benchmarks.md 3.2)."""
    return 0.983 * CELL ** (2.0 / 3.0) * T ** (1.0 / 3.0)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--write", action="store_true")
    p.add_argument("--read", type=Path, default=None)
    p.add_argument("--theory", action="store_true", help="the closed cell's closed-form mean force (kN)")
    args = p.parse_args()
    if args.write:
        write_deck(ROOT / "scenes" / "top_hat.k")
    if args.theory:
        print(json.dumps(closed_cell_mean_force(), indent=1))
    if args.read is not None:
        print(json.dumps(read_run(args.read), indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
