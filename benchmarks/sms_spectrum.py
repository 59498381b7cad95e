"""What step each form of selective mass scaling allows, from the spectrum (issue 29).

For a small shell mesh: the shell's tangent stiffness K at rest (solvers/tangent.py, the
explicit element's own forces by central differences), the lumped masses M of a dynamic
run (model/assembly.py) and, per element, the added mass M_add^e of
stages/selective_mass.py's T_add^e (rigid fit of the corners in the mass metric, the
deformation and the rotations' departure from the element's spin), all at
beta = (target / step)^2 - 1.  Then the highest frequency omega_max of K against

- ``lumped``: M (no scaling; the reference step 2 / omega_max),
- ``consistent``: M + sum_e M_add^e (``sms_solve = "pcg"``, solved to convergence),
- ``element``: the reciprocal mass matrix of element blocks, A = sum_e S_e^T B_e^-1 S_e,
  B_e = M_e + M_add^e, S_e the corners' mass shares (``sms_solve = "reciprocal"``),
- ``patch``: the same with node patches as blocks: for each node, the elements around it,
  each element's corners in 1 / (its corner count) of their masses, and as the block the
  sum of those elements' own blocks B_e / k (the true matrix's share of the patch), inverted
  whole,
- ``patch-fit``: the patch as one element of T_add (one rigid fit over the patch's nodes,
  which a closed-form inverse would need),
- ``split``: the rotations eliminated exactly (their rows of M + M_add are 3 x 3 blocks per
  node), the translations' Schur complement by element blocks, each element's own
  translational block less its coupling through its corners' whole rotation blocks,

and, for the element blocks, the least degree d of a fixed polynomial a = p_d(A Km) A f that
keeps the low modes (|1 - q| <= 0.01 for lambda in [1, 1.05], q(lambda) = lambda p(lambda))
and 0 < q <= 1.3 up to the largest lambda of A Km (a linear program over Chebyshev
coefficients): each degree is one product with Km and one with A, i.e. one iteration,

the lowest few frequencies of each against the lumped ones (the physical modes the scaling
must leave alone).  The step gain is omega_max(lumped) / omega_max(form).

    python benchmarks/sms_spectrum.py [--case plate|plate-fine|tube] [--factor 10]
"""
import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
import scipy.linalg as sl
from numpy.polynomial import chebyshev
from scipy.optimize import linprog

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SCENE = """
material = {{ E = 200.0, nu = 0.3, density = 7.85e-6 }}
section = {{ thickness = 1.0, points = 3, rule = "lobatto" }}
element = {{ hourglass = 0.01 }}
method = {{ kind = "fem" }}
nodesets = {{ corner = {{ ids = [0] }} }}
load = [{{ nodes = "corner", force = [0.0, 0.0, 1.0] }}]
[scene]
name = "spectrum"
units = "kN-mm-ms-kg"
[mesh]
{mesh}
[solve]
{solve}
"""
MESHES = {
    "plate": 'kind = "plate"\nlx = 80.0\nly = 20.0\nnx = 16\nny = 4',
    "plate-fine": 'kind = "plate"\nlx = 80.0\nly = 20.0\nnx = 32\nny = 8',
    "tube": ('kind = "tube"\nwidth = 30.0\ndepth = 30.0\ncorner_radius = 5.0\nlength = 40.0\n'
             'n_flat = 4\nn_corner = 2\nn_length = 8'),
}


def build(case: str, tmp: Path):
    """(model of a dynamic run, K over all 6 n DOFs at rest)."""
    from taichi_shell_mpm.mesh import build_mesh
    from taichi_shell_mpm.model.assembly import assemble
    from taichi_shell_mpm.runtime import init_taichi
    from taichi_shell_mpm.scene import load_scene
    from taichi_shell_mpm.simulation import Simulation

    def scene(solve):
        path = tmp / f"{case}-{len(solve)}.toml"
        path.write_text(SCENE.format(mesh=MESHES[case], solve=solve))
        return load_scene(path)

    dynamic = scene('kind = "dynamic"\nend_time = 1.0')
    model = assemble(dynamic, build_mesh(dynamic.mesh))
    static = scene('kind = "static"\nsolver = "newton"')
    init_taichi("cpu")
    sim = Simulation(static, tmp / "out", quiet=True)
    eq_all = _all_dofs(sim)
    _, K, message = eq_all.evaluate(np.zeros(eq_all.ndof), True)
    assert K is not None, message
    K = K.toarray()
    return model, 0.5 * (K + K.T)


