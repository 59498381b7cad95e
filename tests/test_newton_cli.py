"""Newton statics through the CLI (issue 19), against Sze, Liu & Lo (2004):

* the hinged cylindrical roof (scenes/hinged_roof.toml, 8x8 quarter here) followed by arc
  length through both limit points of its snap-through, compared along the path;
* the same roof under load control: the jump over the snap-through is a warning naming the
  load levels;
* the slit annular plate (scenes/slit_annular_plate.toml on the 6x30 mesh), a plate of
  R/t = 333 lifted to 580 t, that dynamic relaxation does not solve (docs/newton.md);
* the scene checks of the Newton keys.

The runs and the checks go through the command line's code in this process
(test_reliability.cli_run: `main([...])` with its output captured), one after the other.  Bounds are about 1.5x the measured errors,
printed with ``pytest -s``.
"""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from .conftest import ROOT
from .test_reliability import CliResult, cli_run

ROOF_8 = ("--set", "mesh.path=data/hinged_roof_8x8q.vtu")
# the 6x30 mesh: 7 nodes on the lifted face, spacing 2/3: 0.8 x 2/3 on every node less half of it at A and B
SLIT_6 = {"slit_annular_10x80": "slit_annular_6x30", "force = [0.0, 0.0, 3.52]": f"force = [0.0, 0.0, {7 * 0.8 * 2 / 3!r}]",
          "force = [0.0, 0.0, -0.16]": f"force = [0.0, 0.0, {-0.8 / 3!r}]"}
# Sze's limit loads of the 12.7 roof (P / Pmax at the first maximum and the minimum of the table)
ROOF_LIMITS = (0.7421, 0.1729)
# measured (8x8 quarter): along the path mean 0.12 %, max 0.40 % (distance in the scaled plane);
# limit loads 0.7422 and 0.1736 (0.01 % and 0.4 % from Sze's table, whose rows are 0.7 % of
# the path apart there)
ROOF_BOUND = (0.0018, 0.006)
LIMIT_BOUND = 0.006
# the load step over the snap-through reaches the remote branch by Newton's wandering: 63
# iterations measured now (31 when the bound was set, 18 before the large-increment update of
# stages/shell.increment_geometry; the count moved with changes since 2026-12-02); with 45 it cut back
# to the limit point and stopped (the CI failure of stop 34).  The count of a wandering Newton
# is not a property of the model: the bound is 1.5x the measured
JUMP_ITERATIONS = 100
# measured (6x30, 40 load steps): W_A 0.29 / 0.66 %, W_B 0.26 / 0.52 % (Sze's 10x80 reference)
SLIT_BOUND = {"W_A": (0.0045, 0.010), "W_B": (0.0042, 0.008)}


def run_cli(scene: Path, out: Path, *extra: str) -> tuple[Path, CliResult]:
    return out, cli_run("run", str(scene), "--out", str(out), *extra, timeout=900)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("newton")
    text = (ROOT / "scenes" / "slit_annular_plate.toml").read_text()
    for old, new in SLIT_6.items():
        assert old in text
        text = text.replace(old, new)
    scenes = tmp / "scenes"
    scenes.mkdir()
    (scenes / "data").symlink_to(ROOT / "scenes" / "data")
    slit = scenes / "slit.toml"
    slit.write_text(text)
    jobs = {"arc": (ROOT / "scenes" / "hinged_roof.toml", tmp / "arc", *ROOF_8),
            "load": (ROOT / "scenes" / "hinged_roof.toml", tmp / "load", *ROOF_8, "--set", "solve.control=load",
                     "--set", "solve.load_steps=10", "--set", f"solve.max_iterations={JUMP_ITERATIONS}"),
            "slit": (slit, tmp / "slit")}
    return {k: run_cli(*args) for k, args in jobs.items()}


