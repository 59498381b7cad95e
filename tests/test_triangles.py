"""Triangular shells next to quads (issue 17 item 4; stages/triangle.py, docs/element.md
"Triangles").  On the element stage: rigid-body motion, membrane and constant-curvature
patches, the element's power identity and zero-energy modes.  Through the CLI: Sze's
cantilever with its 20x2 quads cut into 80 triangles (fem and mpm) against the Sze table; a
stepped cantilever from a Gmsh file whose root part is triangles and outer part quads
against the closed form, with the per-part output and the frames' triangle block; a restart
of a triangle mesh bit for bit; the reduced tube crush with one face of triangles against
the all-quad tube's mean force."""
from __future__ import annotations

from pathlib import Path

import meshio
import numpy as np
import pytest

from taichi_shell_mpm.mesh import build_mesh
from taichi_shell_mpm.model.assembly import triangle_shear_gain
from taichi_shell_mpm.scene import PlateMesh

from .conftest import ROOT, element_simulation, element_stage, run_scene

E, NU, T = 2.0e5, 0.3, 0.05
KAPPA = 5.0 / 6.0


def rotation_matrix(theta):
    """Rodrigues: rotation by the vector theta."""
    angle = np.linalg.norm(theta)
    k = np.array([[0, -theta[2], theta[1]], [theta[2], 0, -theta[0]], [-theta[1], theta[0], 0]]) / angle
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def mixed_patch(n: int = 4, jitter: float = 0.0, lift: float = 0.0, split=None, seed: int = 3):
    """Nodes, quads and triangles of an n x n patch of 0.4 x 0.3 cells, each row shifted 0.1 in
    x (parallelograms); the cells with `split`(i, j) True are cut into two triangles along
    alternating diagonals (default: all but a diagonal band of quads).  `jitter` moves the
    interior nodes of the left half at random (cells touching a moved node become triangles: a
    distorted triangle patch next to parallelogram quads); `lift` bends the patch out of its
    plane (z = lift (x^2 - y^2)).  Returns points, quads, triangles, interior node ids."""
    split = split or (lambda i, j: (i + j) % 3 != 0)
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    x = 0.4 * i + 0.1 * j
    y = 0.3 * j
    node = lambda a, b: a * (n + 1) + b          # noqa: E731
    interior = np.array([node(a, b) for a in range(1, n) for b in range(1, n)])
    moved = np.zeros((n + 1, n + 1), dtype=bool)
    if jitter:
        rng = np.random.default_rng(seed)
        dx, dy = rng.uniform(-jitter, jitter, size=(2, n + 1, n + 1))
        inner = (i > 0) & (i <= n // 2) & (j > 0) & (j < n)
        x, y = x + np.where(inner, dx, 0.0), y + np.where(inner, dy, 0.0)
        moved = inner
    points = np.column_stack([x.ravel(), y.ravel(), lift * (x.ravel() ** 2 - y.ravel() ** 2)])
    quads, triangles = [], []
    for a in range(n):
        for b in range(n):
            q = [node(a, b), node(a + 1, b), node(a + 1, b + 1), node(a, b + 1)]
            if split(a, b) or moved[a:a + 2, b:b + 2].any():
                if (a + b) % 2:
                    triangles += [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
                else:
                    triangles += [[q[0], q[1], q[3]], [q[1], q[2], q[3]]]
            else:
                quads.append(q)
    return points, np.array(quads, dtype=int).reshape(-1, 4), np.array(triangles), interior


# ------------------------------------------------------------------ numpy twin of stages/triangle.py
def triangle_kinematics(x, v, w):
    """The triangle's rates at corner positions x (3x3) for corner velocities v and angular
    velocities w, written out from the docstring of stages/triangle.py, not from the kernel:
    frame, local coordinates about the centroid, area, membrane, curvature and edge
    transverse shear rates, drilling rates."""
    normal = np.cross(x[1] - x[0], x[2] - x[0])
    e3 = normal / np.linalg.norm(normal)
    r21 = x[1] - x[0]
    e1 = r21 - r21 @ e3 * e3
    e1 /= np.linalg.norm(e1)
    rot = np.array([e1, np.cross(e3, e1), e3])
    xh, yh, _ = ((x - x.mean(axis=0)) @ rot.T).T
    vx, vy, vz = (v @ rot.T).T
    tx, ty, tz = (w @ rot.T).T
    area = 0.5 * ((xh[1] - xh[0]) * (yh[2] - yh[0]) - (xh[2] - xh[0]) * (yh[1] - yh[0]))
    b1 = np.array([yh[1] - yh[2], yh[2] - yh[0], yh[0] - yh[1]]) / (2 * area)
    b2 = np.array([xh[2] - xh[1], xh[0] - xh[2], xh[1] - xh[0]]) / (2 * area)
    membrane = np.array([b1 @ vx, b2 @ vy, b2 @ vx + b1 @ vy])
    curvature = np.array([b1 @ ty, -b2 @ tx, b2 @ ty - b1 @ tx])
    beta = np.column_stack([ty, -tx])
    shear = np.zeros(2)
    for k in range(3):
        m = (k + 1) % 3
        edge = np.array([xh[m] - xh[k], yh[m] - yh[k]])
        mid = 0.5 * np.array([xh[m] + xh[k], yh[m] + yh[k]])
        shear += np.array([-mid[1], mid[0]]) * (vz[m] - vz[k] + 0.5 * (beta[k] + beta[m]) @ edge)
    shear /= area
    drilling = tz - 0.5 * (b1 @ vy - b2 @ vx)
    return rot, area, membrane, curvature, shear, drilling


def resultants(sim, stress, e):
    """N, M' = -int z sigma (paper sign) and Q of element e's point stresses (method.md 3.5)."""
    t = float(sim.model.element.thickness[e])
    s = sim.model.element.section[e]
    zeta, weight = sim.model.sections.zeta[s], sim.model.sections.weight[s]
    return (0.5 * t * weight @ stress[:, :3], -0.25 * t * t * (weight * zeta) @ stress[:, :3],
            0.5 * t * weight @ stress[:, 3:5])


def in_frame(tensor, e1):
    """(xx, yy, xy) of a symmetric in-plane tensor (xy as given: stress or engineering
    curvature, `engineering`) in the frame whose e1 is the unit vector e1 (x-y plane)."""
    c, s = e1[0], e1[1]
    txx, tyy, txy = tensor
    return np.array([txx * c * c + tyy * s * s + 2 * txy * c * s, txx * s * s + tyy * c * c - 2 * txy * c * s,
                     (tyy - txx) * c * s + txy * (c * c - s * s)])


# ------------------------------------------------------------------ the element stage
def rigid_motions_give_nothing(sim, points, label: str) -> None:
    """Translation and a 0.5 rad rotation about a general axis over one step (the nodal omega is
    the rotation's mid-step Cayley rate, which the mid-step strain increment integrates
    exactly) of the patch `points` of `sim`: zero stress, nodal forces and moments, hourglass
    and drilling (or higher-order) resultants, to round-off (1e-12 of a unit strain
    increment's stress)."""
    dt = 1e-4
    centre = points.mean(axis=0)
    theta = np.array([0.2, -0.35, 0.25])
    angle = np.linalg.norm(theta)
    cayley_rate = 2 * np.tan(angle / 2) / dt * theta / angle
    rotated = (points - centre) @ rotation_matrix(theta).T + centre
    shift = np.tile([0.4, -1.1, 0.7], (len(points), 1))
    cases = {"translation": (points + dt * shift, shift, np.zeros_like(points)),
             "rotation": (rotated, (rotated - points) / dt, np.tile(cayley_rate, (len(points), 1)))}
    for name, (end, velocity, omega) in cases.items():
        stress, force, moment, hg, drill = element_stage(sim, end, velocity, omega, dt)
        scale = E * dt * np.abs(velocity).max()        # stress of a unit strain increment
        print(f"\n{label} {name}: max |stress| {np.abs(stress).max():.2e}, |f| {np.abs(force).max():.2e}, "
              f"|m| {np.abs(moment).max():.2e}, |hg| {np.abs(hg).max():.2e}, |drill| {np.abs(drill).max():.2e} "
              f"(scale {scale:.1e})")
        for found in (stress, force, moment, hg, drill):
            assert np.abs(found).max() <= 1e-12 * scale


@pytest.mark.parametrize("lift", [0.0, 0.4], ids=["flat", "curved"])
def test_rigid_motion_of_a_mixed_patch_gives_nothing(tmp_path, lift):
    """A mixed quad/triangle patch, flat and curved (faceted): :func:`rigid_motions_give_nothing`."""
    points, quads, triangles, _ = mixed_patch(lift=lift)
    sim = element_simulation(tmp_path, points, E=E, nu=NU, t=T, quads=quads, triangles=triangles)
    rigid_motions_give_nothing(sim, points, f"{lift=}: {len(quads)} quads, {len(triangles)} triangles:")


STRETCH = np.array([[2e-3, 5e-4, 0.0], [5e-4, -1e-3, 0.0], [0.0, 0.0, 0.0]])   # a uniform stretch rate


def stretch_patch(sim, points, interior, grad=STRETCH, spin: float = 0.0) -> dict:
    """A uniform velocity gradient `grad` (nodal theta_z' = `spin`) over one step of the element
    stage, about the mid-step geometry (dt = 1e-13, so the strain increment is exactly dt sym(L)):
    the plane-stress stress C dt sym(L) it must give ("exact"), the largest relative error of any
    element's stress against it in the element's own frame ("error"), the largest interior
    resultant force over the largest force ("residual"), and the stage's stress, force, moment
    and drilling resultants."""
    dt = 1e-13
    velocity = points @ grad.T
    omega = np.tile([0.0, 0.0, spin], (len(points), 1))
    stress, force, moment, _, drill = element_stage(sim, points + 0.5 * dt * velocity, velocity, omega, dt)
    c = E / (1 - NU ** 2)
    exx, eyy, gxy = grad[0, 0], grad[1, 1], grad[0, 1] + grad[1, 0]
    exact = dt * np.array([c * (exx + NU * eyy), c * (NU * exx + eyy), E / (2 * (1 + NU)) * gxy])
    error = 0.0
    for e, corners in enumerate(sim.model.elements):
        x = points[corners[corners >= 0]]
        e1 = (x[1] - x[0]) / np.linalg.norm(x[1] - x[0])
        error = max(error, np.abs(stress[e][:, :3] - in_frame(exact, e1)).max() / np.abs(exact).max())
    return {"exact": exact, "error": error, "residual": np.abs(force[interior]).max() / np.abs(force).max(),
            "stress": stress, "force": force, "moment": moment, "drill": drill}


def test_membrane_patch_is_exact_on_a_distorted_mixed_patch(tmp_path):
    """A uniform stretch rate (applied about the mid-step geometry, so the strain increment is
    exactly dt sym(L)) on a patch of distorted triangles around parallelogram quads: the
    plane-stress stress C dt eps in every element (its own frame) and point, no transverse
    shear, and zero resultant force at every interior node.  dt = 1e-13: the loads are taken on
    the end-of-step geometry, which differs from the rates' by dt |L| (1e-16 here)."""
    points, quads, triangles, interior = mixed_patch(jitter=0.07)
    sim = element_simulation(tmp_path, points, E=E, nu=NU, t=T, quads=quads, triangles=triangles)
    found = stretch_patch(sim, points, interior)
    error, residual, stress, exact, force, moment = (found[k] for k in ("error", "residual", "stress", "exact",
                                                                      "force", "moment"))
    print(f"\nmembrane patch ({len(quads)} quads, {len(triangles)} triangles): relative stress error {error:.2e}, "
          f"transverse {np.abs(stress[:, :, 3:]).max():.1e}, interior residual / largest force {residual:.1e}")
    assert len(triangles) >= 20 and len(quads) >= 1
    assert error < 1e-12
    assert np.abs(stress[:, :, 3:]).max() < 1e-12 * np.abs(exact).max()
    assert residual < 1e-12
    assert np.abs(moment).max() < 1e-12 * np.abs(force).max()


@pytest.mark.parametrize("triangle", ["c0", "ns"])
@pytest.mark.parametrize("jitter", [0.0, 0.07], ids=["parallelogram", "distorted"])
def test_constant_curvature_patch_is_exact_with_mixed_elements(tmp_path, jitter, triangle):
    """A Kirchhoff field w' = a x^2 + b x y + c y^2 (omega = (dw'/dy, -dw'/dx, 0)) for bending,
    twist and a mix on a mixed patch (parallelogram quads; triangles regular or distorted):
    M' = -dt D kappa' in every element, zero transverse shear in every triangle (each edge's
    tangential shear of a Kirchhoff field is zero, so on any triangle) and quad (on
    parallelograms, method.md 9), and zero resultant force and moment at every interior node.
    dt = 1e-13 and the nodes at X + dt/2 v: the rates see the flat patch (curvature_patch in
    tests/test_shell_element.py).  The node-smoothed triangle ("ns", issue 33) shares the C0
    triangle's bending: the same patch test."""
    points, quads, triangles, interior = mixed_patch(jitter=jitter)
    centre = points.mean(axis=0)
    dt = 1e-13
    sim = element_simulation(tmp_path, points, E=E, nu=NU, t=T, quads=quads, triangles=triangles,
                             element=f'triangle = "{triangle}"')
    assert sim.cfg.triangle_ns == (triangle == "ns")
    bending = E * T ** 3 / (12 * (1 - NU ** 2)) * np.array([[1, NU, 0], [NU, 1, 0], [0, 0, (1 - NU) / 2]])
    elements = sim.model.elements
    for name, (a, b, c) in {"bending": (0.7, 0.0, 0.0), "twist": (0.0, 1.0, 0.0),
                            "mixed": (0.3, -0.5, 0.9)}.items():
        x, y = (points - centre)[:, :2].T
        velocity = np.zeros_like(points)
        omega = np.zeros_like(points)
        velocity[:, 2] = a * x * x + b * x * y + c * y * y
        omega[:, 0] = b * x + 2 * c * y
        omega[:, 1] = -(2 * a * x + b * y)
        curvature = np.array([-2 * a, -2 * c, -2 * b])
        stress, force, moment, _, _ = element_stage(sim, points + 0.5 * dt * velocity, velocity, omega, dt)
        moment_error = shear = 0.0
        for e, corners in enumerate(elements):
            xe = points[corners[corners >= 0]]
            e1 = (xe[1] - xe[0]) / np.linalg.norm(xe[1] - xe[0])
            k = in_frame(curvature * np.array([1, 1, 0.5]), e1) * np.array([1, 1, 2])   # engineering twist
            exact = -dt * bending @ k
            _, m_res, q_res = resultants(sim, stress[e], e)
            moment_error = max(moment_error, np.abs(m_res - exact).max() / np.abs(exact).max())
            shear = max(shear, np.abs(q_res).max() * 0.4 / np.abs(exact).max())
        residual = max(np.abs(moment[interior]).max(), 0.3 * np.abs(force[interior]).max()) / np.abs(moment).max()
        print(f"\n{jitter=} {name}: moments vs D kappa {moment_error:.1e}, Q l / M {shear:.1e}, "
              f"interior residual / boundary moment {residual:.1e}")
        assert moment_error < 1e-12
        assert shear < 1e-12
        assert residual < 1e-12


def test_triangle_power_identity(tmp_path):
    """sum_a (f.v + m.theta) = A (N.eps0' - M'.kappa' + kappa Q.gamma') + sum M_drill (theta_z -
    Omega) for random corner velocities and rotation rates on a triangle out of the x-y plane;
    the rates from the numpy twin above, the loads from the element stage (a thick section,
    raised drilling stiffness: every part of the same order; 3 Gauss points, exact for the
    linear stress, and the patch tests' kernels above).  Also the stress power summed point
    by point, and the element's booked energy increment (1/2 dt of the power)."""
    x = np.array([[0.1, -0.2, 0.3], [1.3, 0.2, -0.1], [0.4, 0.9, 0.5]])
    rng = np.random.default_rng(16)
    dt, t = 1e-10, 0.8
    sim = element_simulation(tmp_path, x, E=E, nu=NU, t=t, triangles=[[0, 1, 2]],
                             section='points = 3\nrule = "gauss"', element="drilling_stiffness = 1.0")
    for draw in range(3):
        v, w = rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
        s = sim.state
        before = s.step.internal_energy[None] + s.step.drilling_energy[None]
        stress, force, moment, hg, drill = element_stage(sim, x, v, w, dt)
        energy = s.step.internal_energy[None] + s.step.drilling_energy[None] - before
        _, area, membrane, curvature, shear, drilling = triangle_kinematics(x, v, w)
        n_res, m_res, q_res = resultants(sim, stress[0], 0)
        parts = area * np.array([n_res @ membrane, -m_res @ curvature, KAPPA * q_res @ shear])
        zeta, weight = sim.model.sections.zeta[0], sim.model.sections.weight[0]
        pointwise = area * 0.5 * t * sum(
            wk * (stress[0, k, :3] @ (membrane + 0.5 * t * zeta[k] * curvature) + KAPPA * stress[0, k, 3:5] @ shear)
            for k, wk in enumerate(weight))
        dr = drill[0, :3] @ drilling
        nodal = np.sum(force * v) + np.sum(moment * w)
        scale = np.sum(np.abs(force * v)) + np.sum(np.abs(moment * w))
        print(f"\ndraw {draw}: nodal power {nodal:.15e}; membrane, bending, shear {parts[0]:.3e}, {parts[1]:.3e}, "
              f"{parts[2]:.3e}, drilling {dr:.3e}: identity {abs(nodal - parts.sum() - dr) / scale:.1e}, point sum "
              f"{abs(pointwise - parts.sum()) / scale:.1e}, energy increment {abs(2 * energy / dt - nodal) / scale:.1e}")
        assert min(*np.abs(parts), abs(dr)) > 1e-3 * scale
        assert abs(nodal - parts.sum() - dr) <= 1e-13 * scale
        assert abs(pointwise - parts.sum()) <= 1e-13 * scale
        assert abs(2 * energy / dt - nodal) <= 1e-8 * scale
        assert np.abs(hg).max() == 0.0 and drill[0, 3] == 0.0       # no hourglass; the 4th slot unused


def stiffness(sim, points, dt=1e-9):
    """The linear stiffness of a patch from the element stage: column j = nodal loads of a unit
    rate of dof j (6 per node) over dt from zero stress, / dt (geometry at X + dt/2 v)."""
    n = len(points)
    k = np.zeros((6 * n, 6 * n))
    for j in range(6 * n):
        rates = np.zeros((n, 6))
        rates[j // 6, j % 6] = 1.0
        _, force, moment, _, _ = element_stage(sim, points + 0.5 * dt * rates[:, :3], rates[:, :3], rates[:, 3:], dt)
        k[:, j] = np.column_stack([force, moment]).ravel() / dt
    return k


@pytest.mark.parametrize("patch,zero_modes", [("one triangle", 7), ("two triangles", 6), ("mixed patch", 6)])
def test_zero_energy_modes(tmp_path, patch, zero_modes):
    """Singular values of the stiffness (translations and rotations scaled by the element size
    so both count alike) below 1e-9 of the largest: the 6 rigid modes; a triangle alone has one
    more, its rotations swirling about the centroid (stages/triangle.py), which an edge shared
    with a neighbour removes; a mixed patch (quads with their hourglass control) has none."""
    if patch == "mixed patch":
        points, quads, triangles, _ = mixed_patch(n=2, split=lambda i, j: i == 0)
    else:
        points = np.array([[0.0, 0.0, 0.0], [1.0, 0.1, 0.0], [0.3, 0.8, 0.0], [1.2, 1.1, 0.0]])
        quads, triangles = None, [[0, 1, 2]] if patch == "one triangle" else [[0, 1, 2], [1, 3, 2]]
        points = points[:3] if patch == "one triangle" else points
    sim = element_simulation(tmp_path, points, E=E, nu=NU, t=T, quads=quads, triangles=triangles)
    assert zero_energy_modes(sim, points, f"{patch}: {len(points)} nodes", zero_modes) == zero_modes


def zero_energy_modes(sim, points, label: str, shown: int) -> int:
    """The singular values of the patch's stiffness (rotations scaled by the element size)
    below 1e-9 of the largest (the smallest `shown` + 1 printed)."""
    k = stiffness(sim, points)
    size = np.sqrt(np.mean(sim.model.area0))
    scale = np.tile([1.0, 1.0, 1.0, 1.0 / size, 1.0 / size, 1.0 / size], len(points))
    singular = np.linalg.svd(k * scale[:, None] * scale[None, :], compute_uv=False)
    ratio = singular / singular[0]
    found = int(np.sum(ratio < 1e-9))
    print(f"\n{label}; smallest singular values / largest "
          f"{', '.join(f'{r:.1e}' for r in np.sort(ratio)[:shown + 1])}: {found} zero-energy modes")
    return found


SHAPES = {"equilateral": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.8660254037844386, 0.0]],
          "right": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
          "sliver 9 deg": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.45, 0.0873, 0.0]],
          "sliver 0.9 deg": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.3, 0.0105, 0.0]]}


