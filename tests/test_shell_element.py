"""Belytschko-Tsay element alone (method.md 3-4, 9): rigid-body modes, membrane patch,
the element's power identity, constant-curvature patches, and the small-deflection
cantilever against beam theory."""
from __future__ import annotations

import numpy as np
import pytest

from taichi_shell_mpm.scene import load_scene
from taichi_shell_mpm.solvers.static import run_static

from .conftest import element_pass, element_simulation, element_stage, simulation

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

    from taichi_shell_mpm.runtime import init_taichi
    from taichi_shell_mpm.stages.drilling import DrillingSpring
    from taichi_shell_mpm.stages.hourglass import Hourglass
    from taichi_shell_mpm.stages.shell import gradient_operators
    init_taichi("cpu")
    hourglass = Hourglass(None, part == "kirchhoff")       # rates and loads only: no state needed
    drilling = DrillingSpring(None)
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


# ------------------------------------------------------------------ numpy twin of method.md 3.1-3.2, 4
HOURGLASS_H = np.array([1.0, -1.0, 1.0, -1.0])


def element_kinematics(x, v, w):
    """The BT element's rates at the corner positions x (4x3) for corner velocities v and
    angular velocities w (method.md 3.1-3.2, 4, and the "kirchhoff" w-rate and drilling
    rate of stages/hourglass.py and stages/drilling.py), written out from the documents, not
    from the kernels: area, membrane rate, curvature rate, transverse shear rate, hourglass
    rates (qMx, qMy, qW, qBx, qBy) and drilling rates (one per corner)."""
    e3 = np.cross(x[2] - x[0], x[3] - x[1])
    e3 /= np.linalg.norm(e3)
    r21 = x[1] - x[0]
    e1 = r21 - r21 @ e3 * e3
    e1 /= np.linalg.norm(e1)
    rot = np.array([e1, np.cross(e3, e1), e3])
    xh, yh, zh = ((x - x.mean(axis=0)) @ rot.T).T
    vx, vy, vz = (v @ rot.T).T
    tx, ty, tz = (w @ rot.T).T
    area = 0.5 * ((xh[2] - xh[0]) * (yh[3] - yh[1]) + (xh[1] - xh[3]) * (yh[2] - yh[0]))
    b1 = np.array([yh[1] - yh[3], yh[2] - yh[0], yh[3] - yh[1], yh[0] - yh[2]]) / (2 * area)
    b2 = np.array([xh[3] - xh[1], xh[0] - xh[2], xh[1] - xh[3], xh[2] - xh[0]]) / (2 * area)
    membrane = np.array([b1 @ vx, b2 @ vy, b2 @ vx + b1 @ vy])
    curvature = np.array([b1 @ ty, -b2 @ tx, b2 @ ty - b1 @ tx])
    shear = np.array([b1 @ vz + 0.25 * ty.sum(), b2 @ vz - 0.25 * tx.sum()])
    gamma = HOURGLASS_H - (HOURGLASS_H @ xh) * b1 - (HOURGLASS_H @ yh) * b2
    zw = 0.25 * HOURGLASS_H @ zh
    quadratic = np.array([gamma @ (xh * xh), gamma @ (yh * yh), gamma @ (xh * yh)])
    hourglass = np.array([gamma @ vx - zw * ty.sum(), gamma @ vy + zw * tx.sum(),
                          gamma @ vz + 0.5 * quadratic @ curvature, gamma @ tx, gamma @ ty])
    drilling = tz - 0.5 * (b1 @ vy - b2 @ vx)
    return area, membrane, curvature, shear, hourglass, drilling


def resultants(sim, stress):
    """N, M' = -int z sigma (paper sign) and Q of one element's point stresses (method.md 3.5)."""
    t = float(sim.model.element.thickness[0])
    zeta, weight = sim.model.sections.zeta[0], sim.model.sections.weight[0]
    return (0.5 * t * weight @ stress[:, :3], -0.25 * t * t * (weight * zeta) @ stress[:, :3],
            0.5 * t * weight @ stress[:, 3:5])


# a thick section and raised artificial stiffnesses: every part's power is of the same order
ARTIFICIAL = "hourglass = 0.5\ndrilling_stiffness = 1.0"


