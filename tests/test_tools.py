"""Rigid tools ([[tool]], issue 18 item 6; stages/tools.py, tools.py).

Every scene here has the same compiled features (fem, dynamic, a rigid body, every tool kind,
a tool moved by a curve), so the step compiles once for the whole file: the kinds a scene does
not test sit far away (DUMMIES).

Run with ``python -m pytest -q -s tests/test_tools.py`` to see the measured errors.
"""

import json
import time
from pathlib import Path

import meshio
import numpy as np
import pytest
import taichi as ti

from taichi_shell_mpm.mesh import build_mesh
from taichi_shell_mpm.model.assembly import assemble
from taichi_shell_mpm.scene import SceneError, load_scene, parse_scene
from taichi_shell_mpm.simulation import Simulation, prepare
from taichi_shell_mpm.runtime import init_taichi
from taichi_shell_mpm.solvers.dynamic import run_dynamic
from taichi_shell_mpm.tool_kinds.mesh import bucket_grid, read_surface

from .test_reliability import assert_clean_output, cli_run

T = 0.002                       # plate thickness
RHO, E, NU = 7850.0, 2e11, 0.3
G = 9.81


def plate_mesh(folder: Path, n: int = 10, size: float = 0.2, patch_at=(0.0, 0.0, 0.5)) -> Path:
    """A free n x n plate of `size` centred at the origin (z = 0), and one far-off quad, the
    rigid body's nodes (every scene has one: the same compiled features)."""
    s = np.linspace(-size / 2, size / 2, n + 1)
    x, y = np.meshgrid(s, s, indexing="ij")
    points = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    quads = np.stack([idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]], axis=-1).reshape(-1, 4)
    h = 0.01
    patch = np.array(patch_at) + np.array([[-h, -h, 0], [h, -h, 0], [h, h, 0], [-h, h, 0]])
    points = np.vstack([points, patch])
    quads = np.vstack([quads, len(points) - 4 + np.arange(4)[None]])
    path = folder / "plate.vtu"
    meshio.write(path, meshio.Mesh(points, [("quad", quads)]))
    return path


def cube_surface(folder: Path, half: float = 0.05, name: str = "cube.obj") -> Path:
    """The surface of the cube [-half, half]^3 as 12 triangles, normals outward."""
    v = half * np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], float)
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tris = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    path = folder / name
    meshio.write(path, meshio.Mesh(v, [("triangle", np.array(tris))]))
    return path


DUMMIES = {      # every kind, far from everything; the last one moved by a curve
    "plane": 'kind = "plane"\ncenter = [0, 0, 90]\nnormal = [0, 0, -1]',
    "rectangle": 'kind = "rectangle"\ncenter = [0, 0, 60]\nnormal = [0, 0, -1]\nsize = [1, 1]',
    "cylinder": 'kind = "cylinder"\ncenter = [0, 0, 70]\naxis = [1, 0, 0]\nradius = 1\nlength = 1',
    "sphere": 'kind = "sphere"\ncenter = [0, 0, 80]\nradius = 1',
    "mesh": 'kind = "mesh"\nfile = "cube.obj"\ncenter = [0, 0, 50]\nvelocity = [0, 0, 1]\ncurve = "ramp"',
}


def scene_text(tools: dict[str, str], *, end_time: float, extra: str = "", history: float = 0.0) -> str:
    """A plate scene with `tools` (name -> [[tool]] body) and a dummy of each kind not in it."""
    used = {next(line.split('"')[1] for line in body.splitlines() if line.startswith("kind")) for body in tools.values()}
    given = dict(tools)
    for kind, body in DUMMIES.items():
        if kind not in used or kind == "mesh":
            given[f"far_{kind}"] = body
    blocks = "\n".join(f'[[tool]]\nname = "{name}"\n{body}\n' for name, body in given.items())
    return f"""
[scene]
name = "tools"
units = "SI"
[mesh]
kind = "file"
path = "plate.vtu"
[material]
E = {E}
nu = {NU}
density = {RHO}
[section]
thickness = {T}
[method]
kind = "fem"
[solve]
kind = "dynamic"
end_time = {end_time}
[output]
history_interval = {history or end_time / 20}
[nodesets.ram]
box = {{min = [-1, -1, 0.4], max = [1, 1, 1]}}
[nodesets.plate]
box = {{min = [-1, -1, -0.1], max = [1, 1, 0.1]}}
[[rigid_body]]
name = "ram"
nodes = "ram"
[curves.ramp]
shape = "ramp"
end = 1.0
{extra}
{blocks}
"""


def write(folder: Path, text: str, name: str = "scene.toml") -> Path:
    plate_mesh(folder)
    cube_surface(folder)
    path = folder / name
    path.write_text(text)
    return path


def run_cli(folder: Path, text: str, name: str, *args: str) -> tuple[Path, dict, dict[str, np.ndarray]]:
    """The scene through the CLI: output folder, summary, force.csv columns."""
    scene = write(folder, text, f"{name}.toml")
    out = folder / f"out_{name}"
    r = cli_run("run", str(scene), "--out", str(out), "--quiet", *args, timeout=900)
    assert r.code == 0, r.out + r.err
    assert_clean_output(r)
    table = np.genfromtxt(out / "force.csv", delimiter=",", names=True)
    return out, json.loads((out / "summary.json").read_text()), table


