"""Belytschko-Tsay element alone (method.md 3-4, 9): rigid-body modes, membrane patch,
and the small-deflection cantilever against beam theory."""
from __future__ import annotations

import numpy as np
import pytest

from taichi_shell_mpm.scene import load_scene
from taichi_shell_mpm.solvers.static import run_static

from .conftest import element_pass, element_simulation, simulation

E, NU, T = 2.0e5, 0.3, 0.05
DT = 1.0e-4

FLAT = np.array([[0.0, 0.0, 0.0], [1.2, 0.1, 0.0], [1.0, 0.9, 0.0], [-0.1, 1.1, 0.0]])
WARPED = FLAT + np.array([[0, 0, 0.06], [0, 0, -0.06], [0, 0, 0.06], [0, 0, -0.06]])


def rotation_matrix(theta):
    """Rodrigues: rotation by the vector theta."""
    angle = np.linalg.norm(theta)
    k = np.array([[0, -theta[2], theta[1]], [theta[2], 0, -theta[0]], [-theta[1], theta[0], 0]]) / angle
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


@pytest.mark.parametrize("corners", [FLAT, WARPED], ids=["flat", "warped"])
def test_rigid_translation_and_rotation_give_nothing(tmp_path, corners):
    """Discrete rigid motions over one step. For the rotation the nodal omega is the
    rotation's mid-step (Cayley) rate 2 tan(theta/2)/dt, which the mid-step strain
    increment integrates exactly; the rotation is large (0.5 rad) on purpose."""
    sim = element_simulation(tmp_path, corners, E=E, nu=NU, t=T)
    centre = corners.mean(axis=0)
    theta = np.array([0.2, -0.35, 0.25])
    angle = np.linalg.norm(theta)
    cayley_rate = 2 * np.tan(angle / 2) / DT * theta / angle
    rotated = (corners - centre) @ rotation_matrix(theta).T + centre
    shift = np.tile([0.4, -1.1, 0.7], (4, 1))
    cases = {"translation": (corners + DT * shift, shift, np.zeros((4, 3))),
             "rotation": (rotated, (rotated - corners) / DT, np.tile(cayley_rate, (4, 1)))}
    for name, (end, velocity, omega) in cases.items():
        stress, force, moment, hg = element_pass(sim, end, velocity, omega, DT)
        scale = E * DT * np.abs(velocity).max()        # stress of a unit strain increment
        print(f"{name}: max |stress| {np.abs(stress).max():.2e}, |f| {np.abs(force).max():.2e}, "
              f"|m| {np.abs(moment).max():.2e}, |hg| {np.abs(hg).max():.2e} (scale {scale:.1e})")
        assert np.abs(stress).max() <= 1e-12 * scale
        assert np.abs(force).max() <= 1e-12 * scale
        assert np.abs(moment).max() <= 1e-12 * scale
        assert np.abs(hg).max() <= 1e-12 * scale


def test_membrane_patch_gives_exact_stress(tmp_path):
    """Uniform stretch rate on a distorted flat quad: plane-stress C dt eps, every point."""
    sim = element_simulation(tmp_path, FLAT, E=E, nu=NU, t=T)
    rate = np.array([[2e-3, 5e-4, 0.0], [5e-4, -1e-3, 0.0], [0.0, 0.0, 0.0]])   # symmetric L
    # displacement increment dt L x applied about the mid-step geometry: x^n = x - dt/2 L x,
    # x^(n+1) = x + dt/2 L x, so the mid-step strain increment is exactly dt sym(L)
    stress, force, _, hg = element_pass(sim, FLAT + 0.5 * DT * FLAT @ rate.T, FLAT @ rate.T,
                                    np.zeros((4, 3)), DT)
    exx, eyy, gxy = rate[0, 0], rate[1, 1], 2 * rate[0, 1]
    c = E / (1 - NU ** 2)
    exact = DT * np.array([c * (exx + NU * eyy), c * (NU * exx + eyy), E / (2 * (1 + NU)) * gxy])
    # the BT frame's e1 runs along edge 1-2; rotate the exact global stress into it
    e1 = (FLAT[1] - FLAT[0]) / np.linalg.norm(FLAT[1] - FLAT[0])
    cth, sth = e1[0], e1[1]
    sx, sy, sxy = exact
    local = np.array([sx * cth ** 2 + sy * sth ** 2 + 2 * sxy * cth * sth,
                      sx * sth ** 2 + sy * cth ** 2 - 2 * sxy * cth * sth,
                      (sy - sx) * cth * sth + sxy * (cth ** 2 - sth ** 2)])
    err = np.abs(stress[:, :3] - local).max() / np.abs(local).max()
    print(f"membrane patch: relative stress error {err:.2e}; hourglass {np.abs(hg).max():.1e}")
    assert err < 1e-12
    assert np.abs(stress[:, 3:]).max() < 1e-12 * np.abs(local).max()
    assert np.abs(hg).max() < 1e-12 * np.abs(force).max()
    assert np.abs(force.sum(axis=0)).max() < 1e-12 * np.abs(force).max()     # self-equilibrated


