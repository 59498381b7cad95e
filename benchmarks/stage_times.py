"""Per-stage cost of the explicit step at any point of a run, from a checkpoint.

    python -m taichi_shell_mpm run scenes/square_tube.toml --set solve.end_time=12 \\
        --checkpoint-every 80000 --out outputs/late
    python benchmarks/stage_times.py outputs/late scenes/square_tube.toml --set solve.end_time=12

Restores the checkpoint (the scene and --set items must be those of the run), times
``Stepper.advance`` over --steps steps, then each stage alone in a kernel of its own
(the quads' update alone; the element pass with the corner loads' gather; the velocity
update: bodies, P2G + G2P + grid clear or the FE node update; contact), in µs per
element-step on the launch the run would use.  The stage kernels keep stepping the
restored state, so only their times mean anything.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import taichi as ti

from taichi_shell_mpm.checkpoint import load_checkpoint, restore_checkpoint
from taichi_shell_mpm.preflight import prepare
from taichi_shell_mpm.simulation import Simulation
from taichi_shell_mpm.runtime import init_taichi


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("checkpoint", type=Path, help="directory holding checkpoint.npz")
    p.add_argument("scene", type=Path)
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--steps", type=int, default=300)
    a = p.parse_args()
    scene, mesh, model = prepare(a.scene, a.set)
    init_taichi("cpu")
    sim = Simulation(scene, a.checkpoint, "cpu", quiet=True, mesh=mesh, model=model)
    restore_checkpoint(sim, load_checkpoint(a.checkpoint))
    s, st = sim.state, sim.stepper
    step = s.step
    step.time_limit[None] = 1e300
    step.dt[None] = step.dt_stable[None]
    n = s.n_elements

    @ti.kernel
    def element():
        for e in range(s.elements.count[None]):
            st.shell.update(e)

    @ti.kernel
    def element_pass():
        st.shell.element_pass()

    @ti.kernel
    def velocity_update():
        st.velocity_update()

    @ti.kernel
    def contact():
        st.contact.forces()

    pairs = (lambda: s.contact.pairs[None]) if st.contact is not None else (lambda: 0)
    print(f"t = {step.time[None]:.4g}, step {step.step[None]}, {n} elements, {sim.cfg.launch} launch")
    t0 = time.perf_counter()
    done = st.advance(a.steps)
    ti.sync()
    print(f"{'step (advance)':24s} {1e6 * (time.perf_counter() - t0) / (done * n):.3f} us/element-step "
          f"({pairs()} contact pairs)")
    stages = [("element (update only)", element), ("element pass (+ gather)", element_pass),
              ("velocity update", velocity_update)]
    if st.contact is not None:
        stages.append(("contact", contact))
    for name, kernel in stages:
        kernel()
        ti.sync()
        t0 = time.perf_counter()
        for _ in range(a.steps):
            kernel()
        ti.sync()
        print(f"{name:24s} {1e6 * (time.perf_counter() - t0) / (a.steps * n):.3f} us/element-step", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
