"""[solve]: static or dynamic, the step, mass scaling and the Newton solver."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

from ..keys import (
    DOFS,
    choice,
    fraction,
    integer,
    key,
    keys_of,
    node_set,
    non_negative,
    number,
    positive,
    target_dt,
)
from .reader import Reader


@dataclass(frozen=True)
class Solve:
    kind: Literal["static", "dynamic"] = key(choice("static", "dynamic"),
        doc="`static`: load stepping, each step relaxed to equilibrium (dynamic relaxation); `dynamic`: explicit "
            "time integration to `end_time`")
    load_steps: int = key(integer(1), "static: number of equal load increments", default=20)
    tolerance: float = key(number(0, 0.1, lo_open=True), default=1e-4,
        doc="static: relative residual ‖R‖ / ‖F_ext‖ that ends a load step")
    max_steps_per_load_step: int = key(integer(1), default=500_000,
        doc="static: step budget of one load step; exceeding it is an error")
    end_time: float = key(non_negative, default=0.0, unit="time", allowed=">= 0; > 0 and required when dynamic",
        doc="dynamic: simulated end time")
    dt_safety: float = key(fraction, "safety factor on the stable time step", default=0.9)
    dt_rule: Literal["both", "shell"] = key(choice("both", "shell"), default="both",
        doc="`both`: min of the shell-element and grid (paper) limits; `shell`: shell-element limit only (plus a "
            "CFL guard), suits dynamic relaxation")
    rotary_inertia: Literal["scaled", "physical"] = key(choice("scaled", "physical"), default="scaled",
        doc="`scaled`: J = m · max(t²/12, A/8) (a triangle: m · max(t²/12, A/4) · g, g ≥ 1.25 its shear gain, "
            "`assembly.triangle_shear_gain`), so rotations never limit the time step; `physical`: J = m t²/12, "
            "and the time step also obeys the rotational limit α·2t·√(ρ/(12κG)) of the transverse-shear–rotation "
            "mode (`stages/timestep.element_limit`; 5× smaller than the membrane limit on the 5 mm tube; a "
            "triangle adds its two frequencies as squares, the rotational one times √g, "
            "`stages/timestep.triangle_limit`).  Dynamic solves only: a static solve keeps `scaled` (a warning "
            "says so), since its masses are the relaxation's own and the equilibrium does not depend on them "
            "[measured: the 10×1 cantilever, fem, 2 load levels, relaxes in 10 098 steps; with the physical "
            "inertia the rotational limit makes dt 7.9× smaller (7.35 × 10⁻⁵ against 5.81 × 10⁻⁴) and FIRE "
            "stalled at a residual of 0.70 of the load after 400 000 steps, with or without mass scaling]")
    relaxation: Literal["fire", "kinetic"] = key(choice("fire", "kinetic"), default="fire",
        doc="static solves: dynamic relaxation by FIRE (restart from rest when the power F·v of the "
            "out-of-balance forces turns negative, otherwise mix the velocity towards the force; Bitzek et al. "
            "2006, time step not adapted) or plain kinetic damping (restart at each kinetic-energy peak). Same "
            "equilibria; FIRE took 22 % fewer steps on the 10×1 cantilever in `mpm` mode, 75 % fewer in `fem` "
            "(bench rows `cantilever_10x1_*_kinetic`, BENCHMARKS.md); kinetic damping with `mass_scaling = "
            "\"uniform_dt\"` does not finish the 16×16 hemisphere in 400 000 steps per load step")
    mass_scaling: Literal["auto", "uniform_dt", "selective", "conventional", "none"] = key(
        choice("auto", "uniform_dt", "selective", "conventional", "none"), default="auto",
        doc="static solves: `uniform_dt` (what `auto` means there) scales each element's density by (L_min/L_e)²,"
            " so every element has the stable step of the smallest one and the larger ones relax as fast as it "
            "does (`assembly.uniform_dt_mass_factor`); `none` keeps the physical masses. Dynamic solves: `auto` ="
            " `none`; `selective`: selective mass scaling to `target_dt` (below; `fem` only): each element below "
            "the target gets a mass matrix that is zero on rigid translations, so the total mass, the momentum "
            "and the rigid motion keep their physical inertia while the element's deformation modes get heavier "
            "(docs/mass_scaling.md); `conventional`: the element's density is raised instead (every mode heavier,"
            " mass added; LS-DYNA DT2MS < 0; what `selective` meant before issue 29, which a warning recalls); "
            "`uniform_dt` is rejected")
    target_dt: float | Literal["auto"] = key(
        target_dt, default=0.0, unit="time", allowed="> 0 or `\"auto\"`; only with those", default_text="required with `selective` or `conventional`",
        doc="the time step mass scaling gives every element at least (after `dt_safety`; LS-DYNA's "
            "TSSFAC·|DT2MS|): an element whose stable step α L_e/c_e is below it gets the factor f_e = "
            "(target/dt_e)² (the factor only grows, as the element distorts): its density under `conventional`, 1"
            " + β_e of its added mass matrix under `selective`; the other elements are left as they are. "
            "`\"auto\"`: 10 × the smallest element's own stable step at the start (the ratio the peers' selective "
            "scaling runs crashes at; at 10× the tube's mean crush force moved +1.1 %, docs/mass_scaling.md); with "
            "`sms_solve = \"reciprocal\"` the largest step its zigzag limit allows, min_e of each element's own "
            "step and that limit; the"
            " step chosen is in summary.json (`mass_scaling.target_dt`, `target_dt_auto`) and the run's summary."
            "  The steps still land in equal parts on the output times, so between two history records h apart "
            "the step is h / ⌈h / target⌉: a target above h / 4 and below h / 3 runs at h / 4 with the mass of "
            "the target (the tube, h = 0.01 ms: targets from 2.5 × 10⁻³ to 3.3 × 10⁻³ ms all take 6 000 steps, "
            "docs/mass_scaling.md)")
    added_mass_limit: float = key(non_negative, default=5.0, allowed=">= 0; only with `conventional`",
        doc="the run stops (one line, exit code 3) once the added mass exceeds this percentage of the shell's "
            "physical mass (0: no limit)")
    sms_solve: Literal["pcg", "reciprocal"] = key(choice("pcg", "reciprocal"), default="pcg",
        allowed="`pcg` or `reciprocal`; only with `selective`",
        doc="how the step's accelerations come from the scaled mass matrix.  `pcg`: conjugate gradients solve "
            "(M + M_add) a = f to `sms_tolerance`: any target step (the tube: its answer holds to 10x), but "
            "16-30 iterations per step, each dearer than the element pass, so a run on a cheap shell is slower "
            "than the unscaled one.  `reciprocal`: a = A f, A the sum of the elements' own inverses of "
            "M_e + M_add^e (a sparse reciprocal mass matrix in the sense of Tkachuk & Bischoff 2015; the solve's "
            "preconditioner): no iterations, momentum kept to round-off, but an element tilting or spinning rigidly "
            "against its neighbours keeps its lumped mass, so each element's step is raised to at most those shear "
            "zigzags' step alpha h / c_s (h its narrowest width, c_s = sqrt(G / rho): 2.4x its own for a square "
            "steel element; the target's mass beyond it is not added; docs/mass_scaling.md)")
    sms_tolerance: float = key(number(0, 0.1, lo_open=True), default=1e-5, allowed="(0, 0.1]; only with `selective`",
        doc="the conjugate-gradient solve of (M + M_add) a = f ends once its residual is this fraction of the "
            "force (norms with the preconditioner's inverse); the momentum is exact whatever it is, the energy "
            "balance is not (at 1e-3 a vibrating strip's balance grew past the guard; docs/mass_scaling.md)")
    sms_max_iterations: int = key(integer(1), default=200, allowed=">= 1; only with `selective`",
        doc="conjugate-gradient iterations of one step; a solve that needs more stops the run (one line naming "
            "the step, exit code 3)")
    progress_every: float = key(non_negative, default=2.0, unit="s (wall clock)",
        doc="seconds of wall time between progress lines (display only: a checkpoint may be continued with "
            "another value)")
    solver: Literal["relaxation", "newton"] = key(choice("relaxation", "newton"), default="relaxation",
        doc="static solves: dynamic relaxation (the keys above) or Newton–Raphson with path following (the keys "
            "below; `fem` mode, `[element].drilling = \"penalty\"`; point loads only: no rigid bodies, walls, "
            "contact, motions, pressure or gravity; docs/newton.md). `mpm` statics keep relaxation (why: "
            "docs/newton.md)")
    control: Literal["load", "displacement", "arc_length"] = key(
        choice("load", "displacement", "arc_length"), default="load",
        doc="Newton: what the path is stepped in. `load`: `load_steps` equal load increments, each solved by "
            "Newton, halved on failure (at most `max_cutbacks` times; a jump to a remote branch between two steps"
            " is reported as a warning naming the load levels); `displacement`: the mean `control_dof` of "
            "`control_nodes` is prescribed in `load_steps` equal steps to `control_displacement`, the load factor"
            " is the unknown (passes load limit points); `arc_length`: Crisfield's cylindrical arc length (passes"
            " load and displacement limit points: snap-through, snap-back), at most `load_steps` points")
    control_nodes: str | None = key(node_set, default=None, allowed="a defined node set",
        doc="Newton: the node set of the controlled (`displacement`) or monitored (`arc_length`: the run stops "
            "once it passes `control_displacement`) DOF")
    control_dof: str = key(choice(*DOFS), "Newton: that DOF (averaged over the set)", default="uz")
    control_displacement: float = key(
        number(), default=0.0, unit="length", allowed="any; non-zero for `displacement`",
        doc="Newton: `displacement`: its final value; `arc_length`: stop once the monitored DOF passes it (0: no "
            "such stop)")
    arc_length: float = key(
        non_negative, default=0.0, allowed=">= 0, at most 10 × the model's bounding-box diagonal × √(3 × nodes) (every node moving ten model sizes; an error naming the bound)",
        doc="Newton, `arc_length`: the first point's arc (a norm of the displacement increment, rotations times "
            "the mean edge); 0: the linear solution's at load factor 1 over `load_steps`.  Then adapted: × "
            "√(`target_iterations` / iterations of the last point), at most ×2 or ÷2 per point and at most 16× "
            "the first; halved on failure")
    max_load_factor: float = key(positive, "Newton, `arc_length`: stop once |load factor| reaches it", default=1.0)
    target_iterations: int = key(integer(1), default=5,
        doc="Newton, `arc_length`: the iteration count the arc is adapted to")
    max_iterations: int = key(integer(1), default=20,
        doc="Newton: iterations of one point before its increment is cut back")
    max_cutbacks: int = key(integer(0), default=10,
        doc="Newton: halvings of one increment (or arc) before the run stops with an error")
    increment_tolerance: float = key(number(0, 1, lo_open=True), default=1e-3,
        doc="Newton: a point converges when the residual is below `tolerance` of the load (as relaxation), the "
            "last correction below this fraction of the point's increment, and its energy (δ·K·δ) below "
            "`energy_tolerance` of the first correction's")
    energy_tolerance: float = key(number(0, 1, lo_open=True), "Newton: see `increment_tolerance`", default=1e-6)

    @property
    def physical_rotary_inertia(self) -> bool:
        """Whether the nodes get the physical rotary inertia m t^2/12: ``rotary_inertia =
        "physical"`` in a dynamic solve.  A static solve's masses are the relaxation's own
        (Newton has none), so it keeps the scaled inertia [measured: the 10 x 1 cantilever in
        fem at 2 load levels relaxes in 10 098 steps with it; with the physical one its
        rotational mode sets dt 7.9x smaller (7.35e-5 against 5.81e-4) and FIRE stalls at a
        residual of 0.70 of the load after 400 000 steps, with or without mass scaling]."""
        return self.rotary_inertia == "physical" and self.kind == "dynamic"


def check_newton(r: Reader, v: dict, data: dict) -> None:
    """[solve] keys of the Newton solver (issue 19) against the rest of the scene."""
    raw = r.raw
    if v.get("solver") == "newton":
        method = raw.get("method", {})
        element = raw.get("element", {})
        if v.get("kind") == "dynamic":
            r.error("[solve].solver", '"newton" solves static scenes (kind = "static")')
        if isinstance(method, dict) and method.get("kind", "mpm") == "mpm":
            r.error("[solve].solver", '"newton" runs in fem mode: set [method].kind = "fem" (mpm statics keep '
                    '"relaxation"; why: docs/newton.md)')
        if isinstance(element, dict) and element.get("drilling") == "projection":
            r.error("[solve].solver", '"newton" needs the drilling spring ([element].drilling = "penalty"): the '
                    "projection leaves the drilling rotation without stiffness")
        for key in ("rigid_body", "wall", "tool", "contact", "contact_pair", "motion", "pressure", "gravity", "tie",
                    "spotweld"):
            if key in raw:       # loads and constraints the element pass of the tangent does not see
                r.error("[solve].solver", f'"newton" does not handle [{key}] (use "relaxation")')
        loads = raw.get("load", [])
        for k, load in enumerate(loads if isinstance(loads, list) else []):
            if isinstance(load, dict) and (load.get("curve") or load.get("follower")):
                r.error(f"[[load]] {k + 1}", '"newton" takes dead loads proportional to the load factor: no '
                        'curve or follower (use "relaxation")')
    else:
        for key in ("control", "control_nodes", "control_displacement", "arc_length", "max_load_factor",
                    "target_iterations", "max_iterations", "max_cutbacks", "increment_tolerance",
                    "energy_tolerance"):
            if key in data:
                r.error(f"[solve].{key}", 'is a key of the Newton solver: set solver = "newton"')
    control = v.get("control")
    if control == "displacement":
        if "control_nodes" not in data:
            r.error("[solve].control_nodes", 'missing required key for control = "displacement" (the node '
                                             "set whose control_dof is prescribed)")
        if "control_displacement" not in data:
            r.error("[solve].control_displacement", 'missing required key for control = "displacement" '
                                                    "(the final mean value of control_dof)")
        elif data["control_displacement"] == 0:
            r.error("[solve].control_displacement", 'expected a non-zero number for control = '
                                                    '"displacement", got 0')
    elif data.get("control_displacement") and not data.get("control_nodes"):
        r.error("[solve].control_nodes", "missing: control_displacement needs the node set it applies to")


def read_solve(r: Reader, data: Any) -> Solve | None:
    mark = len(r.messages)
    v = r.read("[solve]", data, keys_of(Solve), Solve)
    if v is None:
        return None
    check_newton(r, v, data)
    if v.get("kind") == "dynamic" and v.get("end_time") == 0:
        if "end_time" in data:
            r.error("[solve].end_time", "expected a number > 0 for a dynamic solve, got 0")
        else:
            r.error("[solve].end_time", "missing required key (a dynamic solve needs end_time > 0)")
    scaling = data.get("mass_scaling") if isinstance(data, dict) else None
    if v.get("kind") == "dynamic" and scaling == "uniform_dt":
        r.error("[solve].mass_scaling", 'expected "auto", "selective", "conventional" or "none" for a dynamic '
                'solve, got "uniform_dt" (fictitious masses change the dynamics; they are for static solves)')
    if v.get("kind") == "static" and scaling in ("selective", "conventional"):
        r.error("[solve].mass_scaling", f'expected "auto", "uniform_dt" or "none" for a static solve, got '
                f'"{scaling}" (mass scaling to a target step is for dynamic solves)')
    method = r.raw.get("method", {})
    if scaling == "selective" and isinstance(method, dict) and method.get("kind", "mpm") == "mpm":
        r.error("[solve].mass_scaling", '"selective" needs [method].kind = "fem" (in mpm the grid solves '
                'with lumped masses: use "conventional"; docs/mass_scaling.md)')
    if scaling in ("selective", "conventional") and "target_dt" not in data:
        r.error("[solve].target_dt", f'missing required key for mass_scaling = "{scaling}"')
    if isinstance(data, dict):
        for key, kinds in (("target_dt", ("selective", "conventional")), ("added_mass_limit", ("conventional",)),
                           ("sms_tolerance", ("selective",)), ("sms_max_iterations", ("selective",)),
                           ("sms_solve", ("selective",))):
            if key in data and scaling not in kinds:
                r.error(f"[solve].{key}", "only with mass_scaling = " + " or ".join(f'"{k}"' for k in kinds))
        for key in ("sms_tolerance", "sms_max_iterations"):
            if key in data and data.get("sms_solve") == "reciprocal":
                r.error(f"[solve].{key}", 'only with sms_solve = "pcg" (the reciprocal mass matrix does not iterate)')
    if v.get("kind") == "static" and not any(r.raw.get(k) for k in ("load", "motion", "pressure", "gravity")):
        r.error("[[load]]", "a static solve needs at least one [[load]], [[motion]], [[pressure]] or [gravity]")
    return r.build(mark, Solve, v)
