"""Prescribed motion, time curves and the loads of issue 18 item 4 ([curves.NAME],
[[motion]], [[pressure]], [gravity], line loads, follower loads), each through the CLI
against a closed form.

All runs are explicit FE (``fem``) strips or plates, so that the kernels of two
configurations serve every test (static and dynamic, with Features.loads on: a static scene
with only plain nodal loads puts them on the curve LOAD_FACTOR); the curves of
the dynamic tests have corners between outputs, so that a step straddles each.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import meshio
import numpy as np
import pytest

from .test_reliability import assert_clean_output, cli_run

E, T, B = 1.2e6, 0.1, 1.0                 # the Sze strip: E, thickness, width (nu = 0, rho = 1)
EI = E * B * T ** 3 / 12.0

STRIP = """
[scene]
name = "{name}"
units = "consistent (length, force); E in force/length^2"
[mesh]
kind = "plate"
lx = {lx}
ly = {ly}
nx = {nx}
ny = {ny}
[material]
E = {E}
nu = {nu}
density = 1.0
[section]
thickness = {t}
points = 3
rule = "lobatto"
[element]
hourglass = 0.05
[method]
kind = "fem"
[nodesets.clamp]
plane = {{ point = [0.0, 0.0, 0.0], normal = [1.0, 0.0, 0.0] }}
[nodesets.tip]
plane = {{ point = [{lx}, 0.0, 0.0], normal = [1.0, 0.0, 0.0] }}
{body}
"""

STATIC = """
[solve]
kind = "static"
load_steps = {levels}
tolerance = {tolerance}
dt_rule = "shell"
[output]
load_steps = true
"""

DYNAMIC = """
[solve]
kind = "dynamic"
end_time = {end}
[output]
history_interval = {every}
"""


def strip(name: str, body: str, *, lx=10.0, ly=B, nx=10, ny=1, nu=0.0, t=T) -> str:
    return STRIP.format(name=name, lx=lx, ly=ly, nx=nx, ny=ny, E=E, nu=nu, t=t, body=body)


# f(lambda) = lambda, the plain load factor as a curve: a static scene whose loads are all plain
# nodal ones takes it, so that it compiles with Features.loads on like every other scene here
# (the same kernels; one configuration less to compile)
LOAD_FACTOR = """
[curves.load_factor]
points = [[0.0, 0.0], [1.0, 1.0]]
"""


def static(levels: int = 1, tolerance: float = 1e-6) -> str:
    return STATIC.format(levels=levels, tolerance=tolerance)


def dynamic(end: float, every: float) -> str:
    return DYNAMIC.format(end=end, every=every)


def run(tmp_path: Path, text: str, name: str = "scene") -> tuple[Path, dict]:
    """Run the scene `text` through the CLI; (output directory, summary)."""
    scene = tmp_path / f"{name}.toml"
    scene.write_text(text)
    out = tmp_path / f"out_{name}"
    r = cli_run("run", str(scene), "--out", str(out), "--quiet", timeout=600)
    assert r.code == 0, r.out + r.err
    assert_clean_output(r)
    return out, json.loads((out / "summary.json").read_text())


def table(path: Path) -> np.ndarray:
    return np.atleast_1d(np.genfromtxt(path, delimiter=",", names=True))


def integral(points, t: float, order: int) -> float:
    """int_0^t f (order 1) or int_0^t int_0^s f (order 2) of the piecewise-linear curve
    through `points` (flat beyond its ends), exactly: the trapezoid rule between breakpoints
    for f, Simpson's for the piecewise-quadratic F."""
    p = np.asarray(points, float)
    knots = np.unique(np.clip(np.concatenate([[0.0, t], p[:, 0]]), 0.0, t))

    def f(s):
        return np.interp(s, p[:, 0], p[:, 1])

    def first(s):
        edges = np.append(knots[knots < s], s)
        return sum(0.5 * (b - a) * (f(a) + f(b)) for a, b in zip(edges[:-1], edges[1:]))

    if order == 1:
        return first(t)
    return sum((b - a) / 6 * (first(a) + 4 * first((a + b) / 2) + first(b)) for a, b in zip(knots[:-1], knots[1:]))


def smooth_step(s: float, start: float, end: float) -> float:
    x = min(max((s - start) / (end - start), 0.0), 1.0)
    return x ** 3 * (10 - 15 * x + 6 * x * x)


# --------------------------------------------------------------------------- prescribed motion, dynamic
VELOCITY = [[0.0, 0.0], [0.013, 2.0], [0.031, 2.0], [0.05, -1.0]]      # corners between the outputs


