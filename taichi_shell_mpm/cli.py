"""Command line: ``python -m taichi_shell_mpm run|validate|render ...`` (thin: no physics here).

Exit codes: 0 success, 2 scene/mesh error (user mistake, one line per problem; for render:
a bad output directory or option), 3 run-time failure (instability, non-convergence; frames
written so far stay valid; for render: nothing could be drawn), 130 interrupted (Ctrl-C).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

EXIT_SCENE, EXIT_RUNTIME, EXIT_INTERRUPT = 2, 3, 130


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m taichi_shell_mpm",
                                description="Thin shells by CPDI2 double-mapping MPM with Belytschko-Tsay elements.")
    sub = p.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a scene")
    run.add_argument("scene", type=Path)
    run.add_argument("--out", type=Path, default=None, help="output directory (default outputs/<scene name>)")
    run.add_argument("--arch", choices=["cpu", "cuda", "vulkan"], default="cpu")
    run.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                     help="override a scene key by its dotted path, e.g. method.kind=fem")
    run.add_argument("--quiet", action="store_true", help="only the final summary")
    val = sub.add_parser("validate", help="check a scene and its mesh without running")
    val.add_argument("scene", type=Path)
    val.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    ren = sub.add_parser("render", help="draw PNG pictures and plots of a run's output directory")
    ren.add_argument("outdir", type=Path, help="output directory of a run (has frames.pvd)")
    ren.add_argument("--frames", default="all", metavar="all|last|none|T1,T2,...",
                     help="frames to draw, one PNG each: all, last, none, or those nearest to "
                          "the given times / load factors (default all)")
    ren.add_argument("--field", default=None, metavar="NAME[:K]",
                     help="array to colour by (vectors: magnitude, or component K = 0..2 / x, y, z); "
                          "default plastic_strain_max if present, else displacement")
    ren.add_argument("--sheet", default=None, metavar="T1,T2,...|none",
                     help="times of the side-by-side sheet (default 5,10,15 for a dynamic run "
                          "reaching 15, else 3 evenly spread)")
    return p


def _fail(code: int, lines) -> int:
    for line in lines:
        print(f"error: {line}", file=sys.stderr)
    return code


def _validate(args) -> int:
    from .assembly import assemble
    from .mesh import build_mesh
    from .scene import SceneError, load_scene
    try:
        scene = load_scene(args.scene, args.overrides)
        mesh = build_mesh(scene.mesh)
        model = assemble(scene, mesh)
    except SceneError as exc:
        return _fail(EXIT_SCENE, exc.messages)
    for w in mesh.warnings:
        print(f"warning: {w}")
    grid = f", grid {model.grid.dims} nodes at h={model.grid.h:g}" if model.grid else ""
    print(f"{args.scene}: ok ({len(mesh.points)} nodes, {len(mesh.quads)} elements, {scene.method.kind}{grid})")
    return 0


def _run(args) -> int:
    from .scene import SceneError, load_scene
    from .simulation import Simulation, SimulationError, init_taichi
    from .solvers.dynamic import run_dynamic
    from .solvers.static import run_static
    try:
        scene = load_scene(args.scene, args.overrides)
    except SceneError as exc:
        return _fail(EXIT_SCENE, exc.messages)
    init_taichi(args.arch)
    sim = None
    try:
        t0 = time.perf_counter()
        sim = Simulation(scene, args.out, args.arch, quiet=args.quiet)
        for w in sim.mesh.warnings:
            print(f"warning: {w}")
        print(f"{scene.info.name}: {len(sim.model.points)} nodes, {len(sim.model.quads)} elements, "
              f"{sim.cfg.method}, kernels ready in {time.perf_counter() - t0:.1f} s -> {sim.out_dir}")
        extra = run_static(sim) if scene.solve.kind == "static" else run_dynamic(sim)
        summary = sim.write_results(extra)
    except SceneError as exc:
        return _fail(EXIT_SCENE, exc.messages)
    except SimulationError as exc:
        if sim is not None:
            sim.write_frame(sim.state.time[None])
            sim.write_results({"error": str(exc)})
        return _fail(EXIT_RUNTIME, [str(exc)])
    except KeyboardInterrupt:
        if sim is not None:
            sim.write_results({"error": "interrupted"})
        return _fail(EXIT_INTERRUPT, ["interrupted; results so far written to " + str(sim.out_dir if sim else "")])
    print_summary(summary)
    return 0


def print_summary(summary: dict) -> None:
    print(f"done: {summary['steps']} steps, compile {summary['compile_seconds']:.1f} s, "
          f"run {summary['run_seconds']:.2f} s, {summary['us_per_element_step']:.3f} us/element-step")
    e = summary["energies"]
    print(f"energies: kinetic {e['kinetic']:.4e}  internal {e['internal']:.4e}  hourglass {e['hourglass']:.3e}  "
          f"external work {e['external_work']:.4e}  balance error {e['balance_error']:.2e}")
    ref = summary.get("reference")
    if ref:
        for col, r in ref["columns"].items():
            print(f"vs reference {col:<45s} mean {100 * r['mean_rel_error']:.2f}%  max {100 * r['max_rel_error']:.2f}%")


def _render(args) -> int:
    from .render import RenderError, render
    try:
        written, warnings = render(args.outdir, frames=args.frames, field=args.field, sheet=args.sheet)
    except RenderError as exc:
        return _fail(exc.code, [str(exc)])
    for w in warnings:
        print(f"warning: {w}")
    for path in written:
        print(f"wrote {path}")
    return 0


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    return {"validate": _validate, "render": _render}.get(args.command, _run)(args)
