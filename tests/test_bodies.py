"""Point masses and 6-DOF rigid bodies (issue 18 item 5), through the CLI against closed forms.

Every run is a small explicit-FE (``fem``) plate or strip, so a few kernel configurations
serve all the tests.
"""
from __future__ import annotations

import json
import math

import meshio
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from .test_reliability import assert_clean_output, cli_run

PLATE = """
[scene]
name = "{name}"
units = "consistent"
[mesh]
kind = "plate"
lx = {lx}
ly = {ly}
nx = {nx}
ny = {ny}
[material]
E = {E}
nu = 0.0
density = 1.0
[section]
thickness = {t}
{section}
[method]
kind = "fem"
{body}
[solve]
kind = "dynamic"
end_time = {end}
[output]
history_interval = {interval}
"""

# a wall moving with the body, which touches nothing (the body is the whole mesh): so that
# the tests of bodies without walls share their kernels with those with (a compile each, 30-60 s)
SHARED_WALL = '[[wall]]\npoint = [0.0, 0.0, -10.0]\nnormal = [0.0, 0.0, 1.0]\nmoves_with = "{body}"\n'

# the free body: J (xx yy zz xy yz zx), spin about no principal axis
INERTIA = (1.0, 2.0, 3.0, 0.3, -0.2, 0.1)
SPIN = np.array([1.0, 0.5, 2.0])
VELOCITY = np.array([0.1, 0.0, 0.2])
FREE_BODY = f"""
[nodesets.corner]
nearest = [1.0, 1.0, 0.0]
[[rigid_body]]
name = "top"
nodes = "all"
mass = 2.0
inertia = {list(INERTIA)}
mass_from_nodes = false
velocity = {VELOCITY.tolist()}
spin = {SPIN.tolist()}
{SHARED_WALL.format(body="top")}
[[probe]]
name = "corner"
nodes = "corner"
components = ["ux", "uy", "uz"]
"""


def run_scene(tmp_path, text: str, name: str = "case", *extra: str):
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    out = tmp_path / f"out_{name}"
    r = cli_run("run", str(path), "--out", str(out), "--quiet", *extra, timeout=300)
    assert_clean_output(r)
    assert r.code == 0, r.out + r.err
    return out, json.loads((out / "summary.json").read_text())


def table(path):
    return np.genfromtxt(path, delimiter=",", names=True)


def tensor(entries):
    xx, yy, zz, xy, yz, zx = entries
    return np.array([[xx, xy, zx], [xy, yy, yz], [zx, yz, zz]])


def free_rotation(j: np.ndarray, spin: np.ndarray, t: float) -> Rotation:
    """Euler's equations of the free body (body frame Pi' = Pi x J^-1 Pi, R' = R Omega^),
    integrated to 1e-13."""
    j_inv = np.linalg.inv(j)

    def rhs(_, y):
        r, pi = y[:9].reshape(3, 3), y[9:]
        omega = j_inv @ pi
        hat = np.array([[0, -omega[2], omega[1]], [omega[2], 0, -omega[0]], [-omega[1], omega[0], 0]])
        return np.concatenate([(r @ hat).ravel(), np.cross(pi, omega)])

    y = solve_ivp(rhs, (0.0, t), np.concatenate([np.eye(3).ravel(), j @ spin]), method="DOP853",
                  rtol=1e-13, atol=1e-13).y[:, -1]
    return Rotation.from_matrix(y[:9].reshape(3, 3))


def test_free_body_tumbling_keeps_energy_and_angular_momentum(tmp_path):
    """A free rigid body spinning about a non-principal axis for 10 000 steps (the issue: energy
    and angular momentum to 1e-6): the Simo-Wong drift keeps both to round-off.  Its centre
    moves at V0 exactly, its orientation follows Euler's equations (a converged solution) to
    the scheme's second-order error, and the slave nodes sit at x_c + R (X - X_c)."""
    dt_expected = 0.0142                 # the 2x2 plate's stable step (E = 500, rho = 1, L = 0.5)
    end = 10_050 * dt_expected
    out, summary = run_scene(tmp_path, PLATE.format(name="free_body", lx=1.0, ly=1.0, nx=2, ny=2, E=500.0, t=0.05, section="",
                                                    body=FREE_BODY, end=end, interval=end / 20))
    steps = summary["steps"]
    force, energy = table(out / "force.csv"), table(out / "energy.csv")
    kinetic = force["topkinetic"]
    momentum = np.stack([force[f"topangular_momentum_{c}"] for c in "xyz"], axis=1)
    j = tensor(INERTIA)
    k0 = 0.5 * 2.0 * VELOCITY @ VELOCITY + 0.5 * SPIN @ j @ SPIN
    l0 = j @ SPIN
    energy_error = float(np.abs(kinetic / k0 - 1.0).max())          # over time, to the CSV's 10 digits
    momentum_error = float(np.linalg.norm(momentum - l0, axis=1).max() / np.linalg.norm(l0))
    body = summary["rigid_bodies"][0]                                 # at the end, every digit
    energy_end = abs(body["kinetic_energy"] / k0 - 1.0)
    momentum_end = float(np.linalg.norm(np.array(body["angular_momentum"]) - l0) / np.linalg.norm(l0))
    balance = float(np.abs(energy["balance_error"]).max() / k0)
    # the orientation against Euler's equations, the centre against V0 t
    final = Rotation.from_rotvec([force[f"topr{c}"][-1] for c in "xyz"])
    reference = free_rotation(j, SPIN, end)
    orientation_error = float((final * reference.inv()).magnitude())
    centre_error = float(np.abs(np.array([force[f"topu{c}"][-1] for c in "xyz"]) - VELOCITY * end).max())
    # the probed corner node (X = (1, 1, 0), centre (0.5, 0.5, 0)) where the pose puts it
    probes = table(out / "probes.csv")
    offset = np.array([0.5, 0.5, 0.0])
    placed = VELOCITY * end + final.apply(offset) - offset
    slave_error = float(np.abs(np.array([probes[f"corneru{c}"][-1] for c in "xyz"]) - placed).max())
    omega_end = np.linalg.solve(final.as_matrix() @ j @ final.as_matrix().T, l0)
    turned = float(np.degrees(np.arccos(omega_end @ SPIN / np.linalg.norm(omega_end) / np.linalg.norm(SPIN))))
    print(f"\n{steps} steps, {end * np.linalg.norm(SPIN) / (2 * math.pi):.0f} turns: kinetic energy {energy_error:.2e} "
          f"(end: {energy_end:.2e}), angular momentum {momentum_error:.2e} (end: {momentum_end:.2e}), balance {balance:.2e} of the energy; orientation vs Euler's "
          f"equations {orientation_error:.2e} rad; centre {centre_error:.2e}; slave node {slave_error:.2e}; "
          f"the angular velocity turned {turned:.1f} deg in space")
    assert steps >= 10_000
    off_axis = float(np.degrees(np.arccos(l0 @ SPIN / np.linalg.norm(l0) / np.linalg.norm(SPIN))))
    assert off_axis > 10.0 and turned > 1.0      # a non-principal axis (L not along omega): omega moves
    assert energy_error < 1e-6 and momentum_error < 1e-6        # the bound
    # round-off over 10 000 steps (measured 6.9e-13, 3.5e-13, 6.9e-13)
    assert energy_end < 2e-12 and momentum_end < 2e-12
    assert balance < 2e-12
    assert orientation_error < 1.5 * 8.3e-3      # measured 8.25e-3 rad after 52 turns (second order)
    assert centre_error < 1e-10 and slave_error < 1e-8          # the CSVs' 10 digits