def _all_dofs(sim):
    """ShellEquations over every DOF of `sim` (no support): the free shell's tangent."""
    from taichi_shell_mpm.solvers.newton import ShellEquations
    fix = sim.model.fix_mask.copy()
    sim.model.fix_mask[:] = 0
    try:
        eq = ShellEquations(sim)
    finally:
        sim.model.fix_mask[:] = fix
    eq.forces.compile()
    return eq


def element_added(x, m, rho2, normal):
    """The 24 x 24 added mass of T_add / beta over the corners x (k, 3) with masses m (k,):
    L^T W L, L the map from (v, omega) to (d_a, P (omega_a - Omega)) (selective_mass.py)."""
    k = len(m)
    mass = m.sum()
    centre = (m[:, None] * x).sum(0) / mass
    r = x - centre
    J = sum(m[a] * (r[a] @ r[a] * np.eye(3) - np.outer(r[a], r[a])) for a in range(k))
    Jinv = np.linalg.inv(J)
    P = np.eye(3) - np.outer(normal, normal)
    L = np.zeros((6 * k, 6 * k))
    for col in range(6 * k):
        u = np.zeros(6 * k)
        u[col] = 1.0
        v, w = u.reshape(k, 6)[:, :3], u.reshape(k, 6)[:, 3:]
        vbar = (m[:, None] * v).sum(0) / mass
        spin = Jinv @ sum(m[a] * np.cross(r[a], v[a]) for a in range(k))
        d = v - vbar - np.cross(spin, r)
        e = (w - spin) @ P.T
        L[:, col] = np.concatenate([d, e], axis=1).ravel()
    W = np.stack([m, m, m, m * rho2, m * rho2, m * rho2], axis=1).ravel()
    return L.T @ (W[:, None] * L)