def test_small_deflection_cantilever_matches_beam_theory(tmp_path):
    """Tip deflection of the 10x1 strip under a tiny end load: PL^3/3EI + PL/(kGA)."""
    from pathlib import Path
    root = Path(__file__).resolve().parents[1]
    P = 1e-3
    scene = load_scene(root / "scenes" / "cantilever.toml",
                       ["load.0.force=[0.0, 0.0, 0.001]", "solve.load_steps=1", "solve.tolerance=1e-7",
                        "output.load_steps=false"])
    sim = simulation(scene, tmp_path)
    run_static(sim)
    uz = sim.probe_values()[1]
    L, b, t, E_, nu = 10.0, 1.0, 0.1, 1.2e6, 0.0
    EI = E_ * b * t ** 3 / 12
    kGA = 5 / 6 * E_ / (2 * (1 + nu)) * b * t
    exact = P * L ** 3 / (3 * EI) + P * L / kGA
    err = abs(uz - exact) / exact
    print(f"small-deflection tip {uz:.6e} vs beam theory {exact:.6e}: error {100 * err:.3f}%")
    assert err < 0.01


def kirchhoff_rates(corners, coefficients):
    """Nodal rates of the Kirchhoff field w' = a x^2 + b x y + c y^2 about the centre (flat
    quad in z = 0): v = (0, 0, w'), omega = (dw'/dy, -dw'/dx, 0) (shell.py's signs)."""
    a, b, c = coefficients
    x, y = (corners - corners.mean(axis=0))[:, :2].T
    velocity = np.zeros((4, 3))
    omega = np.zeros((4, 3))
    velocity[:, 2] = a * x * x + b * x * y + c * y * y
    omega[:, 0] = b * x + 2 * c * y
    omega[:, 1] = -(2 * a * x + b * y)
    return velocity, omega


@pytest.mark.parametrize("coefficients", [(0.0, 1.0, 0.0), (0.7, 0.0, 0.0), (0.3, -0.5, 0.9)],
                         ids=["twist", "bending", "mixed"])
def test_transverse_hourglass_leaves_kirchhoff_bending_and_twist_alone(tmp_path, coefficients):
    """A quadratic Kirchhoff w-field on the distorted quad FLAT: its bilinear part is not an
    hourglass mode.  The paper's w-rate (w_hourglass = "bt", the default) resists it, the
    "kirchhoff" option (stages/hourglass.py) leaves Q_W at round-off of the mid-step geometry;
    bending stresses are the same.  The spurious mode (w = h, no rotation) is still resisted
    alike by both."""
    velocity, omega = kirchhoff_rates(FLAT, coefficients)
    spurious = np.zeros((4, 3))
    spurious[:, 2] = [1.0, -1.0, 1.0, -1.0]
    results = {}
    for option in ("kirchhoff", "bt"):
        (tmp_path / option).mkdir()
        sim = element_simulation(tmp_path / option, FLAT, E=E, nu=NU, t=T, element=f'w_hourglass = "{option}"')
        bent = element_pass(sim, FLAT + DT * velocity, velocity, omega, DT)
        hourglass = element_pass(sim, FLAT + DT * spurious, spurious, np.zeros((4, 3)), DT)
        results[option] = (bent, hourglass)
    (stress_k, _, _, q_k), (_, _, _, qh_k) = results["kirchhoff"]
    (stress_b, _, _, q_b), (_, _, _, qh_b) = results["bt"]
    print(f"\nQ_W of the Kirchhoff field: kirchhoff {q_k[2]:.3e}, bt {q_b[2]:.3e}; "
          f"of the spurious mode: {qh_k[2]:.4e}, {qh_b[2]:.4e}")
    assert abs(q_b[2]) > 1e-3 * abs(qh_b[2])               # bt does resist the smooth field
    assert abs(q_k[2]) < 1e-6 * abs(q_b[2])
    assert np.allclose(stress_k, stress_b, rtol=0, atol=1e-12 * np.abs(stress_b).max())
    assert abs(qh_k[2] - qh_b[2]) < 1e-9 * abs(qh_b[2])


