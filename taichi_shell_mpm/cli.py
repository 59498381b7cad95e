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
import time
import traceback
from pathlib import Path
from typing import TYPE_CHECKING

from .preflight import assembly_problems, prepare  # noqa: F401  (moved to preflight.py, still importable from here)
from .tables import positive_int

if TYPE_CHECKING:
    import numpy as np

EXIT_INTERNAL, EXIT_SCENE, EXIT_RUNTIME = 1, 2, 3      # interrupted: 128 + the signal (run_control.exit_code)


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


STICKING_CELL_RATIO = 0.75    # contact scenes: grid cell / longest edge above this sticks (docs/crush.md)


GRID_TRANSFER_KEYS = ("transfer", "flip_blend", "fields", "field_contact", "field_friction")
"""[method] keys of the grid transfer: set away from their default in fem mode, a warning."""
THICK_SHELL_RATIO = 1.0      # thickness / shortest edge of an element above this: not a thin shell


def thickness_warnings(scene, model) -> list[str]:
    """A section whose thickness is above THICK_SHELL_RATIO x the shortest edge of some of its
    elements: a shell element is a thin-shell model (plane stress through t, Reissner-Mindlin
    shear over the element), so t >> element size is a unit mistake or a solid modelled as a
    shell (a 1e9 thickness passed every check before)."""
    import numpy as np
    points, elements = model.points, model.elements
    nxt = np.roll(elements, -1, axis=1)
    tri = elements[:, 3] < 0
    nxt[tri, 2] = elements[tri, 0]
    valid = (elements >= 0) & (nxt >= 0)
    edge = np.linalg.norm(points[np.where(valid, elements, 0)] - points[np.where(valid, nxt, 0)], axis=2)
    shortest = np.where(valid, edge, np.inf).min(axis=1)
    lines, seen = [], set()
    for part in model.parts:
        ids = part.elements
        thick = ids[model.element.thickness[ids] > THICK_SHELL_RATIO * shortest[ids]]
        if not len(thick) or part.section in seen:
            continue
        seen.add(part.section)
        e = int(thick[np.argmax(model.element.thickness[thick] / shortest[thick])])
        key = "[section].thickness" if part.section == "section" else (
            f"[sections.{part.section}].thickness" if part.section in scene.sections else
            f"the deck's {part.section} (T1 or *ELEMENT_SHELL_THICKNESS)")
        lines.append(f"{scene.source.name}: {key}: {model.element.thickness[e]:g} is above the shortest edge of "
                     f"{len(thick)} elements of part '{part.name}' (e.g. element {e}: {shortest[e]:.3g}): a shell "
                     "element models a thin shell (t below its size); check the units or model a solid")
    return lines


def unused_key_warnings(scene) -> list[str]:
    """Keys that the scene sets but its kind of run does not read: [method] transfer keys in
    fem mode (not the grid's size and box, which a scene switched to fem by --set keeps),
    [output].times after a dynamic run's end_time; and mass_scaling = "selective", whose
    meaning changed (issue 29: the old one is "conventional")."""
    lines = []
    method = scene.method
    if method.kind == "fem":
        default = type(method)()
        for key in GRID_TRANSFER_KEYS:
            if getattr(method, key) == getattr(default, key):
                continue
            lines.append(f"{scene.source.name}: [method].{key}: not used with kind = \"fem\" (no grid: it is "
                         "for kind = \"mpm\")")
    if scene.solve.kind == "dynamic" and scene.solve.mass_scaling == "selective":
        lines.append(f"{scene.source.name}: [solve].mass_scaling = \"selective\" is selective mass scaling since "
                     "issue 29 (added mass on the deformation modes only); the per-element density scaling it "
                     "meant before is \"conventional\"")
    if scene.solve.kind == "dynamic":
        late = [t for t in scene.output.times if t > scene.solve.end_time]
        if late:
            lines.append(f"{scene.source.name}: [output].times: {', '.join(f'{t:g}' for t in late)} "
                         f"after [solve].end_time = {scene.solve.end_time:g}: no frame is written there")
    return lines


def closed_coincident_pairs(model) -> np.ndarray:
    """The pairs (k, 2) of coincident nodes that an mpm grid moves together: both take the
    grid velocity at the same point, so they part only where their motions are prescribed
    differently.  A pair stays closed when both nodes have the same fixed translations (not
    all three: a pair held in place is closed in fem too), no translation prescribed by a
    [[motion]] and the same rigid body (or none).  One side
    clamped (or moved, or on a body) and the other free: the free one follows the grid and
    the slit opens (the slit annular plate clamped on one face matched Newton's fem to
    0.01 %)."""
    import numpy as np
    from .mesh import coincident_pairs
    pairs = coincident_pairs(model.points)
    n = len(model.points)
    translations = model.fix_mask & 0b111
    moved = (model.loading.motion_mask & 0b111) != 0 if model.loading is not None else np.zeros(n, bool)
    body = model.node_body if model.node_body is not None else np.full(n, -1)
    a, b = pairs[:, 0], pairs[:, 1]
    closed = ((translations[a] == translations[b]) & (translations[a] != 0b111) & ~moved[a] & ~moved[b]
              & (body[a] == body[b]))
    return pairs[closed]