def forms(model, beta: float):
    """The mass forms of the module docstring, as (name, kind, matrix): kind "mass" or "inverse"."""
    x0, elements = model.points, model.elements
    n = len(x0)
    cm, cj = model.corner_mass, model.corner_inertia
    node_m = np.zeros(n)
    node_j = np.zeros(n)
    corners = elements >= 0
    np.add.at(node_m, elements[corners], cm[corners])
    np.add.at(node_j, elements[corners], cj[corners])
    M = np.diag(np.stack([node_m] * 3 + [node_j] * 3, axis=1).ravel())
    dofs = lambda nodes: (6 * np.asarray(nodes)[:, None] + np.arange(6)).ravel()     # noqa: E731
    blocks = []           # per element: (dofs, its own block B_e, its corner masses, inertias)
    normal_sum = np.zeros((n, 3))
    M_add = np.zeros_like(M)
    for e, row in enumerate(elements):
        c = row[row >= 0]
        x, m, j = x0[c], cm[e][row >= 0], cj[e][row >= 0]
        nrm = np.cross(x[2] - x[0], x[3] - x[1]) if len(c) == 4 else np.cross(x[1] - x[0], x[2] - x[0])
        np.add.at(normal_sum, c, nrm)
        nrm = nrm / np.linalg.norm(nrm)
        rho2 = (m * ((x - (m[:, None] * x).sum(0) / m.sum()) ** 2).sum(1)).sum() / (2 * m.sum())
        added = beta * element_added(x, m, rho2, nrm)
        own = np.diag(np.stack([m, m, m, j, j, j], axis=1).ravel()) + added
        M_add[np.ix_(dofs(c), dofs(c))] += added
        blocks.append((c, own, m, j))
    share = np.stack([node_m] * 3 + [node_j] * 3, axis=1).ravel()

    def reciprocal(patches):
        """sum_p S_p^T B_p^-1 S_p over patches [(nodes, B_p, masses (nodes, 6))]."""
        A = np.zeros_like(M)
        for nodes, B, w in patches:
            idx = dofs(nodes)
            S = np.diag(w.ravel() / share[idx])
            A[np.ix_(idx, idx)] += S @ np.linalg.solve(B, S)
        return A

    element = reciprocal([(c, B, np.stack([m, m, m, j, j, j], axis=1)) for c, B, m, j in blocks])
    node_elements = [[] for _ in range(n)]
    for e, row in enumerate(elements):
        for c in row[row >= 0]:
            node_elements[c].append(e)
    patch, patch_fit = [], []
    for centre in range(n):
        nodes = np.unique(np.concatenate([elements[e][elements[e] >= 0] for e in node_elements[centre]]))
        where = {c: i for i, c in enumerate(nodes)}
        B = np.zeros((6 * len(nodes), 6 * len(nodes)))
        w = np.zeros((len(nodes), 6))
        for e in node_elements[centre]:
            c, own, m, j = blocks[e]
            k = len(c)
            local = dofs([where[i] for i in c])
            B[np.ix_(local, local)] += own / k
            for a, i in enumerate(c):
                w[where[i]] += np.array([m[a]] * 3 + [j[a]] * 3) / k
        patch.append((nodes, B, w))
        x = x0[nodes]
        mu = w[:, 0]
        rho2 = (mu * ((x - (mu[:, None] * x).sum(0) / mu.sum()) ** 2).sum(1)).sum() / (2 * mu.sum())
        nrm = normal_sum[centre] / np.linalg.norm(normal_sum[centre])
        patch_fit.append((nodes, np.diag(w.ravel()) + beta * element_added(x, mu, rho2, nrm), w))
    return M, [("lumped", "mass", M), ("consistent", "mass", M + M_add), ("element", "inverse", element),
               ("patch", "inverse", reciprocal(patch)), ("patch-fit", "inverse", reciprocal(patch_fit)),
               ("split", "inverse", split(M + M_add, blocks, share))]


def split(Km, blocks, share):
    """The inverse of Km by its rotation / translation split (module docstring, ``split``):
    [[S^-1, -S^-1 C R^-1], [., R^-1 + R^-1 C^T S^-1 C R^-1]] with S^-1 by element blocks."""
    n = len(Km) // 6
    t = (6 * np.arange(n)[:, None] + np.arange(3)).ravel()
    r = t + 3
    C, R = Km[np.ix_(t, r)], Km[np.ix_(r, r)]
    R_inv = sl.block_diag(*[np.linalg.inv(R[3 * c:3 * c + 3, 3 * c:3 * c + 3]) for c in range(n)])
    S_inv = np.zeros((3 * n, 3 * n))
    for c, own, m, _ in blocks:
        k = len(c)
        lt = (6 * np.arange(k)[:, None] + np.arange(3)).ravel()
        idx = (3 * c[:, None] + np.arange(3)).ravel()
        coupling = own[np.ix_(lt, lt + 3)]
        schur = own[np.ix_(lt, lt)] - coupling @ R_inv[np.ix_(idx, idx)] @ coupling.T
        shares = np.diag(np.repeat(m, 3) / share[(6 * c[:, None] + np.arange(3)).ravel()])
        S_inv[np.ix_(idx, idx)] += shares @ np.linalg.solve(schur, shares)
    A = np.zeros_like(Km)
    X = -S_inv @ C @ R_inv
    A[np.ix_(t, t)], A[np.ix_(t, r)], A[np.ix_(r, t)] = S_inv, X, X.T
    A[np.ix_(r, r)] = R_inv + R_inv @ C.T @ S_inv @ C @ R_inv
    return 0.5 * (A + A.T)


