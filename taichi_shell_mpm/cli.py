"""Command line: ``python -m taichi_shell_mpm run|validate|render|bench|sweep ...`` (thin: no physics here).

Exit codes: 0 success, 1 internal error (a bug: one line; set TAICHI_SHELL_MPM_TRACEBACK=1
for the traceback), 2 scene/mesh/checkpoint error (user mistake, one line per problem,
all problems at once; for render: a bad output directory or option), 3 run-time failure
(instability, non-convergence, too much hourglass energy, a result file that cannot be
written; the last good frame stays the last one, frames.pvd and the results so far are
written; for render: nothing could be drawn), 130 interrupted
(Ctrl-C: the run stops at the next batch boundary, writes a checkpoint, the last frame and
the results so far), 143 / 129 stopped by SIGTERM / SIGHUP (``timeout``, a batch
scheduler's wall-time limit, a closed terminal: handled as a Ctrl-C; run_control.py).
"""
from __future__ import annotations

import argparse
import os
import sys
import traceback
from pathlib import Path

from .preflight import (  # noqa: F401  (setup_warnings, reference_note: still importable from here)
    assembly_problems,
    prepare,
    reference_note,
    setup_warnings,
)
from .api import EXIT_SCENE
from .extras import MissingExtra, require
from .tables import positive_int

EXIT_INTERNAL = 1      # EXIT_SCENE 2 and the run-time failure 3: api.py; interrupted: 128 + the signal (run_control.exit_code)


def _fraction(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}") from None
    if not value >= 0.0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text}")
    return value


