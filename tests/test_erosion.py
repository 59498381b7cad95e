"""Element erosion and conventional mass scaling (issue 18, items 3 and 7; stages/masses.py).

One scene, a steel strip 100 x 10 x 1 mm clamped at x = 0 and pulled (or pushed) at
x = 100 by a 10 kg grip (a rigid body), with a weaker one-element "notch" column at
45-50 mm, serves every test here (one compile: erosion, conventional mass scaling, contact,
a rigid body, mpm): the notch fails and erodes (the reaction falls to zero, the balance
closes, the frames carry the `eroded` flag), a stiffer notch takes mass from conventional
mass scaling at t = 0 (closed form), a compressed notch takes it as it shortens, and the
guard on the added mass stops a run.  Two in-process tests check what the element pass
does with an eroded element at the grid (its mass shares leave the nodes, a node of eroded
elements only leaves the grid) and in the contact (no segment any more).
"""
from __future__ import annotations

import json
import math

import meshio
import numpy as np
import pytest
import taichi as ti

from taichi_shell_mpm.scene import load_scene

from .conftest import run_scene, simulation, write_scene

STRIP = """
[scene]
name = "strip"
units = "kN-mm-ms-kg"
[mesh]
kind = "plate"
lx = 100.0
ly = 10.0
nx = 20
ny = 2
[materials.steel]
E = 200.0
nu = 0.3
density = 7.85e-6
model = "j2"
yield_stress = 0.2
{steel_failure}
[materials.weak]
E = {notch_E}
nu = 0.3
density = 7.85e-6
model = "j2"
yield_stress = 0.1
hardening = 0.2
failure_strain = {failure_strain}
failure_points = 3
{weak_failure}
[sections.sheet]
thickness = 1.0
points = 3
[elementsets.left]
box = {{ min = [0.0, -1.0, -1.0], max = [45.0, 11.0, 1.0] }}
[elementsets.notch]
box = {{ min = [45.0, -1.0, -1.0], max = [50.0, 11.0, 1.0] }}
[elementsets.right]
box = {{ min = [50.0, -1.0, -1.0], max = [100.0, 11.0, 1.0] }}
[[part]]
name = "left"
material = "steel"
section = "sheet"
elements = "left"
[[part]]
name = "notch"
material = "weak"
section = "sheet"
elements = "notch"
[[part]]
name = "right"
material = "steel"
section = "sheet"
elements = "right"
[method]
kind = "mpm"
cell_size = 2.5
[nodesets.clamp]
plane = {{ point = [0.0, 0.0, 0.0], normal = [1.0, 0.0, 0.0] }}
[nodesets.grip]
plane = {{ point = [100.0, 0.0, 0.0], normal = [1.0, 0.0, 0.0] }}
[nodesets.flat]
box = {{ min = [-1.0, -1.0, -1.0], max = [99.0, 11.0, 1.0] }}
[[boundary]]
nodes = "clamp"
fix = {clamp_fix}
[[boundary]]
nodes = "flat"
fix = {flat_fix}
[[rigid_body]]
name = "grip"
nodes = "grip"
mass = 10.0
direction = [1.0, 0.0, 0.0]
[[initial]]
nodes = "grip"
velocity = [{speed}, 0.0, 0.0]
[contact]
[solve]
kind = "dynamic"
end_time = {end_time}
dt_rule = "shell"
mass_scaling = "conventional"
target_dt = {target_dt}
added_mass_limit = {limit}
[output]
times = {times}
history_interval = {history}
{extra}
"""
# dt_rule = "shell": the grid rule (alpha h / c_dil, the stiffest material's) would bind below
# every element's step on this h = L/2 grid and hide what mass scaling does (docs/scenes.md).
PULL = dict(notch_E=200.0, failure_strain=0.1, flat_fix='["uz"]', speed=2.0, end_time=1.0, target_dt=1e-5, limit=5.0,
            times="[0.2, 0.5, 1.0]", history=0.005, clamp_fix='"all"', steel_failure="", weak_failure="", extra="")
