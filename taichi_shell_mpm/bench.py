"""Speed against error: ``python -m taichi_shell_mpm bench [--quick] [--out DIR]`` (issue 4).

Runs, one after the other in one sitting (so that the timings compare), a refinement series
of the two static Sze benchmarks in ``mpm`` mode at two grid-cell/element-size ratios and in
``fem`` mode, the square-tube crush at the paper's mesh and at a finer one, and, when the
optional extra ``peers`` is installed, the same static meshes with an established implicit
code (:mod:`taichi_shell_mpm.peers.kratos`).  Each case is a subprocess
``python -m taichi_shell_mpm run SCENE --quiet --out OUT/runs/CASE --set ...`` (the cases
compile different kernels; a fresh process keeps memory and the Taichi runtime clean); its
``summary.json`` gives compile and run wall time, steps, microseconds per element-step and
the errors against the reference table, ``os.wait4`` the peak resident memory of the child.

Files, under ``--out`` (default ``outputs/bench``, ``outputs/bench_quick`` with ``--quick``):

``results.csv``
    one row per case, rewritten (atomically) as each case finishes; a re-run case replaces
    its row, ``--resume`` skips cases that already have a row with status ``ok``.
``orders.csv``
    observed order of convergence: least-squares slope of log(mean error) against
    log(element size) per scene, mode and component.
``error_vs_time.png``, ``convergence.png``, ``tube.png``
    error (mean and max, both components) against run wall time; mean error against element
    size; crush force against crush distance and the tube's wall time.
``runs/CASE/``
    each run's own output (frames, tables, summary.json) and its console log ``bench.log``.

The report (``--report``, default ``BENCHMARKS.md`` in the working directory for the full
study, ``OUT/BENCHMARKS.md`` with ``--quick``) is regenerated from ``results.csv`` after
every case, so it always shows everything measured so far and lists the planned cases still
missing, with the machine, the date and the exact command.

Element size ``l`` of a case (for the ratios and the convergence slopes): the cantilever's
``10 / nx`` (meshes nx x max(1, nx/10)); for the quarter hemisphere the nominal ``8 / n``
(n x n quarter mesh), chosen so that the scene's default cell, 0.25 at 16 x 16 (shorter than
every edge), is ``l/2`` as the cantilever's default 0.5 is at 10 x 1; the tube's 5 mm or
2.5 mm.  Plots use matplotlib when it imports, else pyvista's charts (as ``render``).
"""
from __future__ import annotations

import argparse
import csv
import datetime
import fnmatch
import json
import math
import os
import platform
import shlex
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np


def atomic_write(path, write) -> None:      # output.py imports meshio: only when writing
    from .output import atomic_write as aw
    aw(path, write)


def write_text(path, text: str) -> None:
    from .output import write_text as wt
    wt(path, text)

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "scenes"
SCENE_FILES = {"cantilever": "cantilever.toml", "hemisphere": "hemisphere.toml", "tube": "square_tube.toml",
               "scaling": "square_tube.toml", "empty_grid": "square_tube.toml",
               "relaxation_cantilever": "cantilever.toml", "relaxation_hemisphere": "hemisphere.toml"}
CANTILEVER_NX = (5, 10, 20, 40)
HEMISPHERE_N = (8, 16, 32)
RATIOS = (1.0, 0.5)                 # grid cell / element size in mpm mode
QUICK_LOAD_STEPS = 10               # hemisphere in --quick: every other Sze row
SCALING_FLAT = (5, 10, 20, 40, 60)  # tube elements across a flat: 720 ... 103 680 elements
SCALING_END_TIME = 0.1              # ms: the impact, yielding and the contact search, no folds yet
WIDE_GRID = ("method.grid_min=[-200,-200,-10]", "method.grid_max=[200,200,310]")   # 16x the grid's area
EMPTY_GRID_PAIRS = 3                # scene grid / wide grid, interleaved: the noise of one pair is ~10 %
EMPTY_GRID_END_TIME = 0.5           # ms: a run of ~1.4 s, long against the per-run fixed costs
COMPONENT_LABEL = {"W_tip": "W_tip", "minus_U_tip": "-U_tip",
                   "radial_disp_outward_loaded_point": "d_out",
                   "radial_disp_inward_loaded_point_magnitude": "d_in"}

COLUMNS = ["case", "scene", "mesh", "mode", "cell_ratio", "cell_size", "element_size", "elements",
           "steps", "wall_s", "compile_s", "run_s", "us_per_element_step", "peak_mem_MB",
           "comp1", "err1_mean", "err1_max", "comp2", "err2_mean", "err2_max", "rows_compared",
           "crush", "mean_force", "peak_force", "half_wavelength", "balance", "hg_ratio", "penetration",
           "status", "date", "machine", "overrides"]
TUBE_KEYS = {"crush": "crush_distance", "mean_force": "mean_crush_force", "peak_force": "peak_support_force",
             "half_wavelength": "half_wavelength", "balance": "energy_balance_error_max",
             "hg_ratio": "hourglass_over_internal", "penetration": "max_penetration_over_thickness"}


@dataclass(frozen=True)
class Case:
    name: str
    scene: str                      # key of SCENE_FILES
    mesh: str                       # label, e.g. "10x1", "16x16q", "10/2/60"
    mode: str                       # mpm | fem | kratos
    ratio: float | None             # grid cell / element size (mpm), else None
    element_size: float
    overrides: tuple[str, ...]

    @property
    def scene_file(self) -> Path:
        return SCENES / SCENE_FILES[self.scene]

    @property
    def series(self) -> str:
        """Mode label of a refinement series (mesh left out)."""
        return f"mpm h={self.ratio:g}l" if self.mode == "mpm" else self.mode


# ------------------------------------------------------------------ the plan
def _ratio_tag(r: float) -> str:
    return f"r{r:g}"


def _mode_cases(scene: str, prefix: str, mesh: str, ell: float, base: tuple[str, ...], ratios, fem: bool,
                peers: bool, tag: str = "") -> list[Case]:
    """One mesh of a static refinement series: mpm at each grid ratio, fem, and the peer."""
    out = [Case(f"{prefix}_mpm_{_ratio_tag(r)}{tag}", scene, mesh, "mpm", r, ell,
                base + ("method.kind=mpm", f"method.cell_size={r * ell:g}")) for r in ratios]
    if fem:
        out.append(Case(f"{prefix}_fem{tag}", scene, mesh, "fem", None, ell, base + ("method.kind=fem",)))
    if peers:
        out.append(Case(f"{prefix}_kratos{tag}", scene, mesh, "kratos", None, ell, base))
    return out


