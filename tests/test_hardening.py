"""Hardening and strain-rate laws of the plane-stress J2 material (issue 18 items 1-2), each
on one BT element (stage S7 alone, tests/conftest.py) against its closed form.

One model holds one element per case, each its own part and material, so that one compile
covers every law and rate law.  Every element is a unit square stretched along x
at a constant true strain increment per step (the corner velocities give exactly the
increment dt d = dt v / w_mid the element computes on its mid-step geometry) to 0.3, far
into the plastic range (ebar >= 0.2):
- uniaxial stress: the lateral (y) increment of each step is found by secant iteration from
  the point's state at the start of the step until sigma_yy = 0 (< 1e-13 sigma_xx), so the
  lateral contraction is free and sigma_xy = 0;
- equibiaxial stress: the same increment along x and y.
For proportional loading the backward-Euler return is exact, so every step must land on the
closed form: uniaxial eps = sigma / E + ebar, sigma = sigma_f(ebar); equibiaxial
eps = (1 - nu) sigma / E + ebar / 2 (ebar from the total increments, the flow stress
sigma_f of the law written out here, independently of the code).  The model is run at three
strain rates (dt = increment / rate); the rate-free elements must give the same result at each.
"""
from __future__ import annotations

import json

import meshio
import numpy as np
import pytest
import taichi as ti

from taichi_shell_mpm.scene import load_scene

from .conftest import ROOT, run_scene, unwarmed_simulation, write_scene
from .test_reliability import cli_run

E, NU, SY0 = 2.0e5, 0.3, 250.0
INCREMENT, STEPS = 0.003, 100             # true strain increment per step, to 0.3
RATES = (0.1, 1.0, 10.0)                  # 1/time: dt = INCREMENT / rate
SWIFT = dict(K=500.0, eps0=0.01, n=0.2)
LUDWIK = dict(B=400.0, n=0.4, hardening=50.0, max_stress=480.0)   # n < 1: infinite slope at ebar = 0; capped
VOCE = dict(Q=150.0, b=15.0, H=200.0)
HOCKETT_SHERBY = dict(saturation_stress=420.0, saturation_rate=6.0, saturation_exponent=0.7, hardening=50.0)
LINEAR_H = 1000.0
CS = dict(C=1.0, p=5.0)                   # Cowper-Symonds: rate / C = 0.1, 1, 10
JC = dict(c=0.05, rate0=0.01)             # Johnson-Cook: rate / rate0 = 10, 100, 1000
TAU = 0.01                                # filter time constant (dt / tau = 3, 0.3, 0.03)
CUTOFF = 20.0                             # filter cutoff frequency: tau = 1 / (2 pi 20)
SAMPLES = np.array([0.0, 0.002, 0.005, 0.01, 0.02, 0.035, 0.05, 0.075, 0.1, 0.15, 0.2, 0.3, 0.45, 0.7])


def swift(p):
    return SWIFT["K"] * (SWIFT["eps0"] + p) ** SWIFT["n"]


def swift_curvature(p):
    """|d2 sigma_y / d ebar^2| of the Swift law (decreasing in ebar)."""
    n = SWIFT["n"]
    return SWIFT["K"] * n * (1 - n) * (SWIFT["eps0"] + p) ** (n - 2)


def interpolated(eps, sig, extrapolate):
    def flow(p):
        out = np.interp(p, eps, sig)
        if extrapolate:
            slope = (sig[-1] - sig[-2]) / (eps[-1] - eps[-2])
            out = np.where(p > eps[-1], sig[-1] + slope * (p - eps[-1]), out)
        return out
    return flow