NOTCH = [9, 29]                       # its elements (plate elements run row by row along x)
RHO, NU, L_E = 7.85e-6, 0.3, 25.0 / math.sqrt(50.0)     # L_e = area / longest diagonal of a 5 mm square


def strip_scene(tmp_path, **values):
    return write_scene(tmp_path, STRIP.format(**{**PULL, **values}), "strip.toml")


def run_cli(scene, out, *sets):
    """The run, in this process through the Python API (conftest.run_scene)."""
    return run_scene(scene, out, *sets)


def table(path):
    return np.genfromtxt(path, delimiter=",", names=True, dtype=None, encoding=None)


def element_step(E: float) -> float:
    """alpha L_e / c_e of a 5 mm square (stages/timestep.element_limit, alpha = 0.9)."""
    return 0.9 * L_E / math.sqrt(E / (RHO * (1.0 - NU ** 2)))


# Measured (pytest -s tests/test_erosion.py, 2026-12, batched launch: the same every run): the
# notch erodes between 0.260 and 0.265 ms; after it, the support force averaged over the rest
# of the run (its impulse) is 0.74 % of the 2.09 kN peak (the released stub rings, undamped,
# at about the peak force); energy balance error at most 0.22 % of the absorbed energy; the
# step of internal + hourglass + drilling + eroded over the record interval of the erosion
# 2.3 % of the eroded energy (the rest of the strip goes on absorbing meanwhile).
REACTION_BOUND = 0.011      # 1.5x measured
BALANCE_BOUND = 0.0033      # 1.5x measured (the issue asks < 1 % of the work done)
JUMP_BOUND = 0.035          # 1.5x measured


def test_strip_pulled_until_it_erodes(tmp_path):
    """The notch reaches the failure strain at all 3 points and erodes: the clamp's reaction
    falls to zero (on average: the released stub rings), the eroded energy takes over the
    notch's internal energy without a jump, the balance closes, no NaN, and the frames carry
    the eroded flag."""
    out = tmp_path / "out"
    proc = run_cli(strip_scene(tmp_path), out)
    assert proc.returncode == 0, proc.stderr[-2000:]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["erosion"]["eroded_elements"] == 2
    assert [(p["name"], p["eroded_elements"]) for p in summary["parts"] if "material" in p] == [
        ("left", 0), ("notch", 2), ("right", 0)]
    assert summary["mass_scaling"]["added_mass"] == 0.0         # the target is below every element's step
    energy, force, parts = table(out / "energy.csv"), table(out / "force.csv"), table(out / "parts.csv")
    for t in (energy, force):
        assert all(np.isfinite(t[name]).all() for name in t.dtype.names)
    t = energy["time"]
    eroded = energy["eroded"]
    k = int(np.argmax(eroded > 0.0))                   # first record after the erosion
    assert k > 0 and eroded[k - 1] == 0.0
    # the notch's energy moves to the eroded column (the stub's and grip piece's change little
    # over one record interval)
    stored = energy["internal"] + energy["hourglass"] + energy["drilling"]
    jump = (stored[k] + eroded[k]) - (stored[k - 1] + eroded[k - 1])
    notch = parts[parts["part"] == "notch"]
    print(f"\nerosion between t = {t[k - 1]:.3f} and {t[k]:.3f} ms: eroded energy {eroded[k]:.4f} J, jump of "
          f"stored + eroded {jump:.2e} J; notch part: eroded {notch['eroded'][-1]:.4f}, internal "
          f"{notch['internal'][-1]:.1e}")
    assert eroded[-1] == pytest.approx(notch["eroded"][-1], rel=1e-9)
    assert notch["internal"][-1] == 0.0 and notch["kinetic"][-1] == 0.0
    assert abs(jump) <= JUMP_BOUND * eroded[k]
    # the reaction: its impulse after the erosion, over its peak x the time
    support = -force["support_x"]
    peak = float(np.max(support))
    after = t >= t[k] + 0.05
    mean_after = (force["support_impulse_x"][-1] - force["support_impulse_x"][after][0]) / (t[-1] - t[after][0])
    print(f"peak support force {peak:.3f} kN; mean after "
          f"the erosion {-mean_after:+.4f} kN = {abs(mean_after) / peak:.2%} of the peak")
    assert peak > 1.0
    assert abs(mean_after) <= REACTION_BOUND * peak
    # the balance, against the energy absorbed
    absorbed = stored + eroded + energy["contact"] + energy["wall"]
    ratio = np.abs(energy["balance_error"][1:]) / absorbed[1:]
    print(f"energy balance error <= {ratio.max():.2%} of the absorbed energy ({absorbed[-1]:.3f} J at the end)")
    assert ratio.max() <= BALANCE_BOUND
    # frames: readable, finite, the eroded flag on the notch only, from its erosion on
    frames = sorted((out / "frames").glob("*.vtu"))
    assert len(frames) == 4                   # t = 0 and the three output times
    flags = []
    for path in frames:
        mesh = meshio.read(path)
        assert np.isfinite(mesh.points).all()
        for name, blocks in mesh.cell_data.items():
            assert np.isfinite(blocks[0]).all(), (path.name, name)
        flags.append(mesh.cell_data["eroded"][0])
        if flags[-1].any():
            assert np.all(mesh.cell_data["membrane_force"][0][flags[-1] == 1] == 0.0)
    expected = np.zeros(40, np.int32)
    expected[NOTCH] = 1
    np.testing.assert_array_equal(flags[0], np.zeros(40))
    np.testing.assert_array_equal(flags[-1], expected)


