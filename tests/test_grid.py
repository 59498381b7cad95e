"""The unbounded background grid (stages/grid.py, issue 20), through the CLI: a plate flying
far through empty space keeps its mass and momentum and constant memory, and the strip that
an end moment rolls up into a circle (Sze's end-moment cantilever) runs with no grid box
given, against the closed form.
"""
from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from taichi_shell_mpm.energy import absorbed as absorbed_energy

from .test_motion_loads import run, table
from .test_reliability import assert_clean_output, cli_run

ROOT = Path(__file__).resolve().parents[1]

FLYER = """
[scene]
name = "flyer"
units = "consistent"
[mesh]
kind = "plate"
lx = 1.0
ly = 1.0
nx = 1
ny = 1
[material]
E = 100.0
nu = 0.0
density = 1.0
[section]
thickness = 0.01
[method]
kind = "mpm"
cell_size = 0.5
[[initial]]
velocity = {velocity}
angular_velocity = [0.0, 0.0, {spin!r}]
center = [0.5, 0.5, 0.0]
[nodesets.corner]
nearest = [1.0, 1.0, 0.0]
[[probe]]
name = "mean"
nodes = "all"
components = ["ux", "uy", "uz"]
[[probe]]
name = "corner"
nodes = "corner"
components = ["ux", "uy", "uz"]
[solve]
kind = "dynamic"
end_time = {end!r}
dt_rule = "shell"
[output]
history_interval = {every!r}
"""


def test_grid_follows_a_plate_flying_through_empty_space(tmp_path):
    """One element (four nodes of equal mass, so their mean is the centre of mass) flies
    diagonally at 0.9 times the wave speed, spinning slowly in its plane, over 1000 times its
    own size: the grid it touches is ~40 times the pool of slots, so the pool is collected
    and reused (memory constant: the size class of four nodes, whatever the distance).
    Momentum: the centre of mass moves at v0 to round-off (the probes' 10 digits).  The grid
    addresses: APIC carries the affine (rigid) velocity field exactly, so the corner follows
    the rigid motion up to the explicit integration's stretch; a grid node handed the slot of
    another would break both."""
    speed = 0.9 * 10.0                                     # c = sqrt(E / rho) = 10
    v0 = speed * np.array([1.0, 0.8, 0.6]) / math.sqrt(2.0)
    spin, end = 0.02, 400.0
    text = FLYER.format(velocity=str([float(v) for v in v0]), spin=spin, end=end, every=end / 10)
    out, summary = run(tmp_path, text, "flyer")
    grid = summary["grid"]
    p = table(out / "probes.csv")
    t = p["time"]
    mean = np.stack([p["meanux"], p["meanuy"], p["meanuz"]], axis=1)
    momentum_err = float(np.max(np.linalg.norm(mean - np.outer(t, v0), axis=1)) / (speed * t[-1]))
    corner0 = np.array([0.5, 0.5, 0.0])                    # the corner (1, 1, 0) from the centre
    rigid = np.stack([np.cos(spin * t) * corner0[0] - np.sin(spin * t) * corner0[1] - corner0[0],
                      np.sin(spin * t) * corner0[0] + np.cos(spin * t) * corner0[1] - corner0[1],
                      np.zeros_like(t)], axis=1) + np.outer(t, v0)
    corner = np.stack([p["cornerux"], p["corneruy"], p["corneruz"]], axis=1)
    rigid_err = float(np.max(np.linalg.norm(corner - rigid, axis=1)))
    print(f"\nflyer: travelled {speed * t[-1]:.0f} sizes in {summary['steps']} steps; grid {grid}; "
          f"centre of mass off v0 t by {momentum_err:.1e} of the distance; corner off the rigid "
          f"motion by {rigid_err:.2e} (spin radius {np.linalg.norm(corner0):.3f})")
    assert speed * t[-1] > 1000.0
    assert grid["collections"] >= 1 and grid["slots"] == 1 << 16     # GRID_CAPACITY_MIN for 4 nodes
    assert grid["slots_used"] <= grid["slots"]
    assert momentum_err < 1e-6     # measured 1.5e-7, 5.3e-7: the probes average nodes of unequal mass,
    #                                so the bending after the impact moves their mean off the centre of mass
    assert rigid_err < RIGID_TOL


