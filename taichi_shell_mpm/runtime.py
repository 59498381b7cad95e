"""The Taichi runtime of a run: the backend it starts on, its CPU threads, how the step's
kernels launch (batched, threads, gpu) and the offline kernel cache of this build."""
from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import taichi as ti

from . import frontend

ARCHS = {"cpu": "cpu", "cuda": "cuda", "vulkan": "vulkan"}
FORCE_LAUNCH: str | None = None         # tests and profiles: "batched" | "threads" | "gpu" on any arch
THREADS_MIN_ELEMENTS = 1000             # CPU: smaller meshes run the batched serial kernel (choose_launch)
SERIAL_NODE_LOOPS_MAX = 5000            # threads launch: meshes up to this many nodes run their light node
#                                         loops on one thread (serial_node_loops)


def serial_node_loops(launch: str, n_nodes: int) -> bool:
    """Whether the ``threads`` launch runs the step's light node loops (the fem node update,
    the corner loads' gather, the contact pairs, the skin check, the mpm nodes' grid look-up,
    selective mass scaling's right-hand side, reciprocal gather and node update: tens of ns of
    work per node) on the calling thread instead of the thread pool [choice,
    measured in docs/performance.md "Thread-pool dispatch"].  Each parallel loop costs a
    dispatch, ~55-75 us on the 2-core machine whatever its length (a loop over 100 items:
    71 us against a 14 us serial kernel), and parallel loops between serial stretches wake
    the pool's threads again each time, so the four fem loops gain together and not one or
    two alone.  The fem tube (2 928 nodes): 1.24-1.33 -> 1.01-1.11 ms per step; even at 5 848
    nodes; 5-20 % slower at 11 616.  The element pass, the mpm transfers and the grid clear
    stay parallel (the clear and G2P serial: no gain on the mpm tube)."""
    return launch == "threads" and n_nodes <= SERIAL_NODE_LOOPS_MAX


def choose_launch(arch: str, n_elements: int, static: bool) -> str:
    """How the step kernels run (solvers/stepper.py): ``gpu`` on a GPU; on the CPU
    ``threads`` (one parallel kernel per step) for a dynamic scene of at least
    THREADS_MIN_ELEMENTS elements when there is more than one core, else ``batched`` (one
    serial kernel for many steps, no launch cost per step).  Statics stay batched: their
    relaxation decisions read energy sums, which threads add in a varying order, and a
    static run should take the same steps every time.  Measured in the note of issue 4."""
    if FORCE_LAUNCH is not None:
        return FORCE_LAUNCH
    if arch != "cpu":
        return "gpu"
    if static or cpu_threads() < 2 or n_elements < THREADS_MIN_ELEMENTS:
        return "batched"
    return "threads"


def cpu_threads() -> int:
    """CPU threads of a run: $TAICHI_SHELL_MPM_THREADS when set (a sweep's local cluster sets
    cores / workers in each worker, so that the cases running at once do not share cores),
    else every core."""
    text = os.environ.get("TAICHI_SHELL_MPM_THREADS", "")
    try:
        return max(1, int(text))
    except ValueError:
        return os.cpu_count() or 1


def init_taichi(arch: str = "cpu", quiet: bool = False, threads: int | None = None, keep: bool = False) -> str:
    """Start Taichi on `arch`; returns the arch it actually runs on ("cpu" when Taichi fell
    back from an unavailable GPU backend).  `quiet`: without its "[Taichi] Starting on"
    line.  `threads`: the CPU threads (default :func:`cpu_threads`).  Taichi's own probing
    warnings for a missing GPU are held back (the caller reports the fallback).
    On the CPU Taichi's own IR optimizations are off unless :func:`ir_optimization`.
    `keep`: when the program this function last started is still Taichi's and was started
    with the same settings, keep it (program.py reuses its state and kernels)."""
    global _started
    settings = Settings(arch, threads or cpu_threads(), ir_optimization(), kernel_cache_dir())
    if keep and _started is not None and _started.settings == settings and _started.program is ti.lang.impl.get_runtime().prog:
        return _started.used
    used = _init(arch, quiet, settings.threads)
    _started = Started(settings, ti.lang.impl.get_runtime().prog, used, quiet)
    return used