def summary_of(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


def test_roof_arc_length_through_the_limit_points(runs):
    out, proc = runs["arc"]
    assert proc.code == 0, proc.err[-2000:]
    s = summary_of(out)
    ref = s["reference"]
    col = ref["columns"]["minus_W_C"]
    with open(out / "probes.csv") as fh:
        rows = list(csv.reader(fh))
    lam = np.array([float(r[0]) for r in rows[1:]])
    print(f"\nhinged roof 8x8q, arc length: {s['points']} points, {s['iterations']} iterations, "
          f"{s['cutbacks']} cut-backs, run {s['run_seconds']:.2f} s; limit points {s['limit_points']} "
          f"(Sze {ROOF_LIMITS}); along the path mean {100 * col['mean_rel_error']:.3f} %, max "
          f"{100 * col['max_rel_error']:.3f} %, {ref['matched']}/{ref['rows']} rows")
    assert rows[0][0] == "load_factor" and len(lam) == s["points"] == len(s["iterations_per_point"])
    assert ref["along"] == "path" and ref["missing_levels"] == []          # the whole table was passed
    assert col["mean_rel_error"] <= ROOF_BOUND[0] and col["max_rel_error"] <= ROOF_BOUND[1]
    assert len(s["limit_points"]) == 2
    for found, sze in zip(s["limit_points"], ROOF_LIMITS):
        assert abs(found - sze) <= LIMIT_BOUND
    assert np.any(np.diff(lam) < 0) and lam[-1] > 1.0                       # down through the snap, up again
    assert s["warnings"] == []


def test_roof_load_control_reports_the_jump(runs):
    out, proc = runs["load"]
    assert proc.code == 0, proc.err[-2000:]
    s = summary_of(out)
    jumps = [w for w in s["warnings"] if "jumped to a remote branch" in w]
    print("\n" + "\n".join(jumps))
    assert len(jumps) == 1 and "between load factors 0.7 and 0.8" in jumps[0]
    assert "jumped to a remote branch" in proc.err + proc.out


def test_slit_annular_plate_converges(runs):
    out, proc = runs["slit"]
    assert proc.code == 0, proc.err[-2000:]
    s = summary_of(out)
    ref = s["reference"]
    print(f"\nslit annular plate 6x30: {s['points']} points, {s['iterations']} iterations, {s['cutbacks']} "
          f"cut-backs, run {s['run_seconds']:.2f} s (elements {s['element_seconds']:.2f} s, factorizations "
          f"{s['linear_solve_seconds']:.2f} s)")
    assert ref["matched"] == ref["rows"] == 23
    for column, (mean_bound, max_bound) in SLIT_BOUND.items():
        r = ref["columns"][column]
        print(f"  {column}: mean {100 * r['mean_rel_error']:.3f} %, max {100 * r['max_rel_error']:.3f} %")
        assert r["mean_rel_error"] <= mean_bound and r["max_rel_error"] <= max_bound


def validate(tmp_path: Path, *sets: str, scene: str = "hinged_roof.toml") -> CliResult:
    return cli_run("validate", str(ROOT / "scenes" / scene), *[a for s in sets for a in ("--set", s)])


@pytest.mark.parametrize("sets, message", [
    (("method.kind=mpm",), '[solve].solver: "newton" runs in fem mode'),
    (("solve.kind=dynamic", "solve.end_time=1"), '[solve].solver: "newton" solves static scenes'),
    (("element.drilling=projection",), "drilling spring"),
    (("solve.control=displacement", "solve.control_displacement=0"), "[solve].control_displacement: expected a non-zero number"),
    (("gravity.acceleration=[0,0,-9.81]",), '[solve].solver: "newton" does not handle [gravity]'),
])
def test_newton_scene_checks(tmp_path, sets, message):
    proc = validate(tmp_path, *sets)
    print(proc.err.strip())
    assert proc.code == 2 and message in proc.err and "Traceback" not in proc.err


def test_newton_keys_need_the_newton_solver(tmp_path):
    proc = validate(tmp_path, "solve.arc_length=2", scene="cantilever.toml")
    assert proc.code == 2 and '[solve].arc_length: is a key of the Newton solver' in proc.err


def test_reference_along_a_path(tmp_path):
    """[reference].along = "path": the distance of each row to the simulated polyline in the
    scaled plane, rows beyond the path's reach missing."""
    from taichi_shell_mpm.reference import compare_with_reference
    from taichi_shell_mpm.scene import Reference, ReferenceColumn
    table = tmp_path / "ref.csv"
    table.write_text("P,W\n0.5,1.0\n1.0,2.0\n0.5,3.0\n1.0,5.0\n")        # up, down, up again
    ref = Reference(file=table, load_column="P", compare=(ReferenceColumn("W", "p.uz", -1.0),), along="path")
    w = np.array([1.0, 2.0, 3.0, 4.0])                     # the path: straight segments through the rows,
    lam = np.array([0.5, 1.0, 0.5, 0.75])                  # the last row (W = 5) beyond its end
    rows = np.stack([lam + np.array([0.0, 0.0, 0.01, 0.0]), -w], axis=1).tolist()
    result = compare_with_reference(ref, ["load_factor", "p.uz"], rows)
    col = result["columns"]["W"]
    # row 3 (W = 3, P = 0.5) lies 0.01 below the path's vertex (3, 0.51), which is its nearest
    # point (both segments there leave it away from the row); the others lie on the path
    print(f"\nalong the path: {col['mean_rel_error']:.3e} / {col['max_rel_error']:.3e}; missing {result['missing_levels']}")
    assert result["missing_levels"] == [1.0] and result["matched"] == 3
    assert col["max_rel_error"] == pytest.approx(0.01, rel=1e-9)
    assert col["mean_rel_error"] == pytest.approx(0.01 / 3, rel=1e-9)
    assert col["path"]["x"] == w.tolist() and col["simulated"][3] is None
