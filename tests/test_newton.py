"""Newton-Raphson statics with path following (issue 19).

* the path-following numerics (solvers/path.py) on a closed-form problem: a shallow
  two-bar (von Mises) truss whose apex carries the load through a soft spring, which snaps
  through (a load limit point) and, seen from the loaded end of the spring, snaps back
  (a displacement limit point);
* the shell's tangent (solvers/tangent.py) against a finite-difference derivative of the
  internal force on random deformed elements, elastic and plastic;
* quadratic convergence of Newton on the elastic cantilever (residual ratios printed);
* the jump monitor of load control.

Relaxation and Newton on the bundled Sze scenes through the CLI: tests/test_benchmarks_cli.py.
Each measured number is printed (``pytest -s``); bounds are about 1.5x the measured values.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from taichi_shell_mpm.solvers.newton import ShellEquations
from taichi_shell_mpm.solvers.path import JumpMonitor, Plan, Settings, follow

# ---------------------------------------------------------------- the closed-form problem
HALF_SPAN, RISE, AXIAL, SPRING = 1.0, 0.2, 1.0, 0.02
LIMIT_TOLERANCE = 4.5e-3     # the path's first load maximum against the closed form's (measured 3.0e-3:
#                              the points' spacing near the maximum)


def truss_load(w):
    """Closed form: the apex load P(w) of the two bars (axial stiffness AXIAL, engineering
    strain) at the apex deflection w (downwards)."""
    l0 = math.hypot(HALF_SPAN, RISE)
    length = np.hypot(HALF_SPAN, RISE - w)
    return 2.0 * AXIAL * (l0 - length) / l0 * (RISE - w) / length


class TwoBarTruss:
    """Unknowns (w, v): the apex deflection and the loaded end of the spring; the load
    pattern F = (0, 1) acts on v.  On the path P = truss_load(w), v = w + P / SPRING; P(w)
    has a limit point (snap-through) and v(w) turns back (snap-back) since SPRING is below
    the bars' largest negative stiffness."""

    def __init__(self):
        self.u = np.zeros(2)
        self.load = np.array([0.0, 1.0])
        self.weight = np.ones(2)

    def evaluate(self, d, tangent):
        w, v = self.u + d
        h = 1e-7
        p = truss_load(w)
        dp = (truss_load(w + h) - truss_load(w - h)) / (2 * h)
        f = np.array([p - SPRING * (v - w), SPRING * (v - w)])
        K = np.array([[dp + SPRING, -SPRING], [-SPRING, SPRING]]) if tangent else None
        return f, K, ""

    def factorize(self, K):
        class Solver:
            sign = int(np.sign(np.linalg.det(K)))

            @staticmethod
            def solve(b):
                return np.linalg.solve(K, b)
        return Solver()


def test_closed_form_truss_has_both_limit_points():
    w = np.linspace(0.0, 2.5 * RISE, 2001)
    p = truss_load(w)
    v = w + p / SPRING
    assert np.any(np.diff(p) < 0) and np.any(np.diff(v) < 0)


def test_arc_length_through_limit_point_and_snap_back():
    """Crisfield's arc length follows the whole path: load up to the limit point, down
    (snap-through), the spring end back (snap-back), and up again, every converged point on
    the closed form."""
    truss = TwoBarTruss()
    points = []

    def accept(outcome, lam_old, record):
        truss.u = truss.u + outcome.d
        points.append((outcome.lam, *truss.u, outcome.iterations))

    selector = np.array([1.0, 0.0])            # stop once the apex passes 2.5 x the rise
    plan = Plan(control="arc_length", steps=400, final=2.5 * RISE, selector=selector, arc_length=0.02,
                max_load_factor=10.0, target_iterations=4)
    log = {}
    follow(truss, Settings(tolerance=1e-10, increment_tolerance=1e-8, energy_tolerance=1e-12), plan, accept, log=log)
    lam, w, v, its = (np.array(c) for c in zip(*points))
    p_max = float(np.max(truss_load(np.linspace(0, RISE, 4001))))       # the first limit load
    load_error = np.max(np.abs(lam - truss_load(w))) / p_max
    spring_error = np.max(np.abs(v - (w + lam / SPRING))) / np.max(np.abs(v))
    print(f"\n{len(points)} points, {int(its.sum())} iterations (mean {its.mean():.2f}), limit points at load "
          f"factors {[round(x, 5) for x in log['limit_points']]}; closed-form limit load {p_max:.5f}; "
          f"path error: load {load_error:.2e} of the limit load, spring {spring_error:.2e}; highest point before the "
          f"snap {1 - log['limit_points'][0] / p_max:.2e} below the limit load")
    assert w[-1] >= 2.5 * RISE
    assert load_error < 1e-8 and spring_error < 1e-8
    assert log["limit_points"][0] == pytest.approx(p_max, rel=LIMIT_TOLERANCE)     # the limit point is resolved
    assert np.min(lam) < -0.5 * p_max                              # the unstable branch: the load reverses
    assert np.any(np.diff(v) < 0)                                  # snap-back: the loaded end moves back
    assert lam[-1] > 0 and np.all(np.diff(w) > 0)                  # up again, never back along the path
    assert len(log["limit_points"]) >= 2