def test_velocity_and_displacement_curves_are_followed_exactly(tmp_path):
    """The tip of a clamped strip driven by a velocity table from a CSV file (uz) and a smooth
    step displacement (ux): the tip follows value x F(t) and value x f(t) to round-off at
    every output, corners of the curve inside steps included; reaction and work are written."""
    (tmp_path / "v.csv").write_text("t,v\n" + "".join(f"{t},{v}\n" for t, v in VELOCITY))
    body = """
[[boundary]]
nodes = "clamp"
fix = "all"
[curves.v]
file = "v.csv"
[curves.pull]
shape = "smooth_step"
start = 0.01
end = 0.045
[[motion]]
name = "push"
nodes = "tip"
dofs = ["uz"]
kind = "velocity"
value = 0.5
curve = "v"
[[motion]]
name = "pull"
nodes = "tip"
dofs = ["ux"]
kind = "displacement"
value = -0.02
curve = "pull"
[[probe]]
name = "tip"
nodes = "tip"
components = ["ux", "uz"]
""" + dynamic(0.06, 0.0025)
    out, summary = run(tmp_path, strip("follow", body))
    probes = table(out / "probes.csv")
    want_z = np.array([0.5 * integral(VELOCITY, t, 1) for t in probes["time"]])
    want_x = np.array([-0.02 * smooth_step(t, 0.01, 0.045) for t in probes["time"]])
    err_z = np.max(np.abs(probes["tipuz"] - want_z)) / np.max(np.abs(want_z))
    err_x = np.max(np.abs(probes["tipux"] - want_x)) / 0.02
    print(f"\nvelocity curve: max |uz - 0.5 F(t)| / max|uz| = {err_z:.2e}; smooth step ux: {err_x:.2e}")
    assert err_z < 1e-9 and err_x < 1e-9               # probes.csv holds 10 digits
    force = table(out / "force.csv")
    assert {"pushreaction_uz", "pushwork", "pullreaction_ux", "pullwork"} <= set(force.dtype.names)
    names = [m["name"] for m in summary["motions"]]
    assert names == ["push", "pull"] and summary["motions"][0]["dofs"] == ["uz"]
    assert summary["motions"][0]["work"] == pytest.approx(force["pushwork"][-1], rel=1e-9)


ACCELERATION = [[0.0, 0.0], [0.01, 3.0], [0.02, 3.0], [0.03, -1.0]]


def test_acceleration_of_a_free_strip_reaction_and_work(tmp_path):
    """Every node of a free strip (mass M = rho t A = 1) accelerated by value x a(t) in ux and
    uz: positions X + value G(t) to round-off; the reaction is M value a wherever a was
    constant over the last two steps; the motion's work is the kinetic energy and the balance
    closes to round-off."""
    body = """
[curves.a]
points = [[0.0, 0.0], [0.01, 3.0], [0.02, 3.0], [0.03, -1.0]]
[[motion]]
name = "shake"
nodes = "all"
dofs = ["ux", "uz"]
kind = "acceleration"
value = [2.0, 1.0]
curve = "a"
[[probe]]
name = "tip"
nodes = "tip"
components = ["ux", "uz"]
""" + dynamic(0.04, 0.005)
    out, summary = run(tmp_path, strip("shake", body))
    probes = table(out / "probes.csv")
    want = np.array([integral(ACCELERATION, t, 2) for t in probes["time"]])
    err = max(np.max(np.abs(probes["tipux"] - 2 * want)), np.max(np.abs(probes["tipuz"] - want))) / want.max()
    force = table(out / "force.csv")
    flat = np.isin(np.round(force["time"], 9), [0.015, 0.02, 0.035, 0.04])      # a = 3, 3, -1, -1 there
    mass = 1.0 * T * 10.0 * B
    a = np.interp(force["time"][flat] - 0.001, *np.asarray(ACCELERATION).T)
    err_r = max(np.max(np.abs(force["shakereaction_ux"][flat] - 2 * mass * a)),
                np.max(np.abs(force["shakereaction_uz"][flat] - mass * a))) / (6 * mass)
    e = summary["energies"]
    print(f"\nacceleration: position error {err:.2e} of the largest, reaction error {err_r:.2e} of 2 M a_max, "
          f"work {e['motion_work']:.10e} vs kinetic {e['kinetic']:.10e}, balance {e['balance_error']:.2e}")
    assert err < 1e-9 and err_r < 1e-9
    assert e["motion_work"] == pytest.approx(e["kinetic"], rel=1e-12)
    assert abs(e["balance_error"]) < 1e-12 * e["kinetic"]


def test_energy_balance_closes_with_prescribed_motion(tmp_path):
    """A cantilever whirled by its tip: uz displaced by a smooth step (0.5 over 0.02) and ry
    turned at a prescribed rate, then held, in a dynamic run: the motions' work (booked
    time-centred with their reactions, energy.py) is what the strip holds as kinetic,
    internal and hourglass energy."""
    body = CLAMP + TIP_PROBE + """
[curves.lift]
shape = "smooth_step"
start = 0.0
end = 0.02
[curves.spin]
points = [[0.0, 0.0], [0.01, 1.0], [0.02, 0.0]]
[[motion]]
name = "lift"
nodes = "tip"
dofs = ["uz"]
kind = "displacement"
value = 0.5
curve = "lift"
[[motion]]
name = "spin"
nodes = "tip"
dofs = ["ry"]
kind = "velocity"
value = -20.0
curve = "spin"
""" + dynamic(0.04, 0.002)
    out, summary = run(tmp_path, strip("whirl", body))
    energy = table(out / "energy.csv")
    work = energy["motion_work"]
    ratio = np.max(np.abs(energy["balance_error"])) / np.max(np.abs(work))
    probes = table(out / "probes.csv")
    print(f"\nwhirled strip: motion work {work[-1]:.6e} (lift {summary['motions'][0]['work']:.4e}, spin "
          f"{summary['motions'][1]['work']:.4e}), kinetic {energy['kinetic'][-1]:.4e}, internal "
          f"{energy['internal'][-1]:.4e}; max |balance error| / max |work| = {ratio:.2e}; tip ry {probes['tipry'][-1]:.6f}")
    assert summary["motions"][0]["work"] + summary["motions"][1]["work"] == pytest.approx(work[-1], rel=1e-9)
    assert float(probes["tipuz"][-1]) == pytest.approx(0.5, rel=1e-9)
    assert float(probes["tipry"][-1]) == pytest.approx(-20.0 * 0.01, rel=1e-9)
    assert ratio < 1.5e-4                                         # measured 9.0e-5


