"""Belytschko-Wong-Chiang warping correction (``[element].warping = "bwc"``,
stages/warping.py, method.md 3.8): rigid motions of a warped element, the curvature a warped
rectangle gets from in-plane stretching, the element's power identity, and the MacNeal-Harder
twisted beam through the CLI."""
from __future__ import annotations

import csv
import json

import meshio
import numpy as np
import pytest

from .conftest import element_pass, element_simulation, write_scene
from .test_shell_element import DT, E, NU, T, WARPED, rotation_matrix


@pytest.mark.parametrize("warping", ["bwc", "none"])
def test_rigid_motions_of_a_warped_element_give_nothing(tmp_path, warping):
    """A warped, distorted quad (warp 0.06 on sides ~1) over one step: a translation, a large
    rotation about a general axis and a pure spin about the element normal (0.5 rad each; the
    nodal omega is the Cayley rate 2 tan(theta/2)/dt, integrated exactly by the mid-step rates).
    Stress, forces, moments and hourglass resultants stay at round-off, with and without bwc.
    The spin needs the drill projection: printed is the curvature rate B^c . v of the raw spin
    velocities, which the projection removes."""
    sim = element_simulation(tmp_path, WARPED, E=E, nu=NU, t=T, element=f'warping = "{warping}"')
    centre = WARPED.mean(axis=0)
    d13, d24 = WARPED[2] - WARPED[0], WARPED[3] - WARPED[1]
    normal = np.cross(d13, d24) / np.linalg.norm(np.cross(d13, d24))
    shift = np.tile([0.4, -1.1, 0.7], (4, 1))
    cases = {"translation": (WARPED + DT * shift, shift, np.zeros((4, 3)))}
    for name, theta in (("rotation", np.array([0.2, -0.35, 0.25])), ("spin", 0.5 * normal)):
        angle = np.linalg.norm(theta)
        rotated = (WARPED - centre) @ rotation_matrix(theta).T + centre
        cases[name] = (rotated, (rotated - WARPED) / DT, np.tile(2 * np.tan(angle / 2) / DT * theta / angle, (4, 1)))
    for name, (end, velocity, omega) in cases.items():
        stress, force, moment, hg = element_pass(sim, end, velocity, omega, DT)
        scale = E * DT * np.abs(velocity).max()        # stress of a unit strain increment
        print(f"{warping} {name}: max |stress| {np.abs(stress).max():.2e}, |f| {np.abs(force).max():.2e}, "
              f"|m| {np.abs(moment).max():.2e}, |hg| {np.abs(hg).max():.2e} (scale {scale:.1e})")
        assert np.abs(stress).max() <= 1e-12 * scale
        assert np.abs(force).max() <= 1e-12 * scale
        assert np.abs(moment).max() <= 1e-12 * scale
        assert np.abs(hg).max() <= 1e-12 * scale
    # what the spin would give without the drill projection (numpy B^c of method.md 3.8)
    mid = 0.5 * (WARPED + cases["spin"][0])
    frame = _frame(mid)
    local = (mid - mid.mean(axis=0)) @ frame.T
    vl = cases["spin"][1] @ frame.T
    x, y, z = local.T
    a2 = (0.5 * ((x[2] - x[0]) * (y[3] - y[1]) + (x[1] - x[3]) * (y[2] - y[0]))) ** 2
    zw = 0.25 * (z[0] - z[1] + z[2] - z[3])
    bc1 = 2 * zw / a2 * np.array([x[0] - x[2], x[3] - x[1], x[2] - x[0], x[1] - x[3]])
    bc2 = 2 * zw / a2 * np.array([y[0] - y[2], y[3] - y[1], y[2] - y[0], y[1] - y[3]])
    raw = np.array([bc1 @ vl[:, 0], bc2 @ vl[:, 1], bc1 @ vl[:, 1] + bc2 @ vl[:, 0]])
    print(f"spin without the drill projection: B^c curvature rate {raw} (x t/2 dt E: stress "
          f"{np.abs(raw).max() * T / 2 * DT * E:.2e})")
    assert np.abs(raw).max() * T / 2 > 1e-3 * np.abs(cases["spin"][1]).max()


def _frame(x):
    """Rows e1, e2, e3 of the BT frame (stages/shell.py corotational_frame)."""
    e3 = np.cross(x[2] - x[0], x[3] - x[1])
    e3 /= np.linalg.norm(e3)
    r21 = x[1] - x[0]
    e1 = r21 - r21 @ e3 * e3
    e1 /= np.linalg.norm(e1)
    return np.array([e1, np.cross(e3, e1), e3])


@pytest.mark.parametrize("gradient", [[[1.0, 0.0], [0.0, 0.0]], [[0.0, 0.5], [0.5, 0.0]], [[0.3, -0.2], [-0.2, 0.7]]],
                         ids=["stretch", "shear", "mixed"])
