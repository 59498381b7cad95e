"""The feature-pair matrix (issue 28, item 15): features that each pass their own tests,
taken in pairs (and the triples a crash model uses) on one few-element scene, each run
asserting the invariants that hold for it.

The scene is a free 4 x 4 sheet (1 x 1 x 0.02, consistent units: N, m, kg, s) thrown at
[0.3, 0.1, -0.2] with its edge x = 1 (`poke`) thrown at +1 along z instead, for 0.2 (some hundred steps).  A feature
is a fragment of that scene (FEATURES); a run of the base plus some fragments checks:

* **finite**: the run ends (no run-time error) with a finite state;
* **mass**: the free nodes' masses plus the rigid bodies' equal the live elements' mass plus
  the point masses plus the mass conventional mass scaling added;
* **momentum**: without an external force the linear momentum sum m v~ (free nodes) + M V
  (bodies) keeps its initial value to round-off; with gravity alone it grows by M g t
  exactly (M the physical mass: a lost point mass, or gravity on eroded mass, shows here);
* **energy**: the balance error stays within 1 % of the energy absorbed (energy.py's guard
  ratio; the run's own guard stops at 5 %);
* **restart** (the CI crash set, every triple in the matrix): the run stopped half
  way and restarted gives byte-identical tables (tests/test_restart.restart_roundtrip).

A seeded fuzz draws new numbers (speeds, spins, tool size and stiffness, failure strain)
for the CI crash set's scene: its kernels are the CI cases', so it costs no compile.

CI runs one feature set, ``CRASH`` (the crash triple with point masses, mass scaling and
gravity), with the numbers of ``CI_VALUES``: a compile of a feature set costs minutes, so CI
compiles one.  The hourglass limit is off (the poked sheet rings in hourglass modes; their
energy is in the balance, which is checked).  The whole matrix runs
with ``python -m pytest tests/test_matrix.py -m matrix`` (a compile per pair: about an hour
on 2 cores).  docs/matrix.md lists what the matrix found.
"""
from __future__ import annotations

import copy
import itertools

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from taichi_shell_mpm.energy import balance_ratio, eroded_elements, mass_factors, node_masses
from taichi_shell_mpm.scene import load_scene
from taichi_shell_mpm.simulation import SimulationError
from taichi_shell_mpm.solvers.dynamic import run_dynamic

from .conftest import simulation, write_scene
from .test_fuzz_run import dump_toml
from .test_restart import restart_roundtrip
from .test_tools import cube_surface

GRAVITY = [0.0, 0.0, -9.81]

BASE = {
    "scene": {"name": "matrix", "units": "consistent: N, m, kg, s"},
    "mesh": {"kind": "plate", "lx": 1.0, "ly": 1.0, "nx": 4, "ny": 4},
    "materials": {"steel": {"E": 1e5, "nu": 0.3, "density": 10.0}},
    "sections": {"sheet": {"thickness": 0.02}},
    "part": [{"name": "sheet", "material": "steel", "section": "sheet", "elements": "all"}],
    "method": {"kind": "mpm"},
    "nodesets": {"poke": {"plane": {"point": [1, 0, 0], "normal": [1, 0, 0]}}, "edge": {"plane": {"point": [0, 0, 0], "normal": [1, 0, 0]}}},
    "initial": [{"nodes": "all", "velocity": [0.3, 0.1, -0.2]},
                {"nodes": "poke", "velocity": [0.3, 0.1, 1.0]}],
    "solve": {"kind": "dynamic", "end_time": 0.2, "dt_rule": "shell"},
    "output": {"times": [0.1]},
}


class Feature:
    """A scene fragment (merged into BASE), and what it does to the invariants."""

    def __init__(self, fragment: dict, *, external: bool = False, mpm_only: bool = False,
                 mesh_file: bool = False):
        self.fragment = fragment
        self.external = external      # a force from outside the sheet: momentum not conserved
        self.mpm_only = mpm_only
        self.mesh_file = mesh_file    # needs the tool mesh written beside the scene


