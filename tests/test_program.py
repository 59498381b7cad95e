"""Runs in one process reuse the live Taichi program's state and kernels when they would build
the same ones (taichi_shell_mpm/program.py, issue 32): a reused run gives byte for byte what
the same run gives in a fresh program, whatever ran before it; anything that would change a
kernel starts afresh; an earlier Simulation is stale and says so."""
from __future__ import annotations

import filecmp

import pytest

from taichi_shell_mpm import program
from taichi_shell_mpm.api import Simulation, run
from taichi_shell_mpm.runtime import init_taichi
from taichi_shell_mpm.scene import load_scene

from .conftest import ROOT

TABLES = ("probes.csv", "energy.csv", "force.csv", "parts.csv")
CASES = {   # scene, the first run's overrides, the second's (other values, the same kernels)
    "cantilever": ("cantilever.toml", ("material.E=1.5e7",), ("material.E=2.5e7", "material.nu=0.25")),
    "sphere_drop": ("sphere_drop.toml", ("solve.end_time=0.8",), ("solve.end_time=0.8", "tool.0.friction=0.1",
                                                                  "element.hourglass=0.08")),
}


def run_in(out, scene: str, overrides) -> None:
    run(load_scene(ROOT / "scenes" / scene, list(overrides)), out=out, progress=False)


def same_tables(a, b) -> list[str]:
    """The history tables that differ between two output folders (those both have)."""
    return [t for t in TABLES if (a / t).is_file() and not filecmp.cmp(a / t, b / t, shallow=False)]


def fresh_program() -> None:
    init_taichi("cpu", quiet=True)          # a new program: the live state is dropped


@pytest.mark.parametrize("case", CASES)
def test_a_reused_run_is_byte_identical_to_the_same_run_in_a_fresh_program(tmp_path, case):
    scene, first, second = CASES[case]
    run_in(tmp_path / "first", scene, first)
    live = program._live
    run_in(tmp_path / "reused", scene, second)
    assert program._live is live, "the second run did not reuse the first one's program"
    fresh_program()
    run_in(tmp_path / "fresh", scene, second)
    assert program._live is not live
    assert (tmp_path / "fresh" / "energy.csv").is_file()
    assert same_tables(tmp_path / "fresh", tmp_path / "reused") == []


def test_a_run_after_an_interrupted_one_is_byte_identical_to_a_fresh_one(tmp_path, monkeypatch):
    """A run stopped half-way (Ctrl-C) leaves its state dirty: the next run clears it."""
    from taichi_shell_mpm import run_control
    from taichi_shell_mpm.api import RunInterrupted
    scene, first, second = CASES["sphere_drop"]
    monkeypatch.setattr(run_control, "stop_hook", lambda sim: sim.state.step.step[None] >= 300)
    with pytest.raises(RunInterrupted):
        run_in(tmp_path / "stopped", scene, first)
    monkeypatch.setattr(run_control, "stop_hook", None)
    live = program._live
    run_in(tmp_path / "reused", scene, second)
    assert program._live is live
    fresh_program()
    run_in(tmp_path / "fresh", scene, second)
    assert same_tables(tmp_path / "fresh", tmp_path / "reused") == []


def test_what_would_change_a_kernel_starts_afresh(tmp_path, monkeypatch):
    """Other features, another mesh size, or a constant a kernel reads changed between runs
    (a module's constant or a class attribute, as a test or a user might patch one): a fresh
    program each time."""
    from taichi_shell_mpm.stages import timestep
    from taichi_shell_mpm.stages.material import PlaneStressElastic
    scene = "cantilever.toml"
    run_in(tmp_path / "a", scene, ())
    for k, overrides in enumerate((("method.kind=fem",), ("method.kind=fem", "mesh.nx=12"))):
        live = program._live
        run_in(tmp_path / f"b{k}", scene, overrides)
        assert program._live is not live, overrides
    for owner, name in ((timestep, "MAX_TURN"), (PlaneStressElastic, "constant_for_this_test")):
        live = program._live
        monkeypatch.setattr(owner, name, getattr(owner, name, 0.0) + 0.125, raising=False)
        run_in(tmp_path / f"c_{name}", scene, ("method.kind=fem", "mesh.nx=12"))
        assert program._live is not live, name
    live = program._live             # nothing changed since: reused
    run_in(tmp_path / "d", scene, ("method.kind=fem", "mesh.nx=12"))
    assert program._live is live


def test_an_earlier_simulation_is_stale_and_says_so(tmp_path):
    scene = ROOT / "scenes" / "sphere_drop.toml"
    first = Simulation(load_scene(scene, ["solve.end_time=0.05"]), out=tmp_path / "first")
    first.advance(0.01)
    second = Simulation(load_scene(scene, ["solve.end_time=0.05"]), out=tmp_path / "second")
    with pytest.raises(RuntimeError, match="stale"):
        first.advance(0.02)
    assert second.advance(0.02) == pytest.approx(0.02)



def test_a_kept_run_never_builds_over_fields_another_run_left(tmp_path):
    """A run that cannot reuse the live program starts a fresh one whenever Taichi's program
    holds fields (program.release): after a Simulation made without `keep` (a Newton run's, a
    test's), a kept run's kernels would otherwise be built over SNode ids the offline cache
    does not have them under, and compile cold."""
    from taichi_shell_mpm.simulation import Simulation as Core
    scene = load_scene(ROOT / "scenes" / "sphere_drop.toml", ["solve.end_time=0.05"])
    fresh_program()
    Core(scene, tmp_path / "loose", quiet=True)             # not kept: its fields stay behind
    held = program.current_program()
    assert held.get_snode_tree_size() > 0
    run(scene, out=tmp_path / "kept", progress=False)
    assert program._live.program is program.current_program() is not held
