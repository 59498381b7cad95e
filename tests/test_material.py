"""J2 plane-stress plasticity (method.md 3.4, Simo & Taylor 1986): the return map at one
point (uniaxial hardening line, return onto the ellipse with normal flow, plastic
incompressibility, random-path robustness) and the limit moment of a plate bent through
one BT element."""

import meshio
import numpy as np
import pytest
import taichi as ti

from taichi_shell_mpm.model.materials import MATERIAL_PARAMETERS, hardening_laws, parameter_row, rate_laws
from taichi_shell_mpm.quadrature import through_thickness_rule
from taichi_shell_mpm.scene import Material, load_scene
from taichi_shell_mpm.runtime import init_taichi
from taichi_shell_mpm.stages.material import PlaneStressJ2

from .conftest import element_stage, unwarmed_simulation, write_scene

E, NU, SY0, H = 2.0e5, 0.3, 250.0, 2000.0
EPS_Y = SY0 / E                                          # uniaxial yield strain
C = E / (1 - NU ** 2) * np.array([[1, NU, 0], [NU, 1, 0], [0, 0, (1 - NU) / 2]])
C_INV = np.linalg.inv(C)
P = np.array([[2, -1, 0], [-1, 2, 0], [0, 0, 6]]) / 3.0  # plane-stress J2: q^2 = 3/2 sigma.P.sigma


def mises(s):
    """Plane-stress von Mises stress q of (..., >=3) stress arrays."""
    return np.sqrt(s[..., 0] ** 2 - s[..., 0] * s[..., 1] + s[..., 1] ** 2 + 3 * s[..., 2] ** 2)


def plastic_tensor(dep):
    """3x3 plastic strain tensor from in-plane (de11, de22, dgamma12): shear halved and
    e33 = -(e11 + e22) (plastic incompressibility; sigma33 = 0 needs no e33 in the update)."""
    return np.array([[dep[0], dep[2] / 2, 0], [dep[2] / 2, dep[1], 0], [0, 0, -dep[0] - dep[1]]])


def equivalent(tensor):
    return np.sqrt(2.0 / 3.0 * np.sum(tensor * tensor))