FLYWHEEL = f"""
[nodesets.corner]
nearest = [1.0, 1.0, 0.0]
[[rigid_body]]
name = "wheel"
nodes = "all"
mass = 2.0
inertia = {list(INERTIA)}
mass_from_nodes = false
fixed = ["ux", "uy", "uz", "rx", "ry"]
""" + SHARED_WALL.format(body="wheel") + """
[[load]]
nodes = "corner"
force = [0.2, -0.1, 0.3]
moment = [0.5, 0.3, 0.6]
"""


def test_body_with_held_rotations_turns_about_its_free_axis(tmp_path):
    """A body held but for the rotation about z, loaded at a node by a force and a moment:
    only M_z = 0.6 + (r x f)_z turns it, L_z = M_z t, theta = M_z t (t + dt) / (2 I_zz) (the
    central difference of a constant acceleration whose first kick is a whole step; I_zz = 3:
    about its one free axis the inertia does not change), at the first output, before the
    dead force's arm has turned by 3e-3 rad; the centre stays put, the held
    rotations stay 0, the kinetic energy is L_z^2 / (2 I_zz), and the load's work is it."""
    end, first = 2.0, 0.2
    out, summary = run_scene(tmp_path, PLATE.format(name="flywheel", lx=1.0, ly=1.0, nx=2, ny=2, E=500.0, t=0.05, section="",
                                                    body=FLYWHEEL, end=end, interval=first))
    force, energy = table(out / "force.csv"), table(out / "energy.csv")
    dt = end / summary["steps"]                    # constant: the body does not deform
    r = np.array([0.5, 0.5, 0.0])                  # the corner from the centre
    m_z = 0.6 + np.cross(r, [0.2, -0.1, 0.3])[2]
    momentum = abs(force["wheelangular_momentum_z"][1] / (m_z * first) - 1.0)
    theta = abs(force["wheelrz"][1] / (m_z * first * (first + dt) / 6.0) - 1.0)
    held = max(float(np.abs(force[f"wheel{c}"]).max()) for c in ("ux", "uy", "uz", "rx", "ry"))
    kinetic = force["wheelkinetic"]
    body = summary["rigid_bodies"][0]             # every digit
    inertia = abs(body["kinetic_energy"] / (body["angular_momentum"][2] ** 2 / 6.0) - 1.0)
    balance = float(np.abs(energy["balance_error"]).max()) / kinetic[-1]
    work = abs(energy["external_work"][-1] / energy["kinetic"][-1] - 1.0)
    print(f"\nat t = {first} ({round(first / dt)} steps): L_z vs M_z t {momentum:.1e}, theta vs M_z t (t + dt) / (2 I_zz) "
          f"{theta:.1e}; held DOFs max {held:.1e}; turned {force['wheelrz'][-1]:.3f} rad by t = {end}: "
          f"KE vs L_z^2 / (2 I_zz) {inertia:.1e}, load work / KE - 1 = {work:.1e}, balance {balance:.1e} of the KE")
    assert momentum < 1.7e-4 and theta < 9e-5      # measured 1.1e-4 and 5.9e-5: the arm turns
    assert held < 1e-12
    assert inertia < 1e-12 and work < 1e-12 and balance < 1e-12


RAM = """[[rigid_body]]
name = "ram"
nodes = "anchor"
mass = {mass}
direction = [0, -1, 0]"""