@pytest.mark.parametrize("inertia", ["scaled", "physical"])
def test_stable_step_holds_on_slivers(tmp_path, inertia):
    """The largest frequency of one triangle, from the element stage's stiffness (18 dofs,
    drilling spring included) and its lumped masses and rotary inertias, against the step
    the code takes (stages/timestep.py: the host's initial_dt, and the element stage's own
    dt_next, which must agree): omega_max dt / 2 <= dt_safety for shapes down to a sliver
    whose smallest angle is 0.9 deg, t = 0.05 of the longest edge.  Without the shear gain g
    in the rotary inertia (scaled) and in the step (physical, then the quad's minimum of the
    two limits) the plate part alone, in numpy, gives omega dt / 2 = 2.28 and 5.58 dt_safety
    on that sliver, 0.95 and 3.69 at 9 deg, and 1.12 (physical) on the equilateral one."""
    assert_stable_step_on_shapes(tmp_path, inertia, solve=f'rotary_inertia = "{inertia}"')


def assert_stable_step_on_shapes(tmp_path, label: str, **options) -> None:
    """On each of SHAPES, one triangle (t = 0.05 of its longest edge; `options` to
    element_simulation): omega_max of its element-stage stiffness against its lumped masses and
    rotary inertias, times the step the host (initial_dt) and the element stage (dt_next) both
    take, over 2, at most dt_safety."""
    from taichi_shell_mpm.stages.timestep import initial_dt
    for shape, x in SHAPES.items():
        (tmp_path / shape).mkdir()
        x = np.array(x)
        sim = element_simulation(tmp_path / shape, x, E=E, nu=NU, t=0.05, triangles=[[0, 1, 2]], **options)
        k = stiffness(sim, x)
        mass = np.column_stack([np.tile(sim.model.node_mass[:, None], 3), np.tile(sim.model.node_inertia[:, None], 3)])
        scale = 1.0 / np.sqrt(mass.ravel())
        omega = np.sqrt(np.linalg.eigvalsh(0.5 * (k + k.T) * scale[:, None] * scale[None, :]).max())
        dt = initial_dt(sim.model, np.zeros_like(x), sim.cfg)
        kernel_dt = float(sim.state.step.dt_next[None])
        ratio = omega * dt / 2 / sim.model.parameters.dt_safety
        gain = float(triangle_shear_gain(x, np.array([[0, 1, 2, -1]]))[0])
        print(f"\n{label} {shape}: shear gain {gain:.2f}, dt {dt:.4e} (element stage {kernel_dt:.4e}), "
              f"omega_max dt / 2 = {ratio:.5f} dt_safety")
        assert kernel_dt == pytest.approx(dt, rel=1e-6)
        assert ratio <= 1.0 + 1e-9          # a sliver's membrane reaches the bound 3 c^2 beta (stages/triangle.py)


