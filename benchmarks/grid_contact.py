"""The fields' interaction on the multi-field grid, penalty contact against the grid contact
condition (issue 20, docs/contact.md): two free sheets of equal mass (tests/test_grid.py's
scene, h = 0.25) through the CLI.

    python -m benchmarks.grid_contact sheets --thickness 0.125 --contact grid [--shift 0 --slide 0]
    python -m benchmarks.grid_contact press --friction 0.3

(`python -m` from the repository root imports this checkout's package and tests.)

``sheets``: the upper sheet falls at 0.2 (and slides at --slide) onto the lower from 0.5 above
(--shift: its offset in x and y; 0.125, a quarter element, by default as in the test): the gap
between the mid-surfaces at the first exchange of momentum, the closest any upper node came to
the lower sheet's surface, the end velocities (a probe's mean over its sheet's nodes) and the
restitution, the energy columns.  ``press``: stacked sheets t = 0.125 apart pressed together
by +-F = 0.0125, the upper one sliding at 0.1, grid contact with --friction: the friction force
on each sheet (its x-momentum's rate) against mu F.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from tests.test_grid import SHEETS, sheets_mesh

GAP, APPROACH = 0.5, -0.2


def scene(folder: Path, thickness: float, contact: str, gap: float, shift: float, slide: float, approach: float,
          end: float, every: float, friction: float = 0.0, press: float = 0.0) -> str:
    sheets_mesh(folder / "sheets.vtu", gap, shift=shift)
    text = SHEETS.format(t=thickness, fields="multi", gap=gap, slide=slide, approach=approach, end=end, every=every)
    cut = min(0.25, gap / 2)
    text = text.replace("max = [2.0, 2.0, 0.25]", f"max = [2.0, 2.0, {cut!r}]").replace(
        "min = [-1.0, -1.0, 0.25]", f"min = [-1.0, -1.0, {cut!r}]")
    if contact == "grid":
        text = text.replace("[contact]\nstiffness = 0.1\ndamping = 0.0\n", "")
        text = text.replace('fields = "multi"', 'fields = "multi"\nfield_contact = "grid"'
                            + (f"\nfield_friction = {friction!r}" if friction else ""))
    if press:
        text += (f'[[load]]\nnodes = "upper"\nforce = [0.0, 0.0, {-press!r}]\n'
                 f'[[load]]\nnodes = "lower"\nforce = [0.0, 0.0, {press!r}]\n')
    # a probe per node (lower 0-8, upper 9-17, row by row)
    text = text.replace("[[probe]]", "".join(f"[nodesets.n{i}]\nids = [{i}]\n" for i in range(18)) + "[[probe]]", 1)
    text += "".join(f'[[probe]]\nname = "n{i}"\nnodes = "n{i}"\ncomponents = ["ux", "uz"]\n' for i in range(18))
    return text


def run(folder: Path, text: str):
    (folder / "s.toml").write_text(text)
    start = time.time()
    r = subprocess.run([sys.executable, "-m", "taichi_shell_mpm", "run", str(folder / "s.toml"), "--out",
                        str(folder / "out"), "--quiet"], capture_output=True, text=True)
    if r.returncode:
        sys.exit(r.stderr)
    table = {name: np.atleast_1d(np.genfromtxt(folder / "out" / f"{name}.csv", delimiter=",", names=True))
             for name in ("probes", "energy")}
    return table["probes"], table["energy"], json.loads((folder / "out" / "summary.json").read_text()), \
        time.time() - start


def closest_over_lower(p, gap: float, shift: float) -> float:
    """The least distance of an upper node above the lower sheet's bilinear surface, over the
    nodes that are over it."""
    zl = np.array([p[f"n{i}uz"] for i in range(9)]).T.reshape(-1, 3, 3)       # [time, row, column]
    steps = np.arange(len(p))
    worst = np.inf
    for k in range(9, 18):
        x = shift + 0.5 * ((k - 9) % 3) + p[f"n{k}ux"]
        y = np.full_like(x, shift + 0.5 * ((k - 9) // 3))
        over = (x >= 0.0) & (x <= 1.0) & (y <= 1.0)
        fx, fy = np.clip(x / 0.5, 0, 1.999999), np.clip(y / 0.5, 0, 1.999999)
        ix, iy = fx.astype(int), fy.astype(int)
        rx, ry = fx - ix, fy - iy
        z = ((1 - rx) * (1 - ry) * zl[steps, iy, ix] + rx * (1 - ry) * zl[steps, iy, ix + 1]
             + (1 - rx) * ry * zl[steps, iy + 1, ix] + rx * ry * zl[steps, iy + 1, ix + 1])
        if over.any():
            worst = min(worst, float((gap + p[f"n{k}uz"] - z)[over].min()))
    return worst


def sheets(args, folder: Path) -> None:
    touch = (GAP - args.thickness) / -APPROACH
    p, e, summary, wall = run(folder, scene(folder, args.thickness, args.contact, GAP, args.shift, args.slide,
                                            APPROACH, touch + 0.6, 0.002))
    t = p["time"]
    lower = np.stack([p["lowerux"], p["loweruy"], p["loweruz"]], 1)
    distance = GAP + p["upperuz"] - p["loweruz"]
    first = int(np.argmax(np.abs(lower).max(axis=1) > 0.0))
    v_lower, v_upper = (np.gradient(p[f"{s}uz"], t)[-1] for s in ("lower", "upper"))
    print(f"{args.contact}, t = {args.thickness}, shift {args.shift}, slide {args.slide}: first exchange at gap "
          f"{distance[first]:.4f} (t {args.thickness}, h 0.25); closest upper node over the lower sheet "
          f"{closest_over_lower(p, GAP, args.shift):.4f}; end vz lower {v_lower:.4f} upper {v_upper:.4f} "
          f"(restitution {-(v_upper - v_lower) / APPROACH:.3f}); KE {e['kinetic'][0]:.3e} -> {e['kinetic'][-1]:.3e}, "
          f"contact {e['contact'][-1]:.3e}, balance error {e['balance_error'][-1]:.1e}; {wall:.0f} s")


def press(args, folder: Path) -> None:
    force, slide, end = 0.0125, 0.1, 1.0
    p, e, summary, wall = run(folder, scene(folder, 0.125, "grid", 0.12, 0.0, slide, 0.0, end, 0.01,
                                            friction=args.friction, press=force))
    t = p["time"]
    mass = 0.125                    # each sheet: density 1, t = 0.125, unit area
    inside = (t > 0.1) & (t < end - 0.05)
    rates = [np.polyfit(t[inside], np.gradient(p[f"{s}ux"], t)[inside], 1)[0] for s in ("upper", "lower")]
    print(f"press, mu = {args.friction}: friction force on the upper sheet {-mass * rates[0]:.6f}, on the lower "
          f"{mass * rates[1]:.6f}, mu N = {args.friction * force:.6f}; balance error {e['balance_error'][-1]:.1e}; "
          f"{wall:.0f} s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("case", choices=("sheets", "press"))
    parser.add_argument("--thickness", type=float, default=0.125)
    parser.add_argument("--contact", choices=("penalty", "grid"), default="grid")
    parser.add_argument("--shift", type=float, default=0.125)
    parser.add_argument("--slide", type=float, default=0.1)
    parser.add_argument("--friction", type=float, default=0.3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        (sheets if args.case == "sheets" else press)(args, Path(folder))


if __name__ == "__main__":
    main()