def test_gravity_and_curve_loads_move_a_free_strip(tmp_path):
    """A free strip (mass M = 1) under gravity that follows a ramp and a force on all its nodes
    that follows a table: it translates as x = F G_f(t) / M, z = -g G_ramp(t) (G: the curve's
    second integral) within the central difference's O(dt^2) (the loads are read at t^n),
    and the loads' work is its kinetic energy to round-off."""
    g, f = 9.81, 3.0
    table_curve = [[0.0, 0.0], [0.013, 1.0], [0.027, -0.5], [0.035, 0.0]]
    body = f"""
[curves.ramp]
shape = "ramp"
start = 0.0
end = 0.02
[curves.push]
points = {table_curve}
[gravity]
acceleration = [0.0, 0.0, {-g}]
curve = "ramp"
[[load]]
nodes = "all"
force = [{f}, 0.0, 0.0]
curve = "push"
[[probe]]
name = "tip"
nodes = "tip"
components = ["ux", "uz"]
""" + dynamic(0.04, 0.005)
    out, summary = run(tmp_path, strip("fall", body))
    probes = table(out / "probes.csv")
    ramp = [[0.0, 0.0], [0.02, 1.0]]
    want_x = np.array([f * integral(table_curve, t, 2) for t in probes["time"]])
    want_z = np.array([-g * integral(ramp, t, 2) for t in probes["time"]])
    err_x = np.max(np.abs(probes["tipux"] - want_x)) / np.max(np.abs(want_x))
    err_z = np.max(np.abs(probes["tipuz"] - want_z)) / np.max(np.abs(want_z))
    e = summary["energies"]
    dt = 0.04 / summary["steps"]
    print(f"\nfree strip: x error {err_x:.2e}, z error {err_z:.2e} of the largest ((dt/t_end)^2 = {(dt / 0.04) ** 2:.1e}); "
          f"load work {e['external_work']:.10e}, kinetic {e['kinetic']:.10e}")
    assert err_x < 5.5e-4 and err_z < 1.7e-4                     # measured 3.7e-4, 1.1e-4
    assert e["external_work"] == pytest.approx(e["kinetic"], rel=1e-12)
    assert e["internal"] < 1e-12 * e["kinetic"]


# --------------------------------------------------------------------------- prescribed motion, static
CLAMP = """
[[boundary]]
nodes = "clamp"
fix = "all"
"""
TIP_PROBE = """
[[probe]]
name = "tip"
nodes = "tip"
components = ["ux", "uz", "ry"]
"""


def test_displacement_control_reaction_equals_the_load(tmp_path):
    """The 10 x 1 cantilever under a tip force P (PL^2/EI = 1: 30 % tip deflection, the
    geometric nonlinearity is in it), then with the tip's uz prescribed to that deflection:
    the motion's reaction is P, and the support reaction -P."""
    P = EI / 10.0 ** 2
    load = CLAMP + TIP_PROBE + LOAD_FACTOR + f"""
[[load]]
nodes = "tip"
force = [0.0, 0.0, {P}]
curve = "load_factor"
""" + static(tolerance=1e-6)
    out, _ = run(tmp_path, strip("loaded", load), "loaded")
    w = float(table(out / "probes.csv")["tipuz"][-1])
    motion = CLAMP + TIP_PROBE + f"""
[[motion]]
name = "lift"
nodes = "tip"
dofs = ["uz"]
kind = "displacement"
value = {w!r}
""" + static(tolerance=1e-6)
    out, summary = run(tmp_path, strip("lifted", motion), "lifted")
    force = table(out / "force.csv")
    reaction = float(force["liftreaction_uz"][-1])
    print(f"\ntip deflection {w:.6f} under P = {P}; prescribed: reaction {reaction:.7f} "
          f"({reaction / P - 1:+.2e}), support {float(force['support_z'][-1]):.7f}; work "
          f"{summary['motions'][0]['work']:.4f}, strain energy {summary['energies']['internal']:.4f}")
    assert reaction == pytest.approx(P, rel=1e-5)            # measured 4e-6 (tolerance 1e-6)
    assert float(force["support_z"][-1]) == pytest.approx(-P, rel=1e-5)
    assert summary["motions"][0]["reaction"]["uz"] == pytest.approx(reaction, rel=1e-9)     # csv: 10 digits


def test_gravity_reaction_is_the_weight(tmp_path):
    """A cantilever under its own weight (static, mass-scaled: gravity takes the physical
    masses): the support reaction is rho t A g to the relaxation tolerance (1e-9)."""
    g = 9.81
    body = CLAMP + TIP_PROBE + f"""
[gravity]
acceleration = [0.0, 0.0, {-g}]
""" + static(tolerance=1e-9)
    out, summary = run(tmp_path, strip("weight", body, nx=10, ny=2))
    force = table(out / "force.csv")
    weight = 1.0 * T * 10.0 * B * g
    err = float(force["support_z"][-1]) / weight - 1
    print(f"\nsupport reaction {float(force['support_z'][-1]):.12f}, weight {weight:.12f}: {err:.2e}")
    assert abs(err) < 2e-9 and abs(float(force["support_x"][-1])) < 2e-9 * weight