class Points:
    """PlaneStressJ2.update run in a kernel at independent points along increment paths: the
    linear material (E, NU, SY0, `hardening`), or the scene material `spec` with its laws,
    with steps of `dt` (the rate laws' time; no filter).  ``converged`` holds each update's
    flag after :meth:`path`."""

    def __init__(self, hardening=0.0, spec=None, dt=1.0):
        init_taichi("cpu")
        spec = spec or Material(E=E, nu=NU, density=1.0, model="j2", yield_stress=SY0, hardening=hardening)
        self.mat = mat = PlaneStressJ2(hardening=hardening_laws([spec]), rates=rate_laws([spec]))
        parameters = tuple(float(x) for x in parameter_row(spec, MATERIAL_PARAMETERS))   # its table row

        @ti.kernel
        def run(stress: ti.types.ndarray(ti.f64, 2), ebar: ti.types.ndarray(ti.f64, 1),
                incr: ti.types.ndarray(ti.f64, 3), out_stress: ti.types.ndarray(ti.f64, 3),
                out_ebar: ti.types.ndarray(ti.f64, 2), out_work: ti.types.ndarray(ti.f64, 2),
                out_converged: ti.types.ndarray(ti.i32, 2)):
            row = ti.Vector(parameters, dt=ti.f64)
            for p in range(incr.shape[0]):
                s = ti.Vector([stress[p, 0], stress[p, 1], stress[p, 2], stress[p, 3], stress[p, 4]])
                ep = ebar[p]
                for k in range(incr.shape[1]):
                    s, ep, _, w, ok = mat.update(row, ti.Vector([1.0, 0.0]), s, ep, 0.0,
                                                 ti.Vector([incr[p, k, 0], incr[p, k, 1], incr[p, k, 2]]),
                                                 ti.Vector([incr[p, k, 3], incr[p, k, 4]]), dt)
                    for i in ti.static(range(5)):
                        out_stress[p, k, i] = s[i]
                    out_ebar[p, k] = ep
                    out_work[p, k] = w
                    out_converged[p, k] = ti.cast(ok, ti.i32)

        self.kernel = run

    def path(self, incr, stress=None, ebar=None):
        """incr (n_points, n_steps, 5 or 3): stress history (n, steps, 5), ebar and work (n, steps)."""
        incr = np.asarray(incr, dtype=float)
        n, steps = incr.shape[:2]
        incr = np.concatenate([incr, np.zeros((n, steps, 5 - incr.shape[2]))], axis=2)
        stress = np.zeros((n, 5)) if stress is None else np.asarray(stress, dtype=float).reshape(n, 5)
        ebar = np.zeros(n) if ebar is None else np.asarray(ebar, dtype=float).reshape(n)
        out_s, out_e, out_w = np.zeros((n, steps, 5)), np.zeros((n, steps)), np.zeros((n, steps))
        self.converged = np.zeros((n, steps), np.int32)
        self.kernel(stress, ebar, incr, out_s, out_e, out_w, self.converged)
        return out_s, out_e, out_w

    def step(self, stress, ebar, d_strain):
        s, e, w = self.path(np.reshape(d_strain, (1, 1, 3)), stress, ebar)
        return s[0, 0], e[0, 0], w[0, 0]

    def uniaxial(self, dexx, steps):
        """Uniaxial plane stress: each step applies dexx and solves deyy (secant) for syy = 0.
        Returns the total strain (steps + 1, 3), stress (steps + 1, 5) and ebar histories."""
        stress, ebar, deyy = np.zeros(5), 0.0, -NU * dexx
        eps, sig, ep = [np.zeros(3)], [np.zeros(5)], [0.0]
        for _ in range(steps):
            def syy(d):
                return self.step(stress, ebar, [dexx, d, 0.0])[0][1]
            x0, x1 = deyy, 0.5 * (deyy - 0.5 * dexx)
            f0, f1 = syy(x0), syy(x1)
            for _ in range(50):
                if abs(f1) < 1e-13 * SY0 or f1 == f0:
                    break
                x0, x1, f0 = x1, x1 - f1 * (x1 - x0) / (f1 - f0), f1
                f1 = syy(x1)
            assert abs(f1) < 1e-12 * SY0
            deyy = x1
            stress, ebar, _ = self.step(stress, ebar, [dexx, deyy, 0.0])
            eps.append(eps[-1] + [dexx, deyy, 0.0])
            sig.append(stress)
            ep.append(ebar)
        return np.array(eps), np.array(sig), np.array(ep)


@pytest.mark.parametrize("hardening", [H, 0.0])
def test_uniaxial_yield_point_and_hardening_slopes(hardening):
    """sigma = E eps up to sigma_y0, then d sigma / d eps_p = H and d sigma / d eps = E H/(E + H)."""
    pts = Points(hardening)
    strain, sig, ebar = pts.uniaxial(EPS_Y / 25, 300)       # to 12 yield strains
    eps, sxx = strain[:, 0], sig[:, 0]
    assert np.abs(sig[:, 1:]).max() < 1e-12 * SY0
    elastic, plastic = ebar == 0, eps > 2 * EPS_Y
    elastic_slope = np.polyfit(eps[elastic], sxx[elastic], 1)[0]
    tangent, offset = np.polyfit(eps[plastic], sxx[plastic], 1)
    yield_stress = E * offset / (E - tangent)                # where sigma = E eps meets the plastic line
    ep_xx = eps - sxx / E                                    # plastic strain, measured from outside
    plastic_modulus = np.polyfit(ep_xx[plastic], sxx[plastic], 1)[0]
    expected_tangent = E * hardening / (E + hardening)
    print(f"H = {hardening}: elastic slope/E = {elastic_slope / E:.12f}, yield intersection "
          f"{yield_stress:.10f} (sigma_y0 {SY0}), d sigma/d eps_p = {plastic_modulus:.6f}, "
          f"d sigma/d eps = {tangent:.6f} (E H/(E+H) = {expected_tangent:.6f}), "
          f"max |ebar - eps_p| = {np.abs(ebar - ep_xx).max():.2e}")
    assert abs(elastic_slope / E - 1) < 1e-10
    assert sxx[elastic].max() <= SY0 * (1 + 1e-12)
    assert abs(yield_stress / SY0 - 1) < 1e-6
    assert abs(plastic_modulus - hardening) <= 1e-3 * max(hardening, 1e-3 * E)
    assert abs(tangent - expected_tangent) <= 1e-3 * max(expected_tangent, 1e-3 * E)
    assert np.abs(ebar - ep_xx).max() < 1e-10 * ebar.max()
    if hardening == 0:
        dev = np.abs(sxx[~elastic] / SY0 - 1).max()
        print(f"perfect plasticity: max |sigma/sigma_y - 1| after yield = {dev:.2e}")
        assert dev < 1e-10


