"""Newton-Raphson statics with path following (``[solve].solver = "newton"``, issue 19;
docs/newton.md).

The shell's equations in the increment from the last converged point
(:class:`ShellEquations`): internal forces and tangent of a trial increment from
solvers/tangent.py (the explicit step's element pass, unchanged), assembled over the free
degrees of freedom (6 per node; fixed components dropped) into a sparse matrix and solved
by SuperLU (scipy.sparse.linalg.splu; the choice among the direct solvers is measured in
docs/newton.md).  The iterations and the path following are solvers/path.py.

Drivers (:func:`run_newton`), by ``[solve].control``:

* ``load``: the relaxation's schedule, load_steps equal load levels, each reached by
  Newton; a level whose iterations fail is approached in halved sub-steps (a cut-back;
  at most ``max_cutbacks`` halvings), which double again after each success.  One probes
  row per level.
* ``displacement``: the mean of ``control_dof`` over the node set ``control_nodes`` is
  prescribed in load_steps equal steps to ``control_displacement``; the load factor of the
  [[load]] pattern is the unknown (the reaction at the controlled DOF, in units of the
  pattern).  One row per step.
* ``arc_length``: Crisfield's cylindrical arc length from the arc ``arc_length`` (0: the
  linear solution's |W u| at load factor 1 over load_steps), adapted by the iteration
  count (ds x sqrt(target_iterations / iterations), within a factor 2 per point and at most
  MAX_ARC_GROWTH x the first), cut back by halving; it stops after load_steps points, when
  |lam| reaches ``max_load_factor``, or when the monitored DOF (``control_nodes`` /
  ``control_dof``) passes ``control_displacement``.  One row per converged point.

``mpm`` mode is refused (scene/solve.py): the double mapping is discussed in docs/newton.md.
"""
from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..nodesets import select_nodes
from ..run_control import RunControl, RunLoop
from ..scene import DOFS
from ..simulation import FAILURES, Simulation, SimulationError
from .path import JumpMonitor, PathError, Plan, Settings, follow
from .tangent import IncrementalForces

# SuperLU: minimum degree on K + K^T, pivots on the diagonal unless one is below 1 % of its
# column (the tangent is nearly symmetric); 6-14x faster than the default partial pivoting,
# which destroyed the symmetric ordering (docs/newton.md)
PERMUTATION = "MMD_AT_PLUS_A"
DIAGONAL_PIVOT = 0.01


class Factorization:
    """SuperLU of the tangent: ``solve(b)`` and ``sign`` (of the determinant: a change
    flags a limit or bifurcation point passed)."""

    def __init__(self, lu):
        self.lu = lu
        diag = lu.U.diagonal()
        negative = int(np.count_nonzero(diag < 0.0))
        self.sign = (-1) ** (negative + _parity(lu.perm_r) + _parity(lu.perm_c))

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self.lu.solve(b)


def _parity(perm: np.ndarray) -> int:
    """Parity of a permutation (number of transpositions mod 2), from its cycles."""
    seen = np.zeros(len(perm), bool)
    swaps = 0
    for i in range(len(perm)):
        if not seen[i]:
            j, length = i, 0
            while not seen[j]:
                seen[j] = True
                j = perm[j]
                length += 1
            swaps += length - 1
    return swaps % 2


def factorize(K) -> Factorization | None:
    try:
        return Factorization(spla.splu(K, permc_spec=PERMUTATION, diag_pivot_thresh=DIAGONAL_PIVOT,
                                       options={"SymmetricMode": True}))
    except RuntimeError:             # "Factor is exactly singular"
        return None