def pushed_plate_with_spinner(tmp_path, name: str, body: str, spinner: str) -> tuple:
    """test_energy's plate pushed by a wall moving with a ram (fem), with a separate quad far
    away (y = -2, on the wall's side), `spinner` its [[rigid_body]] block or none (then it lies still)."""
    return run_scene(tmp_path, pushed_spinner_text(tmp_path, body, spinner), name)


def pushed_spinner_text(tmp_path, body: str, spinner: str, method: str = "fem") -> str:
    """The scene of :func:`pushed_plate_with_spinner` (its mesh written to tmp_path)."""
    import meshio

    from .test_energy import PUSHED
    xs = np.linspace(0.0, 1.0, 5)
    points = [[x, y, 0.0] for y in xs for x in xs]
    quads = [[j * 5 + i, j * 5 + i + 1, j * 5 + i + 6, j * 5 + i + 5] for j in range(4) for i in range(4)]
    for y in (2.0, -2.0):
        base = len(points)
        points += [[0.4, y, 0.0], [0.6, y, 0.0], [0.6, y + 0.2, 0.0], [0.4, y + 0.2, 0.0]]
        quads.append([base, base + 1, base + 2, base + 3])
    meshio.write(tmp_path / "pushed.vtu", meshio.Mesh(np.array(points), [("quad", np.array(quads))]))
    text = PUSHED.format(method=method, method_extra="", mass=1.0e3, velocity=-0.02, end=0.1, interval=0.005)
    return text.replace(RAM.format(mass=1.0e3), body) + "[nodesets.far]\nbox = {min = [0, -2.1, -1], max = [1, -1.7, 1]}\n" \
        + spinner


SIX_DOF_RAM = 'name = "ram"\nnodes = "anchor"\nmass = 1000.0\nfixed = ["ux", "uz", "rx", "ry", "rz"]'
SPINNER = '[[rigid_body]]\nname = "spinner"\nnodes = "far"\nmass = 1.0\ninertia = [0.1, 0.2, 0.3]\nspin = [0.5, 0.0, 2.0]\n'


def test_ram_is_the_translation_only_special_case(tmp_path):
    """The ram of the tube ([[rigid_body]] with `direction`) is a 6-DOF body with the other DOFs
    held: written so, the pushed plate of test_energy gives the same bits (the same compiled
    code: no body rotates); and with another body spinning in the scene, so that the rotation
    is compiled and the ram's slaves are placed by x_c + R (X - X_c), the same to round-off."""
    out_a, _ = pushed_plate_with_spinner(tmp_path, "ram", RAM.format(mass=1000.0), "")
    out_b, _ = pushed_plate_with_spinner(tmp_path, "six", "[[rigid_body]]\n" + SIX_DOF_RAM, "")
    out_c, _ = pushed_plate_with_spinner(tmp_path, "spin", "[[rigid_body]]\n" + SIX_DOF_RAM, SPINNER)
    ea, eb, ec = (table(o / "energy.csv") for o in (out_a, out_b, out_c))
    fa, fb, fc = (table(o / "force.csv") for o in (out_a, out_b, out_c))
    same_bits = (out_a / "energy.csv").read_bytes() == (out_b / "energy.csv").read_bytes()
    columns = np.array_equal(fa["ramdisplacement"], -fb["ramuy"]) and np.array_equal(fa["ramforce"], -fb["ramforce_y"])
    pushed = float(np.abs(fa["ramdisplacement"]).max())
    displacement = float(np.abs(fa["ramdisplacement"] + fc["ramuy"]).max()) / pushed
    wall = float(np.abs(ea["wall"] - ec["wall"]).max() / np.abs(ea["wall"]).max())
    internal = float(np.abs(ea["internal"] - ec["internal"]).max() / ea["internal"].max())
    spin = (out_c / "summary.json").read_text()
    print(f"\nram vs 6-DOF body holding 5 DOFs: energy.csv byte-identical {same_bits}, columns equal {columns}; "
          f"with a spinning body beside it: ram displacement {displacement:.1e}, wall energy {wall:.1e}, plate internal "
          f"energy {internal:.1e} (relative)")
    assert same_bits and columns
    assert "spinner" in spin and np.abs(fc["spinnerrz"]).max() > 0.1
    assert displacement < 1e-9 and wall < 1e-9 and internal < 1e-9


def test_spinning_body_beside_a_pushed_plate_in_mpm_restarts_bit_for_bit(tmp_path, monkeypatch):
    """In mpm mode (the plate's free nodes on the grid, the bodies' slaves off it): the pushed
    plate with the 6-DOF ram and a body tumbling freely beside it, stopped and restarted (and
    restarted from its periodic checkpoint), is bit-for-bit the uninterrupted run, so the
    checkpoint carries the bodies' rotations and angular momenta (tests/test_restart.py's
    round trip); the tumbling body keeps its angular momentum and kinetic energy (Simo-Wong,
    as test_free_body_tumbling...) and the wall pushes the plate."""
    from .test_restart import restart_roundtrip
    scene = tmp_path / "spin.toml"
    scene.write_text(pushed_spinner_text(tmp_path, "[[rigid_body]]\n" + SIX_DOF_RAM, SPINNER, method="mpm"))
    # 18 elements, 20-step batches; 140 steps
    restart_roundtrip(tmp_path, monkeypatch, [str(scene)], stop_step=100, every=50, batch_element_steps=360)
    force, energy = table(tmp_path / "a" / "force.csv"), table(tmp_path / "a" / "energy.csv")
    momentum = np.stack([force[f"spinnerangular_momentum_{c}"] for c in "xyz"], axis=1)
    l_drift = float(np.abs(momentum - momentum[0]).max() / np.linalg.norm(momentum[0]))
    ke_drift = float(np.abs(force["spinnerkinetic"] / force["spinnerkinetic"][0] - 1.0).max())
    print(f"\nspinner turned {np.abs(force['spinnerrz']).max():.3f} rad: L drift {l_drift:.1e}, KE drift {ke_drift:.1e}; "
          f"ram pushed {np.abs(force['ramuy']).max():.2e}, plate internal energy {energy['internal'][-1]:.3e}")
    assert np.abs(force["spinnerrz"]).max() > 0.1 and energy["internal"][-1] > 0.0
    assert l_drift < 1e-12 and ke_drift < 1e-12