# --------------------------------------------------------------------------- pressure
def test_pressure_on_a_clamped_plate(tmp_path):
    """Uniform pressure q on a clamped square plate (a = 1, a/t = 100, nu = 0.3; a quarter on
    a 10 x 10 mesh with symmetry planes), small deflection: the centre deflection against
    Kirchhoff's w = 0.00126532 q a^4 / D (Timoshenko & Woinowsky-Krieger, table 35)."""
    a, t, nu, q, e_mod = 1.0, 0.01, 0.3, 1.0, 1e9
    d = e_mod * t ** 3 / (12 * (1 - nu ** 2))
    body = f"""
[nodesets.edges]
box = {{ min = [0.0, 0.0, 0.0], max = [0.5, 0.5, 0.0] }}
[nodesets.inner_x]
plane = {{ point = [0.5, 0.0, 0.0], normal = [1.0, 0.0, 0.0] }}
[nodesets.inner_y]
plane = {{ point = [0.0, 0.5, 0.0], normal = [0.0, 1.0, 0.0] }}
[nodesets.clamped_x]
plane = {{ point = [0.0, 0.0, 0.0], normal = [1.0, 0.0, 0.0] }}
[nodesets.clamped_y]
plane = {{ point = [0.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0] }}
[nodesets.centre]
nearest = [0.5, 0.5, 0.0]
[[boundary]]
nodes = "clamped_x"
fix = "all"
[[boundary]]
nodes = "clamped_y"
fix = "all"
[[boundary]]
nodes = "inner_x"
symmetry = "x"
[[boundary]]
nodes = "inner_y"
symmetry = "y"
[[pressure]]
value = {-q}
[[probe]]
name = "centre"
nodes = "centre"
components = ["uz"]
""" + static(tolerance=1e-6)
    text = strip("plate", body, lx=a / 2, ly=a / 2, nx=10, ny=10, nu=nu, t=t).replace(f"E = {E}", f"E = {e_mod}")
    out, _ = run(tmp_path, text)
    w = float(table(out / "probes.csv")["centreuz"][-1])
    kirchhoff = -0.00126532 * q * a ** 4 / d
    print(f"\nclamped plate: centre deflection {w:.6e}, Kirchhoff {kirchhoff:.6e}: {w / kirchhoff - 1:+.2e}")
    assert w == pytest.approx(kirchhoff, rel=4e-3)                # measured +2.6e-3


def quarter_cylinder(path: Path, radius: float, height: float, n_theta: int, n_z: int) -> None:
    """A quarter cylinder (theta in [0, 90] deg, z in [0, height]) of flat quads with their
    nodes on the circle; corner order theta, z: normals point outwards."""
    theta = np.linspace(0.0, 0.5 * np.pi, n_theta + 1)
    z = np.linspace(0.0, height, n_z + 1)
    th, zz = np.meshgrid(theta, z, indexing="ij")
    points = np.stack([radius * np.cos(th), radius * np.sin(th), zz], axis=-1).reshape(-1, 3)
    ids = np.arange(points.shape[0]).reshape(n_theta + 1, n_z + 1)
    quads = np.stack([ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]], axis=-1).reshape(-1, 4)
    meshio.write(path, meshio.Mesh(points, [("quad", quads)]))


def test_follower_pressure_inflates_a_cylinder(tmp_path):
    """Inner pressure p on a cylinder (R/t = 10, nu = 0, ends free; a quarter with symmetry
    planes), stretched 5 %: the pressure follows the current surface, so the hoop force is
    p R lambda cos(pi/N) on the polygon of N = 32 flat facets, and with the element's
    logarithmic strain E t ln(lambda) = p R lambda cos(pi/N).  A dead pressure (reference
    area and normal) would give E t ln(lambda) = p R cos(pi/N), 5 % less stretch."""
    radius, n_theta = 1.0, 8
    c = math.cos(math.pi / (4 * n_theta))
    stretch = 1.05
    p = E * T * math.log(stretch) / (radius * stretch * c)
    quarter_cylinder(tmp_path / "cylinder.vtu", radius, 0.5, n_theta, 2)
    text = f"""
[scene]
name = "cylinder"
units = "consistent"
[mesh]
kind = "file"
path = "cylinder.vtu"
[material]
E = {E}
nu = 0.0
density = 1.0
[section]
thickness = {T}
points = 3
rule = "lobatto"
[method]
kind = "fem"
[nodesets.x0]
plane = {{ point = [0.0, 0.0, 0.0], normal = [1.0, 0.0, 0.0] }}
[nodesets.y0]
plane = {{ point = [0.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0] }}
[nodesets.z0]
plane = {{ point = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0] }}
[nodesets.side]
nearest = [{radius}, 0.0, 0.5]
[[boundary]]
nodes = "x0"
symmetry = "x"
[[boundary]]
nodes = "y0"
symmetry = "y"
[[boundary]]
nodes = "z0"
symmetry = "z"
[[pressure]]
value = {p!r}
[[probe]]
name = "side"
nodes = "side"
components = ["ux", "uz"]
""" + static(levels=2, tolerance=1e-7)
    out, _ = run(tmp_path, text)
    probes = table(out / "probes.csv")
    measured = 1.0 + float(probes["sideux"][-1]) / radius
    dead = math.exp(p * radius * c / (E * T))
    print(f"\ncylinder: stretch {measured:.7f}, follower closed form {stretch:.7f} "
          f"({(measured - 1) / (stretch - 1) - 1:+.2e} of the stretch); a dead pressure: {dead:.7f}")
    assert (measured - 1) == pytest.approx(stretch - 1, rel=2e-6)   # measured 7e-7 (tolerance 1e-7)
    assert abs(float(probes["sideuz"][-1])) < 1e-6