def test_conventional_mass_scaling_closed_form_and_step(tmp_path):
    """A notch of E = 800 has half the steel's stable step; with the target between the two,
    only the notch takes mass, f = (target / dt_e)^2, and the step is the target: the run
    takes ceil(T / target) steps (against ceil(T / dt_e) without)."""
    target = 4.5e-4
    out = tmp_path / "out"
    proc = run_cli(strip_scene(tmp_path, notch_E=800.0, failure_strain=10.0, target_dt=target, limit=10.0,
                               end_time=0.1, times="[0.1]", history=0.0), out)
    assert proc.returncode == 0, proc.stderr[-2000:]
    summary = json.loads((out / "summary.json").read_text())
    dt_notch = element_step(800.0)
    m_e = RHO * 25.0 * 1.0
    expected = 2 * ((target / dt_notch) ** 2 - 1.0) * m_e
    added = {p["name"]: p["added_mass"] for p in summary["parts"] if "material" in p}
    frame = meshio.read(sorted((out / "frames").glob("*.vtu"))[-1])
    per_element = frame.cell_data["added_mass"][0]
    print(f"\nnotch step {dt_notch:.4e} ms, steel {element_step(200.0):.4e} ms, target {target:g}: added "
          f"{added['notch']:.6e} kg (closed form {expected:.6e}, {added['notch'] / expected - 1:+.1e}), "
          f"{summary['mass_scaling']['added_mass_percent']:.3f} % of the shell; {summary['steps']} steps")
    assert added["notch"] == pytest.approx(expected, rel=1e-12)
    assert added["left"] == added["right"] == 0.0
    assert np.count_nonzero(per_element) == 2 and per_element[NOTCH] == pytest.approx(expected / 2, rel=1e-12)
    assert summary["mass_scaling"]["added_mass_percent"] == pytest.approx(100 * expected / (40 * m_e), rel=1e-12)
    assert summary["steps"] == math.ceil(0.1 / target - 1e-9)