@pytest.mark.parametrize("hardening", [H, 0.0])
def test_return_lands_on_the_ellipse_with_normal_flow(hardening):
    """Large trial states: q = sigma_y(ebar) after the return; the plastic increment
    d eps - C^-1 d sigma is d lambda P sigma (normal, backward Euler) and its equivalent
    sqrt(2/3 dep:dep) (3-D, e33 = -(e11 + e22)) equals the returned d ebar."""
    start = np.array([120.0, -60.0, 40.0, 3.0, -2.0])
    cases = {"equibiaxial": (np.zeros(5), 0.0, [5 * EPS_Y, 5 * EPS_Y, 0.0]),
             "pure shear": (np.zeros(5), 0.0, [0.0, 0.0, 8 * EPS_Y]),
             "general": (start, 0.01, [4 * EPS_Y, -1.5 * EPS_Y, 6 * EPS_Y])}
    pts = Points(hardening)
    for name, (stress, ebar0, d_strain) in cases.items():
        new, ebar, work = pts.step(stress, ebar0, d_strain)
        sy = SY0 + hardening * ebar
        d_ebar = ebar - ebar0
        dep = np.asarray(d_strain) - C_INV @ (new[:3] - stress[:3])
        normal = P @ new[:3]
        dlam = dep @ normal / (normal @ normal)
        off_normal = np.linalg.norm(dep - dlam * normal) / np.linalg.norm(dep)
        eq = equivalent(plastic_tensor(dep))
        print(f"{name} (H={hardening}): q_trial/sigma_y = {mises(stress + np.r_[C @ d_strain, 0, 0]) / sy:.3f}, "
              f"q/sigma_y(ebar) - 1 = {mises(new) / sy - 1:.1e}, d ebar = {d_ebar:.6e}, "
              f"|dep off normal|/|dep| = {off_normal:.1e}, equivalent(dep)/d ebar - 1 = {eq / d_ebar - 1:.1e}, "
              f"dlambda = {dlam:.4e}, work/(sigma_y_mid d ebar) - 1 = "
              f"{work / ((SY0 + hardening * (ebar0 + ebar) / 2) * d_ebar) - 1:.1e}")
        assert d_ebar > 0 and dlam > 0
        assert abs(mises(new) / sy - 1) < 1e-10
        assert off_normal < 1e-10
        assert abs(eq / d_ebar - 1) < 1e-10
        assert np.array_equal(new[3:], stress[3:])                    # transverse shear: G dgamma = 0 here
        assert abs(work - (SY0 + hardening * (ebar0 + ebar) / 2) * d_ebar) < 1e-12 * work
    new, _, _ = pts.step(np.zeros(5), 0.0, cases["equibiaxial"][2])
    assert new[0] == new[1] and new[2] == 0                             # equibiaxial stays equibiaxial
    new, _, _ = pts.step(np.zeros(5), 0.0, cases["pure shear"][2])
    assert new[0] == 0 and new[1] == 0                                 # pure shear stays pure shear