TIP_MASS = """
[nodesets.clamp]
plane = {{ point = [0.0, 0.0, 0.0], normal = [1.0, 0.0, 0.0] }}
[nodesets.tip]
plane = {{ point = [{L}, 0.0, 0.0], normal = [1.0, 0.0, 0.0] }}
[[boundary]]
nodes = "clamp"
fix = "all"
[[point_mass]]
name = "weight"
nodes = "tip"
total_mass = {M}
[[initial]]
nodes = "tip"
velocity = [0.0, 0.0, {v0}]
[[probe]]
name = "tip"
nodes = "tip"
components = ["uz"]
"""


TIP_LENGTH, TIP_E, TIP_T, TIP_M = 10.0, 1.2e6, 0.1, 10.0


def tip_mass_period():
    """The closed form T = 2 pi sqrt((M + 33/140 m) L^3 / (3 EI)) of the tip-mass cantilever."""
    beam = TIP_LENGTH * 1.0 * TIP_T                 # rho = 1
    ei = TIP_E * TIP_T ** 3 / 12.0
    return 2.0 * math.pi * math.sqrt((TIP_M + 33.0 / 140.0 * beam) * TIP_LENGTH ** 3 / (3.0 * ei))


def run_tip_mass(tmp_path, name: str, material: str = "", solve: str = ""):
    """The tip-mass cantilever (with `material` and `solve` keys added): its measured period
    (mean of the upward zero crossings of the tip, interpolated), the crossings and summary.json."""
    period = tip_mass_period()
    text = PLATE.format(name=name, lx=TIP_LENGTH, ly=1.0, nx=10, ny=1, E=TIP_E, t=TIP_T,
                        section='points = 3\nrule = "lobatto"', body=TIP_MASS.format(L=TIP_LENGTH, M=TIP_M, v0=1e-3),
                        end=2.2 * period, interval=period / 400)
    text = text.replace("density = 1.0\n", "density = 1.0\n" + material).replace(
        'kind = "dynamic"\n', 'kind = "dynamic"\n' + solve)
    out, summary = run_scene(tmp_path, text, name)
    probes = table(out / "probes.csv")
    t, w = probes["time"], probes["tipuz"]
    up = np.nonzero((w[:-1] < 0.0) & (w[1:] >= 0.0))[0]          # upward zero crossings, interpolated
    crossings = t[up] - w[up] * (t[up + 1] - t[up]) / (w[up + 1] - w[up])
    return float(np.diff(crossings).mean()), crossings, summary


def test_tip_point_mass_sets_the_cantilever_frequency(tmp_path):
    """A point mass M = 10 m (m: the strip's mass) at the tip of a cantilever strip (L = 10,
    b = 1, t = 0.1, E = 1.2e6, rho = 1), struck so that it swings: the period of its
    fundamental mode against the closed form T = 2 pi sqrt((M + 33/140 m) L^3 / (3 EI))
    (Rayleigh's mass of the beam, exact to 0.01 % at M = 10 m): -1.1e-3, the 10 x 1 mesh's
    stiffness; without the point mass the period would be sqrt(10.24 / 0.24) = 6.5 x shorter.
    Its kinetic energy is its own parts.csv row."""
    mass, period = TIP_M, tip_mass_period()
    measured, crossings, summary = run_tip_mass(tmp_path, "tip_mass")
    error = measured / period - 1.0
    parts = {p["name"]: p for p in summary["parts"]}
    point = parts["point_mass:weight"]
    print(f"\nperiod {measured:.5f} vs closed form {period:.5f}: {error:+.2e} ({len(crossings)} crossings, "
          f"{summary['steps']} steps); point mass row: mass {point['mass']:.3g}, kinetic {point['energies']['kinetic']:.3e}")
    assert len(crossings) >= 2
    assert abs(error) < 1.5 * 1.2e-3        # measured -1.1e-3 (the 10 x 1 mesh)
    assert point["mass"] == pytest.approx(mass)


def test_tip_point_mass_stays_with_erosion_and_mass_scaling(tmp_path):
    """The tip-mass cantilever with erosion and conventional mass scaling compiled in (issue 28
    item 1: the per-step mass rebuild took the elements' shares only, so the point mass was
    gone after step 1, and the period 6.5 x shorter): J2 with a failure strain it never reaches
    and a target step below every element's (nothing added).  Its period, the point mass's
    row and the kinetic energy are those of the plain run."""
    plain, _, base = run_tip_mass(tmp_path, "plain")
    both, crossings, summary = run_tip_mass(
        tmp_path, "eroding", material='model = "j2"\nyield_stress = 1e9\nfailure_strain = 1.0\n',
        solve='mass_scaling = "conventional"\ntarget_dt = 1e-9\n')
    parts = {p["name"]: p for p in summary["parts"]}
    point, kinetic = parts["point_mass:weight"], summary["energies"]["kinetic"]
    print(f"\nperiod {both:.6f} against the plain run's {plain:.6f}: {both / plain - 1.0:+.1e} "
          f"({len(crossings)} crossings); kinetic energy {kinetic:.6e} against {base['energies']['kinetic']:.6e}; "
          f"point mass row {point['mass']:g}, eroded {summary['erosion']['eroded_elements']}, added "
          f"{summary['mass_scaling']['added_mass']:g}; balance error {summary['energies']['balance_error']:.1e}")
    assert summary["erosion"]["eroded_elements"] == 0 and summary["mass_scaling"]["added_mass"] == 0.0
    assert point["mass"] == pytest.approx(TIP_M)
    assert abs(both / plain - 1.0) < 1e-6
    assert kinetic == pytest.approx(base["energies"]["kinetic"], rel=1e-6)
    assert point["energies"]["kinetic"] == pytest.approx(
        {p["name"]: p for p in base["parts"]}["point_mass:weight"]["energies"]["kinetic"], rel=1e-6)


