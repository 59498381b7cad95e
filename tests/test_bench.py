"""`bench`: the speed-against-error study (taichi_shell_mpm/bench/, cli.py; issue 4).

One ``bench --quick`` through the public CLI in a temporary directory (five small runs:
cantilever 5x1 mpm, 10x1 mpm and fem, quarter hemisphere 8x8 with 10 load steps in mpm and
fem; about 1 minute with Taichi's offline kernel cache warm, 2.5-3 minutes cold), then its
files are checked: the rows of results.csv with sane numbers (not timings), the observed
orders, the plots and the report.  A second call with ``--resume`` must run nothing.
The rest are in-process checks of the plan, the slope fit and the plotting fallback.
"""
from __future__ import annotations

import csv
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from taichi_shell_mpm import bench
from taichi_shell_mpm.bench import plot, report

QUICK_CASES = ["cantilever_5x1_mpm_r0.5", "cantilever_10x1_mpm_r0.5", "cantilever_10x1_fem",
               "hemisphere_8x8_mpm_r0.5_ls10", "hemisphere_8x8_fem_ls10"]
ELEMENTS = {"cantilever_5x1": 5, "cantilever_10x1": 10, "hemisphere_8x8": 64}
MIN_PNG_BYTES = 5000
CHECKOUT = Path(__file__).resolve().parents[1]