RIGID_TOL = 0.045     # measured 3.05e-2: the explicit integration of the spin (omega dt = 1.3e-3)
# 4 levels to M_max, tip errors measured (max over the levels, of the largest reference value):
# h = l/2 on one field w 0.22 %, u 0.06 %; h = l on multi fields w 0.25 %, u 0.06 %
ROLLUP_TOL = {("single", 0.375): {"w": 0.0033, "u": 0.0009}, ("multi", 0.75): {"w": 0.0038, "u": 0.0009}}
SLIDE_TOL = 1.1e-3    # measured 1.8e-4 (t = 0.02), 7.2e-4 (t = 0.125)


ROLLUP_LEVELS, ROLLUP_LOAD = 4, 1.0


def rollup_scene(tmp_path, levels: int, load: float, fields: str = "single", cell: float = 0.375):
    """scenes/rollup.toml at `levels` load steps up to `load` x M_max (its [reference] rows are
    keyed by M / M_max, so the closed form is evaluated here instead)."""
    text = (ROOT / "scenes" / "rollup.toml").read_text()
    text = re.sub(r"\[reference\].*?(?=\[solve\])", "", text, flags=re.S)
    m = float(re.search(r"moment = \[0.0, (\S+), 0.0\]", text).group(1))
    text = text.replace(f"moment = [0.0, {m!r}, 0.0]", f"moment = [0.0, {load * m!r}, 0.0]")
    text = text.replace("load_steps = 20", f"load_steps = {levels}")
    text = text.replace('transfer = "apic"', f'transfer = "apic"\nfields = "{fields}"')
    text = text.replace("cell_size = 0.375", f"cell_size = {cell!r}")
    return text


def rollup_errors(probes, load: float) -> dict:
    """Relative errors of the tip against the closed form (Euler-Bernoulli, kappa = M / EI):
    u = L (sin theta / theta - 1), w = L (1 - cos theta) / theta, theta = 2 pi M / M_max; each
    level's error over the largest reference value of the component, as the Sze tests."""
    length = 12.0
    theta = 2 * math.pi * load * probes["load_factor"]
    ref = {"u": length * (np.sin(theta) / theta - 1.0), "w": length * (1.0 - np.cos(theta)) / theta}
    sim = {"u": probes["tipux"], "w": probes["tipuz"]}
    return {k: np.abs(sim[k] - ref[k]) / np.abs(ref[k]).max() for k in ref}


@pytest.mark.parametrize("fields,cell", [("single", 0.375), ("multi", 0.75)])
def test_rollup_by_an_end_moment_without_a_grid_box(tmp_path, fields, cell):
    """Sze's end-moment cantilever (scenes/rollup.toml: 16 x 1 elements, L = 12, M_max =
    2 pi EI / L rolls it into a full circle, the tip back at the clamp), no grid box given, in
    mpm mode at 4 load levels up to M_max (the strip far outside its initial bounding box, its
    tip meeting the clamp), against the closed form at every level: at h = l/2 on one
    velocity field, and at h = l (the tip and the first free node then share grid nodes) on
    the multi-field grid."""
    out, summary = run(tmp_path, rollup_scene(tmp_path, ROLLUP_LEVELS, ROLLUP_LOAD, fields, cell), "rollup")
    p = table(out / "probes.csv")
    errs = rollup_errors(p, ROLLUP_LOAD)
    print(f"\nrollup ({ROLLUP_LEVELS} levels to {ROLLUP_LOAD} M_max, mpm, h = {cell}, {fields}): " + ", ".join(
          f"{k} mean {100 * e.mean():.2f} % max {100 * e.max():.2f} %" for k, e in errs.items())
          + f"; grid {summary['grid']}")
    assert len(p["load_factor"]) == ROLLUP_LEVELS
    for k, e in errs.items():
        assert e.max() < ROLLUP_TOL[fields, cell][k], k


SHEETS = """
[scene]
name = "sheets"
units = "consistent"
[mesh]
kind = "file"
path = "sheets.vtu"
[materials.soft]
E = 100.0
nu = 0.0
density = 1.0
[sections.sheet]
thickness = {t!r}
[elementsets.lower]
box = {{ min = [-1.0, -1.0, -0.5], max = [2.0, 2.0, 0.25] }}
[elementsets.upper]
box = {{ min = [-1.0, -1.0, 0.25], max = [2.0, 2.0, 2.0] }}
[[part]]
name = "lower"
material = "soft"
section = "sheet"
elements = "lower"
[[part]]
name = "upper"
material = "soft"
section = "sheet"
elements = "upper"
[method]
kind = "mpm"
cell_size = 0.25
fields = "{fields}"
[nodesets.lower]
plane = {{ point = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0] }}
[nodesets.upper]
plane = {{ point = [0.0, 0.0, {gap!r}], normal = [0.0, 0.0, 1.0] }}
[[initial]]
nodes = "upper"
velocity = [{slide!r}, 0.0, {approach!r}]
[[probe]]
name = "lower"
nodes = "lower"
components = ["ux", "uy", "uz"]
[[probe]]
name = "upper"
nodes = "upper"
components = ["ux", "uy", "uz"]
[contact]
stiffness = 0.1
damping = 0.0
[solve]
kind = "dynamic"
end_time = {end!r}
dt_rule = "shell"
[output]
history_interval = {every!r}
"""


