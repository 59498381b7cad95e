"""Numerical stability: a free plate spinning about its normal for 10,000 steps keeps its
kinetic energy and angular momentum (issue 2; method.md 2.2).  Plain PIC does not, which
shows the test can fail and why APIC is the default transfer."""
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
    dt = sim.state.dt[None]
    omega = 3 * np.pi / (STEPS * dt)
    s = sim.state
    s.velocity.from_numpy(sim.model.velocity0 * omega)
    s.grid_velocity.from_numpy(sim.model.velocity0 * omega)
    s.omega.from_numpy(sim.model.omega0 * omega)      # the nodes spin with the plate (drilling kept)
    sim.initial_kinetic = sim.kinetic_energy()          # KE_0 of the balance guard
    m = sim.model.node_mass

    def invariants():
        x, v = s.position.to_numpy(), s.grid_velocity.to_numpy()
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
    """Advance like solvers/dynamic.py with an output time every `every` stable steps."""
    from taichi_shell_mpm.stages.timestep import landing_step
    s = sim.state
    done = 0
    while done < steps:
        s.time_limit[None] = s.time[None] + every * s.dt_stable[None]
        s.dt[None] = landing_step(s.time_limit[None] - s.time[None], s.dt_stable[None])
        while s.dt[None] > 0.0 and done < steps:
            done += sim.stepper.advance(steps - done)
            sim.check_status()


@pytest.mark.parametrize("method", ["fem", "mpm"])
def test_landing_on_output_times_keeps_the_energy(tmp_path, method):
    """An 8x8 free plate ringing (smooth bending and shear velocity fields), with an output
    time every 5.3 stable steps: the steps that land on them (stages/timestep.py) must not
    modulate dt.  Clipping only the last steps to the output time (the rule before) turned
    an element inside out here within 500 steps (fem; mpm: a node left the grid at step
    1 648); now the balance error stays at its start-up value (the initial velocity is
    taken as v^(1/2))."""
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
    s.velocity.from_numpy(velocity)
    s.grid_velocity.from_numpy(velocity)
    sim.initial_kinetic = sim.kinetic_energy()
    land_on_output_times(sim, 3000, 5.3)
    e = sim.energies()
    error = abs(e["balance_error"]) / sim.initial_kinetic
    print(f"\n{method}: {int(s.step[None])} steps: balance error {error:.2e} of the initial KE")
    assert error < 0.05


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
    steps = int(0.25 * 2 * np.pi / 0.1 / s.dt[None])
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
