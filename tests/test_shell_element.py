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