@pytest.mark.parametrize("corners", [FLAT, WARPED], ids=["flat", "warped"])
def test_element_power_identity(tmp_path, corners):
    """method.md 3.6: sum_a (f.v + m.theta) = A (N.eps0' - M'.kappa' + kappa Q.gamma') plus the
    hourglass power Q_hg.q' and the drilling spring's sum M_a (theta_z - Omega), for random
    corner velocities and rotation rates on a distorted (and a warped) quad.  The nodal loads
    come from the element stage (global frame, after its resultants, hourglass and drilling
    update); the rates from the numpy twin above at the same geometry, so the identity holds
    to round-off whatever the resultants are.  The stress power is also summed point by
    point, A t/2 sum_k w_k (sigma_k . (eps0' + z_k kappa') + kappa tau_k . gamma'), which
    checks the resultants' signs (M' = -int z sigma).  Finally the element's own energy
    increments (internal + hourglass + drilling, trapezoidal in time from zero stress, on the
    mid-step geometry) are 1/2 dt times that power up to O(dt |v| / l) = 1e-10 here."""
    rng = np.random.default_rng(16)
    dt = 1e-10
    kappa = 5.0 / 6.0
    t = 0.8
    for draw in range(3):
        (tmp_path / str(draw)).mkdir()
        sim = element_simulation(tmp_path / str(draw), corners, E=E, nu=NU, t=t,
                                 section="points = 5\nrule = \"gauss\"", element=ARTIFICIAL)
        v, w = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
        s = sim.state
        before = s.step.internal_energy[None] + s.step.hourglass_energy[None] + s.step.drilling_energy[None]
        stress, force, moment, q_hg, drill = element_stage(sim, corners, v, w, dt)
        energy = s.step.internal_energy[None] + s.step.hourglass_energy[None] + s.step.drilling_energy[None] - before
        area, membrane, curvature, shear, hourglass_rate, drilling_rate = element_kinematics(corners, v, w)
        n_res, m_res, q_res = resultants(sim, stress[0])
        parts = area * np.array([n_res @ membrane, -m_res @ curvature, kappa * q_res @ shear])
        bt = parts.sum()
        zeta, weight = sim.model.sections.zeta[0], sim.model.sections.weight[0]
        pointwise = area * 0.5 * t * sum(
            wk * (stress[0, k, :3] @ (membrane + 0.5 * t * zeta[k] * curvature) + kappa * stress[0, k, 3:5] @ shear)
            for k, wk in enumerate(weight))
        hg = q_hg[0] @ hourglass_rate
        dr = drill[0] @ drilling_rate
        nodal = np.sum(force * v) + np.sum(moment * w)
        scale = np.sum(np.abs(force * v)) + np.sum(np.abs(moment * w))
        print(f"\ndraw {draw}: nodal power {nodal:.15e}; BT {bt:.6e} (membrane, bending, shear "
              f"{parts[0]:.2e}, {parts[1]:.2e}, {parts[2]:.2e}; point sum {pointwise:.6e}), "
              f"hourglass {hg:.6e}, drilling {dr:.6e}: identity {abs(nodal - bt - hg - dr) / scale:.1e}, "
              f"point sum {abs(pointwise - bt) / scale:.1e}, energy increment {abs(2 * energy / dt - nodal) / scale:.1e}")
        assert min(*np.abs(parts), abs(hg), abs(dr)) > 1e-3 * scale      # every part takes part
        assert abs(nodal - bt - hg - dr) <= 1e-13 * scale
        assert abs(pointwise - bt) <= 1e-13 * scale
        assert abs(2 * energy / dt - nodal) <= 1e-8 * scale


def patch_mesh(kind: str, n: int = 3):
    """Nodes and quads (counter-clockwise, edge 1-2 along +x) of an n x n patch: rectangles
    0.4 x 0.3, parallelograms (the same with each row shifted 0.15 in x), or the rectangles
    with every node moved at random by up to 0.06 (boundary nodes along their edge only)."""
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    x = 0.4 * i + (0.15 * j if kind == "parallelogram" else 0.0)
    y = 0.3 * j
    if kind == "distorted":
        rng = np.random.default_rng(3)
        dx, dy = rng.uniform(-0.06, 0.06, size=(2, n + 1, n + 1))
        x = x + np.where((i > 0) & (i < n), dx, 0.0)
        y = y + np.where((j > 0) & (j < n), dy, 0.0)
    points = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    node = lambda a, b: a * (n + 1) + b          # noqa: E731
    quads = np.array([[node(a, b), node(a + 1, b), node(a + 1, b + 1), node(a, b + 1)]
                      for a in range(n) for b in range(n)])
    interior = np.array([node(a, b) for a in range(1, n) for b in range(1, n)])
    return points, quads, interior


def to_element_frame(kappa, corners):
    """Curvature (xx, yy, xy engineering) of the global x-y axes in the frame of a flat quad in
    z = 0 whose e1 runs along edge 1-2."""
    c, s = (corners[1, :2] - corners[0, :2]) / np.linalg.norm(corners[1, :2] - corners[0, :2])
    kxx, kyy, kxy = kappa
    return np.array([kxx * c * c + kyy * s * s + kxy * c * s, kxx * s * s + kyy * c * c - kxy * c * s,
                     2 * (kyy - kxx) * c * s + kxy * (c * c - s * s)])