def sheets_mesh(path, gap: float, shift: float = 0.125) -> None:
    """Two unit squares of 2 x 2 elements, one at z = 0, one at z = gap, the upper one shifted
    by `shift` in x and y (a quarter element: no node of it sits over a node of the lower)."""
    import meshio
    xs = np.linspace(0.0, 1.0, 3)
    grid = np.array([[x, y] for y in xs for x in xs])
    quads = np.array([[j * 3 + i, j * 3 + i + 1, (j + 1) * 3 + i + 1, (j + 1) * 3 + i] for j in range(2) for i in range(2)])
    lower = np.c_[grid, np.zeros(len(grid))]
    upper = np.c_[grid + shift, np.full(len(grid), gap)]
    meshio.write(path, meshio.Mesh(np.vstack([lower, upper]), [("quad", np.vstack([quads, quads + len(grid)]))]))


@pytest.mark.parametrize("thickness", [0.02, 0.125])
def test_sheets_keep_their_velocities_until_they_touch(tmp_path, thickness):
    """Two free sheets of equal mass (two parts; the upper one sliding at 0.1 and falling at
    0.2, c = 10) on the multi-field grid at h = 0.25: until their
    mid-surfaces are t apart, neither moves the other, though they share grid nodes from 2h
    apart on (t = 0.02: they come within h/4 = 0.0625, to 0.022; t = 0.125: a plate dropped
    on a plate at h = 2t).  Then the frictionless contact hands the lower one the normal
    momentum (the sum kept), they part again, and the slide is left alone.  On
    a single-field grid the lower sheet takes the upper's momentum as soon as they share grid
    nodes (measured in the report of issue 20: --set method.fields=single)."""
    gap, slide, approach = 0.5, 0.1, -0.2
    touch = (gap - thickness) / -approach
    end = touch + 0.6
    sheets_mesh(tmp_path / "sheets.vtu", gap)
    text = SHEETS.format(t=thickness, fields="multi", gap=gap, slide=slide, approach=approach, end=end, every=0.01)
    out, summary = run(tmp_path, text, "sheets")
    p = table(out / "probes.csv")
    t = p["time"]
    lower = np.stack([p["lowerux"], p["loweruy"], p["loweruz"]], axis=1)
    upper = np.stack([p["upperux"], p["upperuy"], p["upperuz"]], axis=1)
    before = t < touch - 1e-9
    distance = gap + upper[:, 2] - lower[:, 2]
    free_err = max(float(np.abs(lower[before]).max()),
                   float(np.abs(upper[before] - np.outer(t[before], [slide, 0.0, approach])).max()))
    momentum_err = float(np.abs(upper[:, 2] + lower[:, 2] - approach * t).max())
    v_lower = (lower[-1, 2] - lower[-2, 2]) / (t[-1] - t[-2])
    slide_err = max(abs(upper[-1, 0] - slide * t[-1]), abs(lower[-1, 0])) / (slide * t[-1])
    print(f"\nsheets t = {thickness}: closest before touching {distance[before].min():.4f} (h/4 = 0.0625), "
          f"off the free flight by {free_err:.1e}; normal momentum off by {momentum_err:.1e}; the lower "
          f"sheet ends at vz {v_lower:.4f} ({v_lower / approach:.2f} of the approach), {distance[-1]:.4f} "
          f"apart; slide off by {slide_err:.1e}; grid {summary['grid']}")
    assert summary["grid"]["fields"] > 1
    assert distance[before].min() < thickness + 0.01
    assert free_err < 1e-12
    assert momentum_err < 1e-6     # measured 1.5e-7, 5.3e-7: the probes average nodes of unequal mass,
    #                                so the bending after the impact moves their mean off the centre of mass
    assert v_lower / approach > 0.5 and distance[-1] > thickness      # momentum handed over, parted
    assert slide_err < SLIDE_TOL