# --------------------------------------------------------------------------- line load
def skewed_strip(path: Path) -> np.ndarray:
    """The 10 x 1 strip on 10 x 4 quads, rows at y = 0, 0.1, 0.35, 0.6, 1 and the last
    interior column skewed (x = 9 + 0.4 (y - 0.5)): the tip column's elements are
    trapezoids, so the tributary area of a tip node is not proportional to its edge length."""
    y = np.array([0.0, 0.1, 0.35, 0.6, 1.0])
    x = np.arange(11.0)
    xx, yy = np.meshgrid(x, y, indexing="ij")
    xx[9] = 9.0 + 0.4 * (y - 0.5)
    points = np.stack([xx, yy, np.zeros_like(xx)], axis=-1).reshape(-1, 3)
    ids = np.arange(points.shape[0]).reshape(11, 5)
    quads = np.stack([ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]], axis=-1).reshape(-1, 4)
    meshio.write(path, meshio.Mesh(points, [("quad", quads)]))
    return points


def test_line_load_is_consistent(tmp_path):
    """A uniform shear line load q along the tip edge of a cantilever meshed with uneven rows
    and a skewed last column: the support reaction is q b to round-off, the tip deflects
    uniformly across the width by Timoshenko's q b L^3 / 3EI + q b L / (kappa G b t), and the
    shares are the nodes' half edge lengths, not their tributary areas."""
    from taichi_shell_mpm.loading import load_shares
    points = skewed_strip(tmp_path / "strip.vtu")
    q = 2e-3                                   # tip deflection 2e-4 L: linear
    body = CLAMP + LOAD_FACTOR + f"""
[[load]]
nodes = "tip"
force_per_length = [0.0, 0.0, {q}]
curve = "load_factor"
[[probe]]
name = "tip"
nodes = "tip"
components = ["uz"]
[nodesets.corner0]
nearest = [10.0, 0.0, 0.0]
[nodesets.corner1]
nearest = [10.0, 1.0, 0.0]
[[probe]]
name = "c0"
nodes = "corner0"
components = ["uz"]
[[probe]]
name = "c1"
nodes = "corner1"
components = ["uz"]
""" + static(tolerance=1e-9)
    text = strip("line", body).replace('kind = "plate"\nlx = 10.0\nly = 1.0\nnx = 10\nny = 1',
                                       'kind = "file"\npath = "strip.vtu"')
    out, _ = run(tmp_path, text)
    force = table(out / "force.csv")
    probes = table(out / "probes.csv")
    reaction = float(force["support_z"][-1])
    w = float(probes["tipuz"][-1])
    spread = abs(float(probes["c0uz"][-1]) - float(probes["c1uz"][-1])) / w
    timoshenko = q * B * 10.0 ** 3 / (3 * EI) + q * B * 10.0 / (5 / 6 * E / 2 * B * T)
    print(f"\nline load: reaction {reaction:.12e} (q b = {q * B:.12e}), tip deflection {w:.6e} vs "
          f"{timoshenko:.6e} ({w / timoshenko - 1:+.2e}), corner difference {spread:.1e} of it")
    assert reaction == pytest.approx(-q * B, rel=2e-9)          # the relaxation tolerance
    assert w == pytest.approx(timoshenko, rel=4e-3)               # measured -2.7e-3
    assert spread < 1e-3                                          # measured 5.8e-4
    tip = np.flatnonzero(np.isclose(points[:, 0], 10.0))
    elements = meshio.read(tmp_path / "strip.vtu").cells_dict["quad"]
    lengths = load_shares("length", tip, None, points, elements)
    np.testing.assert_allclose(lengths, [0.05, 0.175, 0.25, 0.325, 0.2], rtol=1e-12)
    area = np.zeros(len(points))
    corners = points[elements]
    element_area = 0.5 * np.abs(np.cross(corners[:, 2] - corners[:, 0], corners[:, 3] - corners[:, 1])[:, 2])
    np.add.at(area, elements.ravel(), np.repeat(element_area / 4, 4))
    assert np.max(np.abs(area[tip] / area[tip].sum() - lengths)) > 0.01       # the old 'area' shares differ