HARDENING = {          # law: (scene keys, closed form sigma_y(ebar))
    "linear": (f'yield_stress = {SY0}\nhardening = {LINEAR_H}', lambda p: SY0 + LINEAR_H * p),
    "swift": ('hardening_law = "swift"\n' + "\n".join(f"{k} = {v}" for k, v in SWIFT.items()), swift),
    "ludwik": (f'hardening_law = "ludwik"\nyield_stress = {SY0}\n' + "\n".join(f"{k} = {v}" for k, v in LUDWIK.items()),
               lambda p: np.minimum(SY0 + LUDWIK["B"] * p ** LUDWIK["n"] + LUDWIK["hardening"] * p,
                                    LUDWIK["max_stress"])),
    "swift_from_yield": ('hardening_law = "swift"\nK = 500.0\nn = 0.2\nyield_stress = 250.0\nhardening = 100.0',
                         lambda p: 500.0 * ((250.0 / 500.0) ** 5 + p) ** 0.2 + 100.0 * p),
    "voce": (f'hardening_law = "voce"\nyield_stress = {SY0}\nQ = {VOCE["Q"]}\nb = {VOCE["b"]}\nhardening = {VOCE["H"]}',
             lambda p: SY0 + VOCE["Q"] * (1 - np.exp(-VOCE["b"] * p)) + VOCE["H"] * p),
    "hockett_sherby": (f'hardening_law = "hockett_sherby"\nyield_stress = {SY0}\n'
                       + "\n".join(f"{k} = {v}" for k, v in HOCKETT_SHERBY.items()),
                       lambda p: (HOCKETT_SHERBY["saturation_stress"] - (HOCKETT_SHERBY["saturation_stress"] - SY0)
                                  * np.exp(-HOCKETT_SHERBY["saturation_rate"] * p ** HOCKETT_SHERBY["saturation_exponent"])
                                  + HOCKETT_SHERBY["hardening"] * p)),
    "tabulated": ('hardening_law = "tabulated"\nbeyond_curve = "extrapolate"\ncurve = '
                  + json.dumps([[float(e), float(swift(e))] for e in SAMPLES]),
                  interpolated(SAMPLES, swift(SAMPLES), True)),
    "tabulated_flat": ('hardening_law = "tabulated"\ncurve = [[0.0, 250.0], [0.05, 300.0], [0.1, 320.0]]',
                       interpolated([0.0, 0.05, 0.1], [250.0, 300.0, 320.0], False)),
    "tabulated_extrapolated": ('hardening_law = "tabulated"\nbeyond_curve = "extrapolate"\n'
                               'curve = [[0.0, 250.0], [0.05, 300.0], [0.1, 320.0]]',
                               interpolated([0.0, 0.05, 0.1], [250.0, 300.0, 320.0], True)),
}
SWIFT_KEYS = HARDENING["swift"][0]
RATE_KEYS = {"cowper_symonds": f'rate_law = "cowper_symonds"\nC = {CS["C"]}\np = {CS["p"]}',
             "johnson_cook": f'rate_law = "johnson_cook"\nc = {JC["c"]}\nreference_rate = {JC["rate0"]}'}


def rate_factor(law, rate):
    rate = np.asarray(rate, dtype=float)
    if law == "cowper_symonds":
        return 1.0 + (rate / CS["C"]) ** (1.0 / CS["p"])
    return np.maximum(1.0, 1.0 + JC["c"] * np.log(np.maximum(rate, 1e-300) / JC["rate0"]))


def cases():
    """name -> (material keys, stress state, flow law for the reference) of every element."""
    out = {}
    for law, (keys, _) in HARDENING.items():
        out[f"{law}_uniaxial"] = (keys, "uniaxial")
        if law in ("linear", "swift", "ludwik", "voce", "tabulated", "hockett_sherby"):
            out[f"{law}_equibiaxial"] = (keys, "equibiaxial")
    for law, keys in RATE_KEYS.items():
        for measure in ("total", "plastic"):
            out[f"{law}_{measure}_swift"] = (f'{SWIFT_KEYS}\n{keys}\nrate_measure = "{measure}"', "uniaxial")
            out[f"{law}_{measure}_perfect"] = (f'yield_stress = {SY0}\n{keys}\nrate_measure = "{measure}"',
                                               "uniaxial")
    for measure in ("total", "plastic"):       # above every rate here: R = 1
        out[f"johnson_cook_{measure}_threshold"] = (f'{SWIFT_KEYS}\nrate_law = "johnson_cook"\nc = 0.05\n'
                                                    f'reference_rate = 1e6\nrate_measure = "{measure}"', "uniaxial")
    cs = RATE_KEYS["cowper_symonds"]
    out["filter_time_total"] = (f'{SWIFT_KEYS}\n{cs}\nrate_filter_time = {TAU}', "equibiaxial")
    out["filter_cutoff_total"] = (f'{SWIFT_KEYS}\n{cs}\nrate_cutoff_frequency = {CUTOFF}', "equibiaxial")
    out["filter_time_plastic"] = (f'{SWIFT_KEYS}\n{cs}\nrate_measure = "plastic"\nrate_filter_time = {TAU}',
                                  "uniaxial")
    return out


CASES = cases()


