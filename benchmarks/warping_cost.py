"""Cost of ``[element].warping = "bwc"``: both variants of a scene built in one process and
timed in alternating rounds (fair on a shared machine: the minimum and the median over the
rounds are printed), in µs per element-step of wall time and of process CPU time (all
threads; the steadier of the two when other jobs share the cores).

    python -m benchmarks.warping_cost scenes/square_tube.toml --steps 1000 --rounds 8

(`python -m` from the repository root imports this checkout's package.)

First each variant takes --warmup steps; then, per round, --steps full steps of each
(``Stepper.advance``, the launch the run would use); then the element stage alone (its
kernel launched --steps times) with all velocities set to zero, so that the stresses do not
drift (the arithmetic is the same at any rate).
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import taichi as ti

from taichi_shell_mpm.scene import load_scene
from taichi_shell_mpm.simulation import Simulation
from taichi_shell_mpm.runtime import init_taichi

VARIANTS = ("none", "bwc")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scene", type=Path)
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--steps", type=int, default=1000)
    p.add_argument("--rounds", type=int, default=8)
    p.add_argument("--warmup", type=int, default=200)
    a = p.parse_args()
    init_taichi("cpu")
    sims, stages = {}, {}
    out = Path(tempfile.mkdtemp(prefix="warping_cost_"))
    for w in VARIANTS:
        scene = load_scene(a.scene, [*a.set, f"element.warping={w}", "output.times=[]"])
        sim = Simulation(scene, out / w, quiet=True)
        sims[w] = sim
        stages[w] = _element_stage(sim)
        sim.stepper.advance(a.warmup)
    n = sims["none"].state.n_elements
    full = {w: [] for w in VARIANTS}
    element = {w: [] for w in VARIANTS}
    full_cpu = {w: [] for w in VARIANTS}
    element_cpu = {w: [] for w in VARIANTS}
    for r in range(a.rounds):
        for w in VARIANTS if r % 2 == 0 else VARIANTS[::-1]:
            ti.sync()
            t0, c0 = time.perf_counter(), time.process_time()
            done = sims[w].stepper.advance(a.steps)
            ti.sync()
            full[w].append((time.perf_counter() - t0) / max(done, 1) / n * 1e6)
            full_cpu[w].append((time.process_time() - c0) / max(done, 1) / n * 1e6)
    for w in VARIANTS:
        sims[w].state.grid_velocity.fill(0)
        sims[w].state.omega.fill(0)
        stages[w]()
    for r in range(a.rounds):
        for w in VARIANTS if r % 2 == 0 else VARIANTS[::-1]:
            ti.sync()
            t0, c0 = time.perf_counter(), time.process_time()
            for _ in range(a.steps):
                stages[w]()
            ti.sync()
            element[w].append((time.perf_counter() - t0) / a.steps / n * 1e6)
            element_cpu[w].append((time.process_time() - c0) / a.steps / n * 1e6)
    print(f"{a.scene} {' '.join(a.set)}: {n} elements, {sims['none'].cfg.launch} launch, "
          f"{a.rounds} rounds of {a.steps} steps (us per element-step, min / median)")
    for w in VARIANTS:
        print(f"  {w:5s} wall: full step {min(full[w]):.3f} / {statistics.median(full[w]):.3f}, "
              f"element stage {min(element[w]):.3f} / {statistics.median(element[w]):.3f};  "
              f"cpu: full step {min(full_cpu[w]):.3f} / {statistics.median(full_cpu[w]):.3f}, "
              f"element stage {min(element_cpu[w]):.3f} / {statistics.median(element_cpu[w]):.3f}")
    return 0


def _element_stage(sim):
    @ti.kernel
    def stage():
        sim.stepper.shell.element_pass()
    return stage


if __name__ == "__main__":
    raise SystemExit(main())