FEATURES = {
    "fem": Feature({"method": {"kind": "fem"}}),
    "j2": Feature({"materials": {"steel": {"model": "j2", "yield_stress": 30.0, "hardening": 1e3}}}),
    "rate": Feature({"materials": {"steel": {"model": "j2", "yield_stress": 30.0, "rate_law": "cowper_symonds",
                                             "C": 40.0, "p": 5.0}}}),
    "erosion": Feature({"materials": {"steel": {"model": "j2", "yield_stress": 30.0, "failure_strain": 10.0}}}),
    "mass_scaling": Feature({"solve": {"mass_scaling": "conventional", "target_dt": 2.5e-3, "added_mass_limit": 1e4}}),
    # selective mass scaling (fem only; issue 29) at ten times the sheet's step (1.5e-3)
    "selective": Feature({"method": {"kind": "fem"}, "solve": {"mass_scaling": "selective", "target_dt": 1.5e-2}}),
    "point_mass": Feature({"point_mass": [{"name": "tip", "nodes": "poke", "mass": 0.05}]}),
    "body": Feature({"rigid_body": [{"name": "bar", "nodes": "edge", "spin": [0.0, 0.0, 0.5]}]}),
    "triangles": Feature({"mesh": {"triangles": "all"}}),
    # the OPT triangle (issue 33): ANDES membrane with drilling rotations
    "opt_triangles": Feature({"mesh": {"triangles": "all"}, "element": {"triangle": "opt"}}),
    # the node-smoothed triangle (issue 33): membrane strain smoothed over each node's triangles
    "ns_triangles": Feature({"mesh": {"triangles": "all"}, "element": {"triangle": "ns"}}),
    "layered": Feature({"sections": {"sheet": {"plies": [{"material": "steel", "thickness": 0.01, "angle": 0.0},
                                                         {"material": "steel", "thickness": 0.01, "angle": 90.0}]}}}),
    "contact": Feature({"contact": {"stiffness": 0.1}}),
    "multi_field": Feature({"method": {"fields": "multi"}}, mpm_only=True),
    "polypic": Feature({"method": {"transfer": "polypic"}}, mpm_only=True),
    "gravity": Feature({"gravity": {"acceleration": GRAVITY}}, external=True),
    "pressure": Feature({"pressure": [{"value": 0.5}]}, external=True),
    "motion": Feature({"motion": [{"name": "pin", "nodes": "poke", "dofs": ["uz"], "kind": "velocity",
                                   "value": 0.5}]}, external=True),
    "wall": Feature({"wall": [{"point": [0.0, 0.0, -0.03], "normal": [0.0, 0.0, 1.0]}]}, external=True),
    "tool_sphere": Feature({"tool": [{"name": "ball", "kind": "sphere", "center": [0.5, 0.5, -0.15],
                                      "radius": 0.1, "velocity": [0.0, 0.0, 0.5]}]}, external=True),
    "tool_mesh": Feature({"tool": [{"name": "punch", "kind": "mesh", "file": "cube.vtu", "center": [0.4, 0.4, -0.25],
                                    "velocity": [0.0, 0.0, 0.5]}]}, external=True, mesh_file=True),
}

def merge(into: dict, fragment: dict, append: bool = True) -> None:
    """Merge a fragment into a scene document: tables merge key by key; arrays of tables
    ([[tool]], [[initial]] ...) get the fragment's entries appended, or replaced (`append`
    false: the fuzz's new numbers for the same entries)."""
    for key, value in fragment.items():
        if isinstance(value, dict) and isinstance(into.get(key), dict):
            merge(into[key], value, append)
        elif append and isinstance(value, list) and isinstance(into.get(key), list) and value \
                and isinstance(value[0], dict):
            into[key] = into[key] + copy.deepcopy(value)
        else:
            into[key] = copy.deepcopy(value)