def test_displacement_control_through_the_limit_point():
    """The apex deflection prescribed (displacement control on w): the load factor is the
    unknown, down through the limit point and negative, on the closed form."""
    truss = TwoBarTruss()
    points = []

    def accept(outcome, lam_old, record):
        truss.u = truss.u + outcome.d
        if record:
            points.append((outcome.lam, truss.u[0]))

    plan = Plan(control="displacement", steps=40, final=2.0 * RISE, selector=np.array([1.0, 0.0]))
    follow(truss, Settings(tolerance=1e-10, increment_tolerance=1e-8, energy_tolerance=1e-12), plan, accept)
    lam, w = (np.array(c) for c in zip(*points))
    error = np.max(np.abs(lam - truss_load(w)))
    print(f"\ndisplacement control: {len(points)} points, max |lam - P(w)| = {error:.2e}")
    assert np.allclose(w, np.arange(1, 41) / 40 * 2 * RISE, rtol=0, atol=1e-12)
    assert error < 1e-9 and lam.min() < 0


def test_load_control_jump_is_reported():
    """Under load control Newton jumps over the snap-through; the monitor names the step."""
    truss = TwoBarTruss()
    warnings = []

    def accept(outcome, lam_old, record):
        truss.u = truss.u + outcome.d

    p_max = float(np.max(truss_load(np.linspace(0, RISE, 4001))))
    plan = Plan(control="load", steps=10, final=1.0)
    scaled = TwoBarTruss()
    truss.load = scaled.load * 1.5 * p_max                  # load factor 1 = 1.5 x the limit load
    jumps = JumpMonitor(warnings.append)
    follow(truss, Settings(tolerance=1e-10), plan, accept, jumps=jumps)
    jumps.finish()
    print("\n" + "\n".join(warnings))
    assert len(warnings) == 1 and "between load factors 0.6 and 0.7" in warnings[0]


def test_jump_monitor_smooth_path_is_quiet():
    warnings = []
    monitor = JumpMonitor(warnings.append)
    for j, size in enumerate([1.0, 1.1, 1.3, 1.6, 2.0, 2.6, 3.3], start=1):   # a softening path
        monitor.add(j / 7, size)
    monitor.finish()
    assert warnings == []
    monitor.add(8 / 7, 40.0)
    monitor.add(9 / 7, 1.0)
    assert len(warnings) == 1 and "1.143" in warnings[0]


# ---------------------------------------------------------------- the shell's tangent
PATCH = """
[scene]
name = "patch"
units = "consistent"
[mesh]
kind = "file"
path = "patch.vtu"
[material]
E = 1000.0
nu = 0.3
density = 1.0
{material}
[section]
thickness = 0.05
points = 3
rule = "lobatto"
[method]
kind = "fem"
[nodesets.corner]
ids = [0]
[[load]]
nodes = "corner"
force = [0.0, 0.0, 1.0]
[solve]
kind = "static"
solver = "newton"
"""
# |K v - (f(d + e v) - f(d - e v)) / 2e| / |...| over random v at a random deformed, stressed
# state of a warped random 2x2 patch (measured: elastic 8.2e-10, plastic 2.7e-10, triangles
# 5.3e-10 at e = 1e-5, every point yielding; the truncation and round-off of the two
# differences: the strain increment of a trial is a difference of corner coordinates in two
# frames, stages/shell.increment_geometry, round-off ~5 eps of the element's size, about 5x the
# explicit step's v.B, where these were 1.0, 1.4 and 1.0 x 10^-10)
TANGENT_BOUND = {"elastic": 1.3e-9, "plastic": 4.1e-10, "triangles": 8e-10}