# --------------------------------------------------------------------------- follower loads
def test_follower_end_moment_rolls_the_strip_into_a_circle(tmp_path):
    """Sze et al. (2004): the strip L = 12 clamped at one end, a follower end moment up to
    M = 2 pi EI / L in 8 levels: the tip on the polygon of chords that the elastica's circle
    becomes (each element turns by theta / n), back at the clamp at the last level.  On the
    16 x 1 mesh the last level's relaxation ran into the hourglass mode (the non-conservative
    moment pumps it: hourglass energy 116 % of the internal at 0.05); 16 x 2 is stable."""
    length, n = 12.0, 16
    m_max = 2 * math.pi * EI / length
    body = CLAMP + TIP_PROBE + f"""
[[load]]
nodes = "tip"
moment = [0.0, {-m_max!r}, 0.0]
follower = true
""" + static(levels=8, tolerance=1e-6)
    out, _ = run(tmp_path, strip("roll", body, lx=length, nx=n, ny=2))
    probes = table(out / "probes.csv")
    errors = []
    for lam, ux, uz in zip(probes["load_factor"], probes["tipux"], probes["tipuz"]):
        turn = 2 * math.pi * lam / n
        angles = (np.arange(n) + 0.5) * turn
        tip = length / n * np.array([np.cos(angles).sum(), np.sin(angles).sum()])
        errors.append(math.hypot(length + ux - tip[0], uz - tip[1]) / length)
    print(f"\nrolled strip: tip distance from the polygon / L per level {np.array2string(np.array(errors), precision=1)}; "
          f"at M_max ux = {probes['tipux'][-1]:.6f}, uz = {probes['tipuz'][-1]:.2e}")
    assert max(errors) < 2e-5                                     # measured 1.2e-5
    assert float(probes["tipux"][-1]) == pytest.approx(-length, rel=4e-6)   # measured -2.6e-5 / 12


def test_follower_force_turns_with_a_prescribed_rotation(tmp_path):
    """The clamp of the 10 x 1 strip turned by a prescribed rotation ry = -pi/2 (static), a
    follower force P along the tip's normal: the strip stands up and the force turns with it
    into a shear (a dead force would only compress it).  The support reaction is -P R(theta)
    e_z with theta the tip's rotation, the tip deflects by Timoshenko's P L^3/3EI + P L/(kappa
    G b t) on top of the -pi/2 turn, the motion's reaction moment is P L."""
    p, length = 0.01, 10.0
    body = TIP_PROBE + f"""
[[boundary]]
nodes = "clamp"
fix = ["ux", "uy", "uz", "rx", "rz"]
[[motion]]
name = "stand"
nodes = "clamp"
dofs = ["ry"]
kind = "displacement"
value = {-math.pi / 2!r}
[[load]]
nodes = "tip"
force = [0.0, 0.0, {p}]
follower = true
""" + static(tolerance=1e-8)
    out, summary = run(tmp_path, strip("stand", body))
    force = table(out / "force.csv")
    probes = table(out / "probes.csv")
    theta = float(probes["tipry"][-1])
    support = np.array([float(force[f"support_{a}"][-1]) for a in "xyz"])
    turned = -p * np.array([math.sin(theta), 0.0, math.cos(theta)])
    moment = float(force["standreaction_ry"][-1])
    deflection = -float(probes["tipux"][-1]) - length
    timoshenko = p * length ** 3 / (3 * EI) + p * length / (5 / 6 * E / 2 * B * T)
    print(f"\nstood-up strip: tip rotation {theta:.6f}, support {np.array2string(support, precision=8)} vs "
          f"-P R e_z {np.array2string(turned, precision=8)}; clamp moment {moment:.6f} (P L = {p * length}); tip "
          f"deflection {deflection:.6e} vs {timoshenko:.6e} ({deflection / timoshenko - 1:+.2e})")
    np.testing.assert_allclose(support, turned, atol=1e-6 * p)
    assert moment == pytest.approx(p * length, rel=1e-4)          # the force -P e_x at height L
    assert deflection == pytest.approx(timoshenko, rel=6e-3)      # measured +4.1e-3 (10 one-point elements)
    assert summary["motions"][0]["reaction"]["ry"] == pytest.approx(moment, rel=1e-9)


# --------------------------------------------------------------------------- restart
def test_restart_with_motion_and_loads_is_bit_for_bit(tmp_path, monkeypatch):
    """A dynamic run with an acceleration motion (its last mean velocity is state), a
    velocity-driven rotation, a follower load and gravity on curves, stopped and restarted
    (as tests/test_restart.py does): tables and final positions byte-identical."""
    from taichi_shell_mpm import run_control
    from taichi_shell_mpm.solvers import static

    from .test_restart import assert_same_run, position_of
    body = CLAMP + TIP_PROBE + """
[curves.a]
points = [[0.0, 0.0], [0.004, 50.0], [0.012, -20.0]]
[curves.g]
shape = "smooth_step"
end = 0.01
[[motion]]
name = "shake"
nodes = "tip"
dofs = ["uz"]
kind = "acceleration"
value = 1.0
curve = "a"
[[motion]]
name = "spin"
nodes = "tip"
dofs = ["ry"]
kind = "velocity"
value = -2.0
[[load]]
nodes = "tip"
force = [0.0, 0.5, 0.0]
follower = true
curve = "g"
[gravity]
acceleration = [0.0, 0.0, -9.81]
curve = "g"
""" + dynamic(0.016, 0.001)
    scene = tmp_path / "shake.toml"
    scene.write_text(strip("shake", body))
    monkeypatch.setattr(static, "BATCH_ELEMENT_STEPS", 40)            # 4-step batches: 32 steps in all
    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    assert cli_run("run", str(scene), "--out", str(a), "--quiet").code == 0
    monkeypatch.setattr(run_control, "stop_hook", lambda sim: sim.state.step.step[None] >= 11)
    r = cli_run("run", str(scene), "--out", str(b), "--quiet")
    monkeypatch.setattr(run_control, "stop_hook", None)
    assert r.code == 130, r.err
    r = cli_run("run", str(scene), "--restart", str(b), "--out", str(c), "--quiet")
    assert r.code == 0, r.err
    assert_same_run(a, c)
    print(f"\nstopped at {position_of(b)}, restarted: tables byte-identical, final positions identical")


