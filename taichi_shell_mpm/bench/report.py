"""The report (BENCHMARKS.md) from results.csv: the header (machine, date, the exact
command), one table per study (the Sze cantilever and quarter hemisphere, the observed
orders, the static relaxation variants, the square tube, the scaling series, the empty
grid), the plots and the planned cases not measured yet; :func:`regenerate` rewrites
orders.csv, the plots and the report after every case.
"""
from __future__ import annotations

import datetime
import math
import os
from pathlib import Path

import numpy as np

from .cases import EMPTY_GRID_END_TIME, EMPTY_GRID_PAIRS, SCALING_END_TIME, STATIC_SCENES, Case, plan, relaxation_default
from .fit import observed_orders, series_label, write_orders
from .machine import machine_tag
from .plot import plot_all
from .results import num, read_results, write_results, write_text


def _pct(v: float) -> str:
    return "–" if not math.isfinite(v) else f"{100 * v:.2f}"


def fmt(v: float, digits: int = 3) -> str:
    if not math.isfinite(v):
        return "–"
    if abs(v) >= 1000:
        return f"{v:,.0f}".replace(",", " ")
    return f"{v:.{digits}g}"


def _status(r: dict) -> str:
    return str(r.get("status", "")).replace("|", "\\|")


def error_pair(r: dict, k: int) -> str:
    return f"{_pct(num(r, f'err{k}_mean'))} / {_pct(num(r, f'err{k}_max'))}"