def model_scene(tmp_path):
    """The scene of one unit-square element per case, and its nodes: the elements lie on each
    other (nothing connects them in fem mode), so the kinematics of each are computed alike
    to the last bit and elements can be compared bit for bit."""
    names = list(CASES)
    corners = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    points = np.concatenate([corners] * len(names))
    quads = np.arange(4 * len(names)).reshape(-1, 4)
    meshio.write(tmp_path / "laws.vtu", meshio.Mesh(points, [("quad", quads)]))
    text = ['[scene]\nname = "laws"\nunits = "consistent"\n[mesh]\nkind = "file"\npath = "laws.vtu"\n'
            '[sections.membrane]\nthickness = 0.1\npoints = 1\nrule = "gauss"\n'
            '[method]\nkind = "fem"\n[solve]\nkind = "dynamic"\nend_time = 1.0\n']
    for i, name in enumerate(names):
        keys = CASES[name][0]
        text.append(f'[materials.{name}]\nE = {E}\nnu = {NU}\ndensity = 1.0\nmodel = "j2"\n{keys}\n'
                    f'[elementsets.{name}]\nids = [{i}]\n'
                    f'[[part]]\nname = "{name}"\nmaterial = "{name}"\nsection = "membrane"\nelements = "{name}"\n')
    return load_scene(write_scene(tmp_path, "\n".join(text), "laws.toml")), points, names