def polynomial_degree(L: float, most: int = 16) -> int | None:
    """The least d for which a polynomial q(lambda) = lambda p_d(lambda) exists with
    |1 - q| <= 0.01 on [1, 1.05] and 0.02 <= q <= 1.3 on [1.05, L] (module docstring)."""
    lam = np.concatenate([np.linspace(1.0, 1.05, 50), np.linspace(1.05, L, 3000)])
    near = lam <= 1.05
    for d in range(1, most + 1):
        # unknowns: the Chebyshev coefficients of s = 1 - q on [0, L]; s(0) = 1
        V = chebyshev.chebvander(2.0 * lam / L - 1.0, d)
        upper = np.where(near, 0.01, 0.98)          # s <= ...
        lower = np.where(near, -0.01, -0.3)         # s >= ...
        res = linprog(np.zeros(d + 1), A_ub=np.vstack([V, -V]), b_ub=np.concatenate([upper, -lower]),
                      A_eq=chebyshev.chebvander(np.array([-1.0]), d), b_eq=[1.0],
                      bounds=[(None, None)] * (d + 1), method="highs")
        if res.status == 0:
            return d
    return None


def spectrum(K, kind, X):
    """(frequencies^2, mode shapes) of K against the mass X (kind "mass") or the inverse mass X
    ("inverse": X = C C^T, the modes C q of C^T K C q = w^2 q)."""
    if kind == "mass":
        return sl.eigh(K, X)
    C = np.linalg.cholesky(X)
    w2, Q = np.linalg.eigh(C.T @ K @ C)
    return w2, C @ Q


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", choices=sorted(MESHES), default="plate")
    parser.add_argument("--factor", type=float, default=10.0, help="target step / the elements' own step")
    parser.add_argument("--modes", type=int, default=3, help="lowest transverse modes reported")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        model, K = build(args.case, Path(tmp))
    beta = args.factor ** 2 - 1.0
    M, cases = forms(model, beta)
    consistent = cases[1][2]
    w0, V0 = spectrum(K, "mass", M)
    # the lowest elastic modes of the lumped shell that move mostly out of its plane (uz for
    # the plate; for the tube, the modes past the six rigid ones), tracked in each form by
    # their largest mass-weighted overlap
    uz = (V0.T.reshape(len(w0), -1, 6)[:, :, 2] ** 2).sum(1) / (V0 ** 2).sum(0) if args.case.startswith("plate") else None
    low = [i for i in range(6, len(w0)) if uz is None or uz[i] > 0.5][:args.modes]
    print(f"{args.case}: {len(model.elements)} elements, {len(model.points)} nodes; target {args.factor:g}x "
          f"(beta = {beta:g}); lumped lowest modes {', '.join(f'{np.sqrt(w0[i]):.4g}' for i in low)} rad/ms")
    # the rigid motions (3 translations, 3 rotations about the centroid): A Km u = u where exact
    x = model.points - model.points.mean(0)
    rigid = []
    for d in range(6):
        u = np.zeros((len(x), 6))
        if d < 3:
            u[:, d] = 1.0
        else:
            axis = np.eye(3)[d - 3]
            u[:, :3], u[:, 3:] = np.cross(axis, x), axis
        rigid.append(u.ravel())
    print(f"{'form':<11} {'step gain':>9} {'lambda(A Km)':>17} {'rigid error':>11}   lowest modes / lumped")
    for name, kind, X in cases:
        w2, U = spectrum(K, kind, X)
        norm = np.sqrt(np.einsum("ij,ij->j", U, M @ U))
        ratios = [np.sqrt(w2[np.argmax(np.abs(V0[:, i] @ M @ U) / norm)] / w0[i]) for i in low]
        spread, rigid_error = "-", "-"
        if kind == "inverse":
            C = np.linalg.cholesky(X)
            lam = np.linalg.eigvalsh(C.T @ consistent @ C)
            spread = f"{lam.min():.2f}..{lam.max():.1f}"
            rigid_error = f"{max(np.abs(X @ consistent @ u - u).max() / np.abs(u).max() for u in rigid):.1e}"
            if name == "element":
                degree = polynomial_degree(lam.max())
        print(f"{name:<11} {np.sqrt(w0.max() / w2.max()):9.2f} {spread:>17} {rigid_error:>11}   "
              + " ".join(f"{r:.4f}" for r in ratios))
    print(f"a fixed polynomial in the element blocks needs degree {degree} (products with Km and A per step)")


if __name__ == "__main__":
    main()