@pytest.mark.parametrize("part", ["kirchhoff", "bt", "drilling"])
def test_artificial_loads_are_the_transpose_of_the_rates(part):
    """Power identity of the hourglass part (method.md 3.6, 4; w_hourglass "kirchhoff" or "bt")
    and of the drilling spring (stages/drilling.py): for any resultant Q and any nodal rates,
    sum_a (f_a . v_a + m_a . theta_a) = Q . q, on a distorted, warped quad."""
    import taichi as ti

    from taichi_shell_mpm.simulation import init_taichi
    from taichi_shell_mpm.stages.drilling import DrillingSpring
    from taichi_shell_mpm.stages.hourglass import Hourglass
    from taichi_shell_mpm.stages.shell import gradient_operators
    init_taichi("cpu")
    hourglass = Hourglass(E, E / (2 * (1 + NU)), T, 5.0 / 6.0, 0.05, part == "kirchhoff")
    drilling = DrillingSpring(E, T, 1.0)
    rng = np.random.default_rng(7)
    xh, yh, zh = (WARPED - WARPED.mean(axis=0)).T
    v, w, q = rng.normal(size=(4, 3)), rng.normal(size=(4, 3)), rng.normal(size=5)
    out = ti.field(ti.f64, 2)
    data = ti.field(ti.f64, 12 + 12 + 12 + 5)           # xh, yh, zh (4 each), v, w (4x3), q
    data.from_numpy(np.concatenate([xh, yh, zh, v.ravel(), w.ravel(), q]))

    @ti.kernel
    def power():
        xh = ti.Vector([data[a] for a in range(4)])
        yh = ti.Vector([data[4 + a] for a in range(4)])
        zh = ti.Vector([data[8 + a] for a in range(4)])
        vx = ti.Vector([data[12 + 3 * a] for a in range(4)])
        vy = ti.Vector([data[13 + 3 * a] for a in range(4)])
        vz = ti.Vector([data[14 + 3 * a] for a in range(4)])
        tx = ti.Vector([data[24 + 3 * a] for a in range(4)])
        ty = ti.Vector([data[25 + 3 * a] for a in range(4)])
        tz = ti.Vector([data[26 + 3 * a] for a in range(4)])
        q = ti.Vector([data[36 + i] for i in range(5)])
        area, b1, b2 = gradient_operators(xh, yh)
        gam = hourglass.shape_vector(xh, yh, b1, b2)
        zw = hourglass.warp_height(zh)
        moments = hourglass.quadratic_moments(gam, xh, yh)
        curvature_rate = ti.Vector([b1.dot(ty), -b2.dot(tx), b2.dot(ty) - b1.dot(tx)])
        f = ti.Matrix.zero(ti.f64, 4, 3)
        m = ti.Matrix.zero(ti.f64, 4, 3)
        if ti.static(part == "drilling"):
            corner_moments = ti.Vector([q[0], q[1], q[2], q[3]])
            out[0] = corner_moments.dot(drilling.rates(b1, b2, vx, vy, tz))
            f, m = drilling.nodal_loads(corner_moments, b1, b2)
        else:
            out[0] = q.dot(hourglass.rates(gam, zw, vx, vy, vz, tx, ty, moments, curvature_rate))
            f, m = hourglass.nodal_loads(gam, zw, q, moments, b1, b2)
        out[1] = (f[:, 0] * vx + f[:, 1] * vy + f[:, 2] * vz + m[:, 0] * tx + m[:, 1] * ty + m[:, 2] * tz).sum()

    power()
    rate_power, load_power = out.to_numpy()
    print(f"\nQ.q {rate_power:.15e}, loads . rates {load_power:.15e}")
    assert abs(rate_power - load_power) < 1e-12 * (abs(rate_power) + 1.0)