@pytest.mark.parametrize("block, message", [
    ('[[rigid_body]]\nname = "b"\nnodes = "all"\nmass = 1.0\ndirection = [0, 0, 1]\nspin = [0, 0, 1]',
     "[[rigid_body]][0].spin: a body with a direction translates along it only"),
    ('[[rigid_body]]\nname = "b"\nnodes = "all"\nmass_from_nodes = false\nmass = 0.0',
     "[[rigid_body]][0].mass: must be > 0 with mass_from_nodes = false"),
    ('[[rigid_body]]\nname = "b"\nnodes = "all"\nmass_from_nodes = false\nmass = 1.0',
     "[[rigid_body]] 'b': the inertia about its free rotation axes is singular: give inertia"),
    ('[[rigid_body]]\nname = "b"\nnodes = "all"\ninertia = [1.0, 1.0, 1.0, 2.0, 0.0, 0.0]',
     "[[rigid_body]][0].inertia: not positive semi-definite"),
    ('[[rigid_body]]\nname = "b"\nnodes = "all"\nmass_from_nodes = false\nmass = 2.0\ninertia = [1e-30, 1e-30, 1e-30]',
     "[[rigid_body]] 'b': inertia: 1e-30 about a free axis is near-singular"),
    ('[[rigid_body]]\nname = "b"\nnodes = "all"\ncenter = [0.0, 0.0, 0.0]\nfixed = ["ux"]',
     "[[rigid_body]] 'b': center: [0, 0, 0] is not its mass centre [0.5, 0.5, 0]"),
    ('[nodesets.edge]\nplane = { point = [1.0, 0.0, 0.0], normal = [1.0, 0.0, 0.0] }\n[[rigid_body]]\nname = "b"\n'
     'nodes = "edge"\nmass_from_nodes = false\nmass = 1e-12\ninertia = [1.0, 1.0, 1.0]',
     "[[rigid_body]] 'b': mass, inertia: far too small for the elements it carries"),
    ('[[rigid_body]]\nname = "b"\ncenter = [0.0, 0.0, -1.0]\ndirection = [0, 0, 1]',
     "[[rigid_body]][0].mass: a body without nodes needs mass > 0"),
    ('[[rigid_body]]\nname = "b"\nmass = 1.0\ndirection = [0, 0, 1]',
     "[[rigid_body]][0].center: a body without nodes needs its center"),
    ('[[rigid_body]]\nname = "b"\nmass = 1.0\ncenter = [0.0, 0.0, -1.0]',
     "[[rigid_body]] 'b': the inertia about its free rotation axes is singular: give inertia"),
    ('[[point_mass]]\nname = "p"\nnodes = "all"\nmass = 1.0\ntotal_mass = 2.0',
     "[[point_mass]][0].mass: give one of mass (each node's) or total_mass"),
    ('[[point_mass]]\nname = "p"\nnodes = "nowhere"\nmass = 1.0', "[[point_mass]][0].nodes"),
    ('[[rigid_body]]\nname = "b"\nnodes = "all"\nmass = 1.0\ninertia = [1.0, 1.0, 1.0]\n[[motion]]\nname = "m"\n'
     'body = "b"\ndofs = ["ry"]\nkind = "velocity"\nvalue = 1.0',
     "[[motion]] 'm': a body's prescribed rotation needs its other rotations fixed or prescribed too"),
    ('[[rigid_body]]\nname = "b"\nnodes = "all"\nmass = 1.0\ndirection = [0, 0, 1]\n[[motion]]\nname = "m"\n'
     'body = "b"\ndofs = ["uz"]\nkind = "velocity"\nvalue = 1.0',
     "[[motion]][0].body: the [[rigid_body]] 'b' translates along its direction only"),
])
def test_body_and_point_mass_input_errors(tmp_path, block, message):
    """Bad bodies and point masses: one line naming the key, exit code 2."""
    path = tmp_path / "bad.toml"
    path.write_text(PLATE.format(name="bad", lx=1.0, ly=1.0, nx=2, ny=2, E=500.0, t=0.05, section="", body=block,
                                 end=0.1, interval=0.1))
    r = cli_run("run", str(path), "--out", str(tmp_path / "out"), "--quiet")
    assert_clean_output(r)
    print(f"\n{r.err.strip()}")
    assert r.code == 2 and len(r.err.strip().splitlines()) == 1 and message in r.err


