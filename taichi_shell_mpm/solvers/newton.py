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

``mpm`` mode is refused (scene.py): the double mapping is discussed in docs/newton.md.
"""
from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..checkpoint import RunControl
from ..nodesets import select_nodes
from ..scene import DOFS
from ..simulation import Simulation, SimulationError
from .path import Control, JumpMonitor, Settings, newton_point, weighted
from .tangent import DOFS_PER_ELEMENT, IncrementalForces

MAX_ARC_GROWTH = 16.0        # arc length: at most this x the first one
# SuperLU: minimum degree on K + K^T, pivots on the diagonal unless one is below 1 % of its
# column (the tangent is nearly symmetric); 6-14x faster than the default partial pivoting,
# which destroyed the symmetric ordering (docs/newton.md)
PERMUTATION = "MMD_AT_PLUS_A"
DIAGONAL_PIVOT = 0.01
SECANT_PREDICTOR = True         # load/displacement control: start from the last increment, scaled


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
        # sparsity: every (row, col) of the element blocks between free DOFs, and the CSR slot
        # of each element entry (duplicates summed by bincount)
        corners = model.elements
        dof = np.where(corners[:, :, None] >= 0, 6 * corners[:, :, None] + np.arange(6), -1).reshape(-1, DOFS_PER_ELEMENT)
        local = np.where(dof >= 0, index[np.maximum(dof, 0)], -1)
        rows = np.broadcast_to(local[:, :, None], (len(corners), 24, 24)).ravel()
        cols = np.broadcast_to(local[:, None, :], (len(corners), 24, 24)).ravel()
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

    def compile(self) -> None:
        """The kernels of the run, before its clock starts (a zero increment changes nothing)."""
        self.forces.compile()
        self.sim.state.put("nodes.energy", self.sim.state.fetch("nodes.energy"))

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
            from ..simulation import FAILURES
            what = FAILURES.get(status, ("element {index} failed", ""))[0].format(index=failed, ratio="")
            return None, None, f"trial increment rejected: {what}"
        f = self.forces.internal.ravel()[self.free].copy()
        K = None
        if tangent:
            data = np.bincount(self.slot, weights=self.forces.stiffness.ravel()[self.keep], minlength=self.nnz)
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


def run_newton(sim: Simulation, control: RunControl | None = None) -> dict:
    """Drive the static solve of `sim` by Newton with the scene's control (module docstring)."""
    control = control or RunControl()
    scene = sim.scene
    sol = scene.solve
    eq = sim.newton
    settings = Settings(tolerance=sol.tolerance, increment_tolerance=sol.increment_tolerance,
                        energy_tolerance=sol.energy_tolerance, max_iterations=sol.max_iterations)
    data = sim.driver_data
    pos = control.resume or {"level": 1, "lam": 0.0, "step": 0.0, "arc": 0.0, "peak": 0.0}
    data.setdefault("iterations", [])
    data.setdefault("cutbacks", 0)
    data.setdefault("limit_points", [])
    control.start(sim)
    reporter = sim.reporter
    reporter.start(int(sim.state.step.step[None]), None)
    jumps = JumpMonitor(sim.warn)
    selector = None
    if sol.control_nodes:
        selector = eq.selector(select_nodes(scene.nodeset(sol.control_nodes), sim.model.points), sol.control_dof)
    t_start = time.perf_counter()
    try:
        if sol.control == "arc_length":
            _arc_length(sim, eq, settings, control, pos, selector)
        else:
            _stepped(sim, eq, settings, control, pos, selector, jumps)
        jumps.finish()
    finally:
        sim.run_seconds = control.run_seconds()
        reporter.close()
    its = data["iterations"]
    return {"solver": "newton", "control": sol.control, "points": len(its), "iterations": int(sum(its)),
            "iterations_per_point": list(its), "cutbacks": int(data["cutbacks"]),
            "limit_points": data["limit_points"],
            "tangent_evaluations": eq.tangents, "residual_evaluations": eq.evaluations - eq.tangents,
            "element_seconds": eq.tangent_seconds, "linear_solve_seconds": eq.solve_seconds,
            "equations": eq.ndof, "matrix_nonzeros": eq.nnz, "newton_seconds": time.perf_counter() - t_start}