def test_plastic_incompressibility_along_proportional_paths():
    """Paths whose plastic flow keeps one direction: the accumulated 3-D plastic strain
    (e33 = -(e11 + e22): trace-free; sigma33 = 0) gives sqrt(2/3 ep:ep) = ebar, and each
    increment is d lambda dev(sigma) with sigma33 = 0."""
    pts = Points(H)
    steps = 200
    paths = {"equibiaxial": np.tile([EPS_Y / 20, EPS_Y / 20, 0.0], (steps, 1)),
             "pure shear": np.tile([0.0, 0.0, EPS_Y / 15], (steps, 1))}
    histories = {name: (np.cumsum(incr, axis=0), *pts.path(incr[None])[:2]) for name, incr in paths.items()}
    strain, sig, ebar = pts.uniaxial(EPS_Y / 20, steps)
    histories["uniaxial stress"] = (strain[1:], sig[None, 1:], ebar[None, 1:])
    for name, (strain, sig, ebar) in histories.items():
        sig, ebar = sig[0], ebar[0]
        ep = strain - sig[:, :3] @ C_INV.T               # in-plane plastic strain (engineering shear)
        tensor = plastic_tensor(ep[-1])
        worst_flow = 0.0
        for k in range(1, steps):
            dep = plastic_tensor(ep[k] - ep[k - 1])
            if ebar[k] > ebar[k - 1]:
                s3 = np.array([[sig[k, 0], sig[k, 2], 0], [sig[k, 2], sig[k, 1], 0], [0, 0, 0]])   # sigma33 = 0
                dev = s3 - np.trace(s3) / 3 * np.eye(3)
                dlam = np.sum(dep * dev) / np.sum(dev * dev)
                worst_flow = max(worst_flow, np.abs(dep - dlam * dev).max() / np.abs(dep).max())
        ratio = equivalent(tensor) / ebar[-1]
        print(f"{name}: ebar = {ebar[-1]:.6e}, sqrt(2/3 ep:ep) / ebar - 1 = {ratio - 1:.1e}, "
              f"trace ep = {np.trace(tensor):.1e}, ep33 = {tensor[2, 2]:.4e}, "
              f"max |dep - dlambda dev(sigma)|/|dep| = {worst_flow:.1e}")
        assert abs(ratio - 1) < 1e-8
        assert worst_flow < 1e-8


def test_random_paths_stay_admissible():
    """Seeded random increments (all five components, 0.01 to 10 yield strains, reversals):
    finite, q <= sigma_y(ebar)(1 + 1e-10), ebar non-decreasing, plastic work >= 0."""
    rng = np.random.default_rng(20260)
    n, steps = 400, 300
    direction = rng.normal(size=(n, steps, 5))
    direction /= np.linalg.norm(direction, axis=2, keepdims=True)
    incr = direction * EPS_Y * 10 ** rng.uniform(-2, 1, size=(n, steps, 1))
    for hardening in (0.0, H, 50 * H):
        sig, ebar, work = Points(hardening).path(incr)
        sy = SY0 + hardening * ebar
        excess = (mises(sig) / sy - 1).max()
        d_ebar = np.diff(ebar, axis=1).min()
        plastic_steps = np.count_nonzero(np.diff(ebar, axis=1) > 0)
        print(f"H = {hardening}: {n}x{steps} steps, {plastic_steps} plastic, max q/sigma_y - 1 = {excess:.1e}, "
              f"min d ebar = {d_ebar:.1e}, min work = {work.min():.1e}, max ebar = {ebar.max():.3f}")
        assert np.all(np.isfinite(sig)) and np.all(np.isfinite(ebar)) and np.all(np.isfinite(work))
        assert excess <= 1e-10
        assert d_ebar >= 0 and ebar[:, 0].min() >= 0
        assert work.min() >= 0
        assert plastic_steps > n * steps // 10


# Four unconnected copies of the square element, one per rule (3, 5, 7, 9 Lobatto points), each
# its own part and section: one compile serves the four rules (Features.points is the most of any
# section; each section's point count is run-time data).
RULES = (3, 5, 7, 9)
PATCH = """
[scene]
name = "rules"
units = "consistent"
[mesh]
kind = "file"
path = "rules.vtu"
[materials.j2]
E = {E}
nu = {nu}
density = 1.0
model = "j2"
yield_stress = {sy}
hardening = 0.0
[method]
kind = "fem"
[solve]
kind = "dynamic"
end_time = 1.0
"""
RULE = """
[sections.lobatto{n}]
thickness = {t}
points = {n}
rule = "lobatto"
[elementsets.e{i}]
ids = [{i}]
[[part]]
name = "lobatto{n}"
material = "j2"
section = "lobatto{n}"
elements = "e{i}"
"""