def cantilever_cases(nxs=CANTILEVER_NX, ratios=RATIOS, fem=True, peers=False) -> list[Case]:
    out = []
    for nx in nxs:
        ny = max(1, nx // 10)
        ell = 10.0 / nx
        mesh = f"{nx}x{ny}"
        base = (f"mesh.nx={nx}", f"mesh.ny={ny}",
                f"solve.max_steps_per_load_step={int(400_000 * max(1.0, nx / 10))}")
        out += _mode_cases("cantilever", f"cantilever_{mesh}", mesh, ell, base, ratios, fem, peers)
    return out


def hemisphere_cases(ns=HEMISPHERE_N, ratios=RATIOS, fem=True, peers=False, load_steps=None) -> list[Case]:
    out = []
    for n in ns:
        ell = 8.0 / n                 # nominal: the default cell 0.25 at 16x16 is l/2
        mesh = f"{n}x{n}q"
        base = (f"mesh.n_around={n}", f"mesh.n_meridian={n}",
                f"solve.max_steps_per_load_step={int(400_000 * max(1.0, n / 16))}")
        tag = ""
        if load_steps:
            base += (f"solve.load_steps={load_steps}",)
            tag = f"_ls{load_steps}"
        out += _mode_cases("hemisphere", f"hemisphere_{n}x{n}", mesh, ell, base, ratios, fem, peers, tag)
    return out


def tube_cases(end_time: float | None = None) -> list[Case]:
    end = () if end_time is None else (f"solve.end_time={end_time:g}",)
    tag = "" if end_time is None else f"_t{end_time:g}"
    return [Case(f"tube_5mm_mpm{tag}", "tube", "10/2/60", "mpm", 0.5, 5.0, ("method.kind=mpm",) + end),
            Case(f"tube_5mm_fem{tag}", "tube", "10/2/60", "fem", None, 5.0, ("method.kind=fem",) + end),
            Case(f"tube_2.5mm_mpm{tag}", "tube", "20/4/120", "mpm", 0.5, 2.5,
                 ("method.kind=mpm", "mesh.n_flat=20", "mesh.n_corner=4", "mesh.n_length=120",
                  "method.cell_size=1.25") + end)]


def scaling_cases(flats=SCALING_FLAT) -> list[Case]:
    """Time per step against the number of elements: the tube (mpm, J2, contact) at n_flat
    elements across a flat, n_flat / 5 around each fillet, 6 n_flat along, grid h = l/2, to
    SCALING_END_TIME."""
    out = []
    for n in flats:
        ell = 50.0 / n
        mesh = f"{n}/{max(1, round(n / 5))}/{6 * n}"
        base = (f"mesh.n_flat={n}", f"mesh.n_corner={max(1, round(n / 5))}", f"mesh.n_length={6 * n}",
                f"method.cell_size={ell / 2:g}", f"solve.end_time={SCALING_END_TIME:g}", "output.times=[]")
        out.append(Case(f"scaling_{n}", "scaling", mesh, "mpm", 0.5, ell, base))
    return out


def empty_grid_cases(pairs=EMPTY_GRID_PAIRS) -> list[Case]:
    """The empty grid must cost nothing: the paper's tube (2 880 elements, mpm) to
    EMPTY_GRID_END_TIME in its scene grid and in a grid of 16x the area (WIDE_GRID), as
    `pairs` interleaved pairs, so that a drift of the machine falls on both sides; the
    report gives each pair's run-time ratio and their median."""
    base = ("method.kind=mpm", f"solve.end_time={EMPTY_GRID_END_TIME:g}", "output.times=[]")
    out = []
    for k in range(1, pairs + 1):
        out.append(Case(f"empty_grid_scene_{k}", "empty_grid", "10/2/60", "mpm", 0.5, 5.0, base))
        out.append(Case(f"empty_grid_wide_{k}", "empty_grid", "10/2/60 wide grid", "mpm", 0.5, 5.0,
                        base + WIDE_GRID))
    return out


# Static relaxation variants (case = default case + "_" + variant) against the default rows
# (FIRE, uniform_dt mass scaling): plain kinetic damping, the physical masses, and both.
# Their own scene keys keep them out of the refinement tables, slopes and plots.  (The
# cantilever's uniform mesh has one element size: mass scaling changes nothing there.
# Kinetic damping with uniform_dt stalls on the hemisphere: load step 10 ends 400 000 steps
# at a residual of 1.01e-4 of the load, so that pair is not planned.)
RELAXATION_VARIANTS = {"kinetic": ("solve.relaxation=kinetic",), "unscaled": ("solve.mass_scaling=none",),
                       "kinetic_unscaled": ("solve.relaxation=kinetic", "solve.mass_scaling=none")}
RELAXATION = (("cantilever_10x1_mpm_r0.5", "kinetic"), ("cantilever_10x1_fem", "kinetic"),
              ("hemisphere_16x16_mpm_r0.5", "unscaled"), ("hemisphere_16x16_mpm_r0.5", "kinetic_unscaled"))


def relaxation_default(case: str) -> str:
    """The default case of a relaxation variant's name."""
    return next((d for d, v in RELAXATION if case == f"{d}_{v}"), case.rsplit("_", 1)[0])


def relaxation_cases() -> list[Case]:
    """RELAXATION: each variant with the overrides of its default case plus its own."""
    defaults = {c.name: c for c in cantilever_cases((10,), ratios=(0.5,)) + hemisphere_cases((16,), ratios=(0.5,))}
    out = []
    for name, variant in RELAXATION:
        base = defaults[name]
        out.append(Case(f"{name}_{variant}", f"relaxation_{base.scene}", base.mesh, base.mode, base.ratio,
                        base.element_size, base.overrides + RELAXATION_VARIANTS[variant]))
    return out


def peers_available() -> bool:
    try:
        from .peers import kratos
    except ImportError:              # the peer module is optional
        return False
    try:
        return bool(kratos.available())
    except Exception:
        return False


def plan(quick: bool, peers: bool) -> list[Case]:
    if quick:     # each case compiles its own kernels (~20 s on a cold cache): five cases fit in 3 minutes
        return (cantilever_cases((5,), ratios=(0.5,), fem=False, peers=peers)
                + cantilever_cases((10,), ratios=(0.5,), peers=peers)
                + hemisphere_cases((8,), ratios=(0.5,), peers=peers, load_steps=QUICK_LOAD_STEPS))
    return (cantilever_cases(peers=peers) + hemisphere_cases(peers=peers) + relaxation_cases() + tube_cases()
            + scaling_cases() + empty_grid_cases())


# ------------------------------------------------------------------ machine
def machine_info() -> dict:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        import importlib.metadata as md
        taichi_version = md.version("taichi")
    except Exception:
        taichi_version = "unknown"
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:
        cores = os.cpu_count() or 0
    try:
        mem_gb = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    except (ValueError, OSError, AttributeError):
        mem_gb = float("nan")
    return {"cpu": cpu, "cores": cores, "memory_GB": mem_gb, "taichi": taichi_version,
            "python": platform.python_version(), "os": f"{platform.system()} {platform.release()}"}


def machine_tag(info: dict, arch: str) -> str:
    return f"{info['cpu']}, {info['cores']} cores, taichi {info['taichi']}, {arch}"


# ------------------------------------------------------------------ results.csv
def read_results(path: Path) -> list[dict]:
    if not path.exists():
        return []
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def write_results(path: Path, rows: list[dict]) -> None:
    def write(p: Path):
        with open(p, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=COLUMNS, extrasaction="ignore")
            w.writeheader()
            for row in rows:
                w.writerow({k: _cell(row.get(k)) for k in COLUMNS})
    atomic_write(path, write)


def _cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return "" if not math.isfinite(v) else f"{v:.6g}"
    return str(v)


def _num(row: dict, key: str) -> float:
    try:
        return float(row.get(key) or "nan")
    except ValueError:
        return float("nan")


# ------------------------------------------------------------------ running one case
def _peer_command(case: Case, run_dir: Path) -> list[str]:
    code = ("import sys; from taichi_shell_mpm.bench import peer_child; "
            "sys.exit(peer_child(sys.argv[1], sys.argv[2], sys.argv[3:]))")
    return [sys.executable, "-c", code, str(case.scene_file), str(run_dir), *case.overrides]


def case_command(case: Case, run_dir: Path, arch: str = "cpu") -> list[str]:
    if case.mode == "kratos":
        return _peer_command(case, run_dir)
    cmd = [sys.executable, "-m", "taichi_shell_mpm", "run", str(case.scene_file), "--quiet", "--out", str(run_dir)]
    if arch != "cpu":
        cmd += ["--arch", arch]
    for o in case.overrides:
        cmd += ["--set", o]
    return cmd


def peer_child(scene_file: str, out_dir: str, overrides: list[str]) -> int:
    """Child process of a ``kratos`` case: solve the scene with Kratos, write summary.json in
    the shape of ours (compile_seconds = model set-up, run_seconds = Newton solve, steps =
    Newton iterations, reference = errors)."""
    from .cli import prepare
    from .output import write_json
    from .peers import kratos
    scene, mesh, model = prepare(Path(scene_file), overrides)
    result = kratos.solve_static(scene, mesh, model)
    n = int(result["elements"])
    its = int(result["newton_iterations"])
    summary = {"scene": scene.info.name, "method": "kratos", "element": result.get("element"),
               "kratos_version": result.get("kratos_version"), "elements": n, "nodes": int(result["nodes"]),
               "steps": its, "compile_seconds": float(result["setup_seconds"]),
               "run_seconds": float(result["solve_seconds"]),
               "us_per_element_step": 1e6 * float(result["solve_seconds"]) / max(1, its * n),
               "iterations_per_step": result.get("iterations_per_step")}
    if scene.reference is not None:
        summary["reference"] = kratos.compare(scene, result)
    write_json(Path(out_dir) / "summary.json", summary)
    print(f"kratos: {its} Newton iterations, set-up {summary['compile_seconds']:.2f} s, "
          f"solve {summary['run_seconds']:.2f} s")
    return 0


def _last_error(log: Path) -> str:
    try:
        lines = [ln.strip() for ln in log.read_text(errors="replace").splitlines() if ln.strip()]
    except OSError:
        return ""
    errors = [ln for ln in lines if ln.startswith("error:")]
    return (errors or lines or [""])[-1][:300]


def row_from_summary(case: Case, summary: dict) -> dict:
    row = {"case": case.name, "scene": case.scene, "mesh": case.mesh, "mode": case.mode,
           "cell_ratio": case.ratio, "cell_size": summary.get("cell_size"), "element_size": case.element_size,
           "overrides": " ".join(case.overrides)}
    for key, src in (("elements", "elements"), ("steps", "steps"), ("compile_s", "compile_seconds"),
                     ("run_s", "run_seconds"), ("us_per_element_step", "us_per_element_step")):
        row[key] = summary.get(src)
    ref = summary.get("reference") or {}
    cols = list((ref.get("columns") or {}).items())
    for k, (name, col) in enumerate(cols[:2], start=1):
        row[f"comp{k}"] = COMPONENT_LABEL.get(name, name)
        row[f"err{k}_mean"] = col.get("mean_rel_error")
        row[f"err{k}_max"] = col.get("max_rel_error")
    if ref:
        row["rows_compared"] = int(ref.get("rows", 0)) - len(ref.get("missing_levels") or [])
    crush = summary.get("crush") or {}
    for key, src in TUBE_KEYS.items():
        if src in crush:
            row[key] = crush[src]
    return row


def run_case(case: Case, out: Path, arch: str, machine: str, echo=print) -> dict:
    """Run one case in a subprocess; return its results.csv row (status ok or failed)."""
    run_dir = out / "runs" / case.name
    if run_dir.exists():
        shutil.rmtree(run_dir)
    run_dir.mkdir(parents=True)
    cmd = case_command(case, run_dir, arch)
    log = run_dir / "bench.log"
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    t0 = time.perf_counter()
    with open(log, "w") as fh:
        fh.write("$ " + shlex.join(cmd) + "\n")
        fh.flush()
        proc = subprocess.Popen(cmd, stdout=fh, stderr=subprocess.STDOUT, env=env, cwd=ROOT)
        try:
            _, status, usage = os.wait4(proc.pid, 0)
        except KeyboardInterrupt:          # a terminal's Ctrl-C reaches the child too: let it write its results
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:   # it did not get the signal (e.g. `kill -INT` of this process)
                proc.send_signal(signal.SIGINT)
                proc.wait()
            raise
        proc.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - t0
    summary = {}
    try:
        summary = json.loads((run_dir / "summary.json").read_text())
    except (OSError, ValueError):
        pass
    row = row_from_summary(case, summary)
    row.update(wall_s=wall, peak_mem_MB=usage.ru_maxrss / 1024.0,   # Linux: kilobytes
               date=datetime.datetime.now().isoformat(timespec="seconds"), machine=machine)
    if proc.returncode == 0 and summary and not summary.get("error"):
        row["status"] = "ok"
    else:
        why = summary.get("error") or _last_error(log) or "no summary.json"
        row["status"] = f"failed (exit {proc.returncode}): {why}"
    return row


# ------------------------------------------------------------------ analysis
def observed_orders(rows: list[dict]) -> list[dict]:
    """Least-squares slope of log(mean error) vs log(element size), per scene/series/component."""
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        if r.get("status") != "ok" or r["scene"] not in ("cantilever", "hemisphere"):
            continue
        groups.setdefault((r["scene"], _group_key(r)), []).append(r)
    out = []
    for (scene, series), rs in sorted(groups.items()):
        if len({r["mesh"] for r in rs}) < 2:
            continue
        rs = sorted(rs, key=lambda r: -_num(r, "element_size"))
        entry = {"scene": scene, "series": series, "meshes": " ".join(r["mesh"] for r in rs)}
        for k in (1, 2):
            ell = np.array([_num(r, "element_size") for r in rs])
            err = np.array([_num(r, f"err{k}_mean") for r in rs])
            ok = np.isfinite(ell) & np.isfinite(err) & (ell > 0) & (err > 0)
            entry[f"comp{k}"] = rs[0].get(f"comp{k}", "")
            entry[f"order{k}"] = (float(np.polyfit(np.log(ell[ok]), np.log(err[ok]), 1)[0])
                                  if ok.sum() >= 2 and np.ptp(ell[ok]) > 0 else float("nan"))
            entry[f"points{k}"] = int(ok.sum())
        out.append(entry)
    return out


def _series_label(row: dict) -> str:
    if row["mode"] == "mpm":
        return f"mpm h={_num(row, 'cell_ratio'):g}l"
    return row["mode"]


def _group_key(row: dict) -> str:
    """Series label plus any load-step tag of the case name (quick runs use fewer steps)."""
    tag = row["case"].rsplit("_", 1)[-1]
    return _series_label(row) + (f" ({tag})" if tag.startswith("ls") else "")


# ------------------------------------------------------------------ plots
@dataclass
class Series:
    x: np.ndarray
    y: np.ndarray
    label: str
    color: str
    dashed: bool = False
    marker: str = "o"
    filled: bool = True
    notes: tuple = ()               # text next to each point (matplotlib only)


@dataclass
class Panel:
    title: str
    xlabel: str
    ylabel: str
    series: list
    logx: bool = True
    logy: bool = True


PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f")
MARKERS = ("o", "s", "^", "D", "v")


def _color(i: int) -> str:
    return PALETTE[i % len(PALETTE)]


def _plot_matplotlib(panels: list[Panel], path: Path, ncols: int) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import LogFormatter
    nrows = math.ceil(len(panels) / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(6.4 * ncols, 4.6 * nrows), squeeze=False)
    for ax in axes.ravel()[len(panels):]:
        ax.set_visible(False)
    for ax, p in zip(axes.ravel(), panels):
        for s in p.series:
            ok = np.isfinite(s.x) & np.isfinite(s.y)
            if p.logx:
                ok &= s.x > 0
            if p.logy:
                ok &= s.y > 0
            if not ok.any():
                continue
            ax.plot(s.x[ok], s.y[ok], linestyle="--" if s.dashed else "-", marker=s.marker or None,
                    color=s.color, markerfacecolor=s.color if s.filled else "white", label=s.label,
                    linewidth=1.5, markersize=7 if s.filled else 5)
            for x, y, note in zip(s.x[ok], s.y[ok], np.asarray(s.notes, dtype=object)[ok] if s.notes else ()):
                ax.annotate(str(note), (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7,
                            color=s.color)
        for axis, log in ((ax.xaxis, p.logx), (ax.yaxis, p.logy)):
            if log:
                (ax.set_xscale if axis is ax.xaxis else ax.set_yscale)("log")
                axis.set_major_formatter(LogFormatter(labelOnlyBase=False))
                axis.set_minor_formatter(LogFormatter(labelOnlyBase=False, minor_thresholds=(2, 0.5)))
        ax.set_title(p.title, fontsize=10)
        ax.set_xlabel(p.xlabel)
        ax.set_ylabel(p.ylabel)
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    fig.tight_layout()
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    plt.close(fig)


def _plot_pyvista(panels: list[Panel], path: Path, ncols: int) -> None:
    from . import render
    render.ensure_offscreen()
    render._quiet_vtk()
    nrows = math.ceil(len(panels) / ncols)
    p = render._plotter(shape=(nrows, ncols), window_size=(640 * ncols, 460 * nrows))
    for i, panel in enumerate(panels):
        chart = render._chart(panel.title, panel.xlabel, panel.ylabel)
        for s in panel.series:
            ok = np.isfinite(s.x) & np.isfinite(s.y) & ((s.x > 0) if panel.logx else True) \
                & ((s.y > 0) if panel.logy else True)
            if not ok.any():
                continue
            chart.line(s.x[ok], s.y[ok], color=s.color, width=2.0, style="--" if s.dashed else "-",
                       label="" if s.marker else s.label)
            if s.marker:
                chart.scatter(s.x[ok], s.y[ok], color=s.color, size=8, style="o" if s.filled else "s",
                              label=s.label)
        chart.x_axis.log_scale = panel.logx
        chart.y_axis.log_scale = panel.logy
        p.subplot(i // ncols, i % ncols)
        p.add_chart(chart)
    render._save(p, path)


def have_matplotlib() -> bool:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def draw(panels: list[Panel], path: Path, ncols: int = 2) -> Path | None:
    """Draw the panels into the PNG `path` (matplotlib if it imports, else pyvista's charts)."""
    if not panels:
        return None
    (_plot_matplotlib if have_matplotlib() else _plot_pyvista)(panels, path, ncols)
    return path


def _static_rows(rows: list[dict], scene: str) -> dict[str, list[dict]]:
    groups: dict[str, list[dict]] = {}
    for r in rows:
        if r["scene"] == scene and r.get("status") == "ok":
            groups.setdefault(_group_key(r), []).append(r)
    return {k: sorted(v, key=lambda r: _num(r, "elements")) for k, v in sorted(groups.items())}


def _error_panels(rows: list[dict], x_key: str, x_label: str, title: str, mean_label=None,
                  notes: bool = False) -> list[Panel]:
    """One panel per static scene and reference component: mean (solid) and max (dashed)
    error of each series against the column `x_key`; `mean_label(scene, series, k)` adds to
    the mean curve's label, `notes` writes the mesh beside each mean point."""
    panels = []
    for scene in ("cantilever", "hemisphere"):
        groups = _static_rows(rows, scene)
        if not groups:
            continue
        first = next(iter(groups.values()))[0]
        for k in (1, 2):
            series = []
            for i, (label, rs) in enumerate(groups.items()):
                x = np.array([_num(r, x_key) for r in rs])
                extra = mean_label(scene, label, k) if mean_label else ""
                for stat, dashed, filled in (("mean", False, True), ("max", True, False)):
                    e = 100 * np.array([_num(r, f"err{k}_{stat}") for r in rs])
                    mean = stat == "mean"
                    series.append(Series(x, e, f"{label} {stat}" + (extra if mean else ""), _color(i), dashed,
                                         MARKERS[i % len(MARKERS)], filled,
                                         tuple(r["mesh"] for r in rs) if notes and mean else ()))
            panels.append(Panel(f"{scene}: {first.get(f'comp{k}', f'component {k}')} {title}", x_label,
                                "relative error (%)", series))
    return panels


def plot_error_vs_time(rows: list[dict], path: Path) -> Path | None:
    return draw(_error_panels(rows, "run_s", "run wall time (s)",
                              "error vs run time (points: meshes, coarse to fine)", notes=True), path)


def plot_convergence(rows: list[dict], orders: list[dict], path: Path) -> Path | None:
    order_of = {(o["scene"], o["series"]): o for o in orders}

    def slope(scene: str, series: str, k: int) -> str:
        o = order_of.get((scene, series), {}).get(f"order{k}", float("nan"))
        return f", p = {o:.2f}" if math.isfinite(o) else ""
    return draw(_error_panels(rows, "element_size", "element size l", "error vs element size", slope), path)


def _force_curve(run_dir: Path) -> tuple[np.ndarray, np.ndarray] | None:
    path = run_dir / "force.csv"
    try:
        with open(path, newline="") as fh:
            data = list(csv.reader(fh))
        header, body = data[0], np.array(data[1:], dtype=float)
        disp = next(i for i, h in enumerate(header) if h.endswith(".displacement"))
        return -body[:, disp], np.abs(body[:, header.index("support_z")])
    except (OSError, ValueError, IndexError, StopIteration):
        return None


def plot_tube(rows: list[dict], out: Path, path: Path) -> Path | None:
    tubes = [r for r in rows if r["scene"] == "tube" and r.get("status") == "ok"]
    if not tubes:
        return None
    tubes.sort(key=lambda r: _num(r, "elements"))
    curves = []
    for i, r in enumerate(tubes):
        c = _force_curve(out / "runs" / r["case"])
        if c is not None:
            mean = _num(r, "mean_force")
            curves.append(Series(c[0], c[1], r["case"] + (f" (mean {mean:.2f} kN)" if math.isfinite(mean)
                                                         else " (crush < 20 mm: no mean)"), _color(i), marker=""))
    ref = []
    if curves:
        xmax = max(float(np.nanmax(s.x)) for s in curves)
        for value, name, color in ((7.46, "Wierzbicki-Abramowicz 7.46 kN", "#000000"),
                                   (10.22, "Abramowicz-Jones 10.22 kN", "#7f7f7f")):
            ref.append(Series(np.array([0.0, xmax]), np.array([value, value]), name, color, dashed=True,
                              marker=""))
    panels = [Panel("square tube: support force vs crush distance", "crush distance (mm)", "force (kN)",
                    curves + ref, logx=False, logy=False)]
    n = np.array([_num(r, "elements") for r in tubes])
    panels.append(Panel("square tube: wall time vs elements", "elements", "wall time (s)",
                        [Series(n, np.array([_num(r, "run_s") for r in tubes]), "run", _color(0)),
                         Series(n, np.array([_num(r, "compile_s") for r in tubes]), "compile", _color(1),
                                dashed=True, filled=False)]))
    return draw(panels, path)


def plot_scaling(rows: list[dict], path: Path) -> Path | None:
    rs = sorted((r for r in rows if r["scene"] == "scaling" and r.get("status") == "ok"),
                key=lambda r: _num(r, "elements"))
    if not rs:
        return None
    n = np.array([_num(r, "elements") for r in rs])
    per_step = 1e3 * np.array([_num(r, "run_s") / _num(r, "steps") for r in rs])
    series = [Series(n, per_step, "time per step", _color(0))]
    if len(n) > 1:      # the line through the largest case, slope 1
        series.append(Series(n, per_step[-1] * n / n[-1], "linear (through the largest)", "#7f7f7f",
                             dashed=True, marker=""))
    us = np.array([_num(r, "us_per_element_step") for r in rs])
    panels = [Panel("tube (mpm, J2, contact): time per step vs elements", "elements", "ms per step", series),
              Panel("µs per element-step vs elements", "elements", "µs / element-step",
                    [Series(n, us, "µs / element-step", _color(1))], logy=False)]
    return draw(panels, path)


# ------------------------------------------------------------------ report
def _pct(v: float) -> str:
    return "–" if not math.isfinite(v) else f"{100 * v:.2f}"


def _fmt(v: float, digits: int = 3) -> str:
    if not math.isfinite(v):
        return "–"
    if abs(v) >= 1000:
        return f"{v:,.0f}".replace(",", " ")
    return f"{v:.{digits}g}"


def _status(r: dict) -> str:
    return str(r.get("status", "")).replace("|", "\\|")


def _errs(r: dict, k: int) -> str:
    return f"{_pct(_num(r, f'err{k}_mean'))} / {_pct(_num(r, f'err{k}_max'))}"


def _static_table(rows: list[dict]) -> list[str]:
    c1 = next((r["comp1"] for r in rows if r.get("comp1")), "component 1")
    c2 = next((r["comp2"] for r in rows if r.get("comp2")), "component 2")
    lines = [f"| case | mesh | mode | h / l | elements | steps | compile s | run s | µs / element-step "
             f"| peak MB | {c1} mean / max % | {c2} mean / max % | rows | status |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        ratio = _num(r, "cell_ratio")
        h = "–" if not math.isfinite(ratio) else f"{ratio:g}"
        lines.append(f"| {r['case']} | {r['mesh']} | {r['mode']} | {h} "
                     f"| {_fmt(_num(r, 'elements'))} | {_fmt(_num(r, 'steps'))} | {_fmt(_num(r, 'compile_s'))} "
                     f"| {_fmt(_num(r, 'run_s'))} | {_fmt(_num(r, 'us_per_element_step'))} "
                     f"| {_fmt(_num(r, 'peak_mem_MB'))} | {_errs(r, 1)} | {_errs(r, 2)} "
                     f"| {r.get('rows_compared') or '–'} | {_status(r)} |")
    return lines


def _tube_table(rows: list[dict]) -> list[str]:
    lines = ["| case | mesh (flat/corner/length) | elements | steps | compile s | run s | µs / element-step "
             "| peak MB | crush mm | mean force kN | peak force kN | half-wavelength mm | energy balance "
             "| E_hg / E_int | penetration / t | status |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['case']} | {r['mesh']} | {_fmt(_num(r, 'elements'))} | {_fmt(_num(r, 'steps'))} "
                     f"| {_fmt(_num(r, 'compile_s'))} | {_fmt(_num(r, 'run_s'))} "
                     f"| {_fmt(_num(r, 'us_per_element_step'))} | {_fmt(_num(r, 'peak_mem_MB'))} "
                     f"| {_fmt(_num(r, 'crush'), 4)} | {_fmt(_num(r, 'mean_force'))} | {_fmt(_num(r, 'peak_force'))} "
                     f"| {_fmt(_num(r, 'half_wavelength'))} | {_pct(_num(r, 'balance'))} % "
                     f"| {_pct(_num(r, 'hg_ratio'))} % | {_pct(_num(r, 'penetration'))} % | {_status(r)} |")
    return lines


def empty_grid_ratios(rows: list[dict]) -> list[float]:
    """Run time in the wide grid over run time in the scene grid, pair by pair (both ok)."""
    by_name = {r["case"]: r for r in rows if r.get("status") == "ok"}
    out = []
    for k in range(1, EMPTY_GRID_PAIRS + 1):
        scene, wide = by_name.get(f"empty_grid_scene_{k}"), by_name.get(f"empty_grid_wide_{k}")
        if scene and wide and _num(scene, "run_s") > 0:
            out.append(_num(wide, "run_s") / _num(scene, "run_s"))
    return out


def _empty_grid_section(rows: list[dict]) -> list[str]:
    if not rows:
        return []
    L = ["## The empty grid", "",
         f"The paper's tube (2 880 elements, mpm) to {EMPTY_GRID_END_TIME:g} ms in its scene grid "
         "(100 × 100 × 320 mm) and in a grid of 16× the area (400 × 400 × 320 mm, 107 MB of grid nodes "
         "instead of 7 MB), as interleaved pairs so that a drift of the machine falls on both.  Only the "
         "grid nodes around shell nodes are ever written, read or cleared (stages/grid.py).", "",
         "| case | grid | steps | compile s | run s | µs / element-step | peak MB | status |",
         "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        L.append(f"| {r['case']} | {r['mesh']} | {_fmt(_num(r, 'steps'))} | {_fmt(_num(r, 'compile_s'))} "
                 f"| {_fmt(_num(r, 'run_s'))} | {_fmt(_num(r, 'us_per_element_step'))} "
                 f"| {_fmt(_num(r, 'peak_mem_MB'))} | {_status(r)} |")
    ratios = empty_grid_ratios(rows)
    if ratios:
        L += ["", "Run time wide / scene grid, pair by pair: " + ", ".join(f"{x:.3f}" for x in ratios)
              + f"; median {float(np.median(ratios)):.3f}."]
    return L + [""]


def _relaxation_section(rows: list[dict]) -> list[str]:
    """The relaxation variants, each group after its default row: steps and errors (steps of
    a static solve are the same every run: the batched launch is serial)."""
    variants = [r for r in rows if r["scene"].startswith("relaxation_")]
    if not variants:
        return []
    by_name = {r["case"]: r for r in rows}
    L = ["## Static relaxation: FIRE against kinetic damping, and mass scaling", "",
         "The default static solve relaxes each load step with FIRE (`[solve].relaxation = \"fire\"`) and "
         "gives every element the stable step of the smallest one through fictitious densities "
         "(`[solve].mass_scaling = \"uniform_dt\"`); `_kinetic` rows use plain kinetic damping, "
         "`_unscaled` rows the physical masses (`mass_scaling = \"none\"`).  Steps / default: against "
         "the default row of the same mesh and mode (the first line of each group).", "",
         "| case | mode | relaxation | mass scaling | steps | steps / default | run s | error 1 mean / max % "
         "| error 2 mean / max % | status |", "|---|---|---|---|---|---|---|---|---|---|"]
    groups: dict[str, list[dict]] = {}
    for r in variants:
        groups.setdefault(relaxation_default(r["case"]), []).append(r)
    for default, group in groups.items():
        base = by_name.get(default)
        for r in ([base] if base else []) + group:
            over = r.get("overrides", "")
            relax = "kinetic" if "solve.relaxation=kinetic" in over else "fire"
            scaling = "none" if "solve.mass_scaling=none" in over else "uniform_dt"
            ok = base is not None and base.get("status") == "ok" and r.get("status") == "ok"
            ratio = _num(r, "steps") / _num(base, "steps") if ok else float("nan")
            L.append(f"| {r['case']} | {_series_label(r)} | {relax} | {scaling} | {_fmt(_num(r, 'steps'))} "
                     f"| {_fmt(ratio)} | {_fmt(_num(r, 'run_s'))} | {r.get('comp1') or ''} {_errs(r, 1)} "
                     f"| {r.get('comp2') or ''} {_errs(r, 2)} | {_status(r)} |")
    return L + [""]


def write_report(path: Path, out: Path, rows: list[dict], planned: list[Case], command: str, info: dict,
                 arch: str, peers: bool, plots: dict[str, Path | None], quick: bool) -> None:
    rel = lambda p: Path(os.path.relpath(p, path.parent)).as_posix()   # noqa: E731
    now = datetime.datetime.now().isoformat(timespec="seconds")
    this = machine_tag(info, arch)
    L = [f"# Benchmarks: speed against error{' (quick subset)' if quick else ''}", "",
         f"Generated {now} by `{command}` from `{rel(out / 'results.csv')}` "
         "(regenerated after every case: it shows everything measured so far).", "",
         f"**Machine:** {info['cpu']}, {info['cores']} cores available, {info['memory_GB']:.0f} GB memory, "
         f"{info['os']}; Python {info['python']}, Taichi {info['taichi']}, arch `{arch}`, f64.  "
         "Cases run one after the other, each in its own process "
         "(`python -m taichi_shell_mpm run SCENE --quiet --out RUN --set ...`; the exact command is the "
         f"first line of `{rel(out / 'runs')}/CASE/bench.log`).", ""]
    other = sorted({r.get("machine", "") for r in rows if r.get("machine") and r.get("machine") != this})
    if other:
        L += [f"**Note:** some rows were measured on another machine or set-up: {'; '.join(other)} "
              "(column `machine` of results.csv).", ""]
    L += ["**Columns.** compile s: the first advance of the run (Taichi compiling its kernels or loading "
          "them from the offline cache); run s: the solve itself; wall time of the whole process (start, "
          "mesh, kernels, solve, output) is `wall_s` in results.csv.  µs / element-step = run s / (steps × "
          "elements).  Peak MB: largest resident memory of the run's process (`wait4` ru_maxrss).  Errors: "
          "mean / max over the reference rows of e_i = |sim − ref| / max(|ref_i|, 0.1·max|ref|) against "
          "Sze, Liu & Lo (2004), both tabulated components; rows = reference rows compared.  "
          "h / l: grid cell over element size l (cantilever l = 10/nx; quarter hemisphere nominal "
          "l = 8/n, so that the scene's default h = 0.25 at 16×16 is l/2).  For `kratos` rows (implicit "
          "peer): compile s = model set-up, run s = Newton solve, steps = Newton iterations.", ""]
    for scene, title in (("cantilever", "Cantilever strip under end shear (Sze), 20 load steps"),
                         ("hemisphere", "Quarter hemisphere with an 18° hole (Sze)")):
        rs = [r for r in rows if r["scene"] == scene]
        if rs:
            L += [f"## {title}", ""] + _static_table(rs) + [""]
    orders = observed_orders(rows)
    if orders:
        L += ["## Observed order of convergence", "",
              "Least-squares slope p of log(mean error) against log(element size) over the meshes measured "
              "(error ~ l^p).  Below about 0.1 % the errors reach the resolution of the comparison (the "
              "reference tables are rounded to 3 decimals, up to about 0.1 % of their smaller entries; each "
              "load step is relaxed to a residual of 1e-4 of the load), where refining stops paying and the "
              "slope flattens; see the plots.", "",
              "| scene | series | meshes | component 1 | p | component 2 | p |", "|---|---|---|---|---|---|---|"]
        for o in orders:
            L.append(f"| {o['scene']} | {o['series']} | {o['meshes']} | {o['comp1']} | "
                     f"{_fmt(o['order1'], 3)} | {o['comp2']} | {_fmt(o['order2'], 3)} |")
        L.append("")
    L += _relaxation_section(rows)
    tubes = [r for r in rows if r["scene"] == "tube"]
    if tubes:
        L += ["## Square tube crush to 15 ms (a case name ending _tT: to T ms)", "",
              "Mean support force (clamped end and support plane) over 20–200 mm of crush "
              "(Wierzbicki–Abramowicz 7.46 kN, Abramowicz–Jones 10.22 kN); "
              "energy balance error relative to the absorbed energy; half-wavelength expected ≈ 15.1 mm.", ""]
        L += _tube_table(tubes) + [""]
    scaling = [r for r in rows if r["scene"] == "scaling"]
    if scaling:
        L += ["## Scaling: time per step against elements", "",
              f"The tube (mpm, J2, self-contact, grid h = l/2) refined from 720 to 103 680 elements, each run "
              f"to {SCALING_END_TIME:g} ms (impact and yielding; the contact search runs, no folds touch yet).  "
              "Linear scaling = constant µs per element-step.  Launch "
              "(`simulation.choose_launch`): the `threads` kernel on both cores from 1 000 elements on, "
              "the batched serial kernel below (the 720-element case).", "",
              "| case | mesh | elements | steps | compile s | run s | ms / step | µs / element-step | peak MB | status |",
              "|---|---|---|---|---|---|---|---|---|---|"]
        for r in scaling:
            per = 1e3 * _num(r, "run_s") / _num(r, "steps")
            L.append(f"| {r['case']} | {r['mesh']} | {_fmt(_num(r, 'elements'))} | {_fmt(_num(r, 'steps'))} "
                     f"| {_fmt(_num(r, 'compile_s'))} | {_fmt(_num(r, 'run_s'))} | {_fmt(per)} "
                     f"| {_fmt(_num(r, 'us_per_element_step'))} | {_fmt(_num(r, 'peak_mem_MB'))} | {_status(r)} |")
        L.append("")
    L += _empty_grid_section([r for r in rows if r["scene"] == "empty_grid"])
    if not peers and any(r.get("mode") == "kratos" for r in rows):
        L += ["Peer comparison: the `*_kratos` rows are from a sitting with the optional extra `peers` (Kratos) "
              "installed; it is not installed for this run, so no `*_kratos` case ran now.", ""]
    elif not peers:
        L += ["Peer comparison: the optional extra `peers` (Kratos) is not installed here, so no implicit "
              "reference code ran (`pip install taichi_shell_mpm[peers]` adds the `*_kratos` cases).", ""]
    drawn = [(name, p) for name, p in plots.items() if p is not None and p.exists()]
    if drawn:
        L += ["## Plots", ""]
        for name, p in drawn:
            L += [f"![{name}]({rel(p)})", ""]
    done = {r["case"] for r in rows if r.get("status") == "ok"}
    failed = {r["case"] for r in rows if r.get("status") != "ok"}
    missing = [c for c in planned if c.name not in done]
    L += ["## Planned cases not measured", ""]
    if missing:
        L += [f"- `{c.name}`" + (" (failed, see the status column)" if c.name in failed else "") for c in missing]
    else:
        L.append("None: every planned case has a result.")
    L.append("")
    write_text(path, "\n".join(L))


def known_rows(rows: list[dict], quick: bool) -> list[dict]:
    """The rows of cases some plan of this kind still has (with or without the peers):
    rows of renamed or removed cases left in results.csv by an older sitting are dropped."""
    known = {c.name for c in plan(quick, peers=True)}
    return [r for r in rows if r["case"] in known]


def sort_rows(rows: list[dict], quick: bool) -> None:
    """In the order of the plan with the peers, whether or not they are installed here (a
    sitting without them keeps the *_kratos rows of an earlier one in their place)."""
    order = {c.name: i for i, c in enumerate(plan(quick, peers=True))}
    rows.sort(key=lambda r: (order.get(r["case"], len(order)), r["case"]))


def regenerate(out: Path, report: Path, planned: list[Case], command: str, info: dict, arch: str,
               peers: bool, quick: bool) -> dict:
    every = read_results(out / "results.csv")
    rows = known_rows(every, quick)
    if len(rows) != len(every):
        write_results(out / "results.csv", rows)
    sort_rows(rows, quick)
    orders = observed_orders(rows)
    with_cols = ["scene", "series", "meshes", "comp1", "order1", "points1", "comp2", "order2", "points2"]

    def write_orders(p: Path):
        with open(p, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=with_cols)
            w.writeheader()
            for o in orders:
                w.writerow({k: _cell(o[k]) for k in with_cols})
    atomic_write(out / "orders.csv", write_orders)
    plots: dict[str, Path | None] = {}
    for name, fn in (("error against run time", lambda p: plot_error_vs_time(rows, p)),
                     ("convergence", lambda p: plot_convergence(rows, orders, p)),
                     ("square tube", lambda p: plot_tube(rows, out, p)),
                     ("scaling", lambda p: plot_scaling(rows, p))):
        target = out / {"error against run time": "error_vs_time.png", "convergence": "convergence.png",
                        "square tube": "tube.png", "scaling": "scaling.png"}[name]
        try:
            plots[name] = fn(target)
        except Exception as exc:          # a plot must not lose the measurements
            print(f"warning: could not draw {target.name}: {type(exc).__name__}: {exc}", flush=True)
            plots[name] = None
    write_report(report, out, rows, planned, command, info, arch, peers, plots, quick)
    return {"rows": rows, "orders": orders, "plots": plots}


# ------------------------------------------------------------------ entry point
def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--quick", action="store_true",
                   help="small subset, under 3 minutes: cantilever 5x1 (mpm) and 10x1 (mpm, fem), quarter "
                        "hemisphere 8x8 with 10 load steps (mpm, fem); mpm at h = l/2")
    p.add_argument("--out", type=Path, default=None,
                   help="directory of results.csv, plots and runs/ (default outputs/bench, "
                        "outputs/bench_quick with --quick)")
    p.add_argument("--report", type=Path, default=None,
                   help="report file (default BENCHMARKS.md in the working directory for the study into "
                        "the default folder or ./bench; OUT/BENCHMARKS.md with --quick or another --out)")
    p.add_argument("--resume", action="store_true", help="skip cases that already have an ok row in results.csv")
    p.add_argument("--cases", action="append", default=[], metavar="PATTERN",
                   help="run only the cases whose name matches this shell pattern (repeatable), "
                        "e.g. 'cantilever*' or '*_fem'")
    p.add_argument("--list", action="store_true", help="list the planned cases and exit")
    p.add_argument("--report-only", action="store_true", help="regenerate report and plots from results.csv")
    p.add_argument("--arch", choices=["cpu", "cuda", "vulkan"], default="cpu")


def command_line(args: argparse.Namespace) -> str:
    """The bench command as typed, rebuilt from the parsed options."""
    words = ["python", "-m", "taichi_shell_mpm", "bench"]
    for flag in ("quick", "resume", "report_only"):
        if getattr(args, flag, False):
            words.append("--" + flag.replace("_", "-"))
    for flag in ("out", "report"):
        if getattr(args, flag, None) is not None:
            words += ["--" + flag, str(getattr(args, flag))]
    for pat in args.cases:
        words += ["--cases", pat]
    if args.arch != "cpu":
        words += ["--arch", args.arch]
    return shlex.join(words)


def default_out(quick: bool) -> Path:
    return Path("outputs") / ("bench_quick" if quick else "bench")


def default_report(out: Path, quick: bool) -> Path:
    """The committed report (BENCHMARKS.md in the working directory) only for the full study
    into the default folder or ./bench; anything else (--quick, a study into a scratch
    folder) keeps its report beside its results, so it cannot overwrite the committed one."""
    if not quick and out.resolve() in (default_out(False).resolve(), Path("bench").resolve()):
        return Path("BENCHMARKS.md")
    return out / "BENCHMARKS.md"


def main(args: argparse.Namespace) -> int:
    peers = peers_available()
    planned = plan(args.quick, peers)
    out = args.out or default_out(args.quick)
    report = args.report or default_report(out, args.quick)
    selected = [c for c in planned if not args.cases or any(fnmatch.fnmatchcase(c.name, pat) for pat in args.cases)]
    if args.list:
        for c in planned:
            print(f"{c.name:36s} {'*' if c in selected else ' '} {c.scene_file.name} {' '.join(c.overrides)}")
        return 0
    if args.cases and not selected:
        print(f"error: --cases {' '.join(args.cases)}: no planned case matches (see --list)", file=sys.stderr)
        return 2
    try:
        out.mkdir(parents=True, exist_ok=True)
        report.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        print(f"error: cannot create {exc.filename}: {exc.strerror}", file=sys.stderr)
        return 2
    info = machine_info()
    tag = machine_tag(info, args.arch)
    command = command_line(args)
    results = out / "results.csv"
    done = {r["case"] for r in read_results(results) if r.get("status") == "ok"}
    todo = [] if args.report_only else [c for c in selected if not (args.resume and c.name in done)]
    print(f"bench: {len(todo)} case(s) to run of {len(planned)} planned; results in {results}, report {report}",
          flush=True)
    failures = 0
    start = time.perf_counter()
    try:
        for i, case in enumerate(todo, 1):
            print(f"[{i}/{len(todo)}] {case.name} ...", end=" ", flush=True)
            row = run_case(case, out, args.arch, tag)
            rows = [r for r in read_results(results) if r["case"] != case.name] + [row]
            write_results(results, rows)
            ok = row["status"] == "ok"
            failures += not ok
            errs = (f"errors {_errs(row, 1)} | {_errs(row, 2)} %" if row.get("comp1")
                    else f"mean force {_fmt(float(row.get('mean_force') or 'nan'))} kN")
            print(f"{'ok' if ok else row['status']}: wall {row['wall_s']:.1f} s (compile "
                  f"{_fmt(float(row.get('compile_s') or 'nan'))} s, run {_fmt(float(row.get('run_s') or 'nan'))} s), "
                  f"{errs}", flush=True)
            regenerate(out, report, planned, command, info, args.arch, peers, args.quick)
    except KeyboardInterrupt:
        regenerate(out, report, planned, command, info, args.arch, peers, args.quick)
        print(f"\ninterrupted; continue with: {command} --resume", file=sys.stderr)
        return 130
    regenerate(out, report, planned, command, info, args.arch, peers, args.quick)
    print(f"bench: done in {time.perf_counter() - start:.0f} s; {failures} failed; wrote {results}, {report}",
          flush=True)
    return 3 if failures else 0


if __name__ == "__main__":
    _p = argparse.ArgumentParser(prog="python -m taichi_shell_mpm bench")
    add_arguments(_p)
    sys.exit(main(_p.parse_args()))