class Stretch:
    """Drives the element stage of the model step by step (the point state carried over)."""

    def __init__(self, sim, points, names):
        self.sim, self.s = sim, sim.state
        self.points0 = points
        self.names = names
        self.uniaxial = np.array([CASES[n][1] == "uniaxial" for n in names])
        self.state_paths = [p for p in ("points.stress", "points.plastic_strain", "points.strain_rate")
                            if p in self.s.arrays_index()]

        @ti.kernel
        def element_pass():
            for _ in range(1):      # the outermost loop is the parallel one: keep the element loop serial
                sim.stepper.shell.element_pass()
        self.element_pass = element_pass

    def step(self, start, dx, dy, dt):
        """One element pass from point states `start` (dict), widths (w, h) in self.size, with
        true strain increments dx, dy per element: returns the new point states."""
        for path, value in start.items():
            self.s.put(path, value)
        w, h = self.size[:, 0], self.size[:, 1]
        vx = dx * w / (dt * (1.0 - dx / 2.0))      # dt vx / (w + dt vx / 2) = dx
        vy = dy * h / (dt * (1.0 - dy / 2.0))
        velocity = np.zeros((len(self.names), 4, 3))
        velocity[:, [1, 2], 0] = vx[:, None]
        velocity[:, [2, 3], 1] = vy[:, None]
        self.s.put("nodes.position", (self.position + dt * velocity).reshape(-1, 3))
        self.s.put("nodes.grid_velocity", velocity.reshape(-1, 3))
        self.s.step.dt[None] = dt
        self.element_pass()
        assert self.s.step.status[None] == 0, f"status {self.s.step.status[None]} at element " \
                                              f"{self.s.step.status_index[None]}"
        return {path: self.s.fetch(path) for path in self.state_paths}, velocity

    def run(self, rate):
        """STEPS increments of INCREMENT at `rate`: per element the histories of sigma_xx,
        sigma_yy, ebar, the filtered rate (0 unfiltered) and the lateral increments."""
        dt = INCREMENT / rate
        m = len(self.names)
        self.position = self.points0.reshape(m, 4, 3).copy()
        self.size = np.ones((m, 2))
        state = {path: np.zeros_like(self.s.fetch(path)) for path in self.state_paths}
        dx = np.full(m, INCREMENT)
        ratio = np.full(m, -NU)                    # lateral / axial increment, the last step's
        out = {k: np.zeros((STEPS, m)) for k in ("sxx", "syy", "ebar", "rate", "dy")}
        for n in range(STEPS):
            dy = np.where(self.uniaxial, ratio * INCREMENT, INCREMENT)
            new, velocity = self.step(state, dx, dy, dt)
            syy = new["points.stress"][:, 0, 1]
            slope = np.full(m, E / (1 - NU ** 2))   # d sigma_yy / d dy: elastic, then secant
            for _ in range(40):
                open_ = self.uniaxial & (np.abs(syy) > 1e-13 * np.abs(new["points.stress"][:, 0, 0]))
                if not open_.any():
                    break
                trial = np.where(open_, dy - syy / slope, dy)
                new, velocity = self.step(state, dx, trial, dt)
                moved, change = new["points.stress"][:, 0, 1] - syy, trial - dy
                slope = np.where(open_ & (change != 0) & (moved != 0), moved / np.where(change != 0, change, 1), slope)
                dy, syy = trial, new["points.stress"][:, 0, 1]
            assert not open_.any(), f"lateral iteration of {np.array(self.names)[open_]}"
            state = new
            self.position = self.position + dt * velocity
            self.size = self.size + dt * np.stack([velocity[:, 1, 0], velocity[:, 2, 1]], axis=1)
            ratio = np.where(self.uniaxial, dy / INCREMENT, ratio)
            out["sxx"][n], out["syy"][n] = new["points.stress"][:, 0, 0], new["points.stress"][:, 0, 1]
            out["ebar"][n] = new["points.plastic_strain"][:, 0]
            if "points.strain_rate" in new:
                out["rate"][n] = new["points.strain_rate"][:, 0]
            out["dy"][n] = dy
        out["dt"] = dt
        return out


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The model stretched at each of RATES: {rate: histories}, and the element names."""
    tmp = tmp_path_factory.mktemp("laws")
    scene, points, names = model_scene(tmp)
    sim = unwarmed_simulation(scene, tmp)
    stretch = Stretch(sim, points, names)
    return {rate: stretch.run(rate) for rate in RATES}, names


def history(runs, name, rate=RATES[1]):
    data, names = runs
    i = names.index(name)
    h = data[rate]
    return {k: (v[:, i] if isinstance(v, np.ndarray) else v) for k, v in h.items()}


def root(g, lo, hi):
    """The root of the increasing g in [lo, hi] by bisection (to round-off)."""
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if g(mid) > 0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def closed_form(flow, state, strains, factors=None):
    """sigma of each step for total strains `strains` with flow stress flow(ebar) x factor:
    the elastic answer below yield, else the root of sigma = flow(ebar(sigma)) factor."""
    factors = np.ones(len(strains)) if factors is None else factors
    out = np.zeros(len(strains))
    for n, (eps, r) in enumerate(zip(strains, factors)):
        if state == "uniaxial":
            modulus, ebar = E, (lambda s: eps - s / E)
        else:
            modulus, ebar = E / (1 - NU), (lambda s: 2 * (eps - (1 - NU) * s / E))
        if modulus * eps <= flow(0.0) * r:
            out[n] = modulus * eps
        else:
            out[n] = root(lambda s: s - flow(ebar(s)) * r, 0.0, modulus * eps)
    return out


def effective_rates(h):
    """The effective total strain rate of each step: (2/sqrt 3) sqrt(dx^2 + dx dy + dy^2) / dt."""
    dx, dy = INCREMENT, h["dy"]
    return 2.0 / np.sqrt(3.0) * np.sqrt(dx * dx + dx * dy + dy * dy) / h["dt"]


STRAINS = INCREMENT * np.arange(1, STEPS + 1)


@pytest.mark.parametrize("law", list(HARDENING))
def test_hardening_law_closed_form(runs, law):
    """Every law, uniaxial and equibiaxial, to eps = 0.3 (ebar 0.3 / 0.6): sigma and ebar on
    the closed form to 1e-8 (the return is exact on proportional paths: the errors are
    round-off), sigma_yy = 0 (uniaxial) and the same answer at every rate (to round-off)."""
    flow = HARDENING[law][1]
    for state in ("uniaxial", "equibiaxial"):
        name = f"{law}_{state}"
        if name not in CASES:
            continue
        h = history(runs, name)
        expected = closed_form(flow, state, STRAINS)
        modulus = E if state == "uniaxial" else E / (1 - NU)
        ebar = (STRAINS - h["sxx"] / E) if state == "uniaxial" else 2 * (STRAINS - h["sxx"] / modulus)
        error = np.max(np.abs(h["sxx"] / expected - 1))
        ebar_error = np.max(np.abs(h["ebar"] - np.maximum(ebar, 0.0)))
        print(f"\n{name}: ebar {h['ebar'][-1]:.3f}, sigma {h['sxx'][-1]:.4f} (closed form {expected[-1]:.4f}), "
              f"max relative error {error:.1e}, ebar error {ebar_error:.1e}")
        assert h["ebar"][-1] >= 0.2
        assert error <= 1e-8
        assert ebar_error <= 1e-8
        if state == "equibiaxial":
            assert np.max(np.abs(h["syy"] / h["sxx"] - 1)) <= 1e-12
        spread = max(np.max(np.abs(history(runs, name, rate)["sxx"] / h["sxx"] - 1)) for rate in RATES)
        print(f"  largest difference between the three rates {spread:.1e}")
        assert spread <= 1e-10          # round-off of dt v / (w + dt v / 2) at other dt


def test_tabulated_swift_within_its_interpolation_error(runs):
    """The tabulated law sampling Swift at SAMPLES against the Swift element: on every step
    |sigma_tab - sigma_swift| <= h^2/8 max|sigma_y''| of the segment holding ebar (linear
    interpolation of a concave curve lies below it by at most that; at a fixed strain the
    stress error is the flow stress error / (1 + slope / E), no larger), and the error reaches
    a fair share of the bound (a table that silently used the Swift formula would not)."""
    for state in ("uniaxial", "equibiaxial"):
        tab, sw = history(runs, f"tabulated_{state}"), history(runs, f"swift_{state}")
        p = tab["ebar"]
        segment = np.clip(np.searchsorted(SAMPLES, p, side="right") - 1, 0, len(SAMPLES) - 2)
        width = SAMPLES[segment + 1] - SAMPLES[segment]
        bound = width ** 2 / 8 * swift_curvature(SAMPLES[segment])
        inside = p < SAMPLES[-1]
        error = np.abs(tab["sxx"] - sw["sxx"])
        ratio = error[inside] / bound[inside]
        print(f"\n{state}: |sigma_tab - sigma_swift| max {error.max():.3e} ({np.max(error / sw['sxx']):.2e} "
              f"relative), error / bound max {ratio.max():.3f}")
        assert np.all(error[inside] <= bound[inside] * (1 + 1e-9) + 1e-9)
        assert ratio.max() > 0.3


@pytest.mark.parametrize("law", list(RATE_KEYS))
def test_rate_law_total_strain_rate(runs, law):
    """Swift hardening x the rate law on the effective total strain rate, uniaxial at the
    three rates: sigma = sigma_y(ebar) R(rate of the step) on the closed form to 1e-8; the
    perfectly plastic element reaches sigma_y0 R(rate) (once the flow is steady, the
    isochoric increments make the effective rate the axial one)."""
    for rate in RATES:
        h = history(runs, f"{law}_total_swift", rate)
        factors = rate_factor(law, effective_rates(h))
        expected = closed_form(swift, "uniaxial", STRAINS, factors)
        error = np.max(np.abs(h["sxx"] / expected - 1))
        perfect = history(runs, f"{law}_total_perfect", rate)["sxx"][-1]
        steady = SY0 * rate_factor(law, rate)
        print(f"\n{law} total, rate {rate}: R = {factors[-1]:.5f}, sigma {h['sxx'][-1]:.4f}, closed-form error "
              f"{error:.1e}; perfectly plastic {perfect:.6f} against sigma_y0 R = {steady:.6f} "
              f"({abs(perfect / steady - 1):.1e})")
        assert error <= 1e-8
        assert abs(perfect / steady - 1) <= 1e-8
        assert factors[-1] > 1.1


def plastic_rate_reference(flow, law, dt, alpha=1.0):
    """Uniaxial stress with the rate law on the filtered plastic strain rate, step by step
    (backward Euler, as the return map): sigma_n+1 is the root of
    sigma = flow(ebar) R(alpha (ebar - ebar_n) / dt + (1 - alpha) r_n), ebar = eps - sigma / E."""
    out, p_n, r_n = np.zeros(STEPS), 0.0, 0.0
    for n, eps in enumerate(STRAINS):
        def rate(s):
            return alpha * (max(eps - s / E, p_n) - p_n) / dt + (1 - alpha) * r_n
        if E * eps <= flow(p_n) * rate_factor(law, (1 - alpha) * r_n) and E * (eps - p_n) <= flow(p_n) * \
                rate_factor(law, (1 - alpha) * r_n):
            out[n] = E * (eps - p_n)
        else:
            out[n] = root(lambda s: s - flow(eps - s / E) * rate_factor(law, rate(s)), 0.0, E * (eps - p_n))
        r_n = rate(out[n])
        p_n = max(eps - out[n] / E, p_n)
    return out


@pytest.mark.parametrize("law", list(RATE_KEYS))
def test_rate_law_plastic_strain_rate(runs, law):
    """The rate law on the plastic strain rate (solved inside the return: the flow stress
    depends on d ebar / dt): at the three rates each step against the backward-Euler
    recursion written out here (1e-8), and the perfectly plastic element settles at
    sigma_y0 R(rate) (in steady flow the plastic rate is the imposed one)."""
    for rate in RATES:
        h = history(runs, f"{law}_plastic_swift", rate)
        expected = plastic_rate_reference(swift, law, h["dt"])
        error = np.max(np.abs(h["sxx"] / expected - 1))
        perfect = history(runs, f"{law}_plastic_perfect", rate)["sxx"][-1]
        steady = SY0 * rate_factor(law, rate)
        print(f"\n{law} plastic, rate {rate}: sigma {h['sxx'][-1]:.4f} (reference {expected[-1]:.4f}), error "
              f"{error:.1e}; perfectly plastic {perfect:.6f} against sigma_y0 R = {steady:.6f} "
              f"({abs(perfect / steady - 1):.1e})")
        assert error <= 1e-8
        assert abs(perfect / steady - 1) <= 1e-8


def test_rate_below_the_reference_rate_is_rate_free(runs):
    """Johnson-Cook with a reference rate above every rate of the run: R = 1, bit for bit the
    rate-free Swift element, with either rate measure."""
    for rate in RATES:
        free = history(runs, "swift_uniaxial", rate)
        for measure in ("total", "plastic"):
            h = history(runs, f"johnson_cook_{measure}_threshold", rate)
            assert np.array_equal(h["sxx"], free["sxx"]) and np.array_equal(h["ebar"], free["ebar"])


def test_rate_filter_time_constant(runs):
    """The exponential filter of the rate: equibiaxial stretching from rest at a constant rate
    is a step of the effective total rate (2 x the axial rate); the filtered rate must follow
    r (1 - exp(-t / tau)), so tau measured at each step as -t / ln(1 - r_f / r) is tau
    (rate_filter_time) or 1 / (2 pi f_c) (rate_cutoff_frequency), and the stress lands on the
    closed form with R(r_f).  The filtered plastic rate: the step recursion with the filter."""
    for name, tau in (("filter_time_total", TAU), ("filter_cutoff_total", 1 / (2 * np.pi * CUTOFF))):
        for rate in RATES:
            h = history(runs, name, rate)
            t = h["dt"] * np.arange(1, STEPS + 1)
            step = 2.0 * rate
            live = h["rate"] < step * (1 - 1e-6)                 # before the response is within round-off
            measured = -t[live] / np.log(1 - h["rate"][live] / step)
            spread = np.max(np.abs(measured / tau - 1))
            expected = closed_form(swift, "equibiaxial", STRAINS, rate_factor("cowper_symonds", h["rate"]))
            error = np.max(np.abs(h["sxx"] / expected - 1))
            print(f"\n{name}, rate {rate}, dt/tau {h['dt'] / tau:.3g}: tau measured {measured.min():.6g}.."
                  f"{measured.max():.6g} (set {tau:.6g}, {spread:.1e}) over {live.sum()} steps, "
                  f"stress error {error:.1e}")
            assert live.sum() >= 1 and spread <= 1e-9
            assert error <= 1e-8
    for rate in RATES:
        h = history(runs, "filter_time_plastic", rate)
        expected = plastic_rate_reference(swift, "cowper_symonds", h["dt"], 1 - np.exp(-h["dt"] / TAU))
        error = np.max(np.abs(h["sxx"] / expected - 1))
        print(f"\nfilter_time_plastic, rate {rate}: stress error {error:.1e}")
        assert error <= 1e-8


ROBUST = {        # name: (scene Material keys, dt): the laws' singular corners at ebar = 0 and rate = 0
    "ludwik n=0.4, Cowper-Symonds on the plastic rate": (
        dict(hardening_law="ludwik", yield_stress=SY0, B=400.0, n=0.4, max_stress=480.0, rate_law="cowper_symonds",
             C=1.0, p=5.0, rate_measure="plastic"), 1e-4),
    "swift, Johnson-Cook on the plastic rate": (
        dict(hardening_law="swift", K=500.0, eps0=1e-4, n=0.2, rate_law="johnson_cook", c=0.05,
             reference_rate=1.0, rate_measure="plastic"), 1e-3),
    "voce, Cowper-Symonds on the total rate": (
        dict(hardening_law="voce", yield_stress=SY0, Q=150.0, b=15.0, rate_law="cowper_symonds", C=1.0, p=5.0),
        1e-3),
}


def flow_of(spec, ebar, rate):
    """sigma_y(ebar) R(rate) of the ROBUST materials (scene.Material), written out."""
    if spec.hardening_law == "ludwik":
        sy = np.minimum(spec.yield_stress + spec.B * ebar ** spec.n, spec.max_stress)
    elif spec.hardening_law == "swift":
        sy = spec.K * (spec.eps0 + ebar) ** spec.n
    else:
        sy = spec.yield_stress + spec.Q * (1 - np.exp(-spec.b * ebar)) + spec.hardening * ebar
    if spec.rate_law == "cowper_symonds":
        return sy * (1 + (rate / spec.C) ** (1 / spec.p)), sy
    return sy * np.maximum(1.0, 1.0 + spec.c * np.log(np.maximum(rate, 1e-300) / spec.reference_rate)), sy


@pytest.mark.parametrize("name", list(ROBUST))
def test_random_paths_converge_on_the_flow_stress(name):
    """Seeded random increments (all five components, 0.01 to 10 yield strains per step,
    reversals) at one point: every return converges (a safeguarded Newton: the laws' slopes
    are infinite at ebar = 0 (Ludwik n < 1) and at rate 0 (Cowper-Symonds p > 1) and are taken
    as 0 there), q <= sigma_f(1 + 1e-10) on elastic steps and q = sigma_f to 1e-10 on plastic
    steps, with sigma_f = sigma_y(ebar) R(rate) written out here (rate: d ebar / dt, or the
    effective total strain rate of the step).  On the plastic rate the check leaves out the
    steps whose d ebar is below 1e-5 ebar: d ebar from the difference of two stored ebar
    carries an error of 1 ulp of ebar, which there moves R by more than 1e-10."""
    from taichi_shell_mpm.scene import Material

    from .test_material import Points, mises
    keys, dt = ROBUST[name]
    spec = Material(E=E, nu=NU, density=1.0, model="j2", **keys)
    rng = np.random.default_rng(18)
    n, steps = 200, 100
    direction = rng.normal(size=(n, steps, 5))
    direction /= np.linalg.norm(direction, axis=2, keepdims=True)
    incr = direction * SY0 / E * 10 ** rng.uniform(-2, 1, size=(n, steps, 1))
    points = Points(spec=spec, dt=dt)
    sig, ebar, work = points.path(incr)
    d_ebar = np.diff(np.concatenate([np.zeros((n, 1)), ebar], axis=1), axis=1)
    if spec.rate_measure == "plastic":
        rate = d_ebar / dt
    else:
        d = incr[..., :3]
        rate = 2 / np.sqrt(3) * np.sqrt(d[..., 0] ** 2 + d[..., 0] * d[..., 1] + d[..., 1] ** 2
                                        + d[..., 2] ** 2 / 4) / dt
    flow, static = flow_of(spec, ebar, rate)
    ratio = mises(sig) / flow - 1
    plastic = d_ebar > 0
    resolved = plastic & ((d_ebar > 1e-5 * ebar) | (spec.rate_measure == "total"))
    print(f"\n{name}: {n}x{steps} steps, {plastic.sum()} plastic ({(plastic & ~resolved).sum()} below 1e-5 ebar: "
          f"|q/sigma_f - 1| <= {np.abs(ratio[plastic & ~resolved]).max(initial=0):.1e}), not converged "
          f"{np.sum(points.converged == 0)}, elastic steps max q/sigma_f - 1 = {ratio[~plastic].max():.1e}, "
          f"plastic |q/sigma_f - 1| <= {np.abs(ratio[resolved]).max():.1e}, max ebar {ebar.max():.3f}, "
          f"largest R {(flow / static).max():.3f}")
    assert np.all(points.converged == 1)
    assert np.all(np.isfinite(sig)) and work.min() >= 0
    assert ratio[~plastic].max() <= 1e-10
    assert np.abs(ratio[resolved]).max() <= 1e-10
    assert plastic.sum() > n * steps // 10 and (flow / static).max() > 1.1


DECK = """*KEYWORD
*NODE
1,0.0,0.0,0.0
2,1.0,0.0,0.0
3,1.0,1.0,0.0
4,0.0,1.0,0.0
5,2.0,0.0,0.0
6,2.0,1.0,0.0
*ELEMENT_SHELL
1,1,1,2,3,4
2,2,2,5,6,3
*PART
kinematic
1,1,1
*PART
curve
2,1,2
*SECTION_SHELL
1,2,0.833,5
1.0,1.0,1.0,1.0
*MAT_PLASTIC_KINEMATIC
1,7.85e-9,2.1e5,0.3,250.0,1000.0,1.0
40.4,5.0,0.0,0.0
*MAT_024
2,7.85e-9,2.1e5,0.3,250.0
40.4,5.0,7,0,1.0
,
,
*DEFINE_CURVE
7
0.01,260.0
0.1,300.0
0.2,290.0
*END
"""


def test_lsdyna_curve_and_cowper_symonds(tmp_path):
    """*MAT_003: SIGY, ETAN -> linear H = E ETAN / (E - ETAN), SRC/SRP -> Cowper-Symonds on the
    total rate (VP = 0); *MAT_024: its LCSS curve -> the tabulated law, extrapolated (a curve
    from ebar 0.01 takes its first stress from 0, a falling point is held: notes), C/P with
    VP = 1 -> Cowper-Symonds on the plastic rate."""
    from taichi_shell_mpm.model.materials import COL, law_column
    from taichi_shell_mpm.preflight import prepare
    (tmp_path / "deck.k").write_text(DECK)
    scene = write_scene(tmp_path, '[scene]\nname = "deck"\nunits = "N-mm-s"\n[mesh]\nkind = "file"\npath = "deck.k"\n'
                                  '[solve]\nkind = "dynamic"\nend_time = 1.0\n')
    _, _, model = prepare(scene, [])
    mats = model.materials
    assert mats.names == ("mat_1", "mat_2") and mats.hardening == ("linear", "tabulated")
    assert mats.rate_laws == ("cowper_symonds",) and not mats.rate_filter
    kin, cur = mats.rows
    assert kin[COL["hardening_law"]] == 0 and kin[COL["yield_stress"]] == 250.0
    assert kin[COL["hardening"]] == pytest.approx(2.1e5 * 1000.0 / (2.1e5 - 1000.0), rel=1e-15)
    assert (kin[COL["rate_law"]], kin[law_column("cowper_symonds", "C")], kin[law_column("cowper_symonds", "p")],
            kin[COL["rate_plastic"]]) == (0, 40.4, 5.0, 0.0)
    assert cur[COL["hardening_law"]] == 1 and cur[law_column("tabulated", "curve_extrapolate")] == 1.0
    assert (cur[law_column("tabulated", "curve_start")], cur[law_column("tabulated", "curve_points")],
            cur[COL["rate_plastic"]]) == (0, 4, 1.0)
    assert mats.curve_strain.tolist() == [0.0, 0.01, 0.1, 0.2] and mats.curve_stress.tolist() == [260, 260, 300, 300]
    notes = " | ".join(model.notes)
    assert "*MAT_024 2: the curve starts at plastic strain 0.01" in notes
    assert "*MAT_024 2: the curve falls at plastic strain 0.2 (300 -> 290): held at 300" in notes
    assert "straight line" not in notes


def test_cli_mistakes_are_one_line_each(tmp_path):
    """`validate` of the rate-dependent tube with wrong hardening and rate keys: exit code 2,
    one line per mistake naming the key, no traceback."""
    proc = cli_run("validate", str(ROOT / "scenes" / "tube_rate_dependent.toml"), "--set", "material.hardening_law=swift",
                   "--set", "material.K=0.5", "--set", "material.Q=0.1", "--set", "material.rate_measure=viscous",
                   "--set", "material.rate_filter_time=-1")
    lines = proc.err.strip().splitlines()
    print("\n" + proc.err)
    assert proc.code == 2 and "Traceback" not in proc.err
    assert lines == [
        "error: tube_rate_dependent.toml: [material].rate_measure: expected one of total, plastic, got 'viscous'",
        "error: tube_rate_dependent.toml: [material].rate_filter_time: expected a number > 0, got -1",
        'error: tube_rate_dependent.toml: [material].Q: not used by hardening_law = "swift" '
        "(its keys: K, n, eps0, yield_stress, hardening)",
        'error: tube_rate_dependent.toml: [material].n: missing required key for hardening_law = "swift"']
    ok = cli_run("validate", str(ROOT / "scenes" / "tube_rate_dependent.toml"))
    assert ok.code == 0, ok.err


PLATE_RUN = """
[scene]
name = "impact"
units = "kN-mm-ms-kg"
[mesh]
kind = "plate"
lx = 20.0
ly = 5.0
nx = 8
ny = 2
[material]
E = 200.0
nu = 0.3
density = 7.85e-6
model = "j2"
hardening_law = "swift"
K = 0.55
eps0 = 0.005
n = 0.2
rate_law = "cowper_symonds"
C = 0.0404
p = 5.0
rate_cutoff_frequency = 10.0
[section]
thickness = 1.0
points = 3
rule = "gauss"
[method]
kind = "fem"
[nodesets.clamped]
plane = { point = [0.0, 0.0, 0.0], normal = [1.0, 0.0, 0.0] }
[[boundary]]
nodes = "clamped"
fix = "all"
[[initial]]
velocity = [15.0, 0.0, 0.0]
[solve]
kind = "dynamic"
end_time = 0.02
[output]
times = [0.02]
"""


def test_cli_run_with_swift_and_cowper_symonds(tmp_path):
    """A whole run: a strip clamped at x = 0 and flying off along +x at 15 m/s (Swift
    steel with a filtered Cowper-Symonds rate law): the clamped end yields, the run finishes
    and the energy balances."""
    scene = write_scene(tmp_path, PLATE_RUN)
    proc = run_scene(scene, tmp_path / "out")      # in this process, through the Python API
    assert proc.returncode == 0, proc.stderr[-3000:]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    energies = summary["energies"]
    frame = meshio.read(sorted((tmp_path / "out" / "frames").glob("*.vtu"))[-1])
    ebar = frame.cell_data["plastic_strain_max"][0]
    print(f"\nsteps {summary['steps']}, plastic work {energies['plastic_work']:.4e}, internal "
          f"{energies['internal']:.4e}, balance {energies['balance_error']:.2e}, largest ebar {ebar.max():.4f}")
    assert energies["plastic_work"] > 0 and ebar.max() > 1e-3
    assert abs(energies["balance_error"]) <= 0.01 * energies["internal"]