DRIVEN = """
[nodesets.clamp]
plane = { point = [0.0, 0.0, 0.0], normal = [1.0, 0.0, 0.0] }
[nodesets.tip]
plane = { point = [4.0, 0.0, 0.0], normal = [1.0, 0.0, 0.0] }
[[boundary]]
nodes = "clamp"
fix = "all"
[[rigid_body]]
name = "grip"
nodes = "tip"
mass = 0.5
inertia = [0.1, 0.1, 0.1]
fixed = ["rx", "rz"]
[curves.wave]
points = [[0.0, 0.0], [0.13, 1.0], [0.31, -0.5], [0.5, 0.0]]
[[motion]]
name = "lift"
body = "grip"
dofs = ["uz", "ry"]
kind = "velocity"
value = [0.4, -0.3]
curve = "wave"
"""


def test_body_driven_by_a_velocity_curve_follows_it(tmp_path):
    """A [[motion]] of a body: the tip of a strip gripped by a 6-DOF body whose uz and ry follow
    value x a velocity curve with corners between outputs: its displacement and rotation are
    value x the curve's integral to round-off, its free DOFs (ux, uy) move as the strip pulls
    them, and the work of the motion (its reaction's, force.csv/summary.json) balances the
    strip's and the body's energy."""
    out, summary = run_scene(tmp_path, PLATE.format(name="driven", lx=4.0, ly=1.0, nx=4, ny=1, E=1.0e4, t=0.1,
                                                    section="", body=DRIVEN, end=0.5, interval=0.05), "driven")
    force, energy = table(out / "force.csv"), table(out / "energy.csv")
    t = force["time"]
    knots = np.array([[0.0, 0.0], [0.13, 1.0], [0.31, -0.5], [0.5, 0.0]])
    fine = np.linspace(0.0, 0.5, 500_001)
    integral = np.interp(t, fine, np.concatenate([[0.0], np.cumsum(np.diff(fine) * 0.5 * (
        np.interp(fine[1:], *knots.T) + np.interp(fine[:-1], *knots.T)))]))
    uz = float(np.abs(force["gripuz"] - 0.4 * integral).max())
    ry = float(np.abs(force["gripry"] + 0.3 * integral).max())
    held = float(max(np.abs(force["griprx"]).max(), np.abs(force["griprz"]).max()))
    work = energy["motion_work"][-1]
    balance = float(np.abs(energy["balance_error"]).max() / np.abs(energy["motion_work"]).max())
    motion = summary["motions"][0]
    print(f"\nuz vs 0.4 F(t): {uz:.1e}, ry vs -0.3 F(t): {ry:.1e} (peak {0.4 * integral.max():.4f}); held rx, rz "
          f"{held:.1e}; free ux {force['gripux'][-1]:.2e}; motion work {work:.4e} (reaction uz {motion['reaction']['uz']:.3e}), "
          f"balance {balance:.1e} of it")
    assert motion["body"] == "grip"
    assert uz < 1e-9 and ry < 1e-9              # the CSV's 10 digits and the integral's 1e-12
    assert held < 1e-12
    assert balance < 2e-6                       # measured 1.2e-6


STRUCK = """
[scene]
name = "struck"
units = "consistent"
[mesh]
kind = "file"
path = "struck.vtu"
[material]
E = 1.0e4
nu = 0.3
density = 1.0
[section]
thickness = 0.05
[method]
kind = "fem"
[nodesets.striker]
box = {{ min = [0.55, 0.35, 0.4], max = [0.85, 0.65, 0.6] }}
[[rigid_body]]
name = "striker"
nodes = "striker"
mass = 0.5
inertia = [0.01, 0.01, 0.01]
velocity = [0.0, 0.0, -1.0]
[[wall]]
point = [0.7, 0.5, 0.3]
normal = {normal}
moves_with = "striker"
[solve]
kind = "dynamic"
end_time = 0.25
[output]
times = [0.25]
history_interval = 0.01
"""


def test_plate_struck_by_a_rigid_body_keeps_momentum_and_energy(tmp_path):
    """A free plate (1 x 1, t = 0.05, mass 0.05) struck by a 6-DOF body ten times heavier through
    a tilted wall moving with it (the impact of a rigid tool; the tools of issue 18 item 6 load
    a body the same way): the total linear momentum of plate and body is kept to round-off,
    the energy balance closes (the inelastic wall's loss in its column), and the off-centre
    impulses set the body spinning."""
    import meshio

    from taichi_shell_mpm.mesh import build_mesh
    from taichi_shell_mpm.model.assembly import assemble
    from taichi_shell_mpm.scene import load_scene
    xs = np.linspace(0.0, 1.0, 5)
    points = [[x, y, 0.0] for y in xs for x in xs]
    quads = [[j * 5 + i, j * 5 + i + 1, j * 5 + i + 6, j * 5 + i + 5] for j in range(4) for i in range(4)]
    points += [[0.6, 0.4, 0.5], [0.8, 0.4, 0.5], [0.8, 0.6, 0.5], [0.6, 0.6, 0.5]]
    quads.append([25, 26, 27, 28])
    meshio.write(tmp_path / "struck.vtu", meshio.Mesh(np.array(points), [("quad", np.array(quads))]))
    normal = np.array([0.3, 0.0, -1.0]) / np.linalg.norm([0.3, 0.0, -1.0])
    path = tmp_path / "struck.toml"
    path.write_text(STRUCK.format(normal=normal.tolist()))
    out, summary = run_scene(tmp_path, path.read_text(), "struck")
    scene = load_scene(path)
    model = assemble(scene, build_mesh(scene.mesh))
    frame = sorted((out / "frames").glob("*.vtu"))[-1]
    v = meshio.read(frame).point_data["velocity"]
    free = model.node_body < 0
    body = summary["rigid_bodies"][0]
    momentum = (model.node_mass[free, None] * v[free]).sum(axis=0) + body["mass"] * np.array(body["velocity"])
    p0 = body["mass"] * np.array([0.0, 0.0, -1.0])
    momentum_error = float(np.linalg.norm(momentum - p0) / np.linalg.norm(p0))
    energy = table(out / "energy.csv")
    k0 = energy["kinetic"][0]
    balance = float(np.abs(energy["balance_error"]).max() / k0)
    plate = float(np.linalg.norm((model.node_mass[free, None] * v[free]).sum(axis=0)) / np.linalg.norm(p0))
    spin = float(np.linalg.norm(body["angular_velocity"]))
    print(f"\nmomentum of plate + body vs M V0: {momentum_error:.1e} (the plate took {plate:.3f} of it); energy "
          f"balance {balance:.1e} of the initial KE, wall {energy['wall'][-1] / k0:.3f} of it; body spin {spin:.3f} rad/s")
    assert plate > 0.01 and spin > 0.1 and energy["wall"][-1] > 0.0      # it struck (measured 0.020, 0.77)
    assert momentum_error < 1e-12           # measured 2.6e-18
    assert balance < 2e-6                   # measured 1.1e-6