# ------------------------------------------------------------------ geometry
@ti.kernel
def _probe(tools: ti.template(), k: ti.i32, x: ti.types.ndarray(), out: ti.types.ndarray()):
    for i in range(x.shape[0]):
        p = ti.Vector([x[i, 0], x[i, 1], x[i, 2]])
        frame = tools.g.axes[k]
        d, n, hit = tools.distance(k, frame @ (p - tools.g.centre[k]))
        n = frame.transpose() @ n
        out[i, 0] = d
        for a in ti.static(range(3)):
            out[i, 1 + a] = n[a]
        out[i, 4] = 1.0 if hit else 0.0


def _closed_forms(q: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(signed distance, outward normal, in reach) of each geometry test tool at points q."""
    out = {}
    # sphere centre c0, R = 0.05
    c0 = np.array([0.3, 0.0, 0.0])
    r = q - c0
    rn = np.linalg.norm(r, axis=1)
    out["ball"] = (rn - 0.05, r / rn[:, None], np.ones(len(q), bool))
    # cylinder along (1,1,0)/sqrt2 through c1, R = 0.04, length 0.2 (capped)
    c1, a = np.array([-0.3, 0.0, 0.0]), np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    r = q - c1
    along = r @ a
    radial = r - along[:, None] * a
    rho = np.linalg.norm(radial, axis=1)
    u = radial / rho[:, None]
    w0, w1 = rho - 0.04, np.abs(along) - 0.1
    cap = np.sign(along)[:, None] * a
    e0, e1 = np.maximum(w0, 0), np.maximum(w1, 0)
    outside = (w0 > 0) | (w1 > 0)
    d = np.where(outside, np.hypot(e0, e1), np.maximum(w0, w1))
    with np.errstate(invalid="ignore", divide="ignore"):
        n_out = (e0[:, None] * u + e1[:, None] * cap) / d[:, None]
    n = np.where(outside[:, None], n_out, np.where((w0 > w1)[:, None], u, cap))
    out["roller"] = (d, n, np.ones(len(q), bool))
    # rectangle at c2, normal (0,0,1) turned 30 deg about x, first side along x: 0.2 x 0.1
    c2 = np.array([0.0, 0.3, 0.0])
    th = np.radians(30)
    e3 = np.array([0.0, -np.sin(th), np.cos(th)])
    e1 = np.array([1.0, 0.0, 0.0])
    e2 = np.cross(e3, e1)
    r = q - c2
    l1, l2, l3 = r @ e1, r @ e2, r @ e3
    over = (np.abs(l1) <= 0.1) & (np.abs(l2) <= 0.05)
    rim = np.stack([l1 - np.clip(l1, -0.1, 0.1), l2 - np.clip(l2, -0.05, 0.05), l3], axis=1)
    rim_d = np.linalg.norm(rim, axis=1)
    d = np.where(over, l3, rim_d)
    n_local = np.where(over[:, None], [0.0, 0.0, 1.0], rim / rim_d[:, None])
    n = n_local @ np.stack([e1, e2, e3])
    out["board"] = (d, n, (over & (l3 > -T)) | (~over & (l3 >= 0)))   # over it: within reach (one thickness) behind
    # plane through c3 with normal (1, 2, 2)/3
    c3, nn = np.array([0.0, -0.3, 0.0]), np.array([1.0, 2.0, 2.0]) / 3.0
    out["floor"] = ((q - c3) @ nn, np.tile(nn, (len(q), 1)), np.ones(len(q), bool))
    # cube mesh [-0.05, 0.05]^3 at c4: outside, the box's distance (every nearest point on a face)
    c4 = np.array([0.0, 0.0, 0.3])
    r = q - c4
    excess = np.abs(r) - 0.05
    outside = np.maximum(excess, 0)
    d_out = np.linalg.norm(outside, axis=1)
    inside = excess.max(axis=1)
    d = np.where(d_out > 0, d_out, inside)
    with np.errstate(invalid="ignore", divide="ignore"):
        n_out = np.sign(r) * outside / d_out[:, None]
    axis = np.argmax(excess, axis=1)
    n_in = np.zeros_like(r)
    n_in[np.arange(len(r)), axis] = np.sign(r[np.arange(len(r)), axis])
    n = np.where((d_out > 0)[:, None], n_out, n_in)
    out["box"] = (d, n, d > -T)       # nodes deeper than the reach (one thickness) are not found
    return out


GEOMETRY_TOOLS = {
    "ball": 'kind = "sphere"\ncenter = [0.3, 0, 0]\nradius = 0.05',
    "roller": 'kind = "cylinder"\ncenter = [-0.3, 0, 0]\naxis = [1, 1, 0]\nradius = 0.04\nlength = 0.2',
    "board": ('kind = "rectangle"\ncenter = [0, 0.3, 0]\nnormal = [0, -0.5, 0.8660254037844386]\naxis = [1, 0, 0]\n'
              'size = [0.2, 0.1]'),
    "floor": 'kind = "plane"\ncenter = [0, -0.3, 0]\nnormal = [1, 2, 2]',
    "box": 'kind = "mesh"\nfile = "cube.obj"\ncenter = [0, 0, 0.3]',
}


def tools_only(tmp_path, text: str):
    """(model, state, tools stage) of the scene `text` without compiling its step: the
    geometry tests compile only their probe kernel (_probe)."""
    init_taichi("cpu")
    scene = load_scene(write(tmp_path, text))
    model = assemble(scene, build_mesh(scene.mesh))
    _, state, stepper = prepare(scene, model, "batched")
    return model, state, stepper.bodies.tools


def test_signed_distance_and_normal_of_each_kind(tmp_path):
    """Each kind's signed distance and outward normal at random points near its surface
    against the closed form (the mesh: a cube, whose nearest facet gives the box's distance).
    Only the tools' functions are compiled (a probe kernel), not the step with all five kinds."""
    model, _, tools = tools_only(tmp_path, scene_text(GEOMETRY_TOOLS, end_time=1e-4))
    rng = np.random.default_rng(7)
    names = list(model.tools.names)
    centres = {"ball": (0.3, 0, 0), "roller": (-0.3, 0, 0), "board": (0, 0.3, 0), "floor": (0, -0.3, 0),
               "box": (0, 0, 0.3)}
    for name in GEOMETRY_TOOLS:
        spread = 0.053 if name == "box" else 0.13        # the box's buckets reach one thickness out
        q = np.array(centres[name]) + rng.uniform(-spread, spread, (4000, 3))
        forms = _closed_forms(q)
        out = np.zeros((len(q), 5))
        _probe(tools, names.index(name), q, out)
        d, n, reach = forms[name]
        hit = out[:, 4] > 0.5
        near = np.abs(d) < (0.99 * T if name == "box" else 0.02)   # where contact can happen
        assert np.array_equal(hit[near], reach[near]), name
        use = near & reach
        d_err = float(np.max(np.abs(out[use, 0] - d[use])))
        n_err = float(np.max(np.linalg.norm(out[use, 1:4] - n[use], axis=1)))
        print(f"\n{name}: {use.sum()} points within 0.02 of the surface: |d error| {d_err:.2e} m, |n error| {n_err:.2e}")
        assert d_err < 1e-12 and n_err < 1e-9, name


def test_mesh_bucket_grid_finds_what_brute_force_finds(tmp_path):
    """The bucket grid lists every facet within reach of a point's bucket (so it finds what
    the brute force finds: the same distances); printed, not asserted (speed belongs to
    benchmarks, not to tests): the time of both for the signed distance of 10 000 points near
    a 5120-facet sphere (x137-150 measured with 100 000 points)."""
    meshio.write(tmp_path / "ball.stl", meshio.Mesh(*_icosphere(4)))
    vertices, tri = read_surface(tmp_path / "ball.stl")
    x = vertices[tri]
    reach = T
    lo, h, dims, start, items = bucket_grid(x, reach)
    rng = np.random.default_rng(3)
    q = rng.normal(size=(10_000, 3))
    q = q / np.linalg.norm(q, axis=1)[:, None] * (1.0 + rng.uniform(-0.9 * reach, 0.9 * reach, (len(q), 1)))
    cell = np.floor((q - lo) / h).astype(int)
    flat = cell[:, 0] + dims[0] * (cell[:, 1] + dims[1] * cell[:, 2])
    for i in range(300):
        listed = set(items[start[flat[i]]:start[flat[i] + 1]].tolist())
        # a facet whose every vertex is within reach of the point is certainly within reach
        close = np.flatnonzero(np.max(np.linalg.norm(x - q[i], axis=2), axis=1) <= reach)
        assert set(close.tolist()) <= listed
    per_bucket = np.diff(start)
    text = scene_text({"ball": 'kind = "mesh"\nfile = "ball.stl"\ncenter = [0, 0, 3]'}, end_time=1e-4)
    model, state, tools = tools_only(tmp_path, text)
    k = list(model.tools.names).index("ball")
    points = q + np.array([0.0, 0.0, 3.0])
    timing, results = {}, {}
    for mode in ("buckets", "brute force"):
        if mode == "brute force":        # one bucket holding every facet
            g = state.tools
            first = int(model.tools.tri_first[k])
            g.grid_lo[k], g.grid_h[k], g.grid_dims[k] = (-10.0, -10.0, -10.0), 100.0, (1, 1, 1)
            g.bucket_first[k] = 0
            state.write(g.bucket_start, np.array([0, len(tri)], np.int32))
            state.write(g.bucket_items, np.arange(first, first + len(tri), dtype=np.int32))
        out = np.zeros((len(points), 5))
        _probe(tools, k, points[:10], out[:10])        # compiled
        t0 = time.perf_counter()
        _probe(tools, k, points, out)
        timing[mode] = time.perf_counter() - t0
        results[mode] = out
    same = float(np.max(np.abs(results["buckets"][:, 0] - results["brute force"][:, 0])))
    print(f"\n{len(tri)} facets, {int(np.prod(dims))} buckets of {h:.3g}, mean {per_bucket.mean():.2f} facets per "
          f"bucket (max {per_bucket.max()}); {len(points)} points: buckets {1e3 * timing['buckets']:.1f} ms, brute force "
          f"{1e3 * timing['brute force']:.1f} ms (x{timing['brute force'] / timing['buckets']:.0f}); "
          f"largest difference of d {same:.1e}")
    assert np.all(results["buckets"][:, 4] > 0.5) and same == 0.0
    assert per_bucket.max() < len(tri) / 20


def _icosphere(levels: int) -> tuple[np.ndarray, list]:
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
         (8, 6, 7), (9, 8, 1)]
    v = [np.array(p, float) / np.linalg.norm(p) for p in v]
    for _ in range(levels):
        cache, g = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                p = v[a] + v[b]
                v.append(p / np.linalg.norm(p))
                cache[key] = len(v) - 1
            return cache[key]
        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            g += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = g
    return np.array(v), [("triangle", np.array(f))]


# ------------------------------------------------------------------ physics through the CLI
def test_sheet_on_tilted_rectangle_slides_at_the_coulomb_limit(tmp_path):
    """A sheet on a fixed rectangle tilted by 30 deg, mu = 0.2, under gravity: the tool's force
    on it is m g (cos th along the normal, mu cos th up the slope once it slides: the Coulomb
    limit), the sheet accelerates at g (sin th - mu cos th), and the fixed tool's force is the
    support reaction (force.csv support_*)."""
    th, mu = np.radians(30.0), 0.2
    normal = [0.0, float(-np.sin(th)), float(np.cos(th))]
    centre = [float(x) for x in -0.5 * T * np.array(normal)]
    tools = {"slope": f'kind = "rectangle"\ncenter = {centre}\nnormal = {normal}\naxis = [1, 0, 0]\n'
                      f'size = [1.0, 1.0]\nfriction = {mu}\ndamping = 0.5'}
    # the sheet lies on the slope: the plate's nodes turned by th about x
    extra = '[gravity]\nacceleration = [0, 0, -9.81]\n[[probe]]\nname = "sheet"\nnodes = "plate"\ncomponents = ["uy", "uz"]'
    text = scene_text(tools, end_time=0.02, extra=extra, history=0.001)
    folder = tmp_path
    plate_mesh(folder)
    m = meshio.read(folder / "plate.vtu")
    pts = m.points.copy()
    on_plate = np.abs(pts[:, 2]) < 0.1
    rot = np.array([[1, 0, 0], [0, np.cos(th), -np.sin(th)], [0, np.sin(th), np.cos(th)]])
    pts[on_plate] = pts[on_plate] @ rot.T
    cube_surface(folder)
    scene = folder / "slope.toml"
    scene.write_text(text)
    meshio.write(folder / "plate.vtu", meshio.Mesh(pts, m.cells))
    out = folder / "out_slope"
    r = cli_run("run", str(scene), "--out", str(out), "--quiet", timeout=900)
    assert r.code == 0, r.out + r.err
    assert_clean_output(r)
    f = np.genfromtxt(out / "force.csv", delimiter=",", names=True)
    p = np.genfromtxt(out / "probes.csv", delimiter=",", names=True)
    mass = RHO * T * 0.2 * 0.2
    weight = mass * G
    n_vec, down_slope = np.array(normal), np.array([0.0, -np.cos(th), -np.sin(th)])
    late = f["time"] >= 0.01
    force = np.stack([f["slopeforce_x"], f["slopeforce_y"], f["slopeforce_z"]], axis=1)[late]
    normal_force = force @ n_vec
    friction = -(force @ down_slope)
    # the friction law is Coulomb's regularised by the slip speed (v_eps = 1e-6 c, stages/contact.py):
    # mu N v / sqrt(v^2 + v_eps^2) with v = a t, which is within 1.5 % of mu N from t = 10 ms on
    a_exact = G * (np.sin(th) - mu * np.cos(th))
    v_eps = 1e-6 * np.sqrt(E / (RHO * (1 - NU ** 2)))
    v = a_exact * f["time"][late]
    regularised = mu * weight * np.cos(th) * v / np.sqrt(v * v + v_eps * v_eps)
    normal_err = float(np.max(np.abs(normal_force / (weight * np.cos(th)) - 1)))
    coulomb_err = float(np.max(np.abs(friction / (mu * weight * np.cos(th)) - 1)))
    friction_err = float(np.max(np.abs(friction / regularised - 1)))
    support = np.stack([f["support_x"], f["support_y"], f["support_z"]], axis=1)[late]
    # slide along the slope from the probes: s(t) = a t^2 / 2
    s = np.stack([p["sheetuy"], p["sheetuz"]], axis=1) @ down_slope[1:]
    t = p["time"]
    a_fit = np.polyfit(t[t >= 0.005], s[t >= 0.005], 2)[0] * 2
    print(f"\nnormal force / (m g cos th) - 1: {normal_err:.2e}; friction / (mu m g cos th) - 1: {coulomb_err:.2e} "
          f"(against the regularised law: {friction_err:.2e}); acceleration {a_fit:.5f} vs g (sin th - mu cos th) "
          f"= {a_exact:.5f} ({a_fit / a_exact - 1:+.2e}: the regularisation's lower friction while slow)")
    assert np.allclose(support, force, rtol=0, atol=1e-12 * weight)
    assert normal_err < 1e-6 and friction_err < 2.5e-3 and coulomb_err < 0.015
    assert abs(a_fit / a_exact - 1) < 0.008


def test_plate_resting_on_cylinder_and_mesh_reaction_is_its_weight(tmp_path):
    """A plate laid under gravity on a fixed capped cylinder and a fixed cube mesh (through the
    CLI): the tools carry its weight (their forces are the support reaction), on average to
    0.14 % over the last 20 ms (the contact damps its rigid motion, not its bending vibration,
    which swings the instantaneous force by ~10 %), and the energy balance closes (printed)."""
    tools = {"roller": 'kind = "cylinder"\ncenter = [-0.06, 0, -0.021]\naxis = [0, 1, 0]\nradius = 0.02\n'
                       'length = 0.3\ndamping = 1.0',
             "block": 'kind = "mesh"\nfile = "cube.obj"\ncenter = [0.1, 0, -0.051]\ndamping = 1.0'}
    extra = '[gravity]\nacceleration = [0, 0, -9.81]'
    _, summary, f = run_cli(tmp_path, scene_text(tools, end_time=0.06, extra=extra, history=0.002), "rest")
    weight = RHO * T * 0.2 * 0.2 * G
    late = f["time"] >= 0.04
    carried = f["rollerforce_z"][late] + f["blockforce_z"][late]
    # the mean over the last 20 ms: the support impulse's slope
    t, impulse = f["time"][late], f["support_impulse_z"][late]
    mean = (impulse[-1] - impulse[0]) / (t[-1] - t[0])
    e = summary["energies"]
    err = float(np.max(np.abs(carried / weight - 1)))
    print(f"\nweight {weight:.5f} N; the tools carry it to {err:.2e} from 40 ms on (mean {mean / weight - 1:+.2e}); "
          f"roller {f['rollerforce_z'][-1]:.4f} N, block {f['blockforce_z'][-1]:.4f} N; "
          f"balance error {e['balance_error']:.2e} J of external work {e['external_work']:.2e} J")
    assert np.allclose(f["support_z"][late], carried, rtol=1e-9, atol=0)     # force.csv has 10 digits
    assert f["rollerforce_z"][-1] > 0.2 * weight and f["blockforce_z"][-1] > 0.2 * weight
    assert err < 0.15 and abs(mean / weight - 1) < 2e-3
    assert abs(e["balance_error"]) < 0.01 * e["external_work"]
    tools_out = {t["name"]: t for t in summary["tools"]}
    assert tools_out["roller"]["motion"] == "fixed" and tools_out["roller"]["nodes_in_contact"] > 0


def test_tool_driven_by_a_velocity_curve_works_on_the_plate(tmp_path):
    """A plane moved up by a velocity ramp (0 to 1 m/s in 1 ms) lifts a free plate: the work of
    its motion (force.csv <name>.work, energy.csv motion_work) is the plate's kinetic, internal
    and contact energy, and the plate ends at the plane's speed (printed: both errors)."""
    tools = {"lift": 'kind = "plane"\ncenter = [0, 0, -0.0011]\nnormal = [0, 0, 1]\nvelocity = [0, 0, 1]\n'
                     'curve = "ramp"\ndamping = 0.5'}
    text = scene_text(tools, end_time=0.003, history=1e-4).replace("end = 1.0", "end = 0.001")
    out, summary, _ = run_cli(tmp_path, text, "lift")
    e = summary["energies"]
    lift = next(t for t in summary["tools"] if t["name"] == "lift")
    probes = np.genfromtxt(out / "energy.csv", delimiter=",", names=True)
    mass = RHO * T * 0.2 * 0.2
    speed = np.sqrt(2 * (e["kinetic"] - 0.0) / mass)
    print(f"\nwork of the lift {lift['work']:.5e} J = motion_work {e['motion_work']:.5e} J; KE {e['kinetic']:.5e} J "
          f"(plate speed {speed:.5f} m/s), contact {e['contact']:.3e} J, balance error {e['balance_error']:.2e} J "
          f"({e['balance_error'] / lift['work']:.1e} of the work)")
    assert lift["motion"] == "velocity" and lift["work"] == pytest.approx(e["motion_work"], rel=1e-12)
    assert abs(e["balance_error"]) < 1e-6 * lift["work"]
    assert abs(speed - 1.0) < 0.02
    assert probes["motion_work"][-1] == pytest.approx(e["motion_work"], rel=1e-9)


def test_plate_struck_by_sphere_momentum_and_energy(tmp_path):
    """A sphere tool (R = 0.1 m) on a rigid body (1 kg added, 10 m/s) hits a free plate: the total
    momentum of body + plate along the strike is kept, and the energy balance closes (printed: both errors)."""
    tools = {"striker": 'kind = "sphere"\ncenter = [0, 0, 0.106]\nradius = 0.1\nmoves_with = "ram"\ndamping = 0.1'}
    extra = '[[initial]]\nnodes = "ram"\nvelocity = [0, 0, -10]'
    text = scene_text(tools, end_time=0.003, extra=extra, history=1e-4).replace(
        'nodes = "ram"\n[curves', 'nodes = "ram"\nmass = 1.0\n[curves')
    init_taichi("cpu")
    scene = load_scene(write(tmp_path, text))
    sim = Simulation(scene, tmp_path / "out", quiet=True)
    sim.hourglass_limit = 0.0      # a ball on a 10 x 10 plate excites hourglass modes; they are in the balance
    body = sim.model.rigid_bodies[0]
    p0 = body.total_mass * np.asarray(body.velocity0)
    run_dynamic(sim)
    free = sim.model.node_body < 0
    v = sim.state.fetch("nodes.grid_velocity")
    plate_p = (sim.model.node_mass[free, None] * v[free]).sum(axis=0)
    body_p = body.total_mass * sim.state.bodies.velocity[0].to_numpy()
    d = p0 / np.linalg.norm(p0)         # a free 6-DOF body: the sphere turns with it (stages/tools.py)
    p_err = float(abs((plate_p + body_p - p0) @ d) / np.linalg.norm(p0))
    e = sim.energies()
    ke0 = sim.initial_kinetic
    rows = np.array(sim.history.force_rows)
    peak = float(np.abs(rows[:, sim.force_header().index("striker.force_z")]).max())
    plate_ke = 0.5 * float((sim.model.node_mass[free] * (v[free] ** 2).sum(axis=1)).sum())
    print(f"\nplate momentum {plate_p[2]:.6f}, body {body_p[2]:.6f}, initial {p0[2]:.6f}: error {p_err:.2e} of |p0| (lateral {np.linalg.norm(plate_p[:2]):.1e}); "
          f"KE0 {ke0:.4f} J, plate KE {plate_ke:.4f} J, internal {e['internal']:.4f} J, contact {e['contact']:.3e} J, "
          f"balance error {e['balance_error']:.3e} J ({e['balance_error'] / ke0:.2e} of KE0); peak force {peak:.1f} N")
    # the same scene through the CLI: the striker's columns and summary entry
    _, summary, f = run_cli(tmp_path, text, "strike", "--hourglass-limit", "0")
    striker = next(t for t in summary["tools"] if t["name"] == "striker")
    assert striker["motion"] == "body" and striker["work"] > 0.0
    assert summary["energies"]["balance_error"] == pytest.approx(e["balance_error"], rel=1e-6, abs=1e-12 * ke0)
    assert float(np.abs(f["strikerforce_z"]).max()) == pytest.approx(peak, rel=1e-9)
    # struck: a fully inelastic impact would give the plate m_p / (M + m_p) = 0.38 of p0; a
    # local strike on the flexible plate delivers part of it in 3 ms (measured 0.25: the
    # momentum sum and the balance are the checks; the earlier bound, 0.30, was never met)
    plate_mass = float(sim.model.node_mass[free].sum())
    inelastic = plate_mass / (body.total_mass + plate_mass)
    print(f"plate share of p0 {plate_p[2] / p0[2]:.3f} (fully inelastic {inelastic:.3f})")
    assert plate_p[2] / p0[2] > 0.5 * inelastic, "the plate was not struck"
    assert p_err < 1e-10
    assert abs(e["balance_error"]) < 1e-3 * ke0


def test_spinning_body_books_its_tool_work_with_the_time_centred_spin(tmp_path):
    """A body falling at 10 m/s and spinning at 40 rad/s about y strikes the plate with the
    sphere it carries 0.39 m below its centre (a sliding strike, friction 0.3): the tool's work
    on the body's rotation, dt omega . ((c - x_b) x F + M), is booked with the kick's time-centred
    omega and x_b^n, as RigidBodies.update changes the body's kinetic energy with them (issue 28
    item 8).  Measured: balance 6.6e-6 of KE0 (66 J, contact 14 J); with the drift's omega and
    x_b rebuilt after the step, 5.3e-4."""
    tools = {"striker": 'kind = "sphere"\ncenter = [0, 0, 0.106]\nradius = 0.1\nmoves_with = "ram"\n'
                        'damping = 0.1\nfriction = 0.3'}
    extra = '[[initial]]\nnodes = "ram"\nvelocity = [0, 0, -10]'
    text = scene_text(tools, end_time=0.003, extra=extra, history=1e-4).replace(
        'nodes = "ram"\n[curves', 'nodes = "ram"\nmass = 1.0\ninertia = [0.02, 0.02, 0.02]\nspin = [0, 40, 0]\n[curves')
    _, summary, _ = run_cli(tmp_path, text, "spin", "--hourglass-limit", "0")
    e = summary["energies"]
    ke0 = 0.5 * 1.0 * 10.0 ** 2 + 0.5 * 0.02 * 40.0 ** 2      # the ram's (its nodes' mass is ~1e-5 kg)
    print(f"\nKE0 {ke0:.4f} J, contact {e['contact']:.4e} J, balance error {e['balance_error']:.3e} J "
          f"({e['balance_error'] / ke0:.2e} of KE0)")
    assert e["contact"] > 0.1 * ke0, "the sphere did not strike"
    assert abs(e["balance_error"]) < 1e-5 * ke0


# ------------------------------------------------------------------ step, penalty and friction limits (issue 28)
def tool_simulation(tmp_path, tools: dict[str, str], *, end_time: float, extra: str = "", own_mesh: bool = False,
                    edit=lambda text: text):
    """An in-process Simulation of the plate scene with `tools` (its text through `edit`);
    `own_mesh`: the scene's mesh tool replaces the far one (one cube of the same size: the
    same compiled step)."""
    text = edit(scene_text(tools, end_time=end_time, extra=extra, history=end_time))
    if own_mesh:
        text = text.replace(f'[[tool]]\nname = "far_mesh"\n{DUMMIES["mesh"]}\n', "")
    init_taichi("cpu")
    tmp_path.mkdir(parents=True, exist_ok=True)
    scene = load_scene(write(tmp_path, text))
    return Simulation(scene, tmp_path / "out", quiet=True)


def plate_velocity(sim) -> np.ndarray:
    free = sim.model.node_body < 0
    return sim.state.fetch("nodes.grid_velocity")[free]


def drop_on_plane(tmp_path, velocity, *, stiffness: float, damping: float, friction: float = 0.0,
                  phase: float = 0.0):
    """The free plate thrown at `velocity` onto a plane under it, touching it (gap 0) `phase`
    of a step after t = 0: every node has the same mass-proportional spring and damper, so
    the plate moves as one body, the 1-DOF model of the penalty law (scene.penalty_damping_limit).
    Returns the Simulation after the run."""
    tools = {"floor": f'kind = "plane"\ncenter = [0, 0, {-T / 2}]\nnormal = [0, 0, 1]\nstiffness = {stiffness}\n'
                      f'damping = {damping}\nfriction = {friction}'}
    extra = f'[[initial]]\nnodes = "plate"\nvelocity = {list(velocity)}'
    sim = tool_simulation(tmp_path, tools, end_time=1e-4, extra=extra)
    k = list(sim.model.tools.names).index("floor")
    z = -T / 2 - phase * abs(velocity[2]) * sim.state.step.dt[None]
    for field in (sim.state.tools.origin, sim.state.tools.centre):
        field[k] = (0.0, 0.0, z)
    run_dynamic(sim)
    return sim


def test_penalty_law_at_the_extreme_settings_bounces_no_faster_than_it_came(tmp_path):
    """A plate dropped at 1 m/s on a plane at stiffness = 1 and the largest damping accepted
    there (0.5; scene.penalty_damping_limit): it rebounds no faster than it came, at the worst
    arrival (touching at a step's start: the spring and damper's impulse (1 + 2 zeta) m v in
    one step, exactly 2 m v) and half a step later, and the contact energy stays >= 0.  damping
    = 1 at that stiffness (2 v back, measured in the 1-DOF model, docs/contact.md) is refused."""
    for phase in (0.0, 0.5):
        sim = drop_on_plane(tmp_path / f"p{phase}", (0.0, 0.0, -1.0), stiffness=1.0, damping=0.5, phase=phase)
        v = plate_velocity(sim)
        e = sim.energies()
        print(f"\narrival {phase} of a step: rebound {v[:, 2].max():.12f} m/s (spread {np.ptp(v[:, 2]):.1e}) "
              f"after 1 m/s; contact energy {e['contact']:.3e} J, balance error {e['balance_error']:.1e} J")
        assert v[:, 2].min() > 0.0 and v[:, 2].max() <= 1.0 + 1e-9
        assert e["contact"] >= -1e-9 * sim.initial_kinetic
    text = scene_text({"floor": 'kind = "plane"\nnormal = [0, 0, 1]\nstiffness = 1\ndamping = 1'}, end_time=1e-3)
    with pytest.raises(SceneError) as caught:
        load_scene(write(tmp_path, text))
    assert any("[[tool]][0].damping: 1 with stiffness = 1" in m and "at most 0.5" in m
               for m in caught.value.messages), caught.value.messages


def test_sticking_friction_stops_the_slip_without_creating_energy(tmp_path):
    """The plate thrown at 45 deg (1 m/s down and along x) onto a plane with friction = 10 at
    stiffness = 1: friction stops the slip (the force capped at m |v_t| / dt, what stops it in
    one step, stages/contact.coulomb_friction) instead of reversing it step after step (21 %
    of the work created in 7 steps, then the energy guard, before the cap); the run ends with
    the slip stopped, the contact energy >= 0 and the balance error < 1 % of the initial
    kinetic energy (printed)."""
    sim = drop_on_plane(tmp_path, (1.0, 0.0, -1.0), stiffness=1.0, damping=0.1, friction=10.0)
    v = plate_velocity(sim)
    e = sim.energies()
    ke0 = sim.initial_kinetic
    print(f"\nslip after the bounce {np.abs(v[:, 0]).max():.2e} m/s, rebound {v[:, 2].max():.4f} m/s; contact "
          f"energy {e['contact']:.4e} J of KE0 {ke0:.4e} J; balance error {e['balance_error']:.2e} J "
          f"({e['balance_error'] / ke0:.1e} of KE0)")
    assert np.abs(v[:, 0]).max() < 1e-6 and v[:, 2].min() > 0.0
    assert e["contact"] > 0.0 and abs(e["balance_error"]) < 0.01 * ke0


def test_mesh_punch_faster_than_its_reach_per_step_does_not_pass_through(tmp_path):
    """The cube mesh (reach: one thickness behind its faces) on a light rigid body (0.05 kg)
    thrown at the plate at 3 thicknesses per element step: the tools' step limit
    (stages/tools.py, Step limit; the first step's from tools.first_step_limit) keeps each
    step's approach within 0.2 thickness, so the plate's nodes under the punch stay in front of
    its face (without it the punch jumped past them, 11.5 thicknesses in 6 steps).  Printed:
    the deepest node under the punch and the steps taken."""
    from taichi_shell_mpm.model.assembly import element_steps
    init_taichi("cpu")
    start = 0.05 + T                                   # the punch's face one half-thickness clear
    bare = load_scene(write(tmp_path, scene_text({}, end_time=1.0)))
    model = assemble(bare, build_mesh(bare.mesh))
    dt = float(np.min(element_steps(model.points, model.elements, model.element, model.parameters.dt_safety)))
    speed, end = 3 * T / dt, 4 * dt
    tools = {"punch": f'kind = "mesh"\nfile = "cube.obj"\ncenter = [0, 0, {start}]\nmoves_with = "ram"'}
    extra = f'[[initial]]\nnodes = "ram"\nvelocity = [0, 0, {-speed}]'
    sim = tool_simulation(tmp_path, tools, end_time=end, extra=extra, own_mesh=True,
                          edit=lambda text: text.replace('nodes = "ram"\n[curves', 'nodes = "ram"\nmass = 0.05\n[curves'))
    sim.hourglass_limit = 0.0
    run_dynamic(sim)
    x = sim.state.fetch("nodes.position")
    x0 = sim.model.points
    under = (sim.model.node_body < 0) & (np.abs(x0[:, 0]) < 0.045) & (np.abs(x0[:, 1]) < 0.045)
    face = float(x[sim.model.node_body == 0, 2].mean()) - 0.5 + start - 0.05      # the body carries the punch
    depth = float((x[under, 2] - (face - T / 2)).max())
    print(f"\npunch at {speed:.0f} m/s ({speed * dt / T:.1f} thicknesses per element step of {dt:.2e} s): "
          f"{sim.total_steps} steps; deepest node under it {depth / T:.3f} thickness past touching")
    assert under.sum() >= 9 and depth < 0.7 * T


def icosahedron_surface(folder: Path, radius: float = 0.06, name: str = "ico.obj") -> Path:
    """A regular icosahedron (20 triangles, normals outward) of circumradius `radius`."""
    p = (1.0 + 5.0 ** 0.5) / 2.0
    v = np.array([[-1, p, 0], [1, p, 0], [-1, -p, 0], [1, -p, 0], [0, -1, p], [0, 1, p], [0, -1, -p], [0, 1, -p],
                  [p, 0, -1], [p, 0, 1], [-p, 0, -1], [-p, 0, 1]], float)
    v *= radius / np.linalg.norm(v[0])
    tris = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                     [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
                     [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    path = folder / name
    meshio.write(path, meshio.Mesh(v, [("triangle", tris)]))
    return path


def test_a_new_tool_mesh_compiles_nothing_new(tmp_path):
    """Tool geometry is run-time data (issue 28 item 13; shared/design/compile_once.md): a
    scene whose mesh tool reads another surface (the cube's 12 triangles, then an
    icosahedron's 20, other buckets, another size) runs on the kernels the first one cached --
    no file is added to the offline kernel cache.  The triangle and bucket fields are sized in
    power-of-4 classes (state.capacity, at least 16 384 entries), so this holds for any surface
    up to 16 384 triangles; a larger one compiles once per class."""
    from taichi_shell_mpm.runtime import kernel_cache_dir

    def run(surface: str, name: str) -> set[str]:
        tools = {"punch": f'kind = "mesh"\nfile = "{surface}"\ncenter = [0, 0, 0.06]\nvelocity = [0, 0, -1]'}
        text = scene_text(tools, end_time=2e-5).replace(f'[[tool]]\nname = "far_mesh"\n{DUMMIES["mesh"]}\n', "")
        text = text.replace('[[tool]]\nname = "punch"', '[[tool]]\nname = "punch"\ncurve = "ramp"')
        run_cli(tmp_path / name, text, name)
        init_taichi("cpu", quiet=True)            # Taichi writes the offline cache when it is reset
        return {f.name for f in Path(kernel_cache_dir()).glob("*.tic")}

    for name in ("cube", "ico"):
        (tmp_path / name).mkdir(parents=True)
    icosahedron_surface(tmp_path / "ico")
    before = run("cube.obj", "cube")
    after = run("ico.obj", "ico")
    print(f"\n{len(before)} cached kernels after the cube's run; {len(after - before)} added by the icosahedron's")
    assert before and after == before


# ------------------------------------------------------------------ input errors
@pytest.mark.parametrize("body, message", [
    ('kind = "torus"', "kind: expected one of"),
    ('kind = "sphere"', "radius: missing required key"),
    ('kind = "sphere"\nradius = 1\nnormal = [0, 0, 1]', 'normal: not used by kind = "sphere"'),
    ('kind = "rectangle"\nnormal = [0, 0, 1]\nsize = [1, 0]', "size: expected two positive numbers"),
    ('kind = "rectangle"\nnormal = [0, 0, 1]\nsize = [1, 1]\naxis = [0, 0, 2]', "axis: is parallel to normal"),
    ('kind = "sphere"\nradius = 1\nmoves_with = "nobody"', "moves_with: no [[rigid_body]] named 'nobody'"),
    ('kind = "sphere"\nradius = 1\nvelocity = [1, 0, 0]\nmoves_with = "ram"', "a tool moves one way"),
    ('kind = "sphere"\nradius = 1\ndisplacement = [1, 0, 0]', "displacement needs a curve"),
    ('kind = "sphere"\nradius = 1\ncurve = "ramp"', "curve: only with velocity or displacement"),
    ('kind = "sphere"\nradius = 1\nstiffness = 2', "stiffness: expected"),
    ('kind = "sphere"\nradius = 1\nstiffness = 0.8\ndamping = 0.7', "damping: 0.7 with stiffness = 0.8"),
    ('kind = "mesh"\nfile = "missing.stl"', "file: file not found"),
    ('kind = "mesh"\nfile = "empty.obj"', "no triangles or quads"),
])
def test_bad_tool_input_is_one_line_exit_2(tmp_path, body, message):
    """Bad [[tool]] input: one line naming the key, exit code 2 (the CLI), no traceback."""
    (tmp_path / "empty.obj").write_text("v 0 0 0\nv 1 0 0\n")
    text = scene_text({"bad": body}, end_time=1e-3)
    scene = write(tmp_path, text)
    with pytest.raises(SceneError) as caught:
        load_scene(scene)
    assert any(message in line and "[[tool]]" in line for line in caught.value.messages), caught.value.messages
    r = cli_run("validate", str(scene))
    assert r.code == 2 and "Traceback" not in r.out + r.err
    assert any(message in line for line in r.err.splitlines())


def test_duplicate_tool_names_and_newton(tmp_path):
    text = scene_text({"a": 'kind = "sphere"\nradius = 1\ncenter = [5, 5, 5]'}, end_time=1e-3)
    text = text.replace('name = "far_plane"', 'name = "a"')
    with pytest.raises(SceneError) as caught:
        parse_scene(__import__("tomllib").loads(text), write(tmp_path, text))
    assert any("duplicate tool name 'a'" in m for m in caught.value.messages)


def test_every_tool_key_is_documented(tmp_path):
    """Every [[tool]] key the parser accepts is in docs/scenes.md's [[tool]] section."""
    from taichi_shell_mpm.scene import reader as scene_module
    from taichi_shell_mpm.scene.tool import read_tool
    text = (Path(__file__).resolve().parents[1] / "docs" / "scenes.md").read_text()
    section = text.split("## `[[tool]]`", 1)[1].split("\n## ", 1)[0]
    parser = scene_module.Reader({}, tmp_path / "x.toml")
    seen = set()
    original = scene_module.Reader.read

    def recording(self, path, data, spec, cls=None, required=(), extra=()):
        if path.startswith("[[tool]]"):
            seen.update(spec)
        return original(self, path, data, spec, cls, required, extra)
    scene_module.Reader.read = recording
    try:
        read_tool(parser, "[[tool]][0]", {"name": "x", "kind": "sphere", "radius": 1.0}, None, {})
    finally:
        scene_module.Reader.read = original
    missing = sorted(k for k in seen if f"`{k}`" not in section)
    assert seen and not missing, missing