def _point(eq, lam0, ctl, settings, scale, d0=None):
    """Newton on one point: full steps, then (load and displacement control) once more with
    the energy line search if that failed (solvers/path.py)."""
    outcome = newton_point(eq, lam0, ctl, settings, lam_scale=scale, d0=d0)
    if not outcome.converged and ctl.kind != "arc_length":
        retry = newton_point(eq, lam0, ctl, dataclasses.replace(settings, line_search=True), lam_scale=scale, d0=d0)
        if retry.converged:
            return retry
    return outcome


def _accept(sim, eq, outcome, lam_old, key, frame, control):
    """Commit a converged point: state, energies, reaction, counters, record, progress."""
    d = eq.full(outcome.d)
    internal = eq.forces.internal.copy()            # at the converged iterate (its last evaluation)
    eq.forces.commit(d)
    model, st = sim.model, sim.state.step
    lam = outcome.lam
    load = np.concatenate([model.load_force, model.load_moment], axis=1)
    work = 0.5 * (lam_old + lam) * np.sum(load * d, axis=1)          # trapezoidal: dead loads
    energy = sim.state.fetch("nodes.energy")
    energy[:, 0] += work
    sim.state.put("nodes.energy", energy)
    element = sim.state.fetch("elements.energy").sum(axis=0)
    st.internal_energy[None], st.plastic_work[None] = element[0], element[1]
    st.hourglass_energy[None], st.drilling_energy[None] = element[2], element[3]
    st.external_work[None] = float(energy[:, 0].sum())
    fixed = (model.fix_mask & 0b111) == 0b111
    st.reaction[None] = (internal[fixed, :3] - lam * model.load_force[fixed]).sum(axis=0)
    st.load_factor[None] = lam
    st.step[None] += outcome.iterations
    sim.total_steps += outcome.iterations
    sim.driver_data["iterations"].append(outcome.iterations)
    sim.check_hourglass()
    if key is not None:
        sim.record(lam, frame=frame)
    ratios = " ".join(f"{r:.1e}" for r in outcome.residual_ratios)
    sim.progress(f"point {len(sim.driver_data['iterations']):3d}  lambda {lam:+.5f}  iterations {outcome.iterations:2d}"
                 f"  residual/load {ratios}  [{control.run_seconds():.1f} s]")


def _stepped(sim, eq, settings, control, pos, selector, jumps):
    """Load or displacement control: load_steps equal steps of the load factor or of the
    controlled displacement, each reached in sub-steps that are halved on failure."""
    sol = sim.scene.solve
    n_levels = sol.load_steps
    displacement = sol.control == "displacement"
    final = sol.control_displacement if displacement else 1.0
    j, lam = int(pos["level"]), float(pos["lam"])
    done = (j - 1) / n_levels * final                # the controlled quantity reached
    sub = float(pos.get("step") or final / n_levels)
    moved = 0.0
    last = None                                      # (d, control increment, load factor increment)
    sign = None                                      # of det K at the last converged point
    peak = float(pos.get("peak", 0.0))
    while j <= n_levels:
        target = j / n_levels * final
        cuts = 0
        start_lam = lam
        moved = 0.0
        sign_change = False
        while abs(target - done) > 1e-12 * abs(final):
            value = done + math.copysign(min(abs(sub), abs(target - done)), target - done)
            if displacement:
                ctl = Control("displacement", value, selector=selector, start=done)
            else:
                ctl = Control("load", value)
            d0, lam0 = None, lam
            if last is not None and SECANT_PREDICTOR:       # extrapolate the last increment
                ratio = (value - done) / last[1]
                d0, lam0 = ratio * last[0], lam + ratio * last[2]
            scale = abs(value) if not displacement else 0.1 * peak
            outcome = _point(eq, lam0, ctl, settings, scale, d0)
            if not outcome.converged:
                cuts += 1
                sim.driver_data["cutbacks"] += 1
                if cuts > sol.max_cutbacks:
                    what = "displacement" if displacement else "load factor"
                    raise SimulationError(
                        f"load step {j}/{n_levels} ({what} {target:.4g}): Newton failed from {what} {done:.4g} after "
                        f"{sol.max_cutbacks} cut-backs of the increment ({outcome.message}); raise load_steps or "
                        "[solve].max_cutbacks, or follow the path with control = \"arc_length\"")
                sub *= 0.5
                sim.progress(f"load step {j}/{n_levels}: {outcome.message}; cut back to {abs(sub):.3g}")
                continue
            reached = abs(value - target) <= 1e-12 * abs(final)
            moved += weighted(outcome.d, eq.weight) if not displacement else 0.0
            sign_change |= sign is not None and outcome.sign != sign
            sign = outcome.sign
            peak = max(peak, abs(outcome.lam))
            last = (outcome.d, value - done, outcome.lam - lam)
            _accept(sim, eq, outcome, lam, target if reached else None, sim.scene.output.load_steps, control)
            lam, done = outcome.lam, (target if reached else value)
            if cuts == 0 and abs(sub) < final / n_levels:
                sub *= 2.0                                          # recover after a cut-back
        if not displacement:
            jumps.add(lam, moved, sign_change)
        _limit_check(sim, start_lam, lam)
        j += 1
        control.boundary(sim, {"level": j, "lam": lam, "step": sub, "peak": peak})