def setup_warnings(scene, model) -> list[str]:
    """Set-ups that run but are probably not what the user wants: loads whose set includes
    nodes with all translations fixed (that share of the force does nothing; a set of only
    such nodes is an error, see assembly.assemble), coincident nodes that move together in
    mpm mode (:func:`closed_coincident_pairs`: a slit modelled by them stays closed), and self-contact on a
    grid as coarse as the elements without both the multi-field grid and PolyPIC (layers
    stick through one field, and the other transfers filter node-scale waves: the tube at
    h = l gave +18.9 % mean force on one field, +11.4 % on multi fields with APIC, -0.2 %
    with PolyPIC; docs/grid.md)."""
    from .loading import load_shares
    from .nodesets import select_nodes
    lines = list(scene.notes) + list(model.notes) + unused_key_warnings(scene) + thickness_warnings(scene, model)
    fixed = (model.fix_mask & 0b111) == 0b111
    for i, ld in enumerate(scene.loads):
        if not any(ld.force) and not any(ld.force_per_length):
            continue
        ids = select_nodes(scene.nodeset(ld.nodes), model.points)
        share = load_shares(ld.distribute, ids, model.node_area, model.points, model.elements)
        lost = float(share[fixed[ids]].sum() / share.sum())
        if lost > 0.0:
            lines.append(f"{scene.source.name}: [[load]][{i}] on '{ld.nodes}': {int(fixed[ids].sum())} of "
                         f"{len(ids)} nodes have all translations fixed; the {100 * lost:.3g}% of the force "
                         "spread onto them does nothing")
    if model.grid is not None:
        pairs = len(closed_coincident_pairs(model))
        if pairs:
            lines.append(f"{scene.source.name}: [method].kind = \"mpm\": the {pairs} pair{'s' if pairs != 1 else ''} "
                         "of coincident nodes move together (every node moves with the grid velocity at its "
                         "position), so a slit or crack there does not open; use kind = \"fem\" to let it open")
    if scene.contact is not None and model.grid is not None and model.grid.h > STICKING_CELL_RATIO * model.max_edge:
        coarse = (f"{scene.source.name}: [method].cell_size: {model.grid.h:g} is more than "
                  f"{STICKING_CELL_RATIO:g} x the longest element edge ({model.max_edge:.3g}); with [contact], ")
        advice = "use fields = \"multi\" with transfer = \"polypic\", or about half the element size"
        if scene.method.fields == "single":
            lines.append(coarse + "shell layers within two cells stick through the grid (docs/crush.md, "
                         "sticking check): " + advice)
        elif scene.method.transfer != "polypic" and scene.solve.kind == "dynamic":
            lines.append(coarse + f"the {scene.method.transfer} transfer dissipates the waves of a crush "
                         "(docs/grid.md): " + advice)
    return lines


def _internal_error(exc: BaseException) -> int:
    if os.environ.get("TAICHI_SHELL_MPM_TRACEBACK"):
        traceback.print_exc()
    where = traceback.extract_tb(exc.__traceback__)[-1] if exc.__traceback__ else None
    at = f" (at {Path(where.filename).name}:{where.lineno})" if where else ""
    return _fail(EXIT_INTERNAL, [f"internal error, please report: {type(exc).__name__}: {_one_line(exc)}{at}; "
                                 "set TAICHI_SHELL_MPM_TRACEBACK=1 for the traceback"])


# ------------------------------------------------------------------ commands
def reference_note(scene) -> str | None:
    """Why the scene's [reference] comparison will be skipped (a dynamic run), or None."""
    from .reference import skip_reason
    if scene.reference is None:
        return None
    reason = skip_reason(scene.reference, scene.solve.kind)
    return None if reason is None else f"{scene.source.name}: {reason}"


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


def _check_out_dir(out: Path) -> str | None:
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        return f"--out {out}: cannot create the output directory ({exc.strerror or exc})"
    if not os.access(out, os.W_OK | os.X_OK):
        return f"--out {out}: the output directory is not writable"
    return None