def test_free_body_spinning_off_its_mass_centre_keeps_linear_momentum(tmp_path):
    """A free body (the whole 2 x 2 plate, mass_from_nodes) whose `center` is a corner, not its
    mass centre, spinning about no principal axis (issue 28 item 2): it turns about its mass
    centre, so the nodes' momentum sum m_c v_c stays at its initial value to round-off
    (about the corner, omega x M (x_G - x_C) turned with it: the momentum changed with no force)."""
    import meshio

    from taichi_shell_mpm.mesh import build_mesh
    from taichi_shell_mpm.model.assembly import assemble
    from taichi_shell_mpm.scene import load_scene
    body = FREE_BODY.replace("mass = 2.0\ninertia", "center = [0.0, 0.0, 0.0]\ninertia").replace(
        "mass_from_nodes = false", "mass_from_nodes = true")
    end = 2.0
    path = tmp_path / "offset.toml"
    path.write_text(PLATE.format(name="offset", lx=1.0, ly=1.0, nx=2, ny=2, E=500.0, t=0.05, section="", body=body,
                                 end=end, interval=f"{end / 10}\ntimes = [0.5, 1.0, 1.5, 2.0]"))
    out, summary = run_scene(tmp_path, path.read_text(), "offset")
    model = assemble(load_scene(path), build_mesh(load_scene(path).mesh))
    spec = model.rigid_bodies[0]
    p0 = model.node_mass.sum() * (VELOCITY + np.cross(SPIN, spec.center - np.zeros(3)))   # given at the corner
    frames = sorted((out / "frames").glob("*.vtu"))[1:]          # t = 0 holds the nodes' own (zero) velocities
    momenta = np.array([(model.node_mass[:, None] * meshio.read(f).point_data["velocity"]).sum(axis=0) for f in frames])
    drift = float(np.abs(momenta - p0).max() / np.linalg.norm(p0))
    turned = float(np.linalg.norm(summary["rigid_bodies"][0]["rotation_vector"]))
    print(f"\ncentre {spec.center} (the corner given); sum m v over {len(frames)} frames vs its initial value: {drift:.1e} "
          f"relative; turned {turned:.2f} rad")
    assert np.allclose(spec.center, [0.5, 0.5, 0.0]) and len(frames) >= 3 and turned > 1.0
    assert drift < 1e-12


def test_thin_rod_tumbling_keeps_its_energy_with_the_turn_limit(tmp_path):
    """A free body with J = diag(1, 1, 1e-4) (a thin rod) tumbling (issue 28 item 7): at the
    elements' step the Simo-Wong map's Lipschitz constant dt |Pi| / (2 J_min) is ~70 and the
    fixed point diverged; the step limit dt |L| / J_min <= MAX_TURN keeps it a contraction, and
    the drift keeps the kinetic energy and L to round-off."""
    from taichi_shell_mpm.stages.bodies import MAX_TURN
    inertia, spin = (1.0, 1.0, 1.0e-4), np.array([1.0, 0.0, 1.0])
    body = FREE_BODY.replace(f"inertia = {list(INERTIA)}", f"inertia = {list(inertia)}").replace(
        f"spin = {SPIN.tolist()}", f"spin = {spin.tolist()}")
    end = 0.05
    out, summary = run_scene(tmp_path, PLATE.format(name="rod", lx=1.0, ly=1.0, nx=2, ny=2, E=500.0, t=0.05, section="",
                                                    body=body, end=end, interval=end / 10), "rod")
    j = np.diag(inertia)
    k0 = 0.5 * 2.0 * VELOCITY @ VELOCITY + 0.5 * spin @ j @ spin
    rod = summary["rigid_bodies"][0]
    energy_error = abs(rod["kinetic_energy"] / k0 - 1.0)
    momentum_error = float(np.linalg.norm(np.array(rod["angular_momentum"]) - j @ spin) / np.linalg.norm(j @ spin))
    needed = end * np.linalg.norm(j @ spin) / inertia[2] / MAX_TURN
    print(f"\n{summary['steps']} steps (the turn limit needs {needed:.0f}; the elements' step 0.0142 would take "
          f"{end / 0.0142:.0f}): kinetic energy {energy_error:.1e}, angular momentum {momentum_error:.1e}")
    assert summary["steps"] >= needed
    assert energy_error < 1e-12 and momentum_error < 1e-12


