"""Where one explicit step's time goes: the tube at the start of its run, with one stage
switched at a time, in one sitting (each variant in its own process, one after the other).

    python benchmarks/profile_step.py [--steps 400] [--mesh N_FLAT]

Prints µs per element-step of each variant and its difference to the scene (the table of
docs/performance.md).  The scene runs on the ``threads`` launch (all cores); the
"batched" variants on one core.  The scene is scenes/square_tube.toml (mpm, APIC, J2 with 5 Gauss
points, self-contact); the step kernel is compiled (or loaded from the offline cache)
before the clock starts.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VARIANTS = [
    ("mpm (scene)", []),
    ("mpm, batched (1 core)", ["batched"]),
    ("without contact", ["no_contact"]),
    ("PIC instead of APIC", ["method.transfer=pic"]),
    ("elastic instead of J2", ["material.model=elastic"]),
    ("3 instead of 5 points", ["section.points=3"]),
    ("drilling projection instead of spring", ["element.drilling=projection"]),
    ("bt w-hourglass instead of kirchhoff", ["element.w_hourglass=bt"]),
    ("fem (no grid)", ["method.kind=fem"]),
    ("fem, batched (1 core)", ["method.kind=fem", "batched"]),
]


def child(steps: int, overrides: list[str]) -> None:
    import dataclasses
    import time

    import taichi as ti

    from taichi_shell_mpm import runtime
    from taichi_shell_mpm.model.assembly import assemble
    from taichi_shell_mpm.preflight import prepare
    from taichi_shell_mpm.simulation import Simulation
    from taichi_shell_mpm.runtime import init_taichi
    no_contact = "no_contact" in overrides
    if "batched" in overrides:
        runtime.FORCE_LAUNCH = "batched"
    overrides = [o for o in overrides if o not in ("no_contact", "batched")]
    scene, mesh, model = prepare(ROOT / "scenes" / "square_tube.toml", ["solve.end_time=5", *overrides])
    if no_contact:
        scene = dataclasses.replace(scene, contact=None)
        model = assemble(scene, mesh)
    init_taichi("cpu")
    sim = Simulation(scene, Path("outputs") / "profile_step", "cpu", quiet=True, mesh=mesh, model=model)
    s = sim.state
    s.time_limit[None] = scene.solve.end_time
    s.dt[None] = s.dt_stable[None]
    sim.stepper.advance(20)
    t0 = time.perf_counter()
    n = sim.stepper.advance(steps)
    ti.sync()
    seconds = time.perf_counter() - t0
    print(json.dumps({"elements": len(model.elements), "steps": n, "launch": sim.cfg.launch,
                      "us": 1e6 * seconds / (n * len(model.elements)), "compile": sim.compile_seconds}))


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=400)
    p.add_argument("--mesh", type=int, default=10, help="elements across a flat (5 mm at 10)")
    p.add_argument("--child", nargs="*", help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.child is not None:
        child(a.steps, a.child)
        return 0
    mesh = [f"mesh.n_flat={a.mesh}", f"mesh.n_corner={max(1, round(a.mesh / 5))}", f"mesh.n_length={6 * a.mesh}",
            f"method.cell_size={25.0 / a.mesh:g}"]
    base = None
    print(f"{'variant':24s} {'us/element-step':>16s} {'difference':>11s}  (tube, {a.steps} steps at the start)")
    for name, extra in VARIANTS:
        cmd = [sys.executable, __file__, "--steps", str(a.steps), "--child", *mesh, *extra]
        out = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
        lines = [ln for ln in out.stdout.splitlines() if ln.startswith("{")]
        if out.returncode != 0 or not lines:
            print(f"{name:24s} failed: {(out.stderr.strip().splitlines() or ['?'])[-1]}")
            continue
        r = json.loads(lines[-1])
        base = r["us"] if base is None else base
        diff = "" if r["us"] == base else f"{r['us'] - base:+.3f}"
        print(f"{name:24s} {r['us']:16.3f} {diff:>11s}  ({r['elements']} elements, {r['launch']} launch, "
              f"compile {r['compile']:.1f} s)",
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