# --------------------------------------------------------------------------- bad input
BAD = [  # (--set overrides, the one error line's text after "case.toml: ")
    (['motion.0.curve="nope"'], "[[motion]][0].curve: no [curves.nope]"),
    (['curves.table.shape="ramp"'], "[curves.table]: expected exactly one of points, file, shape, got points, shape"),
    (['curves.table.points=[[0.0, 0.0], [0.0, 1.0]]'], "[curves.table].points: expected strictly increasing t"),
    (['curves.up.start=0.5'], "[curves.up]: expected start < end, got start = 0.5, end = 0.4"),
    (['curves.one.end=2.0'], '[curves.one].end: allowed only with shape = "ramp" or "smooth_step"'),
    (['motion.0.curve="one"'], "[[motion]][0].curve: the displacement curve 'one' is 1 at t = 0, not 0"),
    (['motion.0.value=[1.0, 2.0, 3.0]'], "[[motion]][0].value: expected one number or one per DOF (2), got 3"),
    (['motion.1.name="lift"'], "[[motion]]: duplicate motion name 'lift'"),
    (['motion.1.kind="jerk"'], "[[motion]][1].kind: expected one of displacement, velocity, acceleration"),
    (['solve.kind="static"'], '[[motion]][1].kind: a static solve prescribes displacements only, got \'velocity\''),
    (['motion.1.dofs=["uz"]'], "[[motion]] 'push': node 4 has uz prescribed by another [[motion]] too"),
    (['boundary.0.nodes="tip"'], "[[motion]] 'lift': node 4 has uz fixed by a [[boundary]] too"),
    (['pressure.0.elements="nope"'], "[[pressure]][0].elements: no [elementsets.nope]"),
    (['pressure.0.value=0.0'], "[[pressure]][0].value:"),
    (['load.1.force=[1.0, 0.0, 0.0]'], "[[load]][1]: give either force/moment (totals) or force_per_length"),
    (['load.1.distribute="area"'], '[[load]][1].distribute: a line load is distributed by length, got \'area\''),
    (['nodesets.one.nearest=[4.0, 0.0, 0.0]', 'load.1.nodes="one"'],
     "[[load]] on 'one': a line load needs element edges joining two nodes of the set"),
    (['nodesets.one.box={min = [20.0, 0.0, 0.0], max = [21.0, 1.0, 0.0]}', 'motion.1.nodes="one"'],
     "nodeset 'one' (box min=[20,0,0] max=[21,1,0] tol=1e-06) selects no node"),
    (['gravity.acceleration=[0.0, 0.0, 0.0]'], "[gravity].acceleration:"),
    (['gravity.curve=3'], "[gravity].curve: expected a curve name, got 3"),
]


@pytest.mark.parametrize("overrides, expected", BAD, ids=[" ".join(o) for o, _ in BAD])
def test_bad_input_is_one_line(tmp_path, overrides, expected):
    from .test_scene import MOTION_SCENE
    scene = tmp_path / "case.toml"
    scene.write_text(MOTION_SCENE)
    r = cli_run("validate", str(scene), *[a for o in overrides for a in ("--set", o)])
    assert_clean_output(r)
    lines = r.err.splitlines()
    assert r.code == 2 and len(lines) == 1, r.err
    assert lines[0].startswith(f"error: case.toml: {expected}"), lines[0]


def test_bad_curve_file_is_one_line(tmp_path):
    from .test_scene import MOTION_SCENE
    (tmp_path / "v.csv").write_text("t,v\n0,0\n1,x\n")
    scene = tmp_path / "case.toml"
    scene.write_text(MOTION_SCENE.replace("points = [[0.0, 0.0], [0.5, 1.0], [1.0, 0.0]]", 'file = "v.csv"'))
    r = cli_run("validate", str(scene))
    assert_clean_output(r)
    assert r.code == 2 and r.err.splitlines() == [
        "error: case.toml: [curves.table].file: v.csv line 3: expected two finite numbers t, f, got '1,x'"], r.err
    scene.write_text(MOTION_SCENE)
    assert cli_run("validate", str(scene)).code == 0


WINDOW = """
[scene]
name = "window"
units = "consistent"
[mesh]
kind = "plate"
lx = 2.0
ly = 1.0
nx = 2
ny = 1
[material]
E = 1.0e4
nu = 0.3
density = 1.0
[section]
thickness = 0.05
[method]
kind = "{method}"
[[initial]]
velocity = [0.5, 0.0, 0.0]
[[motion]]
name = "push"
nodes = "all"
dofs = ["ux", "uy", "uz"]
kind = "velocity"
value = [0.0, 0.0, 1.0]
start = 0.1
end = 0.3
[[probe]]
name = "p"
nodes = "all"
components = ["ux", "uz"]
[solve]
kind = "dynamic"
end_time = 0.5
[output]
history_interval = 0.05
"""