def test_warped_rectangle_bends_under_in_plane_motion(tmp_path, gradient):
    """The corners of a rectangle (half-sides a, b) warped by z_a = z_w h_a lie on z = c x y,
    c = z_w / (a b).  A symmetric in-plane velocity gradient D turns that surface's normals:
    the slope s = grad z changes at -D^T s, a curvature rate c (D_xy, D_xy, D_xx + D_yy)
    (engineering twist; stages/warping.py).  With bwc the element's bending stress is
    C dt z kappa' with that kappa' to round-off; without it there is none."""
    a, b, zw = 0.6, 0.4, 0.05
    corners = np.array([[-a, -b, zw], [a, -b, -zw], [a, b, zw], [-a, b, -zw]])
    grad = np.zeros((3, 3))
    grad[:2, :2] = gradient
    velocity = corners @ grad.T                       # in-plane only, about the centre
    end = corners + 0.5 * DT * velocity               # mid-step geometry = the rectangle
    c = zw / (a * b)
    d = np.asarray(gradient)
    kappa = c * np.array([d[0, 1], d[1, 0], d[0, 0] + d[1, 1]])
    cmat = E / (1 - NU ** 2) * np.array([[1, NU, 0], [NU, 1, 0], [0, 0, (1 - NU) / 2]])
    expected = DT * (T / 2) * cmat @ kappa            # top (zeta = +1) minus mid point
    for warping in ("bwc", "none"):
        (tmp_path / warping).mkdir()
        sim = element_simulation(tmp_path / warping, corners, E=E, nu=NU, t=T, element=f'warping = "{warping}"')
        stress, _, _, _ = element_pass(sim, end, velocity, np.zeros((4, 3)), DT)
        bending = 0.5 * (stress[2, :3] - stress[0, :3])    # Lobatto 3: zeta = -1, 0, 1
        print(f"{warping}: bending stress {bending}, expected with bwc {expected}")
        if warping == "bwc":
            assert np.abs(bending - expected).max() <= 1e-9 * np.abs(expected).max()
        else:
            assert np.abs(bending).max() <= 1e-12 * np.abs(expected).max()


@pytest.mark.parametrize("geometry", ["warped", "twisted_strip"])
def test_power_identity_with_warping(geometry):
    """sum_a (f_a . v_a + m_a . theta_a) = A (N . eps' - M' . kappa' + kappa Q . gamma') for the
    BT loads (stages/shell.py resultant_loads) plus the BWC loads (stages/warping.py
    nodal_loads), with kappa' the BT curvature rate plus the BWC one, on a warped quad, random
    rates and random resultants: the loads are the exact transpose of the rates."""
    import taichi as ti

    from taichi_shell_mpm.runtime import init_taichi
    from taichi_shell_mpm.stages import warping
    from taichi_shell_mpm.stages.shell import gradient_operators, local_geometry, resultant_loads, strain_rates
    init_taichi("cpu")
    corners = WARPED if geometry == "warped" else _twisted_beam_nodes(1, 1, length=1.0, width=1.1,
                                                                       twist_deg=30.0)[[0, 2, 3, 1]]
    rng = np.random.default_rng(11)
    v, w = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    n_res, m_res, q_res = rng.normal(size=3), rng.normal(size=3), rng.normal(size=2)
    kappa = 5.0 / 6.0
    out = ti.field(ti.f64, 4)
    data = ti.field(ti.f64, 12 * 3 + 8)
    data.from_numpy(np.concatenate([corners.ravel(), v.ravel(), w.ravel(), n_res, m_res, q_res]))

    @ti.kernel
    def power():
        x = ti.Matrix([[data[3 * a + d] for d in range(3)] for a in range(4)])
        rot, xh, yh, zh = local_geometry(x)
        vl = ti.Matrix([[data[12 + 3 * a + d] for d in range(3)] for a in range(4)]) @ rot.transpose()
        wl = ti.Matrix([[data[24 + 3 * a + d] for d in range(3)] for a in range(4)]) @ rot.transpose()
        n = ti.Vector([data[36], data[37], data[38]])
        mp = ti.Vector([data[39], data[40], data[41]])
        q = ti.Vector([data[42], data[43]])
        vx = ti.Vector([vl[a, 0] for a in range(4)])
        vy = ti.Vector([vl[a, 1] for a in range(4)])
        vz = ti.Vector([vl[a, 2] for a in range(4)])
        tx = ti.Vector([wl[a, 0] for a in range(4)])
        ty = ti.Vector([wl[a, 1] for a in range(4)])
        tz = ti.Vector([wl[a, 2] for a in range(4)])
        area, b1, b2 = gradient_operators(xh, yh)
        eps, curv, gam = strain_rates(b1, b2, vx, vy, vz, tx, ty)
        curv_c = warping.curvature_rate(xh, yh, zh, area, b1, b2, vx, vy)
        f, m = resultant_loads(area, b1, b2, n, mp, q, kappa)
        f += warping.nodal_loads(xh, yh, zh, area, b1, b2, mp)
        out[0] = area * (n.dot(eps) - mp.dot(curv + curv_c) + kappa * q.dot(gam))
        out[1] = (f[:, 0] * vx + f[:, 1] * vy + f[:, 2] * vz + m[:, 0] * tx + m[:, 1] * ty + m[:, 2] * tz).sum()
        out[2] = -area * mp.dot(curv_c)                 # the BWC part alone
        out[3] = 0.25 * (zh[0] - zh[1] + zh[2] - zh[3])

    power()
    rate_power, load_power, bwc_power, zw = out.to_numpy()
    print(f"\n{geometry}: z_w {zw:.4f}; A(N.e - M'.k + kQ.g) {rate_power:.15e}, loads . rates {load_power:.15e}, "
          f"BWC part {bwc_power:.3e}")
    assert abs(zw) > 1e-3
    assert abs(bwc_power) > 1e-3 * abs(rate_power)      # the correction takes part
    assert abs(rate_power - load_power) < 1e-13 * (np.abs(v).max() + np.abs(w).max()) * (
        np.abs(n_res).max() + np.abs(m_res).max() + np.abs(q_res).max()) * 10