def test_mass_is_added_as_the_notch_shortens(tmp_path):
    """Pushed, the notch shortens plastically (every node held in its plane), its elements'
    step falls below a target just under the initial one, and mass is added step by step:
    parts.csv's added mass of the notch grows from 0, the others stay at 0, the kinetic
    energy given to it is booked (mass_scaling) and the balance closes."""
    out = tmp_path / "out"
    target = 0.98 * element_step(200.0)
    proc = run_cli(strip_scene(tmp_path, failure_strain=10.0, speed=-2.0, target_dt=target,
                               limit=50.0), out)
    assert proc.returncode == 0, proc.stderr[-2000:]
    parts, energy = table(out / "parts.csv"), table(out / "energy.csv")
    notch = parts["added_mass"][parts["part"] == "notch"]
    others = parts["added_mass"][parts["part"] != "notch"]
    absorbed = energy["internal"] + energy["hourglass"] + energy["drilling"] + energy["contact"] + energy["wall"]
    ratio = np.abs(energy["balance_error"][1:]) / absorbed[1:]
    grows = np.count_nonzero(np.diff(notch) > 0.0)
    print(f"\nnotch added mass 0 -> {notch[-1]:.3e} kg, rising over {grows} of {len(notch) - 1} record intervals; "
          f"mass scaling energy {energy['mass_scaling'][-1]:.3e} J; balance <= {ratio.max():.2e} of absorbed")
    assert notch[0] == 0.0 and notch[-1] > 0.0 and np.all(np.diff(notch) >= 0.0) and grows >= 100   # 174
    assert np.all(others == 0.0)
    assert energy["mass_scaling"][-1] > 0.0
    assert ratio.max() <= 5.6e-6                  # 1.5x measured (3.7e-6)


def test_added_mass_guard_stops_the_run(tmp_path):
    """The stiff notch needs 2.2 % of the shell's mass at t = 0: with a 1 % limit the run stops
    after its first step, one line, exit code 3."""
    target = 3.6e-4
    proc = run_cli(strip_scene(tmp_path, notch_E=800.0, failure_strain=10.0, target_dt=target, limit=1.0),
                   tmp_path / "out")
    lines = [line for line in proc.stderr.splitlines() if line.startswith("error")]
    percent = 100 * 2 * ((target / element_step(800.0)) ** 2 - 1.0) / 40
    print("\n" + "\n".join(lines))
    assert proc.returncode == 3
    assert len(lines) == 1 and "added_mass_limit" in lines[0] and f"{percent:.3g}%" in lines[0]
    assert "Traceback" not in proc.stderr


def test_eroded_elements_leave_the_nodes_and_the_grid(tmp_path):
    """The four elements around node 31 (x = 50, y = 5) marked eroded: after one step every
    free node's mass is the sum of its live elements' shares, node 31 has none, stands still
    and is not located on the grid (it no longer scatters to it), and the run stays finite."""
    scene = load_scene(strip_scene(tmp_path))
    sim = simulation(scene, tmp_path)
    s, model = sim.state, sim.model
    around = [9, 10, 29, 30]
    eroded = np.zeros(40, np.int32)
    eroded[around] = 1
    s.put("elements.eroded", eroded)
    sim.stepper.advance(1)
    mass = s.fetch("nodes.mass")
    live = np.where(eroded[:, None] == 1, 0.0, model.corner_mass)
    expected = np.zeros(len(mass))
    np.add.at(expected, model.elements, live)
    free = model.node_body < 0
    print(f"\nnode 31 mass {mass[31]:g}; free nodes' masses against the live shares: max difference "
          f"{np.abs(mass - expected)[free].max():.1e}")
    np.testing.assert_allclose(mass[free], expected[free], rtol=1e-14, atol=0.0)
    assert mass[31] == 0.0
    sim.stepper.advance(20)
    assert np.all(s.fetch("nodes.grid_velocity")[31] == 0.0)
    assert s.read(s.grid.on_grid, s.n_nodes)[31] == 0          # off the grid (stages/mapping.locate)
    assert sim.state_is_finite()


def test_eroded_elements_leave_the_contact_surface(tmp_path):
    """Grip node 62 moved 0.5 mm above the centre of element 0 (t_c = 1): the contact pairs it
    with element 0; once element 0 is eroded, and for a node without mass, there is no pair."""
    scene = load_scene(strip_scene(tmp_path))
    sim = simulation(scene, tmp_path)
    s = sim.state

    @ti.kernel
    def contact_forces():
        sim.stepper.contact.build_candidates()
        sim.stepper.contact.forces()

    def pair():
        s.contact.rebuild[None] = 1
        contact_forces()
        return int(s.contact.last_element[62]), s.fetch("contact.pair_force")[62]

    points = s.fetch("nodes.position")
    points[62] = [2.5, 2.5, 0.5]
    s.put("nodes.position", points)
    first, force = pair()
    s.put("elements.eroded", np.eye(1, 40, 0, dtype=np.int32)[0])
    after, _ = pair()
    s.put("elements.eroded", np.zeros(40, np.int32))
    mass = s.fetch("nodes.mass")
    mass[62] = 0.0
    s.put("nodes.mass", mass)
    massless, _ = pair()
    print(f"\npair {first} (force {force}), after erosion {after}, without mass {massless}")
    assert first == 0 and force[2] > 0.0
    assert after == -1 and massless == -1