def cli(*args: str, cwd: Path, timeout: float = 600) -> subprocess.CompletedProcess:
    """The bench CLI run from `cwd` on the package of this checkout (a working directory
    outside it would import whichever checkout is installed)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(CHECKOUT), os.environ.get("PYTHONPATH")])))
    return subprocess.run([sys.executable, "-m", "taichi_shell_mpm", "bench", *args], capture_output=True,
                          text=True, timeout=timeout, cwd=cwd, env=env)


def read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    work = tmp_path_factory.mktemp("bench")
    out = work / "out"
    proc = cli("--quick", "--out", str(out), cwd=work)
    return work, out, proc


def test_quick_results(quick):
    work, out, proc = quick
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    rows = read_csv(out / "results.csv")
    assert [r["case"] for r in rows if r["mode"] != "kratos"] == QUICK_CASES     # + *_kratos with the extra
    for r in rows:
        name = r["case"]
        assert r["status"] == "ok", (name, r["status"])
        assert int(r["elements"]) == ELEMENTS["_".join(name.split("_")[:2])], name
        assert r["mode"] in ("mpm", "fem", "kratos") and r["mode"] in name
        assert int(r["steps"]) > (0 if r["mode"] == "kratos" else 1000), name
        for key in ("wall_s", "compile_s", "run_s") + (() if r["mode"] == "kratos" else ("us_per_element_step",)):
            assert 0.0 < float(r[key]) < 1e4, (name, key, r[key])     # (the peer's Newton: ~2e4 us per element-step)
        assert float(r["compile_s"]) + float(r["run_s"]) < float(r["wall_s"]), name
        assert 20.0 < float(r["peak_mem_MB"]) < 16_000, (name, r["peak_mem_MB"])
        assert int(r["rows_compared"]) == (10 if name.endswith("_ls10") else 20), name
        for k in (1, 2):
            mean, worst = float(r[f"err{k}_mean"]), float(r[f"err{k}_max"])
            assert math.isfinite(mean) and math.isfinite(worst), name
            assert 0.0 < mean <= worst < 0.20, (name, k, mean, worst)
        assert (r["comp1"], r["comp2"]) == (("W_tip", "-U_tip") if name.startswith("cantilever") else ("d_out", "d_in"))
        assert (out / "runs" / name / "summary.json").is_file()
        assert (out / "runs" / name / "bench.log").read_text().startswith("$ ")
    # mpm with the grid and fem without it solve the same elements: nearly the same answer
    by = {r["case"]: r for r in rows}
    for mesh in ("cantilever_10x1", "hemisphere_8x8"):
        tag = "_ls10" if mesh.startswith("hemisphere") else ""
        for k in (1, 2):
            assert float(by[f"{mesh}_mpm_r0.5{tag}"][f"err{k}_mean"]) == pytest.approx(
                float(by[f"{mesh}_fem{tag}"][f"err{k}_mean"]), rel=0.05)
    # refinement reduces the cantilever's error
    for k in (1, 2):
        fine, coarse = by["cantilever_10x1_mpm_r0.5"], by["cantilever_5x1_mpm_r0.5"]
        assert float(fine[f"err{k}_mean"]) < float(coarse[f"err{k}_mean"])


def test_quick_orders_plots_report(quick):
    work, out, proc = quick
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    orders = read_csv(out / "orders.csv")
    cantilever = [o for o in orders if o["scene"] == "cantilever"]
    peers = {"kratos"} if bench.peers_available() else set()       # the peer's rows with the extra
    assert {o["series"] for o in cantilever} == {"mpm h=0.5l"} | peers      # fem has one mesh in --quick
    for o in cantilever:
        for k in (1, 2):
            assert 0.5 < float(o[f"order{k}"]) < 5.0, o
    for name in ("error_vs_time.png", "convergence.png"):
        path = out / name
        assert path.is_file() and path.stat().st_size > MIN_PNG_BYTES, name
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not (out / "tube.png").exists()             # no tube in --quick
    report = (out / "BENCHMARKS.md").read_text()
    assert not (work / "BENCHMARKS.md").exists()       # --quick keeps its report in --out
    for case in QUICK_CASES:
        assert f"| {case} |" in report
    assert ("Peer comparison" in report) != bench.peers_available()
    assert "**Machine:**" in report and "Taichi" in report
    assert "python -m taichi_shell_mpm bench --quick --out" in report
    assert "![convergence](convergence.png)" in report
    assert "None: every planned case has a result." in report


def test_resume_and_case_selection(quick):
    work, out, proc = quick
    assert proc.returncode == 0
    before = (out / "results.csv").read_text()
    again = cli("--quick", "--out", str(out), "--resume", cwd=work, timeout=300)
    assert again.returncode == 0, again.stderr
    assert "0 case(s) to run" in again.stdout
    assert (out / "results.csv").read_text() == before
    none = cli("--quick", "--out", str(out), "--cases", "no_such_case*", cwd=work, timeout=120)
    assert none.returncode == 2 and none.stderr.startswith("error: --cases")


# ------------------------------------------------------------------ in-process
def test_plan_names():
    full = bench.plan(quick=False, peers=False)
    names = [c.name for c in full]
    # per static mesh: mpm at two grid ratios, fem relaxation and fem Newton (issue 19)
    # and the hemisphere in triangles (issue 33): per mesh and triangle element mpm, fem and Newton
    assert len(names) == len(set(names)) == (4 * 4 + 3 * 4 + 3 * 3 * len(bench.TRIANGLE_ELEMENTS)
                                             + len(bench.RELAXATION) + 8 + len(bench.SCALING_FLAT)
                                             + 2 * bench.EMPTY_GRID_PAIRS)
    assert {"cantilever_40x4_mpm_r1", "hemisphere_32x32_fem", "hemisphere_32x32_newton", "tube_2.5mm_mpm", "tube_5mm_fem",
            "tube_5mm_fem_sms10", "tube_5mm_fem_sms20", "tube_5mm_fem_sms_reciprocal", "tube_5mm_mpm_h5_multi_polypic",
            "scaling_60",
            "empty_grid_scene_1", "empty_grid_wide_3", "hemisphere_tri_c0_32x32_newton"} <= set(names)
    # the relaxation variants: their default row's overrides plus their own, on scene keys of their own
    by_name = {c.name: c for c in full}
    for default, extra in bench.RELAXATION:
        variant, base = by_name[f"{default}_{extra}"], by_name[default]
        assert variant.overrides == base.overrides + bench.RELAXATION_VARIANTS[extra]
        assert variant.scene_file == base.scene_file and variant.scene == "relaxation_" + base.scene
        assert (variant.mode, variant.ratio) == (base.mode, base.ratio)
        assert bench.relaxation_default(variant.name) == default
    grid = [c for c in full if c.scene == "empty_grid"]
    assert [c.name.rsplit("_", 2)[1] for c in grid] == ["scene", "wide"] * bench.EMPTY_GRID_PAIRS   # interleaved
    for scene, wide in zip(grid[::2], grid[1::2]):
        assert set(wide.overrides) == set(scene.overrides) | set(bench.WIDE_GRID)
    quick = bench.plan(quick=True, peers=False)
    assert [c.name for c in quick] == QUICK_CASES
    with_peers = bench.plan(quick=False, peers=True)
    assert len([c for c in with_peers if c.mode == "kratos"]) == 4 + 3 + 3       # (+ the triangle series)
    tube = next(c for c in full if c.name == "tube_2.5mm_mpm")
    assert {"mesh.n_flat=20", "mesh.n_corner=4", "mesh.n_length=120", "method.cell_size=1.25"} <= set(tube.overrides)
    c = next(c for c in full if c.name == "cantilever_20x2_mpm_r1")
    assert "method.cell_size=0.5" in c.overrides and c.element_size == 0.5


def test_observed_order_is_the_log_log_slope():
    rows = [{"case": f"c{n}_fem", "scene": "cantilever", "mesh": f"{n}x1", "mode": "fem", "cell_ratio": "",
             "element_size": str(10 / n), "status": "ok", "comp1": "a", "comp2": "b",
             "err1_mean": str(0.3 * (10 / n) ** 2), "err2_mean": str(0.1 * (10 / n) ** 1.5)} for n in (5, 10, 20)]
    rows.append(dict(rows[0], case="c5_mpm", mode="mpm", cell_ratio="0.5"))    # one mesh only: no slope
    (o,) = bench.observed_orders(rows)
    assert o["series"] == "fem" and o["meshes"] == "5x1 10x1 20x1"
    assert o["order1"] == pytest.approx(2.0) and o["order2"] == pytest.approx(1.5)


def test_plots_without_matplotlib(tmp_path, monkeypatch):
    """Without matplotlib the plots are drawn with pyvista's charts (as render does)."""
    monkeypatch.setattr(plot, "have_matplotlib", lambda: False)
    monkeypatch.setattr(plot, "_plot_matplotlib", None)
    x = np.array([1.0, 2.0, 4.0])
    panels = [bench.Panel("error", "time", "error (%)", [bench.Series(x, 1 / x ** 2, "mean", "#1f77b4"),
                                                         bench.Series(x, 2 / x ** 2, "max", "#1f77b4", dashed=True,
                                                                      filled=False)]),
              bench.Panel("force", "crush", "force", [bench.Series(x, x, "f", "#d62728", marker="")],
                          logx=False, logy=False)]
    path = bench.draw(panels, tmp_path / "p.png")
    assert path.is_file() and path.stat().st_size > MIN_PNG_BYTES