def _directory(text: str) -> Path:
    """A directory argument: an empty string (which would mean the current directory) is refused."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a directory, got an empty string")
    return Path(text)


SCENE_HELP = ("scene file (TOML): mesh, material, section, method, node sets, boundary conditions, loads, "
              "probes, reference data, solve and output settings; every key is documented in docs/scenes.md; "
              "or an LS-DYNA keyword deck (.k, .key, .dyn, .kw), read as the scene its keywords say "
              "(docs/decks.md)")
ACCEPT_UNREAD_HELP = ("an LS-DYNA deck: run even though some of its keywords that change the physics are not read "
                      "(they are listed with their line numbers, as warnings)")


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m taichi_shell_mpm",
                                description="Thin shells by CPDI2 double-mapping MPM with Belytschko-Tsay elements.")
    sub = p.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a scene",
                         description="Run a scene: frames, probes.csv, energy.csv, force.csv and summary.json "
                                     "in the output directory.",
                         epilog="Scene keys: docs/scenes.md.  Exit codes: 0 done, 2 a mistake in the scene, "
                                "mesh or command line, 3 a run-time failure (the results so far are written), "
                                "130 interrupted (143 SIGTERM, 129 SIGHUP; a checkpoint is written), 1 a bug "
                                "(README.md, 'When something goes wrong').")
    run.add_argument("scene", type=Path, help=SCENE_HELP)
    run.add_argument("--out", type=_directory, default=None,
                     help="output directory (default outputs/<scene name>, or the --restart directory); "
                          "the results of an earlier run there are replaced (its other files are kept)")
    run.add_argument("--overwrite", action="store_true",
                     help="start afresh in an output directory that holds the checkpoint of an unfinished "
                          "(interrupted) run, deleting it (without this option such a run is refused)")
    run.add_argument("--arch", choices=["cpu", "cuda", "vulkan"], default="cpu")
    run.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                     help="override a scene key by its dotted path, e.g. method.kind=fem")
    run.add_argument("--quiet", action="store_true", help="print only warnings, errors and the final summary")
    run.add_argument("--accept-unread", action="store_true", help=ACCEPT_UNREAD_HELP)
    run.add_argument("--checkpoint-every", type=positive_int, default=0, metavar="N",
                     help="write OUTDIR/checkpoint.npz at the first batch boundary after every N steps")
    run.add_argument("--restart", type=_directory, default=None, metavar="DIR",
                     help="continue the run whose checkpoint is DIR/checkpoint.npz (same scene and --set "
                          "options); the result is bit-for-bit that of an uninterrupted run")
    run.add_argument("--hourglass-limit", type=_fraction, default=None, metavar="R",
                     help="stop when the hourglass and drilling energy exceeds R times the internal energy "
                          "(default 0.2; warning at R/2; 0 = never stop)")
    run.add_argument("--energy-limit", type=_fraction, default=None, metavar="R",
                     help="dynamic runs: stop when the energy balance error exceeds R times the energy "
                          "absorbed (default 0.05; warning at R/5; 0 = never stop)")
    val = sub.add_parser("validate", help="check a scene and its mesh without running",
                         epilog="Scene keys: docs/scenes.md.")
    val.add_argument("scene", type=Path, help=SCENE_HELP)
    val.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    val.add_argument("--accept-unread", action="store_true", help=ACCEPT_UNREAD_HELP)
    sch = sub.add_parser("schema", help="print the JSON Schema of scene files (for TOML editors)",
                         epilog="docs/scenes.md, \"Editor support\".")
    sch.add_argument("--docs", type=Path, default=None, metavar="FILE",
                     help="instead, regenerate the key tables of FILE (docs/scenes.md) from the declarations")
    ren = sub.add_parser("render", help="draw PNG pictures and plots of a run's output directory")
    ren.add_argument("outdir", type=_directory, help="output directory of a run (has frames.pvd)")
    ren.add_argument("--frames", default="all", metavar="all|last|none|T1,T2,...",
                     help="frames to draw, one PNG each: all, last, none, or those nearest to "
                          "the given times / load factors (default all)")
    ren.add_argument("--field", default=None, metavar="NAME[:K]",
                     help="array to colour by (vectors: magnitude, or component K = 0..2 / x, y, z); "
                          "default plastic_strain_max if present, else displacement")
    ren.add_argument("--sheet", default=None, metavar="T1,T2,...|none",
                     help="times of the side-by-side sheet (default 5,10,15 for a dynamic run "
                          "reaching 15, else 3 evenly spread)")
    from .bench import add_arguments as bench_arguments
    bench_arguments(sub.add_parser("bench", help="speed against error: refinement study of the benchmark "
                                                 "scenes, results.csv, plots and BENCHMARKS.md"))
    from .sweep import add_arguments as sweep_arguments
    sweep_arguments(sub.add_parser("sweep", help="parameter study: a scene run for each combination of values, "
                                                 "on a local or existing Dask cluster",
                                   description="Run a scene for each case of a parameter study (--param, "
                                               "--cases) on Dask; sweep.csv, sweep.md and plots in --out.",
                                   epilog="docs/sweep.md.  Exit codes: 0 every case ok, 2 a mistake in the "
                                          "options or the scene, 3 some case failed (recorded in sweep.csv), "
                                          "130 interrupted (143 SIGTERM, 129 SIGHUP)."))
    return p


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _fail(code: int, lines) -> int:
    sys.stdout.flush()
    for line in lines:
        print(f"error: {_one_line(line)}", file=sys.stderr, flush=True)
    return code


def _internal_error(exc: BaseException) -> int:
    if os.environ.get("TAICHI_SHELL_MPM_TRACEBACK"):
        traceback.print_exc()
    where = traceback.extract_tb(exc.__traceback__)[-1] if exc.__traceback__ else None
    at = f" (at {Path(where.filename).name}:{where.lineno})" if where else ""
    return _fail(EXIT_INTERNAL, [f"internal error, please report: {type(exc).__name__}: {_one_line(exc)}{at}; "
                                 "set TAICHI_SHELL_MPM_TRACEBACK=1 for the traceback"])


# ------------------------------------------------------------------ commands
def _validate(args) -> int:
    from .scene import SceneError
    try:
        scene, mesh, model = prepare(args.scene, args.overrides, args.accept_unread)
    except SceneError as exc:
        return _fail(EXIT_SCENE, exc.messages)
    note = reference_note(scene)
    for w in (*mesh.warnings, *setup_warnings(scene, model), *([note] if note else [])):
        print(f"warning: {w}")
    grid = f", grid cells h={model.grid.h:g}" if model.grid else ""
    triangles = int(mesh.triangles.sum())
    shapes = f" ({triangles} triangles)" if triangles else ""
    print(f"{args.scene}: ok ({len(mesh.points)} nodes, {len(mesh.elements)} elements{shapes}, {scene.method.kind}{grid})")
    thickness = model.element.thickness
    for p in model.parts:
        t = thickness[p.elements]
        span = f"{t.min():g}" if t.min() == t.max() else f"{t.min():g}-{t.max():g}"
        print(f"  part {p.name}: {len(p.elements)} elements, material {p.material}, section {p.section}, "
              f"thickness {span}")
    return 0


def _run(args) -> int:
    """`run`: api.run with the command line's options; exceptions become exit codes."""
    from .api import RunFailed, RunInterrupted, run
    from .checkpoint import CheckpointError
    from .scene import SceneError
    try:
        scene, mesh, model = prepare(args.scene, args.overrides, args.accept_unread)
    except SceneError as exc:
        return _fail(EXIT_SCENE, exc.messages)
    sets = "".join(f" --set {o}" for o in args.overrides)
    try:
        run(scene, args.out, progress=not args.quiet, arch=args.arch, restart=args.restart,
            checkpoint_every=args.checkpoint_every, overwrite=args.overwrite, hourglass_limit=args.hourglass_limit,
            energy_limit=args.energy_limit, mesh=mesh, model=model, table=True,
            command=f"run {args.scene}{sets}" + (" --accept-unread" if args.accept_unread else ""))
    except (SceneError, CheckpointError) as exc:
        return _fail(EXIT_SCENE, exc.messages)
    except (RunFailed, RunInterrupted) as exc:
        return _fail(exc.code, exc.messages)
    except Exception as exc:  # a bug: the results so far are written (api._finish), then one line
        code = _internal_error(exc)
        for note in getattr(exc, "__notes__", ()):
            print(f"error: {note}", file=sys.stderr, flush=True)
        return code
    return 0