# ------------------------------------------------------------------ whole runs (through the API)
def run_summary(out: Path, scene: Path, *overrides: str) -> dict:
    """`run scene --set ...` in this process through the Python API (conftest.run_scene): the
    summary."""
    proc = run_scene(scene, out, *overrides)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.summary


SZE = ("mesh.nx=20", "mesh.ny=2", "mesh.triangles=all")
# Measured (`python -m pytest -q -s tests/test_triangles.py -k sze`, 2026-12), mean / max of
# e_i over the 20 levels, %: fem W_tip 0.0184 / 0.0516, -U_tip 0.0645 / 0.1674; mpm 0.0186 /
# 0.0481, 0.0641 / 0.1760 (the 20x2 quads: 0.09 / 0.21 %).  Bounds 1.5x those.  The degenerate
# BT quad on the same 80 triangles: 38.7 / 56.8 % mean (benchmarks/triangle_element.py).
SZE_BOUNDS = {"fem": {"W_tip": (0.00028, 0.00078), "minus_U_tip": (0.00097, 0.0026)},
              "mpm": {"W_tip": (0.00028, 0.00073), "minus_U_tip": (0.00097, 0.0027)}}


@pytest.fixture(scope="module")
def sze_runs(tmp_path_factory):
    """Both modes, one after the other, in this process."""
    out = tmp_path_factory.mktemp("sze_triangles")
    scene = ROOT / "scenes" / "cantilever.toml"
    return {m: (out / m, run_summary(out / m, scene, *SZE, f"method.kind={m}")) for m in SZE_BOUNDS}