def restart_taichi() -> None:
    """A fresh program with the settings of the one :func:`init_taichi` last started (its
    fields and kernels freed)."""
    global _started
    _init(_started.settings.arch, _started.quiet, _started.settings.threads)
    _started = dataclasses.replace(_started, program=ti.lang.impl.get_runtime().prog)


@dataclasses.dataclass(frozen=True)
class Settings:
    """What init_taichi starts a program with: the arch asked for, CPU threads, Taichi's IR
    optimizations on the CPU (:func:`ir_optimization`) and the kernel cache folder."""
    arch: str
    threads: int
    ir_optimization: bool
    cache: str


@dataclasses.dataclass(frozen=True)
class Started:
    """The program init_taichi last started: its settings, Taichi's program object, the arch
    it runs on and whether its start was quiet."""
    settings: Settings
    program: object
    used: str
    quiet: bool


_started: Started | None = None        # of init_taichi


def _init(arch: str, quiet: bool, threads: int) -> str:
    import contextlib
    import io
    frontend.speed_up()
    level = ti.WARN if arch == "cpu" else ti.ERROR
    with contextlib.redirect_stdout(io.StringIO()) if quiet else contextlib.nullcontext():
        ti.init(arch=getattr(ti, ARCHS[arch]), default_fp=ti.f64, default_ip=ti.i32, offline_cache=True,
                offline_cache_file_path=kernel_cache_dir(), log_level=level, cpu_max_num_threads=threads,
                advanced_optimization=arch != "cpu" or ir_optimization())
    if level != ti.WARN:
        ti.set_logging_level(ti.WARN)
    cfg = ti.lang.impl.current_cfg()
    used = next((name for name, a in ARCHS.items() if getattr(ti, a) == cfg.arch), "cpu")
    if used == "cpu" and arch != "cpu":
        # Taichi fell back to the CPU: compile as a CPU run does (IR optimizations as
        # ir_optimization() says), so the kernels are a CPU run's, cached under the same keys.
        # Measured: the 4-element cantilever with `--arch cuda` on a machine without a GPU,
        # cold cache, compile 19.7 s with the GPU's setting against 2.8 s.
        cfg.advanced_optimization = ir_optimization()
    return used


def ir_optimization() -> bool:
    """Whether Taichi's own IR optimizations (``advanced_optimization``) run on the CPU:
    only with $TAICHI_SHELL_MPM_IR_OPTIMIZATION=1 [choice, issue 29 session 3; measured in
    docs/performance.md "Cold compile"].  They took two thirds of a cold compile (the tube
    87 s -> 29 s, the cantilever 61 s -> 17 s) and LLVM's -O3, which runs either way, makes
    the step as fast without them on the tube (B/A 1.02 plain, 0.98 with selective mass
    scaling; within noise).  GPU backends always run them (not measured there)."""
    return os.environ.get("TAICHI_SHELL_MPM_IR_OPTIMIZATION", "") == "1"


def kernel_cache_base() -> Path:
    """The folder that holds the kernel caches of every build: $TAICHI_SHELL_MPM_CACHE or
    ~/.cache/taichi_shell_mpm."""
    return Path(os.environ.get("TAICHI_SHELL_MPM_CACHE") or Path.home() / ".cache" / "taichi_shell_mpm")


def kernel_cache_dir() -> str:
    """Taichi's offline kernel cache of this build of the package: a folder per hash of its
    sources, under $TAICHI_SHELL_MPM_CACHE or ~/.cache/taichi_shell_mpm [choice, issue 17].
    Taichi keys a cached kernel by its IR and the SNodes it touches, identified by their own
    structure and id but not by their place in the tree; a kernel cached by another build
    whose tree puts another field at that SNode id would be loaded and address the wrong
    memory (seen: a segmentation fault).  Within one build every run builds the same tree
    (state.py), so the folder is shared by all runs of the build; runs with Taichi's IR
    optimizations (:func:`ir_optimization`) have a folder of their own ("-ir")."""
    import hashlib
    digest = hashlib.sha256()
    for path in sorted(Path(__file__).parent.rglob("*.py")):
        digest.update(path.read_bytes())
    return str(kernel_cache_base() / (digest.hexdigest()[:16] + ("-ir" if ir_optimization() else "")))