def test_peer_case_row(tmp_path, monkeypatch):
    """A ``kratos`` case writes a summary.json shaped like ours (set-up as compile, Newton solve
    as run, iterations as steps) and becomes a results.csv row like the others."""
    from taichi_shell_mpm.peers import kratos
    case = next(c for c in bench.plan(quick=True, peers=True) if c.name == "cantilever_5x1_kratos")
    cmd = bench.case_command(case, tmp_path)
    assert cmd[:2] == [sys.executable, "-c"] and "--set" not in cmd and "mesh.nx=5" in cmd

    def fake_solve(scene, mesh, model):
        tip = np.arange(1, 21)[:, None] / 20 * np.array([-3.3, 6.7])
        return {"probes": tip, "header": ["tip.ux", "tip.uz"], "load_factors": np.arange(1, 21) / 20,
                "solve_seconds": 0.5, "setup_seconds": 0.1, "newton_iterations": 100, "nodes": len(model.points),
                "elements": len(model.elements), "element": "fake", "kratos_version": "0"}
    monkeypatch.setattr(kratos, "solve_static", fake_solve)
    assert bench.peer_child(str(case.scene_file), str(tmp_path), list(case.overrides)) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    row = bench.row_from_summary(case, summary)
    assert row["mode"] == "kratos" and row["elements"] == 5 and row["steps"] == 100
    assert row["compile_s"] == 0.1 and row["run_s"] == 0.5
    assert row["us_per_element_step"] == pytest.approx(1e6 * 0.5 / (100 * 5))
    assert (row["comp1"], row["comp2"]) == ("W_tip", "-U_tip") and row["rows_compared"] == 20
    assert 0.0 < row["err1_mean"] <= row["err1_max"]


def test_empty_grid_box_is_the_scene_box_100x_along_each_axis():
    """The report says the wide rows run in the tube's grid box scaled 100x about its centre."""
    import tomllib
    method = tomllib.loads((bench.SCENES / "square_tube.toml").read_text())["method"]
    wide = {key.split("=")[0]: json.loads(key.split("=")[1]) for key in bench.WIDE_GRID}
    lo, hi = np.array(method["grid_min"]), np.array(method["grid_max"])
    wide_lo, wide_hi = np.array(wide["method.grid_min"]), np.array(wide["method.grid_max"])
    assert wide_hi - wide_lo == pytest.approx(100 * (hi - lo))
    assert wide_hi + wide_lo == pytest.approx(hi + lo)          # the same centre