def scene_doc(names: tuple[str, ...]) -> dict:
    doc = copy.deepcopy(BASE)
    doc["scene"]["name"] = "matrix_" + "_".join(names)
    for name in names:
        merge(doc, FEATURES[name].fragment)
    if "layered" in names:       # the plies replace the section's thickness and the part's material
        doc["sections"]["sheet"].pop("thickness", None)
        doc["part"][0].pop("material")
    return doc


def compatible(names: tuple[str, ...]) -> bool:
    fem = "fem" in names or "selective" in names
    return not (fem and any(FEATURES[n].mpm_only for n in names)) and \
        not ("tool_sphere" in names and "tool_mesh" in names) and not ("selective" in names and "mass_scaling" in names) \
        and sum(n in names for n in ("triangles", "opt_triangles", "ns_triangles")) <= 1


def write_case(tmp_path, names: tuple[str, ...], values: dict | None = None):
    """The case's scene file (and the tool mesh it reads); `values` (merged last, replacing)
    changes numbers of the case, not its feature set (so not its compiled kernels)."""
    doc = scene_doc(names)
    merge(doc, values or {}, append=False)
    if any(FEATURES[n].mesh_file for n in names):
        cube_surface(tmp_path, half=0.1, name="cube.vtu")
    return write_scene(tmp_path, dump_toml(doc), "matrix.toml")


def free_nodes(model, n: int) -> np.ndarray:
    return model.node_body < 0 if model.node_body is not None else np.ones(n, bool)


def momentum(sim) -> np.ndarray:
    """sum m v~ over the free nodes + M V over the rigid bodies (the kinetic energy's velocities)."""
    state, model = sim.state, sim.model
    m, _ = node_masses(state, model)
    free = free_nodes(model, len(m))
    v = state.read(state.nodes.grid_velocity, state.n_nodes)
    p = (m[free, None] * v[free]).sum(axis=0)
    for b, body in zip(model.rigid_bodies, sim.body_state()):
        p = p + b.total_mass * body["velocity"]
    return p


def total_mass(sim) -> float:
    """The mass the step moves: the free nodes' and the rigid bodies'."""
    m, _ = node_masses(sim.state, sim.model)
    return float(m[free_nodes(sim.model, len(m))].sum()) + sum(b.total_mass for b in sim.model.rigid_bodies)


def accounted_mass(sim) -> tuple[float, float]:
    """(physical, added): the mass the step must move, from the model and the elements' state.
    Physical: the live elements' shares and the point masses on the free nodes, and each rigid
    body's mass (fixed when it is built, from its nodes' shares: an element eroding at a
    body's node, or scaled there, leaves the body's mass as it was).  Added: conventional mass scaling's
    (f_e - 1) shares of the live elements on the free nodes."""
    model = sim.model
    free = free_nodes(model, len(model.points))
    live = ~eroded_elements(sim.state)
    shares = (model.corner_mass * free[model.elements])[live]
    factors = mass_factors(sim.state, model)[live]
    if sim.cfg.selective_mass:          # its added mass is a matrix, zero on translations: no mass added
        factors = np.ones_like(factors)
    points = sum(pm.mass * float(free[pm.nodes].sum()) for pm in model.point_masses)
    physical = float(shares.sum()) + points + sum(b.total_mass for b in model.rigid_bodies)
    return physical, float(((factors - 1.0)[:, None] * shares).sum())


def created_ratio(e: dict) -> float:
    """The balance ratio when energy was created (the side the run's guard stops on), else 0."""
    return balance_ratio(e) if e["balance_error"] > 0.0 else 0.0