def _unfinished_checkpoint(out: Path) -> bool:
    """`out` holds the checkpoint of a run that can still be continued: no summary.json, or
    one saying it was interrupted."""
    import json
    if not (out / "checkpoint.npz").is_file():
        return False
    try:
        summary = json.loads((out / "summary.json").read_text())
    except (OSError, ValueError):
        return True
    return not isinstance(summary, dict) or summary.get("error") == "interrupted"


def _state_is_a_result(sim) -> bool:
    """After an interrupt: the current state may be written as the last frame.  A dynamic
    state at a batch boundary is one; a static one only once its load level has converged
    (mid-level it is not the equilibrium at the level's load factor)."""
    if sim.scene.solve.kind != "static":
        return True
    rows = sim.history.probe_rows
    return bool(rows) and rows[-1][0] == float(sim.state.step.load_factor[None])


def _undeformed_frame(sim) -> None:
    """A static run stopped before its first converged load level has no frame: write the
    undeformed shell at load factor 0 (the equilibrium before any load) as its last good
    frame, so that frames.pvd opens.  Nothing when the scene writes no frames."""
    import numpy as np

    from .output import FrameWriter
    if sim.scene.solve.kind != "static" or not sim.scene.output.load_steps or sim.frames is not None:
        return
    zero = np.zeros_like(sim.model.points)
    cells = {k: (v if k == "thickness" else np.zeros_like(v)) for k, v in sim.element_results().items()}
    frames = FrameWriter(sim.out_dir, sim.model.elements)
    frames.write(0.0, sim.model.points, {"displacement": zero, "velocity": zero, "rotation": zero}, cells)
    sim.frames = frames


def _finish(sim, message: str, interrupted: bool = False) -> str | None:
    """After a failure or an interrupt: tables and summary with the error, and (interrupt
    only) the current state as the last frame.  After a failure the last frame written stays
    the last one: the failing state (runaway, inside out, not converged) is not a result.
    Returns a line saying what could not be written, or None."""
    from .run_control import deferred_interrupt
    if sim is None:
        return None
    try:
        with deferred_interrupt():
            try:
                if interrupted and _state_is_a_result(sim):
                    sim.final_frame()
                _undeformed_frame(sim)
            finally:
                sim.write_results({"error": message})
    except KeyboardInterrupt:
        return "interrupted again while writing the results"
    except Exception as exc:  # keep the one-line report of the original failure
        from .output import OutputError
        if isinstance(exc, OutputError):
            return f"while writing the results: {exc}"
        return f"could not write all results: {type(exc).__name__}: {_one_line(exc)}"
    return None