def _limit_check(sim, lam_a, lam_b) -> None:
    """Displacement or arc-length control: remember where the load factor turned."""
    data = sim.driver_data
    trend = data.get("trend", 0.0)
    change = lam_b - lam_a
    if change != 0.0:
        if trend != 0.0 and (change > 0) != (trend > 0):
            data["limit_points"].append(float(lam_a))
        data["trend"] = change


def _arc_length(sim, eq, settings, control, pos, selector):
    sol = sim.scene.solve
    data = sim.driver_data
    j, lam = int(pos["level"]), float(pos["lam"])
    peak = float(pos.get("peak", 0.0))
    ds = float(pos.get("arc") or 0.0)
    if ds == 0.0:
        ds = sol.arc_length
        if ds == 0.0:                     # the linear solution at load factor 1, over load_steps points
            f, K, message = eq.evaluate(np.zeros(eq.ndof), True)
            solver = eq.factorize(K) if f is not None else None
            if solver is None:
                raise SimulationError(f"arc length: the initial tangent cannot be factorized ({message or 'singular'})")
            ds = weighted(solver.solve(eq.load), eq.weight) / sol.load_steps
    ds_max = MAX_ARC_GROWTH * ds
    data.setdefault("first_arc", ds)
    ds_max = MAX_ARC_GROWTH * float(data["first_arc"])
    previous = np.asarray(data["previous"]) if data.get("previous") is not None else None
    monitor = float(data.get("monitor", 0.0))
    cuts = 0
    while j <= sol.load_steps:
        ctl = Control("arc_length", ds, previous=previous)
        outcome = _point(eq, lam, ctl, settings, 0.1 * peak)
        if not outcome.converged:
            cuts += 1
            data["cutbacks"] += 1
            if cuts > sol.max_cutbacks:
                raise SimulationError(
                    f"arc length point {j} (load factor {lam:.4g}): Newton failed after {sol.max_cutbacks} cut-backs "
                    f"of the arc length to {ds:.3g} ({outcome.message}); lower [solve].arc_length or raise "
                    "max_cutbacks")
            ds *= 0.5
            sim.progress(f"point {j}: {outcome.message}; arc length cut back to {ds:.3g}")
            continue
        _limit_check(sim, lam, outcome.lam)
        _accept(sim, eq, outcome, lam, outcome.lam, sim.scene.output.load_steps, control)
        previous = outcome.d.copy()
        lam = outcome.lam
        peak = max(peak, abs(lam))
        if selector is not None:
            monitor += float(selector @ outcome.d)
        iterations = max(outcome.iterations, 1)
        grow = math.sqrt(sol.target_iterations / iterations)
        ds = min(ds * min(max(grow, 0.5), 2.0), ds_max) if cuts == 0 else ds
        cuts = 0
        j += 1
        data["previous"] = previous.tolist()
        data["monitor"] = monitor
        stop = abs(lam) >= sol.max_load_factor or (
            selector is not None and sol.control_displacement != 0.0
            and monitor / sol.control_displacement >= 1.0)
        if stop:
            j = sol.load_steps + 1
        control.boundary(sim, {"level": j, "lam": lam, "arc": ds, "peak": peak})