# ------------------------------------------------------------------ MacNeal-Harder twisted beam
# MacNeal & Harder (1985), Finite Elements in Analysis and Design 1:3-20: L = 12, width 1.1,
# E = 29.0e6, nu = 0.22, twisted 90 deg from root to tip, root clamped, unit tip force along the
# tip's width ("in-plane") or its normal ("out-of-plane"); tip deflection along the load.
# Thick case t = 0.32, P = 1; thin t = 0.0032, P = 1e-6 (deflections of the same order).
TWISTED_REFERENCE = {0.32: {"in_plane": 5.424e-3, "out_of_plane": 1.754e-3},
                     0.0032: {"in_plane": 5.256e-3, "out_of_plane": 1.294e-3}}

TWISTED_SCENE = """
[scene]
name = "twisted_beam"
units = "consistent (MacNeal-Harder 1985: lb, in)"
[mesh]
kind = "file"
path = "twisted_beam.vtu"
[material]
E = 29.0e6
nu = 0.22
density = 1.0
[section]
thickness = {t}
[element]
warping = "{warping}"
[method]
kind = "fem"
[nodesets.root]
plane = {{point = [0, 0, 0], normal = [1, 0, 0]}}
[nodesets.tip]
plane = {{point = [12, 0, 0], normal = [1, 0, 0]}}
[[boundary]]
nodes = "root"
fix = "all"
[[load]]
nodes = "tip"
force = {force}
[[probe]]
name = "tip"
nodes = "tip"
components = ["uy", "uz"]
[solve]
kind = "static"
load_steps = 1
tolerance = {tolerance}
[output]
load_steps = false
"""


def _twisted_beam_nodes(nx: int, ny: int, *, length=12.0, width=1.1, twist_deg=90.0):
    """Nodes (i along the length, j across; index i (ny + 1) + j) of the strip twisted about
    x: the width runs along y at the root and turns by twist_deg to the tip."""
    x = np.linspace(0.0, length, nx + 1)
    s = np.linspace(-width / 2, width / 2, ny + 1)
    phi = np.radians(twist_deg) * x / length
    return np.array([[xi, si * np.cos(p), si * np.sin(p)] for xi, p in zip(x, phi) for si in s])