@pytest.mark.parametrize("method", ["fem", "mpm"])
def test_sze_cantilever_on_80_triangles(sze_runs, method):
    out, summary = sze_runs[method]
    ref = summary["reference"]
    assert summary["elements"] == 80 and ref["rows"] == 20 and ref["missing_levels"] == []
    print(f"\nSze cantilever, 80 triangles ({method}): {summary['steps']} steps, run {summary['run_seconds']:.1f} s")
    for column, r in ref["columns"].items():
        print(f"  {column:<12s} mean {100 * r['mean_rel_error']:.4f} % max {100 * r['max_rel_error']:.4f} % "
              f"(bounds {100 * SZE_BOUNDS[method][column][0]:.3f} / {100 * SZE_BOUNDS[method][column][1]:.3f} %)")
    for column, (mean_bound, max_bound) in SZE_BOUNDS[method].items():
        assert ref["columns"][column]["mean_rel_error"] <= mean_bound, column
        assert ref["columns"][column]["max_rel_error"] <= max_bound, column
    energies = summary["energies"]
    assert energies["hourglass"] == 0.0           # no hourglass control in a triangle
    frame = meshio.read(sorted((out / "frames").glob("*.vtu"))[-1])
    assert [c.type for c in frame.cells] == ["triangle"] and len(frame.cells[0].data) == 80
    assert frame.cell_data["von_mises_mid"][0].shape == (80,)


