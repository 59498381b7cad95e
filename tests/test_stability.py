"""Numerical stability: a free plate spinning about its normal for 10,000 steps keeps its
kinetic energy and angular momentum (issue 2; method.md 2.2).  Plain PIC does not, which
shows the test can fail and why APIC is the default transfer.  Energy conservation of
ringing plates (method.md 9) and the period of a simply supported strip against the
Timoshenko beam."""
from __future__ import annotations

import numpy as np
import pytest

from .conftest import plate_scene, simulation

STEPS = 10_000


def spin(tmp_path, method, transfer):
    """4x4 plate of unit side, omega chosen for ~1.5 revolutions in STEPS steps."""
    scene = plate_scene(tmp_path, method=method, transfer=transfer,
                        method_extra="cell_size = 0.125" if method == "mpm" else "",
                        extra="[[initial]]\nangular_velocity = [0.0, 0.0, 1.0]\ncenter = [0.5, 0.5, 0.0]\n")
    sim = simulation(scene, tmp_path)
    sim.hourglass_limit = 0      # PIC wrecks the spin into hourglass modes: measure it, don't stop
    dt = sim.state.step.dt[None]
    omega = 3 * np.pi / (STEPS * dt)
    s = sim.state
    s.put("nodes.velocity", sim.model.velocity0 * omega)
    s.put("nodes.grid_velocity", sim.model.velocity0 * omega)
    s.put("nodes.omega", sim.model.omega0 * omega)      # the nodes spin with the plate (drilling kept)
    sim.initial_kinetic = sim.kinetic_energy()          # KE_0 of the balance guard
    m = sim.model.node_mass

    def invariants():
        x, v = s.fetch("nodes.position"), s.fetch("nodes.grid_velocity")
        ke = 0.5 * np.sum(m * np.sum(v * v, axis=1))
        centre = (m[:, None] * x).sum(axis=0) / m.sum()
        L = np.sum(m[:, None] * np.cross(x - centre, v), axis=0)[2]
        return ke, L

    ke0, L0 = invariants()
    done, worst = 0, 0.0
    for _ in range(10):
        done += sim.stepper.advance(STEPS // 10)
        sim.check_status()
        ke1, L1 = invariants()
        worst = max(worst, abs(ke1 - ke0) / ke0)
    print(f"largest KE deviation during the run {100 * worst:.2f}%")
    angle = omega * STEPS * dt / (2 * np.pi)
    return done, abs(ke1 - ke0) / ke0, abs(L1 - L0) / abs(L0), angle


@pytest.mark.parametrize("method,bound", [("mpm", 0.01), ("fem", 0.001)])
def test_free_spin_keeps_energy_and_angular_momentum(tmp_path, method, bound):
    done, dke, dl, revs = spin(tmp_path, method, "apic")
    print(f"{method}/apic: {done} steps, {revs:.2f} rev: KE change {100 * dke:.3f}%, L change {100 * dl:.3f}%")
    assert done == STEPS
    assert dke < bound and dl < bound


def test_pic_transfer_dissipates_the_spin(tmp_path):
    done, dke, dl, revs = spin(tmp_path, "mpm", "pic")
    print(f"mpm/pic: {done} steps, {revs:.2f} rev: KE change {100 * dke:.1f}%, L change {100 * dl:.1f}%")
    assert dke > 0.1



def land_on_output_times(sim, steps: int, every: float) -> None:
    """Advance `steps` steps like solvers/dynamic.py with an output time every `every` stable
    steps (an interval under way is continued)."""
    from taichi_shell_mpm.stages.timestep import landing_step
    s = sim.state
    done = 0
    while done < steps:
        if s.step.dt[None] <= 0.0 or s.step.time_limit[None] - s.step.time[None] > 1.5 * every * s.step.dt_stable[None]:
            s.step.time_limit[None] = s.step.time[None] + every * s.step.dt_stable[None]
            s.step.dt[None] = landing_step(s.step.time_limit[None] - s.step.time[None], s.step.dt_stable[None])
        done += sim.stepper.advance(steps - done)
        sim.check_status()


def leapfrog_energy(sim, advance_one) -> float:
    """Total energy of the central-difference scheme at step n: 1/2 v^(n-1/2) . M v^(n+1/2)
    (likewise J for the rotations) + the stored energy at x^n (internal, hourglass, drilling;
    the trapezoidal sums of the element stage, which for a linear system are exactly
    1/2 x^n . K x^n).  For a linear system at constant dt it is conserved exactly (the
    scheme's discrete energy); the kinetic energy of energy.csv, 1/2 m |v^(n+1/2)|^2 at the
    half step, against the stored energy at x^(n+1), oscillates about it by up to
    omega dt / 2 of the energy of each mode.  Reads v^(n-1/2), calls `advance_one` (one step)
    and reads v^(n+1/2)."""
    s = sim.state
    m, inertia = sim.model.node_mass, sim.model.node_inertia
    e = sim.energies()
    stored = e["internal"] + e["hourglass"] + e["drilling"]
    va, wa = s.fetch("nodes.grid_velocity"), s.fetch("nodes.omega")
    advance_one()
    vb, wb = s.fetch("nodes.grid_velocity"), s.fetch("nodes.omega")
    return (0.5 * np.sum(m * np.sum(va * vb, axis=1)) + 0.5 * np.sum(inertia * np.sum(wa * wb, axis=1))
            + stored)


@pytest.mark.parametrize("method", ["fem", "mpm"])
def test_landing_on_output_times_keeps_the_energy(tmp_path, method):
    """An 8x8 free plate ringing (smooth bending and shear velocity fields), with an output
    time every 5.3 stable steps: the steps that land on them (stages/timestep.py) must not
    modulate dt.  Clipping only the last steps to the output time (the rule before) turned
    an element inside out here within 500 steps (fem; mpm: a node left the grid at step
    1 648).  Measured over 3 000 steps (about 6 periods of the bending mode, 100 of the
    in-plane shear mode): the scheme's energy (leapfrog_energy) drifts by 1.2e-4 of the
    initial energy (fem and mpm; at h = l/2 on this aligned mesh every shell node sits on
    a grid node, so mpm is fem), bound 1.8e-4, well inside method.md 9's 0.5 %.  The
    balance error of energy.csv swings by -2 % to +6 % of it here: the in-plane mode has
    omega dt = 0.3, and that figure sets the kinetic energy of the half step against the
    stored energy of the full step (an artefact of the measurement, not of the scheme)."""
    scene = plate_scene(tmp_path, nx=8, ny=8, method=method,
                        method_extra="cell_size = 0.0625" if method == "mpm" else "",
                        extra='[element]\ndrilling = "penalty"\n')
    sim = simulation(scene, tmp_path)
    sim.hourglass_limit = 0
    s = sim.state
    x = sim.model.points
    velocity = np.zeros_like(x)
    velocity[:, 2] = 1e-2 * np.sin(np.pi * x[:, 0]) * np.sin(2 * np.pi * x[:, 1])
    velocity[:, 0] = 1e-2 * np.sin(2 * np.pi * x[:, 1])
    s.put("nodes.velocity", velocity)
    s.put("nodes.grid_velocity", velocity)
    sim.initial_kinetic = sim.kinetic_energy()
    step = lambda: land_on_output_times(sim, 1, 5.3)     # noqa: E731
    energy0 = leapfrog_energy(sim, step)
    drift, swing = 0.0, []
    for _ in range(10):
        land_on_output_times(sim, 299, 5.3)
        drift = max(drift, abs(leapfrog_energy(sim, step) - energy0) / energy0)
        swing.append(sim.energies()["balance_error"] / sim.initial_kinetic)
    print(f"\n{method}: {int(s.step.step[None])} steps: energy drift {drift:.2e} of the initial energy; "
          f"energy.csv balance error {min(swing):.2e} .. {max(swing):.2e} of the initial KE")
    assert int(s.step.step[None]) == 3001
    assert drift < 1.8e-4


CAP = """
[scene]
name = "cap"
units = "consistent"
[mesh]
kind = "hemisphere"
radius = 1.0
hole_deg = 18
n_around = 16
n_meridian = 4
quarter = false
[material]
E = 1e4
nu = 0.3
density = 1.0
[section]
thickness = 0.02
[method]
kind = "fem"
[[initial]]
angular_velocity = [0.0, 0.0, 0.1]
center = [0.0, 0.0, 0.0]
[solve]
kind = "dynamic"
end_time = 100.0
dt_rule = "shell"
"""


@pytest.mark.parametrize("drilling,bound", [("penalty", 1e-5), ("projection", None)])
def test_a_spinning_curved_shell_stays_unstrained(tmp_path, drilling, bound):
    """A hemisphere (18 deg hole) spinning rigidly about its axis for a quarter turn: the spin
    has a component along every nodal normal.  With the drilling spring (stages/drilling.py,
    the default) the nodes keep it and E_int/KE stays at the order of the centrifugal strain
    rho w^2 R^2 / E = 1e-6 (measured 9e-7 to 2e-6).  The paper's projection (omega . n = 0)
    bends the curved mesh: measured 7.5e-2, asserted > 1e-2 -- the defect that made the
    hemisphere benchmark 2-3 % too stiff at every refinement."""
    from taichi_shell_mpm.scene import load_scene

    from .conftest import write_scene
    sim = simulation(load_scene(write_scene(tmp_path, CAP + f'[element]\ndrilling = "{drilling}"\n')), tmp_path)
    sim.hourglass_limit = 0      # the strain energy is round-off: measure, do not stop
    s = sim.state
    steps = int(0.25 * 2 * np.pi / 0.1 / s.step.dt[None])
    done = sim.stepper.advance(steps)
    sim.check_status()
    e = sim.energies()
    ratio = e["internal"] / e["kinetic"]
    print(f"\n{drilling}: {done} steps, a quarter turn: E_int/KE {ratio:.2e}, "
          f"E_hg/KE {e['hourglass'] / e['kinetic']:.2e}, balance {e['balance_error'] / e['kinetic']:.1e}")
    assert done == steps
    if bound is None:
        assert ratio > 1e-2
    else:
        assert ratio < bound


STRIP = """
[scene]
name = "strip"
units = "consistent"
[mesh]
kind = "plate"
lx = {L}
ly = {b}
nx = {nx}
ny = 1
[material]
E = {E}
nu = 0.0
density = {rho}
[section]
thickness = {t}
[method]
kind = "fem"
[nodesets.left]
plane = {{point = [0, 0, 0], normal = [1, 0, 0]}}
[nodesets.right]
plane = {{point = [{L}, 0, 0], normal = [1, 0, 0]}}
[[boundary]]
nodes = "left"
fix = ["uz"]
[[boundary]]
nodes = "right"
fix = ["uz"]
[solve]
kind = "dynamic"
end_time = 100.0
dt_rule = "shell"
"""


def timoshenko_frequency(k, EI, kGA, mass, inertia_arm):
    """Lowest circular frequency of a Timoshenko beam's simply supported mode of wave number k
    (w = W sin kx, psi = Psi cos kx), mass per length `mass`, rotary inertia per length
    mass * inertia_arm: the 2x2 eigenproblem of m w'' = kGA (w'' - psi'),
    rho I psi'' = EI psi'' + kGA (w' - psi)."""
    stiffness = np.array([[kGA * k * k, -kGA * k], [-kGA * k, EI * k * k + kGA]])
    inertia = np.diag([mass, mass * inertia_arm])
    return float(np.sqrt(np.min(np.linalg.eigvals(np.linalg.solve(inertia, stiffness)).real)))


def ring_strip(tmp_path, nx, periods=10.0, chunk=40):
    """A simply supported strip (a plate in cylindrical bending, nu = 0; L = 1, b = 0.05,
    t = 0.01: L/t = 100), fem, set ringing in its first mode from w = 0 with the mode's
    velocity (amplitude 0.1 t) and rotation rate.  Returns the mid-span history, the
    analytic frequencies and the energies over `periods` periods."""
    L, b, t, E, rho = 1.0, 0.05, 0.01, 1.0e4, 1.0
    from taichi_shell_mpm.scene import load_scene

    from .conftest import write_scene
    sim = simulation(load_scene(write_scene(tmp_path, STRIP.format(L=L, b=b, t=t, E=E, rho=rho, nx=nx))), tmp_path)
    s = sim.state
    x = sim.model.points
    k = np.pi / L
    mass, EI, kGA = rho * b * t, E * b * t ** 3 / 12, 5.0 / 6.0 * E / 2 * b * t
    euler_bernoulli = k * k * np.sqrt(EI / mass)
    # [solve].rotary_inertia = "scaled": J = m max(t^2/12, A/8) = m A/8 here (A/8 = 3.1e-4
    # against t^2/12 = 8.3e-6 at nx = 20): the scheme's beam has that rotary inertia
    arm = float(sim.model.node_inertia.sum() / sim.model.node_mass.sum())
    scheme = timoshenko_frequency(k, EI, kGA, mass, arm)
    physical = timoshenko_frequency(k, EI, kGA, mass, t * t / 12)
    amplitude = 1e-3 * euler_bernoulli                        # w_max = 0.1 t
    velocity, omega = np.zeros_like(x), np.zeros_like(x)
    velocity[:, 2] = amplitude * np.sin(k * x[:, 0])
    omega[:, 1] = -amplitude * k * np.cos(k * x[:, 0])        # omega = (dw'/dy, -dw'/dx, 0)
    s.put("nodes.velocity", velocity)
    s.put("nodes.grid_velocity", velocity)
    s.put("nodes.omega", omega)
    sim.initial_kinetic = sim.kinetic_energy()
    mid = np.nonzero(np.abs(x[:, 0] - 0.5 * L) < 1e-9)[0]
    step = lambda: sim.stepper.advance(1)                     # noqa: E731
    energy0 = leapfrog_energy(sim, step)
    times, deflection, drift, balance = [], [], 0.0, 0.0
    while s.step.time[None] < periods * 2 * np.pi / scheme + 0.25 * chunk * s.step.dt[None]:
        assert sim.stepper.advance(chunk - 1) == chunk - 1
        sim.check_status()
        drift = max(drift, abs(leapfrog_energy(sim, step) - energy0) / energy0)
        balance = max(balance, abs(sim.energies()["balance_error"]) / sim.initial_kinetic)
        times.append(s.step.time[None])
        deflection.append(s.fetch("nodes.position")[mid, 2].mean())
    return (np.array(times), np.array(deflection), euler_bernoulli, scheme, physical, drift, balance,
            s.step.dt[None], int(s.step.step[None]))


def test_free_vibration_period_and_energy(tmp_path):
    """method.md 9: a free vibrating plate conserves its energy over 10 periods, here with its
    period against the analytic one.  The period is twice the slope of the mid-span
    deflection's zero crossings (linear interpolation between samples 40 steps apart, 1/170
    of a period) against their count, over 10 periods.  Reference: the Timoshenko beam of the
    same section (kappa = 5/6) with the scheme's rotary inertia J/m = A/8 (the scaled
    inertia, which alone lowers the frequency by 0.15 % at nx = 20 against Euler-Bernoulli,
    shear 0.01 %).  Measured (frequency error against it): nx = 10: +0.411 %, nx = 20:
    +0.103 %, nx = 40: +0.026 % (second order; nx = 40 takes 25 s and is left out); bounds
    1.5x.  Cross-check of the inertia correction: with rotary_inertia = "physical" the nx = 20
    strip gives +0.103 % against the Timoshenko beam with J/m = t^2/12 as well (run at
    dt_safety = 0.2: at the default 0.9 it diverges within 9 steps, the time step having no
    rotational limit; method.md 5).  Energy: the scheme's energy (leapfrog_energy) stays to 2.4e-12 of the initial
    (round-off over 56 000 and 71 000 steps; bound 1e-11, method.md 9 asks < 0.5 %); the
    energy.csv balance error reaches omega dt / 2 of it (4.5e-4 at nx = 20: the stagger of
    the half-step kinetic energy), asserted below 1.5 omega dt / 2."""
    bounds = {10: 6.2e-3, 20: 1.55e-3}
    errors = {}
    for nx, bound in bounds.items():
        (tmp_path / str(nx)).mkdir()
        times, w, euler_bernoulli, scheme, physical, drift, balance, dt, steps = ring_strip(tmp_path / str(nx), nx)
        sign = np.sign(w)
        i = np.nonzero(sign[:-1] * sign[1:] < 0)[0]
        crossings = times[i] - w[i] * (times[i + 1] - times[i]) / (w[i + 1] - w[i])
        period = 2 * np.polyfit(np.arange(len(crossings)), crossings, 1)[0]
        frequency = 2 * np.pi / period
        errors[nx] = frequency / scheme - 1
        print(f"\nnx = {nx}: {steps} steps, {len(crossings)} zero crossings: omega {frequency:.6f}; Timoshenko "
              f"(scheme's J) {scheme:.6f}: error {100 * errors[nx]:+.3f} %; Euler-Bernoulli {euler_bernoulli:.6f} "
              f"({100 * (frequency / euler_bernoulli - 1):+.3f} %), physical J {physical:.6f}; energy drift "
              f"{drift:.1e}, energy.csv balance {balance:.2e} (omega dt / 2 = {0.5 * scheme * dt:.2e})")
        assert len(crossings) == 20
        assert abs(errors[nx]) <= bound
        assert drift <= 1e-11
        assert balance <= 1.5 * 0.5 * scheme * dt
    order = np.log2(errors[10] / errors[20])
    print(f"observed order {order:.2f}")
    assert 1.8 < order < 2.2