@pytest.mark.parametrize("method", ["fem", "mpm"])
def test_a_motion_holds_its_dofs_only_in_its_time_window(tmp_path, method):
    """[[motion]] start/end (LS-DYNA BIRTH/DEATH): a free plate drifting at 0.5 along x is held
    to (0, 0, 1) from t = 0.1 to 0.3, then released: it keeps that velocity.  Positions to
    round-off at every record (the window's edges fall on steps: landing on the records);
    the released DOFs do no work (balance).  In mpm too: a held node is off the grid and
    carries the velocity it moves with, and rejoins the grid with it (no stale affine field,
    its grid slots looked up again)."""
    from .conftest import run_scene
    scene = tmp_path / "window.toml"
    scene.write_text(WINDOW.format(method=method))
    proc = run_scene(scene, tmp_path / "out")
    assert proc.returncode == 0, proc.stderr
    rows = np.genfromtxt(tmp_path / "out" / "probes.csv", delimiter=",", names=True)
    t = rows["time"]
    ux = np.where(t <= 0.1, 0.5 * t, 0.05)
    uz = np.clip(t - 0.1, 0.0, None)
    error = max(np.abs(rows["pux"] - ux).max(), np.abs(rows["puz"] - uz).max())
    balance = proc.summary["energies"]["balance_error"]
    print(f"\nwindowed motion ({method}): position error {error:.1e}, balance {balance:.1e}")
    assert error < 1e-12 and abs(balance) < 1e-12


@pytest.mark.parametrize("method", ["fem", "mpm"])
def test_a_body_motion_holds_its_translations_only_in_its_time_window(tmp_path, method):
    """The same windowed motion on the plate made one [[rigid_body]]: the body's translations
    are held from 0.1 to 0.3, free before and after (fem and mpm: its slaves are off the grid),
    positions to round-off, no work when released; a window on a body's rotation is refused."""
    from .conftest import run_scene
    text = WINDOW.format(method=method).replace('nodes = "all"\ndofs', 'body = "plate"\ndofs').replace(
        "[[motion]]", '[[rigid_body]]\nname = "plate"\nnodes = "all"\n[[motion]]')
    scene = tmp_path / "body_window.toml"
    scene.write_text(text)
    proc = run_scene(scene, tmp_path / "out")
    assert proc.returncode == 0, proc.stderr
    rows = np.genfromtxt(tmp_path / "out" / "probes.csv", delimiter=",", names=True)
    t = rows["time"]
    error = max(np.abs(rows["pux"] - np.where(t <= 0.1, 0.5 * t, 0.05)).max(),
                np.abs(rows["puz"] - np.clip(t - 0.1, 0.0, None)).max())
    balance = proc.summary["energies"]["balance_error"]
    print(f"\nwindowed body motion ({method}): position error {error:.1e}, balance {balance:.1e}")
    assert error < 1e-12 and abs(balance) < 1e-12
    scene.write_text(text.replace('dofs = ["ux", "uy", "uz"]', 'dofs = ["rz"]').replace(
        "value = [0.0, 0.0, 1.0]", "value = 1.0").replace('nodes = "all"\n[[motion]]',
                                                          'nodes = "all"\nfixed = ["rx", "ry"]\n[[motion]]'))
    proc = run_scene(scene, tmp_path / "rotation")
    assert proc.returncode == 2 and "start / end (a time window) hold a body's translations only" in proc.stderr


EDGE_WINDOW = """
[scene]
name = "edge"
units = "consistent"
[mesh]
kind = "plate"
lx = 4.0
ly = 1.0
nx = 8
ny = 2
[material]
E = 1.0e4
nu = 0.3
density = 1.0
[section]
thickness = 0.1
[method]
kind = "{method}"
[nodesets.edge]
plane = {{ point = [0.0, 0.0, 0.0], normal = [1.0, 0.0, 0.0] }}
[[motion]]
name = "lift"
nodes = "edge"
dofs = ["ux", "uy", "uz"]
kind = "velocity"
value = [0.0, 0.0, 1.0]
start = 0.05
end = 0.15
[solve]
kind = "dynamic"
end_time = 0.5
[output]
history_interval = 0.05
"""
# measured (balance / the motion's work 3.6e-2): fem -2.7e-5 (the time integration); mpm 1.34e-3,
# of which 1.24e-3 at the step the edge leaves the grid (its nodes' momentum leaves the grid nodes
# it shared with its neighbours: the same with a window that never ends) and 1.1e-4 after the
# release, when it rejoins.  Bounds 1.5x.
EDGE_BALANCE = {"fem": 4.0e-5, "mpm": 2.0e-3}


@pytest.mark.parametrize("method", ["fem", "mpm"])
def test_an_edge_lifted_in_a_window_then_released(tmp_path, method):
    """A strip at rest whose edge x = 0 is lifted at 1 from t = 0.05 to 0.15 and then released
    (it swings on): the motion's work goes into the strip's kinetic and strain energy, the
    balance closes (bounds above), the released edge has no reaction."""
    from .conftest import run_scene
    scene = tmp_path / "edge.toml"
    scene.write_text(EDGE_WINDOW.format(method=method))
    proc = run_scene(scene, tmp_path / "out")
    assert proc.returncode == 0, proc.stderr
    e = proc.summary["energies"]
    share = e["balance_error"] / e["motion_work"]
    print(f"\nedge window ({method}): motion work {e['motion_work']:.4e}, kinetic {e['kinetic']:.4e}, internal "
          f"{e['internal']:.4e}, balance {share:.2e} of the work")
    assert e["motion_work"] > 0.03 and e["kinetic"] > 0.0 and e["internal"] > 0.0
    assert abs(share) <= EDGE_BALANCE[method]
    assert proc.summary["motions"][0]["reaction"] == {"ux": 0.0, "uy": 0.0, "uz": 0.0}