def write_mixed_strip(path: Path) -> None:
    """The stepped strip of tests/test_parts.py (20x1 on 10 x 1) as Gmsh 2.2: the root half
    (x < 5) cut into 20 triangles, physical group 'root' (tag 1, the triangle block), the
    outer half 10 quads, 'outer' (tag 2)."""
    from .test_parts import A, B, L
    m = build_mesh(PlateMesh(lx=L, ly=B, nx=20, ny=1, triangles=((0.0, -1.0, -1.0), (A, 2.0, 1.0))))
    tri, quad = m.elements[m.triangles, :3], m.elements[~m.triangles]
    meshio.write(path, meshio.Mesh(m.points, [("triangle", tri), ("quad", quad)],
                                   cell_data={"gmsh:physical": [np.full(len(tri), 1), np.full(len(quad), 2)],
                                              "gmsh:geometrical": [np.full(len(tri), 1), np.full(len(quad), 2)]},
                                   field_data={"root": np.array([1, 2]), "outer": np.array([2, 2])}),
                 file_format="gmsh22", binary=False)


# Measured (pytest -s, 2026-12): tip deflection -0.097 % against the piecewise closed form in
# fem and in mpm (the all-quad strip of tests/test_parts.py: -0.105 %); root share of the
# strain energy 0.6752 against the bending closed form's 0.6747.  Bound 1.5x.
MIXED_STEPPED_BOUND = 0.0015