def measure(tmp_path, names: tuple[str, ...], values: dict | None = None,
            externals: tuple[str, ...] | None = None) -> dict:
    """Run the case in-process to its end time; the invariants' figures.  `externals`: the
    features that push from outside in this case (default: those of `names`; a tool parked
    far away pushes nothing)."""
    sim = simulation(load_scene(write_case(tmp_path, names, values)), tmp_path)
    sim.hourglass_limit = 0.0        # the poked sheet rings in hourglass modes: their energy is in the balance
    mass0, _ = accounted_mass(sim)
    p0 = momentum(sim)
    run_dynamic(sim)
    t = float(sim.state.step.time[None])
    physical, added = accounted_mass(sim)
    eroded = int(eroded_elements(sim.state).sum())
    p1 = momentum(sim)
    figures = {"case": "+".join(names), "steps": int(sim.state.step.step[None]), "eroded": eroded,
               "balance": balance_ratio(sim.energies()), "created": created_ratio(sim.energies()), "mass_error": (total_mass(sim) - physical - added) / mass0,
               "added": added / mass0,
               "finite": bool(np.isfinite(sim.state.read(sim.state.nodes.position, sim.state.n_nodes)).all())}
    if externals is None:
        externals = tuple(n for n in names if FEATURES[n].external)
    if eroded == 0 and not externals:
        figures["momentum_drift"] = float(np.linalg.norm(p1 - p0)) / mass0
    elif eroded == 0 and externals == ("gravity",):
        figures["momentum_drift"] = float(np.linalg.norm(p1 - p0 - mass0 * np.array(GRAVITY) * t)) / mass0
    print(f"\n{figures}")
    return figures


SINGLES = [(n,) for n in FEATURES]
PAIRS = [p for p in itertools.combinations(FEATURES, 2) if compatible(p)]
# the triples a crash model is made of: erosion + contact + a tool + a rigid body, and more
TRIPLES = [("erosion", "contact", "tool_sphere", "body"), ("erosion", "contact", "tool_mesh", "body"),
           ("j2", "mass_scaling", "point_mass", "gravity"), ("erosion", "mass_scaling", "point_mass", "body"),
           ("fem", "erosion", "contact", "tool_sphere", "body")]
# CI: one feature set (one compile: ~12 min cold on one core for this mpm set, so one only),
# the crash triple with the review's defects (point masses under erosion and mass scaling,
# gravity with erosion), taken with different numbers:
CRASH = ("erosion", "mass_scaling", "point_mass", "contact", "tool_sphere", "body", "gravity")
CI_VALUES = {
    # the ball strikes and elements fail: mass and balance
    "strike": {"tool": [{"name": "ball", "kind": "sphere", "center": [0.5, 0.5, -0.15], "radius": 0.1,
                         "velocity": [0.0, 0.0, 3.0]}],
               "materials": {"steel": {"failure_strain": 0.02}}},
    # the ball parked far away, nothing fails: gravity is the only external force, so the
    # momentum grows by M g t to round-off (a point mass lost, or gravity on a mass that is
    # not there, shows)
    # (target_dt below every element's step: mass scaling compiled in, adding nothing)
    "free": {"tool": [{"name": "ball", "kind": "sphere", "center": [0.5, 0.5, -100.0], "radius": 0.1,
                       "velocity": [0.0, 0.0, 0.0]}],
             "solve": {"target_dt": 1e-9}},
    # the same with conventional mass scaling adding mass (61 % here): a matrix finding
    # (docs/matrix.md) -- the added mass is recomputed every step and a node's velocity is kept
    # when its mass changes, so sum m v drifts (0.17 m/s of 1.96 m/s of fall, per unit mass):
    # what conventional scaling is; selective scaling (issue 29, fem) adds no mass and keeps
    # the momentum (tests/test_selective_mass.py)
    "free_scaled": {"tool": [{"name": "ball", "kind": "sphere", "center": [0.5, 0.5, -100.0], "radius": 0.1,
                              "velocity": [0.0, 0.0, 0.0]}]},
}
HOURGLASS_OFF = ["--hourglass-limit", "0"]      # as measure's (CLI runs)


def check_invariants(tmp_path, names: tuple[str, ...], values: dict | None = None,
                     externals: tuple[str, ...] | None = None) -> dict:
    """The case's invariants: finite, mass accounted to round-off, momentum (where no external
    force acts, or gravity alone) to round-off (per unit mass: a velocity, against speeds of
    order 1), balance within 1 % of the energy absorbed."""
    figures = measure(tmp_path, names, values, externals)
    assert figures["finite"], figures
    assert abs(figures["mass_error"]) < 1e-12, figures
    if "momentum_drift" in figures:
        assert figures["momentum_drift"] < 1e-10, figures
    assert figures["balance"] < 0.01, figures
    return figures