# round-off (measured: velocities 5.6e-16, probe momentum 5.0e-12, contact energy 2.9e-16 and
# balance 8.6e-16 of the loss); the bounds leave room for other architectures' round-off
GRID_CONTACT_VELOCITY_TOL = 1e-13
GRID_CONTACT_MOMENTUM_TOL = 1e-11
GRID_CONTACT_ENERGY_TOL = 1e-13


def test_grid_contact_sheets_meet_plastically_with_coulomb_friction(tmp_path):
    """The grid contact condition ([method].field_contact = "grid", stages/grid.py) on two
    stacked sheets of equal mass (two parts, t = 0.125, h = 0.25 = 2t, no [contact]): the upper
    one falls at 0.2 and slides at 0.1 onto the lower, mu = 0.3.  Closed form of a perfectly
    plastic impact with Coulomb friction: both end at the common normal velocity
    (m1 v1 + m2 v2) / (m1 + m2) = -0.1, and the friction impulse, mu times the normal one
    (0.3 x 0.1 m per sheet), takes 0.03 off the upper's slide and gives it to the lower's
    (0.07, 0.03); the kinetic energy lost, 1/2 m1 m2 / (m1 + m2) (0.2^2 + (0.1^2 - 0.04^2)),
    is the contact column.  No exchange before the mid-surfaces are t apart."""
    t, gap, slide, approach, mu = 0.125, 0.175, 0.1, -0.2, 0.3      # (h = 0.25: SHEETS)
    touch = (gap - t) / -approach
    every = 0.005
    sheets_mesh(tmp_path / "sheets.vtu", gap, shift=0.0)
    text = SHEETS.format(t=t, fields="multi", gap=gap, slide=slide, approach=approach, end=touch + 0.2, every=every)
    text = text.replace("max = [2.0, 2.0, 0.25]", "max = [2.0, 2.0, 0.06]").replace("min = [-1.0, -1.0, 0.25]",
                                                                                       "min = [-1.0, -1.0, 0.06]")
    text = text.replace("[contact]\nstiffness = 0.1\ndamping = 0.0\n", "")
    text = text.replace('fields = "multi"', f'fields = "multi"\nfield_contact = "grid"\nfield_friction = {mu!r}')
    out, summary = run(tmp_path, text, "sheets")
    p, e = table(out / "probes.csv"), table(out / "energy.csv")
    time = p["time"]
    lower = np.stack([p["lowerux"], p["loweruy"], p["loweruz"]], axis=1)
    upper = np.stack([p["upperux"], p["upperuy"], p["upperuz"]], axis=1)
    distance = gap + upper[:, 2] - lower[:, 2]
    first = int(np.argmax(np.abs(lower).max(axis=1) > 0.0))
    v_end = (np.r_[upper[-1], lower[-1]] - np.r_[upper[-2], lower[-2]]) / (time[-1] - time[-2])
    v_ref = np.array([slide - mu * 0.1, 0.0, -0.1, mu * 0.1, 0.0, -0.1])
    velocity_err = float(np.abs(v_end - v_ref).max())
    momentum_err = float(np.abs(upper + lower - np.outer(time, [slide, 0.0, approach])).max())
    mass = 0.125                        # each sheet: density 1, t = 0.125, unit area
    loss = 0.5 * 0.5 * mass * (approach ** 2 + slide ** 2 - (slide - 2 * mu * 0.1) ** 2)
    energy_err = abs(e["contact"][-1] - loss) / loss
    balance = abs(e["balance_error"][-1]) / loss
    print(f"\ngrid contact, stacked sheets t = h/2, mu = {mu}: first exchange at gap {distance[first]:.4f} "
          f"(t = {t}; previous output {distance[first - 1]:.4f}), closest {distance.min():.4f}; end velocities "
          f"off the closed form by {velocity_err:.1e}; momentum off by {momentum_err:.1e}; contact energy "
          f"{e['contact'][-1]:.6f} vs the loss {loss:.6f} ({energy_err:.1e}), balance {balance:.1e} of it")
    assert distance[first - 1] > t - 1e-12 and distance[first] > t + approach * every
    assert np.abs(lower[:first]).max() == 0.0
    assert distance.min() > t + approach * every
    assert velocity_err < GRID_CONTACT_VELOCITY_TOL
    assert momentum_err < GRID_CONTACT_MOMENTUM_TOL
    assert energy_err < GRID_CONTACT_ENERGY_TOL and balance < GRID_CONTACT_ENERGY_TOL