@pytest.mark.parametrize("method", ["fem", "mpm"])
def test_stepped_cantilever_with_a_triangle_part_from_gmsh(tmp_path, method):
    """Parts from a Gmsh file holding triangles and quads: the thick root is the triangle
    block, the thin outer half the quad block.  Tip deflection against the piecewise
    Euler-Bernoulli + shear closed form; the frames hold a quad and a triangle block with the
    part and thickness of each element; parts.csv sums to energy.csv and the root (triangles)
    has no hourglass energy; each half holds its bending share of the strain energy."""
    from .test_parts import COMMON, NAMED, T1, T2, A, L, P, stepped_tip_deflection
    write_mixed_strip(tmp_path / "strip.msh")
    scene = tmp_path / "mixed.toml"
    scene.write_text(COMMON.format(mesh='[mesh]\nkind = "file"\npath = "strip.msh"\n', method=method, P=P)
                     + NAMED.format(E=1.2e6, T1=T1, T2=T2, sets="", root="root", outer="physical:2"))
    out = tmp_path / "out"
    summary = run_summary(out, scene)
    uz = float(np.atleast_1d(np.genfromtxt(out / "probes.csv", delimiter=",", names=True)["tipuz"])[-1])
    exact = stepped_tip_deflection()
    error = uz / exact - 1.0
    frame = meshio.read(sorted((out / "frames").glob("*.vtu"))[-1])
    parts = summary["parts"]
    share = parts[0]["energies"]["internal"] / summary["energies"]["internal"]
    bending = (L ** 3 - (L - A) ** 3) / T1 ** 3 / ((L ** 3 - (L - A) ** 3) / T1 ** 3 + (L - A) ** 3 / T2 ** 3)
    print(f"\nstepped cantilever, root 20 triangles + outer 10 quads ({method}): tip {uz:.6e}, closed form "
          f"{exact:.6e}, error {100 * error:+.3f} %; root share of the strain energy {share:.4f} (bending {bending:.4f})")
    assert abs(error) <= MIXED_STEPPED_BOUND
    assert [(c.type, len(c.data)) for c in frame.cells] == [("quad", 10), ("triangle", 20)]
    assert frame.cell_data["part"][0].tolist() == [1] * 10 and frame.cell_data["part"][1].tolist() == [0] * 20
    assert frame.cell_data["thickness"][0].tolist() == [T2] * 10 and frame.cell_data["thickness"][1].tolist() == [T1] * 20
    assert [(p["name"], p["elements"]) for p in parts] == [("root", 20), ("outer", 10)]
    assert parts[0]["energies"]["hourglass"] == 0.0
    energy = np.genfromtxt(out / "energy.csv", delimiter=",", names=True)
    table = np.genfromtxt(out / "parts.csv", delimiter=",", names=True, dtype=None, encoding=None)
    for column in ("kinetic", "internal", "hourglass", "drilling"):
        assert table[column].sum() == pytest.approx(float(np.atleast_1d(energy[column])[-1]), rel=2e-9, abs=1e-30)
    assert share == pytest.approx(bending, abs=0.001)