def twisted_beam(tmp_path, *, load: str, warping: str, t: float = 0.32, nx: int = 12, ny: int = 2,
                 tolerance: float = 1e-6, twist_deg: float = 90.0, sets=(), triangles: bool = False
                 ) -> tuple[float, float, dict]:
    """Runs the twisted beam through the CLI (fem, statics in one load step); returns the tip
    deflection along the load (mean of the tip nodes), its relative error against MacNeal &
    Harder, and the summary.  `triangles`: each quad cut into two along alternating diagonals
    (a checkerboard, as the generated meshes' ``mesh.triangles = "all"``)."""
    from .test_reliability import cli_run
    nodes = _twisted_beam_nodes(nx, ny, twist_deg=twist_deg)
    quads = [[i * (ny + 1) + j, (i + 1) * (ny + 1) + j, (i + 1) * (ny + 1) + j + 1, i * (ny + 1) + j + 1]
             for i in range(nx) for j in range(ny)]
    cells = [("quad", np.array(quads))]
    if triangles:
        cut = [tri for n, (a, b, c, d) in enumerate(quads)
               for tri in (([a, b, c], [a, c, d]) if (n // ny + n % ny) % 2 == 0 else ([a, b, d], [b, c, d]))]
        cells = [("triangle", np.array(cut))]
    meshio.write(tmp_path / "twisted_beam.vtu", meshio.Mesh(nodes, cells))
    p = 1.0 if t >= 0.1 else 1e-6
    # tip: width along z ("in-plane" load), normal along -y ("out-of-plane" load)
    direction, component = ([0.0, 0.0, 1.0], "uz") if load == "in_plane" else ([0.0, 1.0, 0.0], "uy")
    force = "[" + ", ".join(str(p * d) for d in direction) + "]"
    scene = write_scene(tmp_path, TWISTED_SCENE.format(t=t, warping=warping, force=force, tolerance=tolerance),
                        name="twisted_beam.toml")
    out = tmp_path / f"out_{load}_{warping}"
    r = cli_run("run", str(scene), "--out", str(out), "--quiet", *[a for item in sets for a in ("--set", item)],
                timeout=900)
    assert r.code == 0, r.err
    with open(out / "probes.csv") as fh:
        rows = list(csv.DictReader(fh))
    deflection = float(rows[-1][f"tip.{component}"])
    reference = TWISTED_REFERENCE[t][load]
    return deflection, (deflection - reference) / reference, json.loads((out / "summary.json").read_text())


# Measured (t = 0.32, 12x2, fem, tolerance 1e-6; docs/element.md): tip error in the load direction
# in-plane +3.34 % (none) / +3.35 % (bwc), out-of-plane +6.23 % / +6.19 %; asserted at ~1.5x.
TWISTED_TOLERANCE = {"in_plane": 0.050, "out_of_plane": 0.093}


@pytest.mark.parametrize("load", ["in_plane", "out_of_plane"])
def test_twisted_beam(tmp_path, load):
    """MacNeal-Harder twisted beam, 12x2, t = 0.32, with and without bwc, through the CLI.  The
    correction moves the tip by < 0.1 % of itself: the elements are warped (z_w = 0.018 on
    0.55 x 1) but the in-plane strains that B^c turns into curvature are small against the
    bending; the error left is the one-point element's in-plane bending across two elements
    (12x4: +0.45 % / -1.4 %; docs/element.md)."""
    errors = {}
    for warping in ("none", "bwc"):
        deflection, error, summary = twisted_beam(tmp_path, load=load, warping=warping)
        errors[warping] = error
        print(f"\ntwisted beam t = 0.32, {load} load, warping {warping}: tip {deflection:.5e} "
              f"(MacNeal-Harder {TWISTED_REFERENCE[0.32][load]:.4e}), error {100 * error:+.2f} %, "
              f"{summary['steps']} steps, run {summary['run_seconds']:.1f} s")
    for warping, error in errors.items():
        assert abs(error) <= TWISTED_TOLERANCE[load], (warping, error)


def main(argv=None):
    """The twisted-beam study of docs/element.md:
    python -m tests.test_warping [--t 0.0032] [--nx 12 --ny 2] [--twist 90] [--tolerance 1e-6] [--triangles]
        [--set KEY=VALUE ...]
    (errors against the twisted beam's reference whatever --twist is)"""
    import argparse
    import tempfile
    from pathlib import Path
    ap = argparse.ArgumentParser(description=main.__doc__)
    ap.add_argument("--t", type=float, default=0.32, choices=sorted(TWISTED_REFERENCE))
    ap.add_argument("--nx", type=int, default=12)
    ap.add_argument("--ny", type=int, default=2)
    ap.add_argument("--twist", type=float, default=90.0, help="root-to-tip twist, degrees")
    ap.add_argument("--tolerance", type=float, default=1e-6)
    ap.add_argument("--set", action="append", default=[], help="extra scene override, repeatable")
    ap.add_argument("--triangles", action="store_true", help="each quad cut into two triangles (checkerboard)")
    args = ap.parse_args(argv)
    for load in ("in_plane", "out_of_plane"):
        for warping in ("none", "bwc"):
            with tempfile.TemporaryDirectory() as tmp:
                deflection, error, summary = twisted_beam(Path(tmp), load=load, warping=warping, t=args.t, nx=args.nx,
                                                          ny=args.ny, tolerance=args.tolerance, twist_deg=args.twist,
                                                          sets=args.set, triangles=args.triangles)
            print(f"t = {args.t}, {args.nx}x{args.ny}, twist {args.twist:g} deg, {load}, warping {warping}: tip {deflection:.5e} "
                  f"(MacNeal-Harder {TWISTED_REFERENCE[args.t][load]:.4e}), error {100 * error:+.3f} %, "
                  f"{summary['steps']} steps, run {summary['run_seconds']:.1f} s", flush=True)


if __name__ == "__main__":
    main()