def patch_equations(tmp_path, plastic: bool, triangles: bool = False, cells: int = 2, element: str = "",
                    mixed: bool = False):
    """Newton's equations of a warped random patch of cells x cells quads (or twice as many
    triangles; `mixed`: the lower half of the rows in triangles) at a deformed, stressed
    converged state; `element`: [element] lines."""
    from .conftest import simulation, write_scene
    from taichi_shell_mpm.scene import load_scene
    import meshio
    rng = np.random.default_rng(7)
    side = cells + 1
    x, y = np.meshgrid(np.linspace(0, 1, side), np.linspace(0, 1, side), indexing="xy")
    n = side * side
    points = np.stack([x.ravel(), y.ravel(), np.zeros(n)], axis=1)
    points[:, :2] += rng.uniform(-0.08, 0.08, (n, 2)) * 2 / cells
    points[:, 2] += rng.uniform(-0.05, 0.05, n) * 2 / cells      # warped quads
    i, j = np.meshgrid(np.arange(cells), np.arange(cells), indexing="ij")
    first = (side * i + j).ravel()
    quads = np.stack([first, first + 1, first + side + 1, first + side], axis=1)
    cut = np.full(len(quads), triangles) | (mixed & (first // side < cells // 2))
    cells_out = [("quad", quads[~cut]), ("triangle", np.concatenate([quads[cut][:, :3], quads[cut][:, [0, 2, 3]]]))]
    cells_out = [cell for cell in cells_out if len(cell[1])]
    meshio.write(tmp_path / "patch.vtu", meshio.Mesh(points, cells_out))
    material = 'model = "j2"\nyield_stress = 0.5\nhardening = 10.0' if plastic else ""
    text = PATCH.format(material=material)
    if element:
        text = text.replace("[solve]", f"[element]\n{element}\n[solve]", 1)
    scene = load_scene(write_scene(tmp_path, text))
    sim = simulation(scene, tmp_path)
    eq = ShellEquations.compiled(sim)
    # a deformed, stressed converged state: one random increment committed
    first = random_increment(rng, n)
    f, _, message = eq.evaluate(first[eq.free], False)
    assert f is not None, message
    eq.forces.commit(eq.full(first[eq.free]))
    return sim, eq, rng


def random_increment(rng, n: int) -> np.ndarray:
    """Random translations (0.02) and rotations (0.15) of n nodes, as one (6 n) vector."""
    return np.concatenate([rng.normal(0, 0.02, (n, 3)), rng.normal(0, 0.15, (n, 3))], axis=1).ravel()


def tangent_errors(eq, d, K, rng, count: int = 6) -> list[float]:
    """|K v - (f(d + eps v) - f(d - eps v)) / 2 eps| / |that difference| for `count` random
    directions v (displacements and rotations in the equations' weights)."""
    errors = []
    for _ in range(count):
        v = rng.normal(0, 1, eq.ndof) / eq.weight * 0.01
        eps = 1e-5
        fp, _, _ = eq.evaluate(d + eps * v, False)
        fm, _, _ = eq.evaluate(d - eps * v, False)
        fd = (fp - fm) / (2 * eps)
        errors.append(np.linalg.norm(K @ v - fd) / np.linalg.norm(fd))
    return errors


@pytest.mark.parametrize("kind", ["elastic", "plastic", "triangles"])
def test_tangent_against_finite_differences(tmp_path, kind):
    sim, eq, rng = patch_equations(tmp_path, kind == "plastic", triangles=kind == "triangles")
    d = random_increment(rng, 9)[eq.free]
    f, K, message = eq.evaluate(d, True)
    assert f is not None, message
    if kind == "plastic":
        before = sim.state.fetch("points.plastic_strain")
        after = eq.forces.v.fetch("points.plastic_strain")[:len(before)]
        yielding = float(np.mean(after > before + 1e-12))
        print(f"\n{100 * yielding:.0f} % of the through-thickness points yield in the trial increment")
        assert yielding > 0.5
    errors = tangent_errors(eq, d, K, rng)
    asym = abs(K - K.T).max() / abs(K).max()
    print(f"{kind}: tangent against the directional difference: max {max(errors):.2e} (bound "
          f"{TANGENT_BOUND[kind]:.0e}); asymmetry max|K - K^T| / max|K| = {asym:.2e}")
    assert max(errors) < TANGENT_BOUND[kind]


# ---------------------------------------------------------------- quadratic convergence
ORDER = 1.5         # observed order log(r_(k+2) / r_(k+1)) / log(r_(k+1) / r_k) near the solution (measured >= 1.79)
NEAR, FLOOR = 0.1, 1e-8     # "near the solution": r_k below NEAR; r_(k+2) above the round-off floor (~1e-9 here)


def test_quadratic_convergence_on_the_cantilever(tmp_path):
    """Newton on the elastic 10x1 cantilever (Sze): the residual ratios of the first load
    steps, printed; near the solution each iteration about squares the residual."""
    from .conftest import ROOT, simulation
    from taichi_shell_mpm.scene import load_scene
    from taichi_shell_mpm.solvers.path import Control, newton_point
    scene = load_scene(ROOT / "scenes" / "cantilever.toml", ["method.kind=fem", "solve.solver=newton"])
    sim = simulation(scene, tmp_path)
    eq = ShellEquations.compiled(sim)
    settings = Settings(tolerance=2e-9, increment_tolerance=1e-12, energy_tolerance=1e-20)
    lam = 0.0
    orders = []
    for target in (0.05, 0.1, 0.15, 0.2):
        outcome = newton_point(eq, lam, Control("load", target), settings, lam_scale=target)
        assert outcome.converged, outcome.message
        r = outcome.residual_ratios
        found = [math.log(c / b) / math.log(b / a) for a, b, c in zip(r, r[1:], r[2:]) if a < NEAR and c > FLOOR]
        print(f"\nload factor {target}: {outcome.iterations} iterations, residual / load "
              + " ".join(f"{x:.1e}" for x in r) + "; observed orders " + " ".join(f"{p:.2f}" for p in found))
        orders += found
        eq.forces.commit(eq.full(outcome.d))
        lam = target
    assert orders and min(orders) >= ORDER


# ---------------------------------------------------------------- a rotation probe past a half turn
ROLL_LEVELS, ROLL_LOAD = 5, 1.25        # 5 load levels to 1.25 M_max: the tip turns by 5 pi / 2
ROLL_BOUND = 1.5e-7                     # |ry - closed form| / (2 pi) (measured 9.4e-8: the Newton tolerance)


def test_rotation_probe_accumulates_past_a_full_turn(tmp_path):
    """Issue 28 item 8c: scenes/rollup.toml in fem by Newton, 5 load levels to 1.25 M_max.
    The tip's ry is the angle turned, -M L / (EI) = -2 pi M / M_max (Euler-Bernoulli, constant
    curvature), at every level: down to -5 pi / 2, where the principal rotation vector of
    the orientation reads +3 pi / 2 (Newton's ry read +6.283 at the full turn, relaxation's
    -6.282: Simulation.displacements)."""
    from .conftest import simulation, write_scene
    from .test_grid import rollup_scene
    from taichi_shell_mpm.scene import load_scene
    from taichi_shell_mpm.solvers.newton import run_newton
    text = rollup_scene(tmp_path, ROLL_LEVELS, ROLL_LOAD).replace('components = ["ux", "uz"]',
                                                                   'components = ["ux", "uz", "ry"]')
    scene = load_scene(write_scene(tmp_path, text), ["method.kind=fem", "solve.solver=newton"])
    sim = simulation(scene, tmp_path)
    run_newton(sim, ShellEquations.compiled(sim))
    rows = np.array(sim.history.probe_rows)
    lam, ry = rows[:, 0], rows[:, sim.history.probe_header.index("tip.ry")]
    exact = -2.0 * math.pi * ROLL_LOAD * lam
    error = np.abs(ry - exact).max() / (2.0 * math.pi)
    print(f"\nroll-up to {ROLL_LOAD} M_max by Newton: tip ry {np.round(ry, 6).tolist()} vs -M L / EI "
          f"{np.round(exact, 6).tolist()}: max error {error:.1e} of a turn (bound {ROLL_BOUND:.1e})")
    assert len(lam) == ROLL_LEVELS and exact[-1] < -2.0 * math.pi
    assert error < ROLL_BOUND
