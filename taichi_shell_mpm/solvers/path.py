"""Newton-Raphson on a static equilibrium with path following (issue 19): the numerics,
independent of the shell (the shell's equations are solvers/newton.ShellEquations; a
closed-form two-bar truss in tests/test_newton.py uses the same code).

Equations.  Unknowns: the increment d of the free degrees of freedom from the last
converged point and the load factor lam; residual r = lam F - f_int(d) (F: the load
pattern, f_int: resisting forces); tangent K = df_int/dd.  One Newton iteration solves
K da = r and, when lam is an unknown, K db = F, and takes d += da + dlam db with dlam from
the control (Batoz & Dhatt 1979; Crisfield 1981):

* load control: lam fixed (dlam = 0);
* displacement control: c . (d + da + dlam db) = eta, c the mean of a node set's degree of
  freedom (linear: met exactly from the first iteration);
* arc length (Crisfield's cylindrical form): |W (d + da + dlam db)| = ds, W = 1 for
  translations and the reference length L for rotations; of the two roots the one that
  keeps the increment closest to its direction before the iteration (the first iteration of
  a point: the one along the previous point's increment, Feng et al. 1996 / Crisfield
  1997 s. 9.5; the very first: load rising).  No real root: the point is cut back.

Convergence (all three): |r|_w <= tolerance |lam F|_w (today's relaxation criterion;
moments / L in the norm), |W delta|  <= increment_tolerance |W d| (the last correction
against the increment), |delta . K delta| <= energy_tolerance x that of the first correction
(delta . K delta = delta . (r + dlam F): the energy of a correction).  Path following near lam = 0 measures the
residual against max(|lam|, 0.1 max |lam| so far) F.

Evaluations.  The tangent is computed with a trial when the residual the trial corrects is
above sqrt(tolerance) of the load: from there one quadratically converging step does not
reach the tolerance, so the iterations go on and need it [choice, measured: one launch
instead of two per iteration, docs/newton.md].  Closer in, the trial is evaluated without it
(the forces alone: 1/49 of a tangent evaluation, solvers/tangent.py) and the tangent is
computed afterwards only if the point is not converged, so the converged iterate of a point
costs no tangent.

Steps.  A full Newton step is taken unless its evaluation fails (an element inside out, a
return map that does not converge): then the step is halved (back-tracking, at most
LINE_SEARCH_TRIALS times).  With ``Settings.line_search`` (load and displacement control)
Crisfield's energy line search is used instead: the step s along the correction is
accepted when |delta . r(s)| <= LINE_SEARCH_RATIO |delta . r(0)|, else s from regula falsi
on delta . r(s) (at most LINE_SEARCH_TRIALS evaluations).  The drivers try a point with
plain steps first and with the line search when they fail, before cutting the increment
back [choice, measured]: on the thin cantilever the first load step's linear predictor
stretches the strip (membrane strains ~ w'^2 / 2: residual 3 100 x the load), the full
Newton steps converge from there in 5 iterations, while the energy line search, which
reads the huge axial residual as an overshoot of the transverse correction, took 18.  A
point fails when its residual grew for DIVERGING_ITERATIONS iterations in a row, is not
finite, or is not converged after max_iterations; the driver then cuts the increment
back (solvers/newton.py).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

LINE_SEARCH_RATIO = 0.8
LINE_SEARCH_TRIALS = 4
DIVERGING_ITERATIONS = 4
JUMP_RATIO = 5.0          # a load step's displacement increment this many times its neighbours': a jump


@dataclass(frozen=True)
class Settings:
    tolerance: float = 1e-4
    increment_tolerance: float = 1e-3
    energy_tolerance: float = 1e-6
    max_iterations: int = 20
    line_search: bool = False


@dataclass
class Control:
    """What fixes the load factor of a point: ``kind`` "load" (lam = target), "displacement"
    (c . d_total = target, `selector` c over the free DOFs, `start` c . d_total at the last
    point) or "arc_length" (|W d| = target)."""
    kind: str
    target: float
    selector: np.ndarray | None = None
    start: float = 0.0
    previous: np.ndarray | None = None      # arc length: the last point's increment (direction)


@dataclass
class Outcome:
    converged: bool
    d: np.ndarray
    lam: float
    iterations: int
    residual_ratios: list[float] = field(default_factory=list)
    """|r| / reference load after each evaluation (the last is the converged one)."""
    sign: int = 0
    """Sign of det K at the last factorization (next to the converged point): a change from
    one point to the next says a limit or bifurcation point was passed."""
    message: str = ""


class Equations:
    """The interface the iterations need (ShellEquations, tests' closed forms):

    ``load`` (F over the free DOFs), ``weight`` (W: 1 or L per DOF), ``evaluate(d, tangent)``
    -> (f_int or None when an element failed, K (sparse) or None, message), and
    ``factorize(K)`` -> an object with ``solve(b)`` and ``sign`` (of det K)."""
    load: np.ndarray
    weight: np.ndarray


def weighted(v: np.ndarray, w: np.ndarray) -> float:
    return float(np.linalg.norm(v * w))


def residual_norm(r: np.ndarray, w: np.ndarray) -> float:
    """Forces as they are, moments / L (today's relaxation residual)."""
    return float(np.linalg.norm(r / w))


def newton_point(eq, lam0: float, control: Control, settings: Settings, lam_scale: float,
                 d0: np.ndarray | None = None) -> Outcome:
    """Iterate one point of the path from the last converged point (d = 0, lam = lam0).
    `lam_scale`: the load factor the residual is measured against (at least |lam|)."""
    F, W = eq.load, eq.weight
    d = np.zeros_like(F) if d0 is None else d0.copy()
    lam = control.target if control.kind == "load" else lam0
    f, K, message = eq.evaluate(d, True)
    out = Outcome(False, d, lam, 0)
    if f is None:
        out.message = message
        return out
    first_energy = None
    last_delta = None
    last_energy = None
    r0 = None
    growing = 0
    for it in range(settings.max_iterations + 1):
        r = lam * F - f
        reference = max(abs(lam), lam_scale) * residual_norm(F, W)
        rnorm = residual_norm(r, W)
        ratio = rnorm / reference if reference > 0 else rnorm
        out.residual_ratios.append(ratio)
        if not math.isfinite(rnorm):
            out.message = "the residual is not finite"
            return out
        if r0 is not None and rnorm > r0:
            growing += 1
            if growing >= DIVERGING_ITERATIONS:
                out.message = f"diverged (residual {ratio:.2e} of the load, growing for {growing} iterations)"
                return out
        else:
            growing = 0
        r0 = rnorm
        if last_delta is not None and ratio <= settings.tolerance:
            dn = weighted(d, W)
            inc_ok = weighted(last_delta, W) <= settings.increment_tolerance * max(dn, 1e-300)
            energy_ok = last_energy <= settings.energy_tolerance * max(first_energy, 1e-300)
            if inc_ok and energy_ok:
                out.converged, out.d, out.lam, out.iterations = True, d, lam, it
                return out
        if it == settings.max_iterations:
            out.message = f"not converged in {settings.max_iterations} iterations (residual {ratio:.2e} of the load)"
            return out
        if K is None:                   # the tangent where the trial was not converged (module docstring)
            f, K, message = eq.evaluate(d, True)
            if f is None:
                out.message = message
                return out
        solver = eq.factorize(K)
        if solver is None:
            out.message = "the tangent stiffness is singular"
            return out
        out.sign = solver.sign
        da = solver.solve(r)
        dlam = 0.0
        if control.kind != "load":
            db = solver.solve(F)
            if control.kind == "displacement":
                c = control.selector
                dlam = (control.target - control.start - c @ (d + da)) / (c @ db)
            else:
                roots = _arc_roots(d + da, db, W, control.target)
                if roots is None:
                    out.message = "the arc-length constraint has no real root"
                    return out
                dlam = _choose_root(roots, d, da, db, W, control.previous, it)
        delta = da + dlam * db if control.kind != "load" else da
        g0 = float(delta @ r)
        work = float(delta @ (r + dlam * F))        # delta . K delta: the correction's energy
        step = 1.0
        trial = _try(eq, d, delta, step, tangent=ratio > math.sqrt(settings.tolerance))
        if settings.line_search and control.kind != "arc_length":
            step, trial = _line_search(eq, d, lam, delta, dlam, g0, trial)
        else:
            for _ in range(LINE_SEARCH_TRIALS):
                if trial[0] is not None:
                    break
                step *= 0.5                 # an element failed: back-track
                trial = _try(eq, d, delta, step)
        if trial[0] is None:
            out.message = trial[2] or "every trial of the line search failed"
            return out
        d = d + step * delta
        lam = lam + step * dlam
        f, K = trial[0], trial[1]             # K: the tangent when the trial computed it
        last_delta = step * delta
        last_energy = abs(step * work)
        first_energy = last_energy if first_energy is None else first_energy
        out.d, out.lam, out.iterations = d, lam, it + 1
    return out


def _try(eq, d, delta, step, tangent=False):
    """The internal forces of a trial step, and its tangent when asked (module docstring:
    Evaluations)."""
    return eq.evaluate(d + step * delta, tangent)


def _line_search(eq, d, lam, delta, dlam, g0, trial):
    """Regula falsi on g(s) = delta . r(d + s delta) from s = 1 (`trial`); returns the
    accepted step and its evaluation."""
    F = eq.load
    lo, g_lo, hi, g_hi = 0.0, g0, None, None
    s, f = 1.0, trial[0]
    last_good = None
    for _ in range(LINE_SEARCH_TRIALS):
        if f is None:                       # an element failed: halve towards the last good point
            hi, g_hi = s, None
            s = 0.5 * (lo + s)
        else:
            last_good = (s, trial)
            g = float(delta @ ((lam + s * dlam) * F - f))
            if abs(g) <= LINE_SEARCH_RATIO * abs(g0) or (g * g0 > 0.0 and hi is None):
                return s, trial             # enough decrease, or still descending at s = 1: take it
            if g * g0 > 0.0:
                lo, g_lo = s, g
            else:
                hi, g_hi = s, g
            if g_hi is None:
                s = 0.5 * (lo + hi)
            else:
                s = lo + (hi - lo) * g_lo / (g_lo - g_hi)
                s = min(max(s, lo + 0.1 * (hi - lo)), lo + 0.9 * (hi - lo))
        trial = _try(eq, d, delta, s)
        f = trial[0]
    if f is not None:
        return s, trial
    return last_good if last_good is not None else (s, trial)


def _arc_roots(dd, db, W, ds):
    a = float((W * db) @ (W * db))
    b = 2.0 * float((W * db) @ (W * dd))
    c = float((W * dd) @ (W * dd)) - ds * ds
    disc = b * b - 4.0 * a * c
    if disc < 0.0 or a == 0.0:
        return None
    root = math.sqrt(disc)
    q = -0.5 * (b + math.copysign(root, b))
    r1 = q / a
    r2 = c / q if q != 0.0 else -r1
    return r1, r2


def _choose_root(roots, d, da, db, W, previous, iteration):
    if iteration == 0 and not np.any(d):
        if previous is None:
            return max(roots)                       # the first point: load rising
        return max(roots, key=lambda x: float((W * (da + x * db)) @ (W * previous)))
    return max(roots, key=lambda x: float((W * (d + da + x * db)) @ (W * d)))


class PathError(Exception):
    """A point failed after every cut-back (one line)."""


@dataclass(frozen=True)
class Plan:
    """How the path is followed (solvers/newton.py reads it from [solve]): ``control``
    "load" (``steps`` equal steps of the load factor to 1), "displacement" (``steps`` equal
    steps of selector . u to ``final``), "arc_length" (at most ``steps`` points from the arc
    ``arc_length``, 0: the linear |W u| at load factor 1 / steps; stop at |lam| >=
    ``max_load_factor`` or when selector . u passes ``final`` (0: never))."""
    control: str
    steps: int
    final: float = 1.0
    selector: np.ndarray | None = None
    arc_length: float = 0.0
    max_load_factor: float = 1.0
    target_iterations: int = 5
    max_cutbacks: int = 10


MAX_ARC_GROWTH = 16.0        # arc length: at most this x the first one
SECANT_PREDICTOR = True      # load/displacement control: start from the last increment, scaled [choice, measured]


def solve_point(eq, lam0: float, control: Control, settings: Settings, scale: float,
                d0: np.ndarray | None = None) -> Outcome:
    """Newton on one point: full steps, then (load and displacement control) once more with
    the energy line search if that failed."""
    outcome = newton_point(eq, lam0, control, settings, lam_scale=scale, d0=d0)
    if not outcome.converged and control.kind != "arc_length":
        retry = newton_point(eq, lam0, control, replace(settings, line_search=True), lam_scale=scale, d0=d0)
        if retry.converged:
            return retry
    return outcome


def follow(eq, settings: Settings, plan: Plan, accept, position: dict | None = None, log: dict | None = None,
           boundary=None, note=None, jumps=None) -> dict:
    """Follow the path of `eq` by `plan`.  ``accept(outcome, lam_old, record)`` commits each
    converged point (`record`: it ends a load step, or is an arc-length point);
    ``boundary(position)`` is called after each step (checkpoints); ``note(text)`` tells of
    cut-backs; `jumps` (load control) is a JumpMonitor.  `position` resumes, `log` keeps
    counters (cutbacks, limit_points, ...).  Returns the final position.  Raises PathError."""
    log = {} if log is None else log
    log.setdefault("cutbacks", 0)
    log.setdefault("limit_points", [])
    boundary = boundary or (lambda pos: None)
    note = note or (lambda text: None)
    if plan.control == "arc_length":
        return _follow_arc(eq, settings, plan, accept, dict(position or {}), log, boundary, note)
    return _follow_steps(eq, settings, plan, accept, dict(position or {}), log, boundary, note, jumps)


def _turn(log: dict, lam_a: float, lam_b: float) -> None:
    """Remember where the load factor turned (a limit point of the path)."""
    change = lam_b - lam_a
    trend = log.get("trend", 0.0)
    if change != 0.0:
        if trend != 0.0 and (change > 0) != (trend > 0):
            log["limit_points"].append(float(lam_a))
        log["trend"] = change


def _follow_steps(eq, settings, plan, accept, pos, log, boundary, note, jumps):
    """Load or displacement control: plan.steps equal steps of the load factor or of the
    controlled displacement, each reached in sub-steps that are halved on failure and
    doubled again after each success."""
    displacement = plan.control == "displacement"
    n, final = plan.steps, plan.final
    j, lam = int(pos.get("level", 1)), float(pos.get("lam", 0.0))
    peak = float(pos.get("peak", 0.0))
    done = (j - 1) / n * final
    sub = float(pos.get("step") or final / n)
    last = None                                      # (d, control increment, load factor increment)
    sign = log.get("det_sign")                       # of det K at the last converged point (kept for a restart)
    while j <= n:
        target = j / n * final
        cuts, moved, sign_change, lam_start = 0, 0.0, False, lam
        while abs(target - done) > 1e-12 * abs(final):
            value = done + math.copysign(min(abs(sub), abs(target - done)), target - done)
            control = (Control("displacement", value, selector=plan.selector, start=done) if displacement
                       else Control("load", value))
            d0, lam0 = None, lam
            if last is not None and SECANT_PREDICTOR:       # extrapolate the last increment
                ratio = (value - done) / last[1]
                d0, lam0 = ratio * last[0], lam + ratio * last[2]
            scale = 0.1 * peak if displacement else abs(value)
            outcome = solve_point(eq, lam0, control, settings, scale, d0)
            if not outcome.converged:
                cuts += 1
                log["cutbacks"] += 1
                what = "displacement" if displacement else "load factor"
                if cuts > plan.max_cutbacks:
                    raise PathError(
                        f"load step {j}/{n} ({what} {target:.4g}): Newton failed from {what} {done:.4g} after "
                        f"{plan.max_cutbacks} cut-backs of the increment ({outcome.message}); raise load_steps or "
                        "[solve].max_cutbacks, or follow the path with control = \"arc_length\"")
                sub *= 0.5
                note(f"load step {j}/{n}: {outcome.message}; increment cut back to {abs(sub):.3g}")
                continue
            reached = abs(value - target) <= 1e-12 * abs(final)
            last = (outcome.d, value - done, outcome.lam - lam)
            moved += weighted(outcome.d, eq.weight)
            sign_change |= sign is not None and outcome.sign != sign
            sign = log["det_sign"] = int(outcome.sign)
            accept(outcome, lam, reached)
            lam, done = outcome.lam, (target if reached else value)
            peak = max(peak, abs(lam))
            if cuts == 0 and abs(sub) < abs(final) / n:
                sub *= 2.0
        if jumps is not None and not displacement:
            jumps.add(lam, moved, sign_change)
            log.setdefault("level_increments", []).append((lam, moved))
        _turn(log, lam_start, lam)
        j += 1
        pos = {"level": j, "lam": lam, "step": sub, "peak": peak}
        boundary(pos)
    return pos


def _follow_arc(eq, settings, plan, accept, pos, log, boundary, note):
    """Crisfield's cylindrical arc length, adapted by the iteration count, halved on failure."""
    j, lam = int(pos.get("level", 1)), float(pos.get("lam", 0.0))
    peak = float(pos.get("peak", 0.0))
    ds = float(pos.get("arc") or 0.0)
    if ds == 0.0:
        ds = plan.arc_length
        if ds == 0.0:                     # the linear solution at load factor 1, over the points
            f, K, message = eq.evaluate(np.zeros_like(eq.load), True)
            solver = eq.factorize(K) if f is not None else None
            if solver is None:
                raise PathError(f"arc length: the initial tangent cannot be factorized ({message or 'singular'})")
            ds = weighted(solver.solve(eq.load), eq.weight) / plan.steps
    log.setdefault("first_arc", ds)
    ds_max = MAX_ARC_GROWTH * float(log["first_arc"])
    previous = np.asarray(log["previous"]) if log.get("previous") is not None else None
    monitor = float(log.get("monitor", 0.0))
    cuts = 0
    while j <= plan.steps:
        outcome = solve_point(eq, lam, Control("arc_length", ds, previous=previous), settings, 0.1 * peak)
        if not outcome.converged:
            cuts += 1
            log["cutbacks"] += 1
            if cuts > plan.max_cutbacks:
                raise PathError(f"arc-length point {j} (load factor {lam:.4g}): Newton failed after {plan.max_cutbacks} "
                                f"cut-backs of the arc length to {ds:.3g} ({outcome.message}); lower [solve].arc_length "
                                "or raise max_cutbacks")
            ds *= 0.5
            note(f"point {j}: {outcome.message}; arc length cut back to {ds:.3g}")
            continue
        _turn(log, lam, outcome.lam)
        accept(outcome, lam, True)
        previous = outcome.d.copy()
        lam = outcome.lam
        peak = max(peak, abs(lam))
        if plan.selector is not None:
            monitor += float(plan.selector @ outcome.d)
        if cuts == 0:
            grow = math.sqrt(plan.target_iterations / max(outcome.iterations, 1))
            ds = min(ds * min(max(grow, 0.5), 2.0), ds_max)
        cuts = 0
        j += 1
        log["previous"] = previous.tolist()
        log["monitor"] = monitor
        if abs(lam) >= plan.max_load_factor or (
                plan.selector is not None and plan.final != 0.0 and monitor / plan.final >= 1.0):
            j = plan.steps + 1
        pos = {"level": j, "lam": lam, "arc": ds, "peak": peak}
        boundary(pos)
    return pos


class JumpMonitor:
    """Load control: a jump to a remote branch between two load steps (issue 19).  A step's
    displacement increment |du| larger than JUMP_RATIO x those of its neighbours (the
    previous and, once known, the next step), or, with Newton, a tangent whose determinant
    changed sign within the step, is reported once per step with its load level."""

    def __init__(self, warn):
        self.warn = warn
        self.levels: list[float] = []
        self.sizes: list[float] = []
        self.reported: set[int] = set()

    def replay(self, increments) -> None:
        """A restarted run: the (level, size) of the steps before the checkpoint, without
        checks: those of every step but the last were made (and reported) before it, the
        last one's is made with the next step, as in an uninterrupted run."""
        for level, size in increments:
            self.levels.append(level)
            self.sizes.append(size)

    def add(self, level: float, size: float, sign_change: bool = False) -> None:
        self.levels.append(level)
        self.sizes.append(size)
        j = len(self.sizes) - 1
        if sign_change:
            self._report(j, "the tangent stiffness lost its positive definiteness within the step (a limit or "
                            "bifurcation point was passed)")
        if j >= 1:
            self._check(j - 1)

    def finish(self) -> None:
        if self.sizes:
            self._check(len(self.sizes) - 1)

    def _check(self, j: int) -> None:
        around = [self.sizes[k] for k in (j - 1, j + 1) if 0 <= k < len(self.sizes)]
        if around and self.sizes[j] > JUMP_RATIO * max(around) and self.sizes[j] > 0.0:
            self._report(j, f"its displacement increment is {self.sizes[j] / max(around):.3g} times the largest of "
                            "its neighbours'")

    def _report(self, j: int, why: str) -> None:
        if j in self.reported:
            return
        self.reported.add(j)
        previous = self.levels[j - 1] if j > 0 else 0.0
        self.warn(f"load control: between load factors {previous:.4g} and {self.levels[j]:.4g} the solution jumped "
                  f"to a remote branch of the equilibrium path ({why}); the path between them is not computed: follow "
                  "it with [solve].solver = \"newton\" and control = \"arc_length\" or \"displacement\"")