def test_lsdyna_fail_and_tdel_become_erosion(tmp_path):
    """*MAT_003 FS and *MAT_024 FAIL -> failure_strain (one point), *MAT_024 TDEL ->
    failure_min_dt; a static solve with them is one line."""
    from taichi_shell_mpm.preflight import prepare
    from taichi_shell_mpm.scene import SceneError

    from .test_hardening import DECK
    deck = DECK.replace("40.4,5.0,0.0,0.0", "40.4,5.0,0.25,0.0").replace(
        "2,7.85e-9,2.1e5,0.3,250.0\n", "2,7.85e-9,2.1e5,0.3,250.0,,0.4,2e-7\n")
    (tmp_path / "deck.k").write_text(deck)
    text = '[scene]\nname = "deck"\nunits = "N-mm-s"\n[mesh]\nkind = "file"\npath = "deck.k"\n[solve]\nkind = "{}"\n{}'
    _, _, model = prepare(write_scene(tmp_path, text.format("dynamic", "end_time = 1.0\n")), [])
    kin, cur = model.materials.failure                  # failure strain, points, step
    assert model.materials.erosion
    assert tuple(kin) == (0.25, 1, 0.0) and tuple(cur) == (0.4, 1, 2e-7)
    with pytest.raises(SceneError) as err:
        prepare(write_scene(tmp_path, text.format("static", "[[load]]\nnodes = \"all\"\nforce = [0, 0, 1]\n")), [])
    assert err.value.messages == ["scene.toml: material 'mat_1': erosion (failure_strain, failure_min_dt; a deck's "
                                  'FAIL, TDEL) needs [solve].kind = "dynamic"']


def test_restart_through_mass_scaling_and_erosion_is_bit_for_bit(tmp_path, monkeypatch):
    """The pushed strip with a notch that fails at 10 % plastic strain: mass is added to it from
    ~0.13 ms (its elements shorten below the target step) and it erodes at ~0.25 ms; the run
    stopped at 0.83 ms and restarted (and restarted from its periodic checkpoint at 0.67 ms) is
    bit-for-bit the uninterrupted one, so the checkpoint carries the eroded elements, their
    energies and the added masses (tests/test_restart.py's round trip)."""
    from .test_restart import restart_roundtrip
    scene = strip_scene(tmp_path, failure_strain=0.1, speed=-2.0, target_dt=0.98 * element_step(200.0), limit=50.0)
    # 40 elements, 100-step batches; 1 800 steps to 1 ms
    restart_roundtrip(tmp_path, monkeypatch, [str(scene)], stop_step=1500, every=1200, batch_element_steps=4000)
    energy, parts = table(tmp_path / "a" / "energy.csv"), table(tmp_path / "a" / "parts.csv")
    notch = parts["added_mass"][parts["part"] == "notch"]
    eroded_at = energy["time"][np.argmax(energy["eroded"] > 0.0)]
    print(f"added mass from {parts['time'][parts['part'] == 'notch'][np.argmax(notch > 0.0)]:.3f} ms "
          f"({notch[-1]:.3e} kg at the end), eroded at {eroded_at:.3f} ms")
    assert notch[-1] > 0.0 and energy["eroded"][-1] > 0.0 and eroded_at < 0.6      # before both stops


# gravity along the strip (1 g) and a pressure on the notch (along z, which every node but the
# grip's holds): one compile for the two tests below
GRAVITY_PRESSURE = '[gravity]\nacceleration = [9.81e-3, 0.0, 0.0]\n[[pressure]]\nelements = "notch"\nvalue = 1e-3'
ERODES_AT_ONCE = "failure_min_dt = 1.0"      # above every element's step: it fails in step 1