def test_grid_contact_needs_the_multi_field_grid(tmp_path):
    """field_contact = "grid" on a single-field grid: one line naming the key, exit code 2."""
    sheets_mesh(tmp_path / "sheets.vtu", 0.5)
    text = SHEETS.format(t=0.02, fields="single", gap=0.5, slide=0.0, approach=-0.2, end=0.1, every=0.1)
    path = tmp_path / "bad.toml"
    path.write_text(text.replace('fields = "single"', 'fields = "single"\nfield_contact = "grid"'))
    r = cli_run("run", str(path), "--out", str(tmp_path / "out"), "--quiet")
    assert_clean_output(r)
    print(f"\n{r.err.strip()}")
    assert r.code == 2 and len(r.err.strip().splitlines()) == 1 and "[method].field_contact" in r.err


def test_multi_field_claim_rounds_of_the_gpu_launch_match_the_serial_claim(tmp_path, monkeypatch):
    """The GPU launch chooses the fields with atomics in MAX_FIELDS rounds
    (GridUpdate.claim_rounds) instead of the CPU's claim in P2G order; run here on the CPU's
    threads (runtime.FORCE_LAUNCH = "gpu"), the two sheets of the test above, approaching
    within h/4 and touching, take the same path as on the serial launch (to round-off: the
    atomic sums change the order of additions)."""
    from taichi_shell_mpm import runtime
    gap, slide, approach, thickness = 0.5, 0.1, -0.2, 0.02
    end = (gap - thickness) / -approach + 0.3
    sheets_mesh(tmp_path / "sheets.vtu", gap)
    text = SHEETS.format(t=thickness, fields="multi", gap=gap, slide=slide, approach=approach, end=end, every=0.01)
    probes = {}
    for launch in ("batched", "gpu"):
        monkeypatch.setattr(runtime, "FORCE_LAUNCH", launch)
        out, summary = run(tmp_path, text, f"sheets_{launch}")
        assert summary["launch"] == launch and summary["grid"]["fields"] > 1
        assert summary["grid"]["field_overflow"] == 0
        probes[launch] = np.loadtxt(out / "probes.csv", delimiter=",", skiprows=1)
    diff = float(np.abs(probes["gpu"] - probes["batched"]).max())
    print(f"\nclaim rounds (gpu launch on the CPU) vs serial claim: largest probe difference {diff:.1e} "
          f"over {len(probes['gpu'])} rows")
    assert probes["gpu"].shape == probes["batched"].shape
    assert diff < 1e-9


# The tube at h = l to 0.5 ms (the impact's stress wave, before the folds), multi-field grid,
# batched launch: energy lost (balance error) measured -0.103 J of 151.2 J absorbed (0.068 %)
# with PolyPIC; APIC -8.85 J, 5.7 % (one field; `python -m taichi_shell_mpm run
# scenes/square_tube.toml --set solve.end_time=0.5 --set method.cell_size=5 --set
# method.transfer=apic`, docs/grid.md)
POLYPIC_TUBE_LOSS_TOL = 0.001


def test_polypic_keeps_the_tube_wave_at_one_cell_per_element(tmp_path, monkeypatch):
    """scenes/square_tube.toml at h = l (5 mm cells on 5 mm elements) on the multi-field grid
    with ``transfer = "polypic"``, to 0.5 ms: the ram's impact sends a stress wave up the
    straight tube, which APIC's round trip grid -> nodes -> grid filters at one cell per
    element (its energy lost: 5.7 % of the absorbed energy); PolyPIC hands the grid back the
    cell's whole trilinear field.  The same run stopped and restarted is bit-for-bit (the
    nodes' velocity modes travel in the checkpoint)."""
    from .test_restart import restart_roundtrip
    args = [str(ROOT / "scenes" / "square_tube.toml")]
    for item in ["solve.end_time=0.5", "method.cell_size=5", "method.fields=multi", "method.transfer=polypic",
                 "output.times=[0.25]", "output.history_interval=0.05"]:
        args += ["--set", item]
    # 2 880 elements, batches of 200 steps; ~1 100 steps to 0.5 ms
    restart_roundtrip(tmp_path, monkeypatch, args, stop_step=700, every=400, batch_element_steps=576_000)
    e = json.loads((tmp_path / "a" / "summary.json").read_text())["energies"]
    absorbed = absorbed_energy(e)
    loss = e["balance_error"]
    print(f"\ntube at h = l, multi fields, PolyPIC, 0.5 ms: balance error {loss:.3f} J of {absorbed:.1f} J "
          f"absorbed ({100 * abs(loss) / absorbed:.2f} %; APIC, one field: -8.85 J, 5.7 %)")
    assert abs(loss) < POLYPIC_TUBE_LOSS_TOL * absorbed