def test_empty_grid_ratios_pair_the_interleaved_runs():
    rows = []
    for k, (scene, wide) in enumerate([(1.0, 1.10), (2.0, 1.90), (1.5, 1.5)], start=1):
        rows += [{"case": f"empty_grid_scene_{k}", "scene": "empty_grid", "mesh": "10/2/60", "status": "ok",
                  "run_s": str(scene)},
                 {"case": f"empty_grid_wide_{k}", "scene": "empty_grid", "mesh": "10/2/60 box x100",
                  "status": "ok" if k != 3 else "failed: x", "run_s": str(wide)}]
    assert bench.empty_grid_ratios(rows) == pytest.approx([1.10, 0.95])      # the failed pair left out
    text = "\n".join(report._empty_grid_section(rows))
    assert "1.100, 0.950; median 1.025" in text


def test_rows_of_cases_no_plan_has_are_dropped():
    """A case renamed or removed since an older sitting (scaling_10_wide_grid became the
    empty_grid pairs) must not stay in the report beside the new rows."""
    rows = [{"case": "scaling_10_wide_grid"}, {"case": "scaling_60"}, {"case": "hemisphere_16x16_kratos"}]
    assert [r["case"] for r in bench.known_rows(rows, quick=False)] == ["scaling_60", "hemisphere_16x16_kratos"]
    assert bench.known_rows(rows, quick=True) == []


def test_only_the_study_into_its_folder_writes_the_committed_report(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert bench.default_report(bench.default_out(False), quick=False) == Path("BENCHMARKS.md")
    assert bench.default_report(Path("bench"), quick=False) == Path("BENCHMARKS.md")
    assert bench.default_report(tmp_path / "bench", quick=False) == Path("BENCHMARKS.md")
    assert bench.default_report(tmp_path / "scratch", quick=False) == tmp_path / "scratch" / "BENCHMARKS.md"
    assert bench.default_report(Path("x"), quick=True) == Path("x") / "BENCHMARKS.md"
    assert bench.default_report(bench.default_out(True), quick=True) == Path("outputs") / "bench_quick" / "BENCHMARKS.md"


def test_relaxation_variants_have_their_own_table():
    """The relaxation rows are reported after their default row (steps and their ratio), and
    stay out of the refinement series (slopes, plots)."""
    base = {"scene": "hemisphere", "mesh": "16x16q", "mode": "mpm", "cell_ratio": "0.5", "element_size": "0.5",
            "status": "ok", "comp1": "d_out", "comp2": "d_in", "err1_mean": "0.0016", "err1_max": "0.006",
            "err2_mean": "0.0023", "err2_max": "0.0064", "run_s": "12.5", "elements": "256"}
    rows = [dict(base, case="hemisphere_16x16_mpm_r0.5", steps="200000",
                 overrides="mesh.n_around=16 method.kind=mpm"),
            dict(base, case="hemisphere_16x16_mpm_r0.5_unscaled", scene="relaxation_hemisphere", steps="500000",
                 overrides="mesh.n_around=16 method.kind=mpm solve.mass_scaling=none"),
            dict(base, case="hemisphere_8x8_mpm_r0.5", mesh="8x8q", element_size="1", elements="64",
                 steps="100000", overrides="")]
    text = "\n".join(report._relaxation_section(rows))
    assert "| hemisphere_16x16_mpm_r0.5 | mpm h=0.5l | fire | uniform_dt | 200 000 | 1 |" in text
    assert "| hemisphere_16x16_mpm_r0.5_unscaled | mpm h=0.5l | fire | none | 500 000 | 2.5 |" in text
    (o,) = bench.observed_orders(rows)
    assert o["meshes"] == "8x8q 16x16q"
    assert [r["case"] for r in plot._static_rows(rows, "hemisphere")["mpm h=0.5l"]] == [
        "hemisphere_8x8_mpm_r0.5", "hemisphere_16x16_mpm_r0.5"]


def test_rows_keep_the_plan_order_without_the_peers():
    """A sitting without Kratos regenerates the report with the *_kratos rows of an earlier
    sitting in their place beside their meshes, not moved to the end."""
    rows = [{"case": name} for name in ("cantilever_5x1_kratos", "cantilever_10x1_fem", "cantilever_5x1_fem",
                                        "cantilever_10x1_kratos")]
    bench.sort_rows(rows, quick=False)
    assert [r["case"] for r in rows] == ["cantilever_5x1_fem", "cantilever_5x1_kratos", "cantilever_10x1_fem",
                                         "cantilever_10x1_kratos"]
