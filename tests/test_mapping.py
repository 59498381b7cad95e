"""The double mapping (method.md 2.1-2.2): partition of unity, conservation of mass and
momentum through P2G/G2P, and exact reproduction of FE mode on a non-overlapping grid."""
from __future__ import annotations

import numpy as np
import taichi as ti

from taichi_shell_mpm.model.assembly import cpdi2_weights

from .conftest import plate_scene, simulation


def test_cpdi2_weights_sum_to_one_and_parallelogram_quarters():
    pts = np.array([[0, 0, 0], [2.0, 0.2, 0], [2.3, 1.5, 0], [-0.2, 1.1, 0], [1, 0, 0], [2, 0, 0], [1.5, 1, 0],
                    [0.5, 1, 0]], dtype=float)
    quads = np.array([[0, 1, 2, 3], [0, 4, 6, 7]])
    area, w = cpdi2_weights(pts, quads)
    print("CPDI2 weights", w.round(4).tolist())
    assert np.allclose(w.sum(axis=1), 1.0, atol=1e-14)
    assert np.allclose(w[1], 0.25)                                # parallelogram
    assert not np.allclose(w[0], 0.25)


def test_partition_of_unity_and_linear_completeness(tmp_path):
    sim = simulation(plate_scene(tmp_path, method_extra="cell_size = 0.3"), tmp_path)
    mapping = sim.stepper.mapping
    rng = np.random.default_rng(1)
    n = 200
    pts = ti.Vector.field(3, ti.f64, n)
    out = ti.Vector.field(4, ti.f64, n)
    grad_out = ti.Matrix.field(4, 3, ti.f64, n)       # rows: sum grad N_I, sum x_I grad N_I^T
    pts.from_numpy(rng.uniform([-0.2, -0.2, -0.2], [1.2, 1.2, 0.2], (n, 3)))

    @ti.kernel
    def sums():
        for p in range(n):
            base, frac, inside = mapping.stencil(pts[p])
            w_axis = mapping.axis_weights(frac)
            total, first = 0.0, ti.Vector([0.0, 0.0, 0.0])
            grad_sum, grad_first = ti.Vector([0.0, 0.0, 0.0]), ti.Matrix.zero(ti.f64, 3, 3)
            for i, j, k in ti.static(ti.ndrange(2, 2, 2)):
                w, grad = mapping.weight(w_axis, i, j, k)
                total += w
                node = ti.cast(base + ti.Vector([i, j, k]), ti.f64) * sim.state.grid.h[None]
                first += w * node
                grad_sum += grad
                grad_first += node.outer_product(grad)
            out[p] = ti.Vector([total, first[0], first[1], first[2]])
            for d in ti.static(range(3)):
                grad_out[p][0, d] = grad_sum[d]
                for e in ti.static(range(3)):
                    grad_out[p][1 + e, d] = grad_first[e, d]

    sums()
    res = out.to_numpy()
    grads = grad_out.to_numpy()
    err_unity = np.abs(res[:, 0] - 1).max()
    err_linear = np.abs(res[:, 1:] - pts.to_numpy()).max()
    err_grad = max(np.abs(grads[:, 0]).max() * sim.model.grid.h, np.abs(grads[:, 1:] - np.eye(3)).max())
    print(f"partition of unity error {err_unity:.1e}, linear completeness error {err_linear:.1e}, "
          f"gradient (sum, linear) error {err_grad:.1e}")
    assert err_unity < 1e-14 and err_linear < 1e-13 and err_grad < 1e-12


def test_p2g_g2p_conserve_mass_and_momentum(tmp_path):
    sim = simulation(plate_scene(tmp_path, nx=5, ny=3, method_extra="cell_size = 0.5"), tmp_path)
    s = sim.state
    rng = np.random.default_rng(2)
    s.put("nodes.position", sim.model.points + rng.normal(0, 0.05, sim.model.points.shape))
    s.put("nodes.velocity", rng.normal(0, 1, (s.n_nodes, 3)))
    s.put("nodes.affine", rng.normal(0, 1, (s.n_nodes, 3, 3)))
    s.step.dt[None] = 1e-4
    m = sim.model.node_mass
    momentum = (m[:, None] * s.fetch("nodes.velocity")).sum(axis=0)
    stepper = sim.stepper
    grid_totals = ti.field(ti.f64, 4)

    @ti.kernel
    def transfer():
        stepper.begin()
        stepper.mapping.particles_to_grid()
        for g in range(s.grid.mass.shape[0]):
            grid_totals[0] += s.grid.mass[g]
            for d in ti.static(range(3)):
                grid_totals[1 + d] += s.grid.momentum[g][d]
        stepper.mapping.grid_to_particles()
        stepper.mapping.clear_grid()

    s.put("nodes.force_int", np.zeros((s.n_nodes, 3)))
    transfer()
    g = grid_totals.to_numpy()
    after = (m[:, None] * s.fetch("nodes.grid_velocity")).sum(axis=0)
    scale = np.sum(m * np.linalg.norm(s.fetch("nodes.velocity"), axis=1))
    print(f"mass error {abs(g[0] - m.sum()):.1e}; P2G momentum error {np.abs(g[1:] - momentum).max():.1e}; "
          f"G2P momentum error {np.abs(after - momentum).max():.1e} (scale {scale:.2f})")
    assert abs(g[0] - m.sum()) < 1e-14 * m.sum()
    # clearing around the nodes leaves the whole grid empty for the next step
    assert not s.grid.mass.to_numpy().any() and not s.grid.momentum.to_numpy().any()
    assert getattr(s.grid, "force", None) is None or not s.grid.force.to_numpy().any()
    assert np.abs(g[1:] - momentum).max() < 1e-13 * scale
    assert np.abs(after - momentum).max() < 1e-13 * scale


def test_fine_grid_reproduces_fem(tmp_path):
    """h < d_min / (2 sqrt 3): no grid node is shared, so S = I and mpm == fem (method.md 9)."""
    runs = {}
    for method in ("fem", "mpm"):
        d = tmp_path / method
        d.mkdir()
        scene = plate_scene(d, lx=4.0, ly=1.0, nx=4, ny=1, E=1e5, t=0.1, method=method,
                            method_extra="cell_size = 0.25",
                            extra="[nodesets.clamp]\nplane = {point=[0,0,0], normal=[1,0,0]}\n"
                                  "[nodesets.tip]\nplane = {point=[4,0,0], normal=[1,0,0]}\n"
                                  "[[boundary]]\nnodes='clamp'\nfix='all'\n"
                                  "[[load]]\nnodes='tip'\nforce=[0.0, 0.0, 0.5]\n")
        sim = simulation(scene, d)
        sim.state.step.load_factor[None] = 1.0
        positions = []
        for _ in range(3):
            sim.stepper.advance(1 if not positions else 500)
            positions.append(sim.state.fetch("nodes.position"))
        runs[method] = np.array(positions)
    diff = np.abs(runs["mpm"] - runs["fem"]).max(axis=(1, 2))
    moved = np.abs(runs["fem"][-1] - runs["fem"][0]).max()
    print(f"|x_mpm - x_fem| after 1, 501, 1001 steps: {diff.tolist()} (tip moved {moved:.3f})")
    assert diff[0] < 1e-15 and diff[-1] < 1e-12 and moved > 1e-3