@pytest.mark.parametrize("kind", ["rectangular", "parallelogram", "distorted"])
def test_constant_curvature_patch(tmp_path, kind):
    """method.md 9: constant-curvature patches are exact on parallelogram meshes.  A 3x3 patch
    gets the nodal rates of a Kirchhoff field w' = a x^2 + b x y + c y^2 (about the patch
    centre; omega = (dw'/dy, -dw'/dx, 0)) for pure bending, pure twist and a mix: the
    curvature rate is kappa' = -(2a, 2c, 2b) and, from zero stress, M' = -dt D kappa' in every
    element.  Checked on every mesh: those moments (the B operators differentiate linear
    rotations exactly on any quad) and zero hourglass rates (gamma is orthogonal to linear
    rotations, and the "kirchhoff" w-rate removes a quadratic w).  On the rectangles and
    parallelograms also zero transverse shear Q and zero resultant force and moment at the
    four interior nodes (the patch is in equilibrium under its boundary moments alone).  On
    the distorted patch the one-point shear sum B1 w + 1/4 sum theta is not exact (method.md 9):
    its Q and interior residual are printed, not asserted.
    dt = 1e-13: the stage evaluates the rates on the mid-step geometry x - dt/2 v and the
    forces on x; the nodes are placed at x = X + dt/2 v, so the rates see the flat patch and
    the forces a patch bent by ~1e-13 (round-off)."""
    points, quads, interior = patch_mesh(kind)
    centre = points.mean(axis=0)
    t, dt = T, 1e-13
    sim = element_simulation(tmp_path, points, E=E, nu=NU, t=t, quads=quads)
    bending = E * t ** 3 / (12 * (1 - NU ** 2)) * np.array([[1, NU, 0], [NU, 1, 0], [0, 0, (1 - NU) / 2]])
    hourglass_r = sim.scene.element.hourglass
    for name, (a, b, c) in {"bending": (0.7, 0.0, 0.0), "twist": (0.0, 1.0, 0.0),
                            "mixed": (0.3, -0.5, 0.9)}.items():
        x, y = (points - centre)[:, :2].T
        velocity = np.zeros_like(points)
        omega = np.zeros_like(points)
        velocity[:, 2] = a * x * x + b * x * y + c * y * y
        omega[:, 0] = b * x + 2 * c * y
        omega[:, 1] = -(2 * a * x + b * y)
        curvature = np.array([-2 * a, -2 * c, -2 * b])
        stress, force, moment, q_hg, _ = element_stage(sim, points + 0.5 * dt * velocity, velocity, omega, dt)
        moment_error = shear_rate = shear = hourglass = stage_hourglass = 0.0
        for e, quad in enumerate(quads):
            exact = -dt * bending @ to_element_frame(curvature, points[quad])
            _, m_res, q_res = resultants(sim, stress[e])
            moment_error = max(moment_error, np.abs(m_res - exact).max() / np.abs(exact).max())
            area, _, _, gamma, rates, _ = element_kinematics(points[quad], velocity[quad], omega[quad])
            ell = np.sqrt(area)
            shear_rate = max(shear_rate, np.abs(gamma).max() / (np.abs(curvature).max() * ell))
            shear = max(shear, np.abs(q_res).max() * ell / np.abs(exact).max())
            hourglass = max(hourglass, np.abs(rates).max() / np.abs(velocity[quad]).max())
            # what the stage's Q_hg would be for rates of the size of the nodal ones (method.md 4)
            xh, yh = points[quad, 0], points[quad, 1]
            b1 = np.array([yh[1] - yh[3], yh[2] - yh[0], yh[3] - yh[1], yh[0] - yh[2]]) / (2 * area)
            b2 = np.array([xh[3] - xh[1], xh[0] - xh[2], xh[1] - xh[3], xh[2] - xh[0]]) / (2 * area)
            beta = b1 @ b1 + b2 @ b2
            g = E / (2 * (1 + NU))
            size = dt * max(hourglass_r * 5 / 6 * g * t ** 3 * beta / 12 * np.abs(velocity[quad]).max(),
                            hourglass_r * E * t ** 3 * area * beta / 192 * np.abs(omega[quad]).max())
            stage_hourglass = max(stage_hourglass, np.abs(q_hg[e]).max() / size)
        residual = max(np.abs(moment[interior]).max(), np.abs(force).max() * 0.3) / np.abs(moment).max()
        print(f"\n{kind} {name}: moments vs D kappa {moment_error:.1e}; hourglass rates {hourglass:.1e} "
              f"(stage Q_hg {stage_hourglass:.1e}); shear rate / (kappa l) {shear_rate:.1e}, Q l / M {shear:.1e}; "
              f"interior residual / boundary moment {residual:.1e}")
        assert moment_error < 1e-12
        assert hourglass < 1e-12
        assert stage_hourglass < 1e-12
        if kind != "distorted":
            assert shear_rate < 1e-12 and shear < 1e-12
            assert residual < 1e-12
