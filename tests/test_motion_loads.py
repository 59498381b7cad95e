"""Prescribed motion, time curves and the loads of issue 18 item 4 ([curves.NAME],
[[motion]], [[pressure]], [gravity], line loads, follower loads), each through the CLI
against a closed form.

All runs are explicit FE (``fem``) strips or plates, so that the kernels of two
configurations serve every test (static and dynamic, with Features.loads on); the curves of
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
    load = CLAMP + TIP_PROBE + f"""
[[load]]
nodes = "tip"
force = [0.0, 0.0, {P}]
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