class ShellEquations:
    """The equilibrium of `sim`'s shell over its free DOFs, in the increment from the last
    converged point (solvers/path.Equations)."""

    def __init__(self, sim: Simulation):
        self.sim = sim
        model = sim.model
        self.forces = IncrementalForces(sim)
        n = len(model.points)
        fixed = ((model.fix_mask[:, None] >> np.arange(6)) & 1).astype(bool)
        used = np.zeros(n, bool)
        used[model.elements[model.elements >= 0]] = True
        fixed |= ~used[:, None]                         # a node of no element has no stiffness
        self.free = ~fixed.ravel()
        self.n = n
        index = np.full(6 * n, -1, np.int64)
        index[self.free] = np.arange(int(self.free.sum()))
        self.ndof = int(self.free.sum())
        L = model.mean_edge
        self.load = np.concatenate([model.load_force, model.load_moment], axis=1).ravel()[self.free]
        self.weight = np.tile([1.0, 1.0, 1.0, L, L, L], n)[self.free]
        # sparsity: every (row, col) of the tangent's entries between free DOFs (element blocks,
        # or the smoothed triangles' coloured columns: tangent.py), and the CSC slot of each
        # entry (duplicates summed by bincount)
        dof_rows, dof_cols = self.forces.entries
        rows = np.where(dof_rows >= 0, index[np.maximum(dof_rows, 0)], -1)
        cols = np.where(dof_cols >= 0, index[np.maximum(dof_cols, 0)], -1)
        self.keep = (rows >= 0) & (cols >= 0)
        keys = rows[self.keep] * self.ndof + cols[self.keep]
        unique, self.slot = np.unique(keys, return_inverse=True)
        self.pattern_rows = unique // self.ndof
        self.pattern_cols = unique % self.ndof
        self.nnz = len(unique)
        self.evaluations = 0
        self.tangents = 0
        self.tangent_seconds = 0.0
        self.solve_seconds = 0.0

    @classmethod
    def compiled(cls, sim: Simulation) -> "ShellEquations":
        """The equations of `sim` with their kernels compiled (a zero increment changes
        nothing), before the run's clock starts; the time joins ``sim.compile_seconds`` (and the
        process CPU time ``sim.compile_cpu_seconds``)."""
        t0, cpu0 = time.perf_counter(), time.process_time()
        eq = cls(sim)
        eq.forces.compile()
        sim.check_hourglass()           # its scalar reads compile on first use (~40 ms); nothing to check yet
        sim.compile_seconds += time.perf_counter() - t0
        sim.compile_cpu_seconds += time.process_time() - cpu0
        return eq

    def full(self, d: np.ndarray) -> np.ndarray:
        out = np.zeros(6 * self.n)
        out[self.free] = d
        return out.reshape(self.n, 6)

    def evaluate(self, d: np.ndarray, tangent: bool):
        t0 = time.perf_counter()
        failed = self.forces.evaluate(self.full(d), tangent)
        self.evaluations += 1
        self.tangents += int(tangent)
        self.tangent_seconds += time.perf_counter() - t0
        if failed >= 0:
            status = self.forces.v.step.status[None]
            what = FAILURES.get(status, ("element {index} failed", ""))[0].format(index=failed, ratio="")
            return None, None, f"trial increment rejected: {what}"
        f = self.forces.internal.ravel()[self.free].copy()
        K = None
        if tangent:
            data = np.bincount(self.slot, weights=self.forces.values()[self.keep], minlength=self.nnz)
            K = sp.csc_matrix((data, (self.pattern_rows, self.pattern_cols)), shape=(self.ndof, self.ndof))
        return f, K, ""

    def factorize(self, K):
        t0 = time.perf_counter()
        out = factorize(K)
        self.solve_seconds += time.perf_counter() - t0
        return out

    def selector(self, nodes: np.ndarray, dof: str) -> np.ndarray:
        """c with c . d = the mean of `dof` over `nodes` (free DOFs only; a fixed one adds 0)."""
        c = np.zeros(6 * self.n)
        c[6 * nodes + DOFS.index(dof)] = 1.0 / len(nodes)
        return c[self.free]


def run_newton(sim: Simulation, eq: ShellEquations, control: RunControl | None = None) -> dict:
    """Drive the static solve of `sim` (its equations `eq`, :meth:`ShellEquations.compiled`)
    by Newton with the scene's control (module docstring)."""
    scene = sim.scene
    sol = scene.solve
    settings = Settings(tolerance=sol.tolerance, increment_tolerance=sol.increment_tolerance,
                        energy_tolerance=sol.energy_tolerance, max_iterations=sol.max_iterations)
    selector = None
    if sol.control_nodes:
        selector = eq.selector(select_nodes(scene.nodeset(sol.control_nodes), sim.model.points), sol.control_dof)
    plan = Plan(control=sol.control, steps=sol.load_steps,
                final=1.0 if sol.control == "load" else sol.control_displacement, selector=selector,
                arc_length=sol.arc_length, max_load_factor=sol.max_load_factor,
                target_iterations=sol.target_iterations, max_cutbacks=sol.max_cutbacks)
    data = sim.driver_data
    data.setdefault("iterations", [])
    t_start = time.perf_counter()
    with RunLoop(sim, control) as loop:
        def accept(outcome, lam_old, record):
            _accept(sim, eq, outcome, lam_old, record, loop)

        try:
            jumps = JumpMonitor(sim.warn) if sol.control == "load" else None
            if jumps is not None:
                jumps.replay(data.get("level_increments", []))      # a restart: the steps before it
            follow(eq, settings, plan, accept, position=loop.resume, log=data, boundary=loop.boundary,
                   note=sim.progress, jumps=jumps)
            if jumps is not None:
                jumps.finish()
        except PathError as exc:
            raise SimulationError(str(exc)) from None
    its = data["iterations"]
    return {"solver": "newton", "control": sol.control, "points": len(its), "iterations": int(sum(its)),
            "iterations_per_point": list(its), "cutbacks": int(data["cutbacks"]),
            "limit_points": data["limit_points"],
            "tangent_evaluations": eq.tangents, "residual_evaluations": eq.evaluations - eq.tangents,
            "element_seconds": eq.tangent_seconds, "linear_solve_seconds": eq.solve_seconds,
            "equations": eq.ndof, "matrix_nonzeros": eq.nnz, "newton_seconds": time.perf_counter() - t_start}


def _accept(sim, eq, outcome, lam_old, record, loop):
    """Commit a converged point: state, energies, reaction, counters (one launch:
    tangent.IncrementalForces._commit), record, progress."""
    lam = outcome.lam
    # eq.forces.internal: the converged iterate's forces (its last evaluation)
    eq.forces.commit(eq.full(outcome.d), eq.forces.internal, lam_old, lam, outcome.iterations)
    sim.total_steps += outcome.iterations
    sim.driver_data["iterations"].append(outcome.iterations)
    sim.check_hourglass()
    if record:
        loop.record(lam, frame=sim.scene.output.load_steps)
    ratios = " ".join(f"{r:.1e}" for r in outcome.residual_ratios)
    loop.note(f"point {len(sim.driver_data['iterations']):3d}  lambda {lam:+.5f}  iterations {outcome.iterations:2d}"
              f"  residual/load {ratios}")