def test_restart_of_a_triangle_mesh_is_bit_for_bit(tmp_path, monkeypatch):
    """tests/test_restart.py's static round trip on the cantilever cut into 8 triangles."""
    from .test_restart import CANTILEVER, restart_roundtrip
    stopped, _ = restart_roundtrip(tmp_path, monkeypatch, [*CANTILEVER, "--set", "mesh.triangles=all"],
                                   stop_step=7000, every=5000, batch_element_steps=8000)
    assert stopped["started"] and 0 < stopped["steps"]


# Measured (pytest -s, 2026-12; 928 elements, batched serial launch): mean crush force 10.486 kN
# over 20-37.4 mm against the all-quad 10.563 of tests/test_crush.py (-0.73 %; the all-quad
# tube run by this code: 10.538, -0.49 %); 3 lobes, H 12.2 mm, balance 0.24 % of the absorbed
# energy, E_hg/E_int 8.0 %.  The full 6 ms tube:
# benchmarks/triangle_tube.py (docs/element.md, "Triangles").
TUBE_BAND = "mesh.triangles={min = [-31.0, 29.5, -1.0], max = [31.0, 31.0, 81.0]}"


def test_reduced_crush_with_a_face_of_triangles(tmp_path):
    """tests/test_crush.py's reduced crush (80 mm, 2.5 ms, mpm, contact) with the +y face (10 x
    16 quads between the fillets) cut into 320 triangles: the mean crush force within 10 % of
    the all-quad tube's (the issue's bound), the triangle block in the frames, the energy
    balance and penetration as bounded for the all-quad tube."""
    from .test_crush import REDUCED_MEAN_FORCE, SHORT
    summary = run_summary(tmp_path, ROOT / "scenes" / "square_tube.toml", *SHORT, TUBE_BAND)
    c = summary["crush"]
    frame = meshio.read(sorted((tmp_path / "frames").glob("*.vtu"))[-1])
    shapes = [(cell.type, len(cell.data)) for cell in frame.cells]
    ratio = c["mean_crush_force"] / REDUCED_MEAN_FORCE
    print(f"\nmixed tube {shapes}: crush {c['crush_distance']:.1f} mm, mean {c['mean_crush_force']:.3f} kN over "
          f"{c['mean_force_window']} ({100 * (ratio - 1):+.2f} % of the all-quad {REDUCED_MEAN_FORCE}), lobes "
          f"{c['lobes']}, H {c['half_wavelength']}, balance {100 * c['energy_balance_error_max']:.2f} %, hourglass/"
          f"internal {100 * c['hourglass_over_internal']:.1f} %, penetration "
          f"{100 * c['max_penetration_over_thickness']:.1f} % t, {summary['steps']} steps")
    assert shapes == [("quad", 768 - 160), ("triangle", 320)]
    assert c["crush_distance"] > 30 and c["lobes"] >= 2
    assert abs(ratio - 1.0) <= 0.10
    assert c["energy_balance_error_max"] <= 0.004            # the all-quad bound (measured 0.24 %)
    assert c["max_penetration_over_thickness"] <= 0.021      # the all-quad bound


def test_generated_triangles_key(tmp_path):
    """`[mesh].triangles` through `validate`: the count of triangles, and one-line errors (exit 2)
    for a bad value and for a box with min > max."""
    from .test_reliability import cli_run
    scene = str(ROOT / "scenes" / "cantilever.toml")
    r = cli_run("validate", scene, "--set", "mesh.nx=20", "--set", "mesh.ny=2", "--set", "mesh.triangles=all")
    assert r.code == 0 and "80 elements (80 triangles)" in r.out, r.out + r.err
    r = cli_run("validate", scene, "--set", "mesh.triangles={min = [0, 0, -1], max = [5, 1, 1]}")
    assert r.code == 0 and "15 elements (10 triangles)" in r.out, r.out + r.err
    for value, problem in (("some", "got 'some'"), ("{min = [1, 0, 0], max = [0, 1, 1]}", "min <= max")):
        r = cli_run("validate", scene, "--set", f"mesh.triangles={value}")
        print(r.err.strip())
        assert r.code == 2 and len(r.err.strip().splitlines()) == 1 and "Traceback" not in r.err
        assert "[mesh].triangles: expected \"none\", \"all\" or a box" in r.err and problem in r.err