def print_summary(summary: dict) -> None:
    """Print the final summary table (kept for callers of the old name)."""
    from .progress import format_summary
    print(format_summary(summary))


def _render(args) -> int:
    require("render", "render")
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


def _bench(args) -> int:
    require("render", "bench (its plots)")
    from .bench import main as bench_main
    return bench_main(args)


def _sweep(args) -> int:
    require("sweep", "sweep")
    from .sweep import main as sweep_main
    return sweep_main(args, run=main)      # each case calls main(["run", ...]) in its worker


def _schema(args) -> int:
    """`schema`: the scene files' JSON Schema on stdout, or --docs FILE: its key tables regenerated."""
    import json

    from .scene.schema import scene_schema, write_docs
    if args.docs is None:
        print(json.dumps(scene_schema(), indent=2, ensure_ascii=False))
        return 0
    try:
        changed = write_docs(args.docs)
    except OSError as exc:
        return _fail(2, [f"{args.docs}: {exc.strerror}"])
    print(f"{args.docs}: key tables {'regenerated' if changed else 'already up to date'}")
    return 0


def main(argv=None) -> int:
    import numpy as np

    from .run_control import exit_code, signal_name, stop_on_signals
    args = _parser().parse_args(argv)
    command = {"validate": _validate, "render": _render, "bench": _bench, "sweep": _sweep,
               "schema": _schema}.get(args.command, _run)
    try:
        # SIGTERM / SIGHUP stop like a Ctrl-C; a diverging run overflows: reported as a failure, not warnings
        with stop_on_signals(), np.errstate(all="ignore"):
            return command(args)
    except KeyboardInterrupt as exc:
        return _fail(exit_code(exc), [f"interrupted{signal_name(exc)}"])
    except MissingExtra as exc:           # a lean install: the command's extra is not there
        return _fail(EXIT_SCENE, [str(exc)])
    except Exception as exc:
        return _internal_error(exc)