def test_after_erosion_gravity_acts_on_the_mass_that_remains(tmp_path):
    """The strip free along x (clamp and plane hold uz only, the grip at rest) falls along x
    under gravity; the notch erodes in step 1 (failure_min_dt).  Its corner nodes (x = 45, 50)
    keep only the left and right elements' shares, and gravity acts on that physical mass: every
    free node, and the grip, falls at g (with the notch's shares still weighed, those nodes
    were pulled at up to (m + m_notch)/m g).  The pressure on the notch acts in step 1 (its
    forces are computed before the element pass erodes it) and never after."""
    g = 9.81e-3
    scene = load_scene(strip_scene(tmp_path, clamp_fix='["uz"]', speed=0.0, weak_failure=ERODES_AT_ONCE,
                                   extra=GRAVITY_PRESSURE))
    sim = simulation(scene, tmp_path)
    s, model = sim.state, sim.model
    s.step.load_factor[None] = 1.0        # dead loads in full, as solvers/dynamic.run_dynamic sets them
    sim.stepper.advance(1)
    eroded = s.fetch("elements.eroded")
    first = np.abs(s.read(s.nodes.pressure_force, s.n_nodes)).max()
    sim.stepper.advance(60)
    after = np.abs(s.read(s.nodes.pressure_force, s.n_nodes)).max()
    free = model.node_body < 0
    mass, physical = s.fetch("nodes.mass"), s.fetch("nodes.physical_mass")
    v = s.fetch("nodes.grid_velocity")[:, 0]
    t = s.step.time[None]
    fall = g * t          # v^(n+1/2) = sum of the kicks g dt (the first one full: stages/timestep.impulse_time)
    spread = np.abs(v[free] / fall - 1.0).max()
    grip = float(s.read(s.bodies.velocity, 1)[0][0]) / fall - 1.0
    e = sim.energies()
    print(f"\neroded {np.flatnonzero(eroded).tolist()}; pressure force max {first:.3e} in step 1, {after:.1e} after; "
          f"at t = {t:.4f}: free nodes' v_x / (g t) - 1 within {spread:.1e}, grip {grip:+.1e}; "
          f"physical vs nodal mass {np.abs(physical - mass)[free].max():.1e}; balance error "
          f"{e['balance_error']:.2e} of work {e['external_work']:.3e}")
    np.testing.assert_array_equal(np.flatnonzero(eroded), NOTCH)
    assert first > 0.0 and after == 0.0
    np.testing.assert_allclose(physical[free], mass[free], rtol=1e-14, atol=0.0)     # no mass was added
    assert spread < 1e-9 and abs(grip) < 1e-9
    assert abs(e["balance_error"]) <= 1e-6 * e["external_work"]


def test_every_element_eroding_in_the_first_step_ends_cleanly(tmp_path):
    """Every element fails in step 1 (failure_min_dt on both materials): the eroded energy is
    what the nodes did work on them (their step-1 stress power less the forces they never
    wrote: ~0), no false "energy created" stop, exit 0 with all 40 eroded."""
    out = tmp_path / "out"
    proc = run_cli(strip_scene(tmp_path, steel_failure=ERODES_AT_ONCE, weak_failure=ERODES_AT_ONCE,
                               extra=GRAVITY_PRESSURE, times="[1.0]"), out)
    print("\n" + proc.stderr[-1500:])
    assert proc.returncode == 0, proc.stderr[-2000:]
    summary = json.loads((out / "summary.json").read_text())
    e = summary["energies"]
    print(f"eroded {summary['erosion']['eroded_elements']}, {summary['steps']} steps; eroded energy {e['eroded']:.2e}, "
          f"balance error {e['balance_error']:.2e}, kinetic {e['kinetic']:.4f}; warnings {summary['warnings']}")
    assert summary["erosion"]["eroded_elements"] == 40
    assert abs(e["balance_error"]) <= 1e-9 * e["kinetic"]
    assert not any("energy" in w for w in summary["warnings"])