def stacked_sheets_scene(tmp_path, layers: int = 5, spacing: float = 0.04) -> Path:
    """`layers` free unit squares of 2 x 2 elements at z = 0, spacing, ..., one part each, all
    within one cell (h = 0.25) of the multi-field grid, at rest (the features of SHEETS)."""
    import meshio
    xs = np.linspace(0.0, 1.0, 3)
    grid = np.array([[x, y] for y in xs for x in xs])
    quads = np.array([[j * 3 + i, j * 3 + i + 1, (j + 1) * 3 + i + 1, (j + 1) * 3 + i] for j in range(2) for i in range(2)])
    meshio.write(tmp_path / "stack.vtu", meshio.Mesh(
        np.vstack([np.c_[grid, np.full(len(grid), k * spacing)] for k in range(layers)]),
        [("quad", np.vstack([quads + k * len(grid) for k in range(layers)]))]))
    parts = "".join(
        f'[elementsets.s{k}]\nbox = {{ min = [-1.0, -1.0, {(k - 0.5) * spacing!r}], max = [2.0, 2.0, {(k + 0.5) * spacing!r}] }}\n'
        f'[[part]]\nname = "s{k}"\nmaterial = "soft"\nsection = "sheet"\nelements = "s{k}"\n' for k in range(layers))
    text = (f'[scene]\nname = "stack"\nunits = "consistent"\n[mesh]\nkind = "file"\npath = "stack.vtu"\n'
            f'[materials.soft]\nE = 100.0\nnu = 0.0\ndensity = 1.0\n[sections.sheet]\nthickness = 0.02\n{parts}'
            '[method]\nkind = "mpm"\ncell_size = 0.25\nfields = "multi"\n[contact]\nstiffness = 0.1\ndamping = 0.0\n'
            '[solve]\nkind = "dynamic"\nend_time = 3.0\ndt_rule = "shell"\n[output]\nhistory_interval = 0.1\n')
    path = tmp_path / "stack.toml"
    path.write_text(text)
    return path


def test_stacked_sheets_beyond_the_fields_warn_once_and_restart(tmp_path, monkeypatch):
    """Five sheets (five parts) within one cell: every grid node they reach holds 5 layers,
    one more than its MAX_FIELDS fields, so the fifth joins the last field (issue 28 item 6):
    the run warns once, naming the step and the grid nodes (all 6 x 6 x 2 of the stencils), on
    the console and in summary.json; the count and the warning are in the checkpoint, so the
    stopped and restarted run's summary (overflow count and warnings) is the uninterrupted one's."""
    from .test_restart import restart_roundtrip
    scene = stacked_sheets_scene(tmp_path)
    r = cli_run("run", str(scene), "--out", str(tmp_path / "once"), timeout=600)
    assert r.code == 0, r.out + r.err
    said = [line for line in (r.out + r.err).splitlines()      # the warning itself (the end summary repeats it)
            if line.startswith("warning:") and "ran out of velocity fields" in line]
    summary = json.loads((tmp_path / "once" / "summary.json").read_text())
    print(f"\n{said}\ngrid {summary['grid']}, {summary['steps']} steps")
    assert len(said) == 1 and "72 grid nodes" in said[0] and "step 1:" in said[0]
    noted = [w for w in summary["warnings"] if "velocity fields" in w]
    assert len(noted) == 1 and noted[0].startswith("72 grid nodes") and "step 1:" in noted[0]
    assert summary["grid"]["field_overflow"] > 0
    # 20 elements: 20-step batches; stopped at step 50 and restarted, and from the checkpoint at 40
    restart_roundtrip(tmp_path, monkeypatch, [str(scene)], stop_step=50, every=30, batch_element_steps=400)
    a, c = (json.loads((tmp_path / d / "summary.json").read_text()) for d in ("a", "c"))
    assert a["grid"]["field_overflow"] == c["grid"]["field_overflow"] > 0
    assert a["warnings"] == c["warnings"] and len(a["warnings"]) == 1