def test_light_body_named_when_it_sets_the_step_and_refused_far_below(tmp_path):
    """Issue 28 item 7 (host checks: no kernels): a body with its nodes' masses on the matrix
    sheet's edge sets the step (its stable step on the elements it carries is below theirs):
    a warning naming it; the same body with a user mass and inertia 1e-9 of its own (not its
    nodes') would need a step below 1e-3 of the elements': refused, naming the body."""
    from taichi_shell_mpm.preflight import prepare
    from taichi_shell_mpm.scene import SceneError

    from .test_matrix import write_case
    scene = write_case(tmp_path, ("body",))
    _, _, model = prepare(scene, [])
    said = [n for n in model.notes if "[[rigid_body]] 'bar' limits the time step" in n]
    print("\n" + "\n".join(said))
    assert len(said) == 1
    with pytest.raises(SceneError) as err:
        prepare(scene, ["rigid_body.0.mass_from_nodes=false", "rigid_body.0.mass=1e-9",
                        "rigid_body.0.inertia=[1e-9, 1e-9, 1e-9]"])
    print(err.value.messages)
    assert any("[[rigid_body]] 'bar': mass, inertia: far too small" in m for m in err.value.messages)


def test_more_bodies_than_the_old_limit_of_sixteen(tmp_path):
    """A free strip (21 x 1 elements) spinning in its plane carries 20 rigid bodies (the limit was
    16), each a cross-section of two nodes (as a deck's nodal rigid bodies): it runs, every body
    keeps its two nodes 1 apart, the balance closes."""
    bodies = "".join(f'[nodesets.s{k}]\nids = [{k}, {k + 22}]\n[[rigid_body]]\nname = "b{k}"\nnodes = "s{k}"\n'
                     for k in range(1, 21))
    body = bodies + "[[initial]]\nvelocity = [0.3, 0.1, 0.0]\nangular_velocity = [0.0, 0.0, 0.5]\ncenter = [10.5, 0.5, 0.0]\n"
    path = tmp_path / "many.toml"
    path.write_text(PLATE.format(name="many", lx=21.0, ly=1.0, nx=21, ny=1, E=500.0, t=0.05, section="", body=body,
                                 end=1.0, interval=0.5))
    out = tmp_path / "out"
    r = cli_run("run", str(path), "--out", str(out), "--quiet")
    assert_clean_output(r)
    assert r.code == 0, r.out + r.err
    summary = json.loads((out / "summary.json").read_text())
    assert len(summary["rigid_bodies"]) == 20
    mesh = meshio.read(sorted((out / "frames").glob("*.vtu"))[-1])
    gaps = [np.linalg.norm(mesh.points[k] - mesh.points[k + 22]) - 1.0 for k in range(1, 21)]     # (deformed points)
    balance = summary["energies"]["balance_error"] / summary["energies"]["kinetic"]
    print(f"\n20 bodies: largest change of a body's length {max(map(abs, gaps)):.1e}, balance {balance:.1e} of the "
          "kinetic energy")
    assert max(map(abs, gaps)) < 1e-12
    # measured -1.2e-4 (the same strip without the bodies: -1.7e-4, 36 steps of a spinning strip)
    assert abs(balance) < 1.8e-4


def test_body_fields_are_read_as_one_set(tmp_path):
    """state.SNAPSHOTS: a rigid body's record fields come in one launch whichever is asked for
    (inside State.reads_cached the set is read once and shared; outside, each read is a fresh,
    writable copy), with the values the field-by-field reader gives; and the energies the run
    loop's checks, record and progress line ask for are made once per scope (State.derived)."""
    from taichi_shell_mpm.scene import load_scene
    from taichi_shell_mpm.state import SNAPSHOTS, State
    from .conftest import unwarmed_simulation
    body = ('[nodesets.bar]\nids = [1, 24]\n[[rigid_body]]\nname = "bar"\nnodes = "bar"\n'
            '[[initial]]\nvelocity = [0.3, 0.1, 0.0]\nangular_velocity = [0.0, 0.0, 0.5]\ncenter = [10.5, 0.5, 0.0]\n')
    path = tmp_path / "set.toml"
    path.write_text(PLATE.format(name="set", lx=21.0, ly=1.0, nx=21, ny=1, E=500.0, t=0.05, section="", body=body,
                                 end=1.0, interval=0.5))
    sim = unwarmed_simulation(load_scene(path), tmp_path)
    state, bodies = sim.state, sim.state.bodies
    names = [n for n in SNAPSHOTS["bodies"] if n in bodies._entries]
    assert len(names) >= 11
    rng = np.random.default_rng(3)
    for name in names:          # distinct values, so that a mixed-up offset shows
        field = getattr(bodies, name)
        State.write(field, rng.normal(size=State._read(field, 1).shape))
    expected = {name: State._read(getattr(bodies, name), 1) for name in names}
    with state.reads_cached():
        got = {name: state.read(getattr(bodies, name), 1) for name in names}
        assert [key for key in state._cache] == ["bodies"]      # one set read, shared by every field
        assert not got[names[0]].flags.writeable
    for name in names:
        assert np.array_equal(got[name], expected[name]), name
        fresh = state.read(getattr(bodies, name), 1)
        assert fresh.flags.writeable and np.array_equal(fresh, expected[name])
    # the energies (State.derived) made once per scope, and anew outside it
    made = []
    with state.reads_cached():
        first = state.derived("energies", lambda: made.append(1) or sim.energies())
        again = state.derived("energies", lambda: made.append(1) or {})
        assert sim.energies() == first == again and len(made) == 1
    assert state.derived("energies", lambda: {"anew": 1.0}) == {"anew": 1.0}