@pytest.mark.parametrize("case", [
    "strike", "free",
    pytest.param("free_scaled", marks=pytest.mark.xfail(strict=True, reason="conventional scaling adds mass "
                                                                              "at the nodes' velocity"))])
def test_ci_crash_set_invariants(tmp_path, case):
    figures = check_invariants(tmp_path, CRASH, CI_VALUES[case], None if case == "strike" else ("gravity",))
    if case == "strike":
        assert figures["eroded"] > 0, figures        # erosion was exercised
    else:
        assert "momentum_drift" in figures, figures


def test_ci_crash_set_restarts_bit_for_bit(tmp_path, monkeypatch):
    scene = write_case(tmp_path, CRASH, CI_VALUES["strike"])
    restart_roundtrip(tmp_path, monkeypatch, [str(scene), *HOURGLASS_OFF], stop_step=40, every=25,
                      batch_element_steps=90)


@pytest.mark.matrix
@pytest.mark.parametrize("names", SINGLES + PAIRS + TRIPLES, ids="+".join)
def test_matrix_invariants(tmp_path, names):
    check_invariants(tmp_path, names)


@pytest.mark.matrix
@pytest.mark.parametrize("names", TRIPLES, ids="+".join)
def test_matrix_restart(tmp_path, monkeypatch, names):
    scene = write_case(tmp_path, names)
    restart_roundtrip(tmp_path, monkeypatch, [str(scene), *HOURGLASS_OFF], stop_step=40, every=25,
                      batch_element_steps=90)


# ------------------------------------------------------------------ seeded run-time fuzz
def drawn_values(data) -> dict:
    """New numbers for the CI crash set's scene: its feature set (so its compiled kernels)
    stays, the loads, speeds, masses and contact settings change."""
    vec = st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3)
    return {
        "initial": [{"nodes": "all", "velocity": data.draw(vec)}, {"nodes": "poke", "velocity": data.draw(vec)}],
        "rigid_body": [{"name": "bar", "nodes": "edge", "spin": data.draw(vec)}],
        "tool": [{"name": "ball", "kind": "sphere", "radius": data.draw(st.floats(0.05, 0.4)),
                  "center": [0.5, 0.5, -data.draw(st.floats(0.1, 0.6))],
                  "velocity": [0.0, 0.0, data.draw(st.floats(0.0, 3.0))],
                  "stiffness": data.draw(st.floats(0.01, 1.0)), "friction": data.draw(st.floats(0.0, 1.0))}],
        "contact": {"stiffness": data.draw(st.floats(0.01, 1.0))},
        "materials": {"steel": {"failure_strain": data.draw(st.floats(0.005, 1.0))}},
        "point_mass": [{"name": "tip", "nodes": "poke", "mass": data.draw(st.floats(1e-3, 1.0))}],
    }


@settings(max_examples=4, deadline=None, database=None, suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_seeded_fuzz_of_the_crash_set(tmp_path_factory, data):
    """Random numbers on the CI crash set (derandomized, so the same draws on every run;
    HYPOTHESIS_PROFILE=explore draws new ones): a run either stops with a one-line
    SimulationError (the guards) or ends with the mass accounted and the balance within the
    guard's 5 %."""
    tmp = tmp_path_factory.mktemp("fuzz")
    values = drawn_values(data)
    try:
        figures = measure(tmp, CRASH, values)
    except SimulationError as exc:          # a guard stopped it: one line, naming the cause
        assert "\n" not in str(exc)
        print(f"stopped: {exc}")
        return
    # the run's guard stops on energy created above 5 % of the energy absorbed; energy lost
    # (transfer dissipation, erosion's booking) is warned of, not stopped: so only the created
    # side is bounded here (both printed)
    assert figures["finite"] and abs(figures["mass_error"]) < 1e-12, figures
    assert figures["created"] < 0.05, figures
