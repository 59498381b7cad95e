"""What a parallel loop costs the threads launch, and the step with its light node loops serial or not.

    python benchmarks/dispatch_cost.py loops
    python benchmarks/dispatch_cost.py step --nodes-max 0 --set method.kind=fem
    python benchmarks/dispatch_cost.py step --nodes-max 100000 --set method.kind=fem --set mesh.n_flat=20

``loops``: a kernel launched from Python with a serial body, with one parallel loop over N
items (N = 100, 2 928, 16 000; a vector update per item), and with the same loop serialized:
µs per launch (median of 5 timings of 2 000 launches).  The parallel loop's excess over the
serial kernel is the thread pool's dispatch.

``step``: scenes/square_tube.toml (or --scene) stepped by ``Stepper.advance`` with
runtime.SERIAL_NODE_LOOPS_MAX set to --nodes-max (0: every node loop parallel; large: the
light node loops serial, runtime.serial_node_loops) and the launch --launch, three timings of ~3e6 element-steps
after 30 steps: ms per step and µs per element-step.  Alternate the two settings in one
sitting: only ratios within one sitting mean anything on a shared machine.
"""

import argparse
import statistics
import time

import taichi as ti


def loops() -> None:
    ti.init(arch=ti.cpu, default_fp=ti.f64, offline_cache=False, log_level=ti.ERROR, advanced_optimization=False)
    for n in (100, 2928, 16000):
        v = ti.Vector.field(3, ti.f64, shape=n)

        @ti.kernel
        def serial_body() -> ti.i32:
            v[0] = v[0] * 0.999
            return 1

        @ti.kernel
        def parallel_loop() -> ti.i32:
            for i in range(n):
                v[i] = v[i] * 0.999 + ti.Vector([1.0, 2.0, 3.0])
            return 1

        @ti.kernel
        def serial_loop() -> ti.i32:
            ti.loop_config(serialize=True)
            for i in range(n):
                v[i] = v[i] * 0.999 + ti.Vector([1.0, 2.0, 3.0])
            return 1

        row = []
        for kernel in (serial_body, parallel_loop, serial_loop):
            for _ in range(200):
                kernel()
            times = []
            for _ in range(5):
                t = time.perf_counter()
                for _ in range(2000):
                    kernel()
                times.append((time.perf_counter() - t) / 2000 * 1e6)
            row.append(statistics.median(times))
        print(f"N = {n:6d}: serial body {row[0]:6.1f} us, parallel loop {row[1]:6.1f} us, "
              f"serialized loop {row[2]:6.1f} us per launch")


def step(scene_path: str, sets: list[str], nodes_max: int, launch: str | None) -> None:
    from taichi_shell_mpm import runtime
    from taichi_shell_mpm.preflight import prepare
    from taichi_shell_mpm.simulation import Simulation
    runtime.SERIAL_NODE_LOOPS_MAX = nodes_max
    runtime.FORCE_LAUNCH = launch
    scene, mesh, model = prepare(scene_path, ["solve.end_time=5", "output.times=[]", *sets])
    runtime.init_taichi("cpu", quiet=True)
    sim = Simulation(scene, None, "cpu", quiet=True, mesh=mesh, model=model)
    sim._compile()
    stepper = sim.stepper
    stepper.advance(30)
    ti.sync()
    n = len(model.elements)
    count = max(100, int(3e6 / n))
    times = []
    for _ in range(3):
        t = time.perf_counter()
        done = stepper.advance(count)       # (its contact rebuilds when due)
        ti.sync()
        assert done == count, f"stopped after {done} steps"
        times.append((time.perf_counter() - t) / count)
    print(f"{sim.cfg.launch} launch, serial_node_loops {getattr(sim.cfg, 'serial_node_loops', None)}, {n} elements, "
          f"{len(model.points)} nodes: ms per step " + " ".join(f"{1e3 * w:.3f}" for w in times)
          + f"; min {1e6 * min(times) / n:.3f} us per element-step")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("what", choices=["loops", "step"])
    p.add_argument("--scene", default="scenes/square_tube.toml")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--nodes-max", type=int, default=5000, help="runtime.SERIAL_NODE_LOOPS_MAX for `step`")
    p.add_argument("--launch", choices=["batched", "threads"], help="runtime.FORCE_LAUNCH for `step` (default: its choice)")
    a = p.parse_args()
    if a.what == "loops":
        loops()
    else:
        step(a.scene, a.set, a.nodes_max, a.launch)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