def _static_table(rows: list[dict]) -> list[str]:
    c1 = next((r["comp1"] for r in rows if r.get("comp1")), "component 1")
    c2 = next((r["comp2"] for r in rows if r.get("comp2")), "component 2")
    lines = [f"| case | mesh | mode | h / l | elements | steps | compile s | run s | µs / element-step "
             f"| peak MB | {c1} mean / max % | {c2} mean / max % | rows | status |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        ratio = num(r, "cell_ratio")
        h = "–" if not math.isfinite(ratio) else f"{ratio:g}"
        lines.append(f"| {r['case']} | {r['mesh']} | {r['mode']} | {h} "
                     f"| {fmt(num(r, 'elements'))} | {fmt(num(r, 'steps'))} | {fmt(num(r, 'compile_s'))} "
                     f"| {fmt(num(r, 'run_s'))} | {fmt(num(r, 'us_per_element_step'))} "
                     f"| {fmt(num(r, 'peak_mem_MB'))} | {error_pair(r, 1)} | {error_pair(r, 2)} "
                     f"| {r.get('rows_compared') or '–'} | {_status(r)} |")
    return lines


def _tube_table(rows: list[dict]) -> list[str]:
    lines = ["| case | mesh (flat/corner/length) | elements | steps | compile s | run s | µs / element-step "
             "| peak MB | crush mm | mean force kN | peak force kN | half-wavelength mm | energy balance "
             "| E_hg / E_int | penetration / t | status |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['case']} | {r['mesh']} | {fmt(num(r, 'elements'))} | {fmt(num(r, 'steps'))} "
                     f"| {fmt(num(r, 'compile_s'))} | {fmt(num(r, 'run_s'))} "
                     f"| {fmt(num(r, 'us_per_element_step'))} | {fmt(num(r, 'peak_mem_MB'))} "
                     f"| {fmt(num(r, 'crush'), 4)} | {fmt(num(r, 'mean_force'))} | {fmt(num(r, 'peak_force'))} "
                     f"| {fmt(num(r, 'half_wavelength'))} | {_pct(num(r, 'balance'))} % "
                     f"| {_pct(num(r, 'hg_ratio'))} % | {_pct(num(r, 'penetration'))} % | {_status(r)} |")
    return lines


def empty_grid_ratios(rows: list[dict]) -> list[float]:
    """Run time in the box x100 over run time in the scene box, pair by pair (both ok)."""
    by_name = {r["case"]: r for r in rows if r.get("status") == "ok"}
    out = []
    for k in range(1, EMPTY_GRID_PAIRS + 1):
        scene, wide = by_name.get(f"empty_grid_scene_{k}"), by_name.get(f"empty_grid_wide_{k}")
        if scene and wide and num(scene, "run_s") > 0:
            out.append(num(wide, "run_s") / num(scene, "run_s"))
    return out


def _empty_grid_section(rows: list[dict]) -> list[str]:
    if not rows:
        return []
    L = ["## The empty grid", "",
         f"The paper's tube (2 880 elements, mpm) to {EMPTY_GRID_END_TIME:g} ms in its scene grid box "
         "(100 × 100 × 320 mm) and in a box 100× larger along each axis (10 × 10 × 32 m: 10⁶ times the "
         "volume, 2.0 × 10¹¹ grid nodes at h = 2.5 mm, 6.6 TB as a dense grid), as interleaved pairs so "
         "that a drift of the machine falls on both.  The grid is hashed (stages/grid.py): only the grid "
         "nodes of the shell nodes' stencils exist, in storage sized by the shell's node count, and the box "
         "only bounds where the nodes may go.", "",
         "| case | grid | steps | compile s | run s | µs / element-step | peak MB | status |",
         "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        L.append(f"| {r['case']} | {r['mesh']} | {fmt(num(r, 'steps'))} | {fmt(num(r, 'compile_s'))} "
                 f"| {fmt(num(r, 'run_s'))} | {fmt(num(r, 'us_per_element_step'))} "
                 f"| {fmt(num(r, 'peak_mem_MB'))} | {_status(r)} |")
    ratios = empty_grid_ratios(rows)
    if ratios:
        L += ["", "Run time box ×100 / scene box, pair by pair: " + ", ".join(f"{x:.3f}" for x in ratios)
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
            ratio = num(r, "steps") / num(base, "steps") if ok else float("nan")
            L.append(f"| {r['case']} | {series_label(r)} | {relax} | {scaling} | {fmt(num(r, 'steps'))} "
                     f"| {fmt(ratio)} | {fmt(num(r, 'run_s'))} | {r.get('comp1') or ''} {error_pair(r, 1)} "
                     f"| {r.get('comp2') or ''} {error_pair(r, 2)} | {_status(r)} |")
    return L + [""]


def _parallel(rows: list[dict]) -> bool:
    """Some row was measured with other cases running at once (bench --workers: machine_tag)."""
    return any("cases at a time" in (r.get("machine") or "") for r in rows)


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
         + ("Cases run one after the other, each in its own process " if not _parallel(rows) else
            "**Some cases ran several at a time** (`--workers`; their machine column says how many), so their "
            "timings shared the cores and do not compare with a quiet machine's.  Each case runs in its own process ")
         + "(`python -m taichi_shell_mpm run SCENE --quiet --out RUN --set ...`; the exact command is the "
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
          "peer): compile s = model set-up, run s = Newton solve, steps = Newton iterations.  For `newton` "
          "rows (`[solve].solver = \"newton\"`, fem, issue 19): steps = Newton iterations, run s includes, as for "
          "every row of ours, recording each load step (probes, energies, a frame), which the peer does not.", ""]
    for scene, title in STATIC_SCENES.items():
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
                     f"{fmt(o['order1'], 3)} | {o['comp2']} | {fmt(o['order2'], 3)} |")
        L.append("")
    L += _relaxation_section(rows)
    tubes = [r for r in rows if r["scene"] == "tube"]
    if tubes:
        L += ["## Square tube crush to 15 ms (a case name ending _tT: to T ms)", "",
              "Mean support force (clamped end and support plane) over 20–200 mm of crush "
              "(Wierzbicki–Abramowicz 7.46 kN, Abramowicz–Jones 10.22 kN); "
              "energy balance error relative to the absorbed energy; half-wavelength expected ≈ 15.1 mm.  "
              "`_h5`: one grid cell per element (h = ℓ = 5 mm; docs/grid.md): on one field with APIC the folds "
              "glue and the transfer filters the impact's wave; `_multi_polypic`: multi-velocity fields with "
              "the PolyPIC transfer, which keep both.", ""]
        L += _tube_table(tubes) + [""]
    scaling = [r for r in rows if r["scene"] == "scaling"]
    if scaling:
        L += ["## Scaling: time per step against elements", "",
              f"The tube (mpm, J2, self-contact, grid h = l/2) refined from 720 to 103 680 elements, each run "
              f"to {SCALING_END_TIME:g} ms (impact and yielding; the contact search runs, no folds touch yet).  "
              "Linear scaling = constant µs per element-step.  Launch "
              "(`runtime.choose_launch`): the `threads` kernel on both cores from 1 000 elements on, "
              "the batched serial kernel below (the 720-element case).", "",
              "| case | mesh | elements | steps | compile s | run s | ms / step | µs / element-step | peak MB | status |",
              "|---|---|---|---|---|---|---|---|---|---|"]
        for r in scaling:
            per = 1e3 * num(r, "run_s") / num(r, "steps")
            L.append(f"| {r['case']} | {r['mesh']} | {fmt(num(r, 'elements'))} | {fmt(num(r, 'steps'))} "
                     f"| {fmt(num(r, 'compile_s'))} | {fmt(num(r, 'run_s'))} | {fmt(per)} "
                     f"| {fmt(num(r, 'us_per_element_step'))} | {fmt(num(r, 'peak_mem_MB'))} | {_status(r)} |")
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
    """Everything from results.csv (after every case, and with ``--report-only``): drop the
    rows of cases no plan has, orders.csv, the plots, the report."""
    every = read_results(out / "results.csv")
    rows = known_rows(every, quick)
    if len(rows) != len(every):
        write_results(out / "results.csv", rows)
    sort_rows(rows, quick)
    orders = observed_orders(rows)
    write_orders(out / "orders.csv", orders)
    plots = plot_all(rows, orders, out)
    write_report(report, out, rows, planned, command, info, arch, peers, plots, quick)
    return {"rows": rows, "orders": orders, "plots": plots}