def test_bending_limit_moment_through_bt_element(tmp_path):
    """Square flat element, nodal rotations theta_y = kappa_dot x (zero translations): a
    uniform curvature rate kappa_xx with kappa_yy = 0, so every point is in plane stress
    with eyy = 0 (plane strain in y). At full plasticity there, dev strain rate has no yy part:
    syy = sxx/2 and q = sqrt(3)/2 sxx = sigma_y, i.e. sxx = 2 sigma_y/sqrt(3). Stresses
    accumulate over 500 steps to 50 yield curvatures; the limit moment is then
    M_xx = (t^2/4) sum_k w_k |zeta_k| 2 sigma_y/sqrt(3), for each of the four Lobatto rules."""
    t, dt, steps = 0.05, 1e-4, 500
    factor = 2 / np.sqrt(3)                                   # plane-strain limit sxx / sigma_y
    square = np.array([[-0.5, -0.5, 0.0], [0.5, -0.5, 0.0], [0.5, 0.5, 0.0], [-0.5, 0.5, 0.0]])
    corners = np.concatenate([square + [0.0, 2.0 * i, 0.0] for i in range(len(RULES))])   # apart along y
    meshio.write(tmp_path / "rules.vtu", meshio.Mesh(corners, [("quad", np.arange(4 * len(RULES)).reshape(-1, 4))]))
    text = PATCH.format(E=E, nu=NU, sy=SY0) + "".join(RULE.format(n=n, i=i, t=t) for i, n in enumerate(RULES))
    sim = unwarmed_simulation(load_scene(write_scene(tmp_path, text)), tmp_path)
    # first yield at the surface: elastic plane strain sxx = E' exx, syy = nu sxx, q = sxx sqrt(1 - nu + nu^2)
    kappa_y = 2 / t * SY0 * (1 - NU ** 2) / (E * np.sqrt(1 - NU + NU ** 2))
    kappa_dot = 50 * kappa_y / (steps * dt)
    stress, *_ = element_stage(sim, corners, np.zeros_like(corners),
                               np.column_stack([np.zeros(len(corners)), kappa_dot * corners[:, 0],
                                                np.zeros(len(corners))]), dt, steps=steps)
    ebar = sim.state.fetch("points.plastic_strain")
    ratios = []
    for i, points in enumerate(RULES):
        sig = stress[i, :points]
        zeta, w = through_thickness_rule("lobatto", points)
        ratio = np.sum(w * zeta * sig[:, 0]) / SY0                  # M_xx / (sigma_y t^2/4)
        ratio_yy = np.sum(w * zeta * sig[:, 1]) / SY0
        predicted = factor * np.sum(w * np.abs(zeta))
        ratios.append(ratio)
        print(f"Lobatto {points}: M_xx/(sigma_y t^2/4) = {ratio:.10f}, predicted {predicted:.10f} "
              f"(sum w|zeta| = {np.sum(w * np.abs(zeta)):.6f}), rel. error {ratio / predicted - 1:.1e}; "
              f"M_yy/M_xx = {ratio_yy / ratio:.8f}; ebar at the surface {ebar[i, points - 1]:.4e}; "
              f"continuum 2/sqrt(3) = {factor:.6f}")
        assert abs(ratio / predicted - 1) < 1e-6
        assert np.abs(sig[:, 3:]).max() < 1e-12 * SY0                 # no transverse shear
    assert abs(ratios[0] / factor - 2 / 3) < 1e-6
    assert np.all(np.diff(ratios) > 0) and ratios[-1] < factor
    print(f"Lobatto 9 is {100 * (1 - ratios[-1] / factor):.2f}% below the continuum limit")
    assert ratios[-1] / factor > 0.97