def _run(args) -> int:
    from .checkpoint import (CheckpointError, check_compatible, finished_run, load_checkpoint, restore_checkpoint,
                             summary_is_final)
    from .output import OutputError, clear_run_files
    from .progress import format_summary
    from .run_control import RunControl, exit_code, signal_name
    from .scene import SceneError
    try:
        scene, mesh, model = prepare(args.scene, args.overrides, args.accept_unread)
        ckpt = None
        if args.restart is not None:
            ckpt = load_checkpoint(args.restart)
            check_compatible(ckpt, scene, model.points, model.elements)
    except (SceneError, CheckpointError) as exc:
        return _fail(EXIT_SCENE, exc.messages)
    if ckpt is not None and finished_run(ckpt.path.parent, ckpt, scene):
        print(f"nothing to do: the run in {ckpt.path.parent} is finished (its checkpoint is at the end and its "
              "summary.json records no error); its results are there.  Run without --restart to compute it "
              "again", flush=True)
        return 0
    if ckpt is not None and summary_is_final(ckpt.path.parent) and not args.quiet:
        print(f"{ckpt.path.parent}: this run had finished; its checkpoint is at step {ckpt.meta.get('step')}, "
              "so the steps after it are computed again (bit-for-bit the same)", flush=True)
    out = args.out if args.out is not None else (args.restart if args.restart is not None
                                                  else Path("outputs") / scene.info.name)
    problem = _check_out_dir(out)
    if problem:
        return _fail(EXIT_SCENE, [problem])
    in_place = ckpt is not None and out.resolve() == ckpt.path.parent.resolve()
    if not in_place:         # the results of an earlier run in `out` are replaced, never mixed in
        if _unfinished_checkpoint(out) and not args.overwrite:
            return _fail(EXIT_SCENE, [f"--out {out}: holds the checkpoint of an unfinished run: continue it with "
                                      f"--restart {out}, or start afresh with --overwrite (deletes its results)"])
        try:
            removed = clear_run_files(out)
        except OutputError as exc:
            return _fail(EXIT_SCENE, [f"--out {out}: cannot replace the results of an earlier run ({exc})"])
        if removed and not args.quiet:
            print(f"{out}: removed {removed} files of an earlier run (frames, tables, summary, checkpoint, "
                  "pictures); other files are kept", flush=True)

    if args.quiet:           # Taichi prints a banner when imported unless told not to
        os.environ.setdefault("ENABLE_TAICHI_HEADER_PRINT", "false")
    from .simulation import Simulation, SimulationError
    from .runtime import init_taichi
    from .solvers.dynamic import run_dynamic
    from .solvers.newton import ShellEquations, run_newton
    from .solvers.tangent import newton_is_serial
    from .solvers.static import run_static
    sim = None
    control = RunControl(args.checkpoint_every, resume=ckpt.position if ckpt else None)
    try:
        threads = None
        if scene.solve.kind == "static" and scene.solve.solver == "newton" and newton_is_serial(len(model.elements)):
            threads = 1             # its kernels are serial: no thread pool (solvers/tangent.newton_is_serial)
        arch = init_taichi(args.arch, quiet=args.quiet, threads=threads)
        if not args.quiet:
            print("compiling kernels (a configuration's first run takes 15-70 s; later runs load them from "
                  "Taichi's offline cache) ...", flush=True)
        t0 = time.perf_counter()
        sim = Simulation(scene, out, arch, quiet=args.quiet, mesh=mesh, model=model)
        if arch != args.arch:
            sim.arch_requested = args.arch
        if args.hourglass_limit is not None:
            sim.hourglass_limit = args.hourglass_limit
        if args.energy_limit is not None:
            sim.energy_limit = args.energy_limit
        newton = None
        if scene.solve.kind == "static" and scene.solve.solver == "newton":
            newton = ShellEquations.compiled(sim)
        for w in (*sim.mesh.warnings, *setup_warnings(scene, model)):
            print(f"warning: {w}")
        if ckpt is not None:
            for w in restore_checkpoint(sim, ckpt):
                sim.warn(w)
        fallback = (f"--arch {args.arch}: not available on this machine; Taichi fell back to {arch}, "
                    f"the run is on {arch}")
        for note in ((fallback if arch != args.arch else None), reference_note(scene)):
            if note is not None and note not in sim.warnings:
                sim.warn(note)
        sim.progress(f"{scene.info.name}: {len(sim.model.points)} nodes, {len(sim.model.elements)} elements, "
                     f"{sim.cfg.method}, kernels ready in {time.perf_counter() - t0:.1f} s -> {sim.out_dir}"
                     + (f" (restarted at step {sim.state.step.step[None]})" if ckpt else ""))
        if scene.solve.kind == "dynamic":          # each driver runs in a run_control.RunLoop (signals too)
            extra = run_dynamic(sim, control)
        elif newton is not None:
            extra = run_newton(sim, newton, control)
        else:
            extra = run_static(sim, control)
        summary = sim.write_results(extra)
    except (SceneError, CheckpointError) as exc:
        return _fail(EXIT_SCENE, exc.messages)
    except (SimulationError, OutputError) as exc:
        what = str(exc) if isinstance(exc, SimulationError) else (
            f"{exc}" + (f" at {sim.where()}" if sim is not None else "")
            + " (disk full, read-only or no permission?); the results that could be written are there")
        more = _finish(sim, what)
        return _fail(EXIT_RUNTIME, [what] + ([more] if more and not isinstance(exc, OutputError) else []))
    except KeyboardInterrupt as exc:      # Ctrl-C, SIGTERM, SIGHUP (run_control.Interrupted)
        more = _finish(sim, "interrupted", interrupted=True)
        code, by = exit_code(exc), signal_name(exc)
        if sim is None:
            return _fail(code, [f"interrupted{by} before the run started; nothing written"])
        sets = "".join(f" --set {o}" for o in args.overrides)
        follow = (f"; continue with: run {args.scene}{sets} --restart {sim.out_dir}"
                  if control.last_checkpoint is not None else "")
        return _fail(code, [f"interrupted{by} at {sim.where()}; results so far written to {sim.out_dir}"
                            + follow] + ([more] if more else []))
    except Exception as exc:  # a bug: results so far, then one line
        more = _finish(sim, f"internal error: {type(exc).__name__}: {_one_line(exc)}")
        code = _internal_error(exc)
        if more:
            print(f"error: {more}", file=sys.stderr, flush=True)
        return code
    print(format_summary(summary), flush=True)
    return 0


def print_summary(summary: dict) -> None:
    """Print the final summary table (kept for callers of the old name)."""
    from .progress import format_summary
    print(format_summary(summary))


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


def _bench(args) -> int:
    from .bench import main as bench_main
    return bench_main(args)


def _sweep(args) -> int:
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
    except Exception as exc:
        return _internal_error(exc)
