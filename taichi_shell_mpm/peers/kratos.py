"""The static benchmark scenes solved by KratosMultiphysics (implicit, Newton-Raphson).

The Kratos model is written here from our own scene, not from Kratos input files: the mesh
(nodes, quads and triangles of :func:`taichi_shell_mpm.mesh.build_mesh`) becomes
``ShellThinElementCorotational3D4N`` elements (corotational DKQ-type thin quad of the
StructuralMechanicsApplication) and ``ShellThinElementCorotational3D3N`` (its DKT-type thin
triangle, the peer of issue 33) with E, nu and the thickness of the scene
(``LinearElasticPlaneStress2DLaw``); the fixed-DOF masks of
:func:`taichi_shell_mpm.assembly.assemble` (clamps, symmetry planes, single restraints) fix
``DISPLACEMENT_*``/``ROTATION_*``; the reference nodal forces of the model (the same
tributary-area split our solver uses) become ``PointLoadCondition3D1N`` with
``POINT_LOAD = lambda * F``.  Load control takes ``[solve].load_steps`` equal increments,
each solved by ``ResidualBasedNewtonRaphsonStrategy`` (static incremental-update scheme,
block builder, Eigen sparse LU) to a residual criterion.  After each increment the probes
are read exactly as :meth:`taichi_shell_mpm.simulation.Simulation.probe_values` reads ours
(nodal mean over the probe's node set), so :func:`compare` can use the same error measure
as our ``summary.json`` (:func:`taichi_shell_mpm.reference.compare_with_reference`).

Rotation probe components (``rx``, ``ry``, ``rz``) are Kratos's nodal ``ROTATION``
(accumulated rotation increments), which equals our rotation vector only for small or
single-axis rotations; the benchmark scenes probe displacements only.

Kratos is imported lazily (:func:`available`, :func:`solve_static`); importing this module
never imports Kratos.  Install: ``pip install taichi_shell_mpm[peers]`` (Kratos 10.4.x).
"""
from __future__ import annotations

import contextlib
import os
import sys
import time

import numpy as np

ELEMENT = "ShellThinElementCorotational3D4N"
TRIANGLE = "ShellThinElementCorotational3D3N"
CONDITION = "PointLoadCondition3D1N"
COMPONENTS = ("ux", "uy", "uz", "rx", "ry", "rz")
_MODULES = ("KratosMultiphysics", "KratosMultiphysics.StructuralMechanicsApplication",
            "KratosMultiphysics.LinearSolversApplication")
_available: bool | None = None


class KratosSolveError(RuntimeError):
    """A load step did not converge, or the scene uses something this wrapper does not map."""


@contextlib.contextmanager
def _quiet_stdout(enabled: bool = True):
    """Silence file descriptor 1 (Kratos's C++ banners go straight to it, not via sys.stdout)."""
    if not enabled:
        yield
        return
    sys.stdout.flush()
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):   # captured / replaced stdout: nothing to do
        yield
        return
    saved = os.dup(fd)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), fd)
            try:
                yield
            finally:
                sys.stdout.flush()
                os.dup2(saved, fd)
    finally:
        os.close(saved)


def _import(quiet: bool = True):
    with _quiet_stdout(quiet):
        import KratosMultiphysics as KM
        import KratosMultiphysics.LinearSolversApplication  # noqa: F401  (registers sparse_lu)
        import KratosMultiphysics.StructuralMechanicsApplication as SMA
        KM.Logger.GetDefaultOutput().SetSeverity(KM.Logger.Severity.WARNING)
    return KM, SMA


def available() -> bool:
    """True when KratosMultiphysics and its Structural Mechanics and Linear Solvers
    applications import (the ``peers`` extra is installed)."""
    global _available
    if _available is None:
        try:
            _import()
            _available = True
        except Exception:            # ImportError, or a broken binary wheel
            _available = False
    return _available


def version() -> str | None:
    """Kratos kernel version string, or None when Kratos is not available."""
    if not available():
        return None
    KM, _ = _import()
    try:
        return str(KM.KratosGlobals.Kernel.Version()).replace('"', "")
    except Exception:
        return "unknown"


def probe_header(model) -> list[str]:
    """Probe column names in the order of our ``probes.csv`` (without the load-factor column)."""
    return [f"{p.name}.{c}" for p in model.probes for c in p.components]


def _check_supported(scene, model) -> None:
    problems = []
    if scene.solve.kind != "static":
        problems.append(f"[solve].kind is '{scene.solve.kind}', only 'static' is mapped")
    if scene.material is None:
        problems.append("the scene has several parts ([[part]]): only one [material] and [section] are mapped")
    elif scene.material.model != "elastic":
        problems.append(f"[material].model is '{scene.material.model}', only 'elastic' is mapped")
    if scene.rigid_bodies or scene.point_masses or scene.walls or scene.tools or scene.contact is not None \
            or scene.contact_pairs:
        problems.append("rigid bodies, point masses, walls, tools and contact are not mapped")
    if np.any(model.load_moment):
        problems.append("nodal moments are not mapped")
    if scene.motions or model.loading.loads:
        problems.append("prescribed motion, pressure, gravity, curve and follower loads are not mapped")
    if problems:
        raise KratosSolveError("Kratos peer: " + "; ".join(problems))


def _build(KM, SMA, scene, model, linear_solver: str, rel_tol: float, abs_tol: float, max_iterations: int):
    """Model part, strategy and the loaded nodes of a Kratos model of `scene`."""
    kmodel = KM.Model()
    mp = kmodel.CreateModelPart("shell")
    mp.SetBufferSize(2)
    mp.ProcessInfo[KM.DOMAIN_SIZE] = 3
    for var in (KM.DISPLACEMENT, KM.ROTATION, KM.REACTION, KM.REACTION_MOMENT, KM.VOLUME_ACCELERATION,
                SMA.POINT_LOAD):
        mp.AddNodalSolutionStepVariable(var)

    prop = mp.GetProperties()[1]
    prop.SetValue(KM.YOUNG_MODULUS, float(scene.material.E))
    prop.SetValue(KM.POISSON_RATIO, float(scene.material.nu))
    prop.SetValue(KM.THICKNESS, float(scene.section.thickness))
    prop.SetValue(KM.DENSITY, float(scene.material.density))
    prop.SetValue(KM.VOLUME_ACCELERATION, [0.0, 0.0, 0.0])
    prop.SetValue(KM.CONSTITUTIVE_LAW, SMA.LinearElasticPlaneStress2DLaw())

    for i, (x, y, z) in enumerate(model.points):
        mp.CreateNewNode(i + 1, float(x), float(y), float(z))
    dofs = [(KM.DISPLACEMENT_X, KM.REACTION_X), (KM.DISPLACEMENT_Y, KM.REACTION_Y),
            (KM.DISPLACEMENT_Z, KM.REACTION_Z), (KM.ROTATION_X, KM.REACTION_MOMENT_X),
            (KM.ROTATION_Y, KM.REACTION_MOMENT_Y), (KM.ROTATION_Z, KM.REACTION_MOMENT_Z)]
    for var, reaction in dofs:
        KM.VariableUtils().AddDof(var, reaction, mp)
    for e, corners in enumerate(model.elements):
        if corners[3] < 0:       # a triangle (-1 as its fourth corner)
            mp.CreateNewElement(TRIANGLE, e + 1, [int(c) + 1 for c in corners[:3]], prop)
        else:
            mp.CreateNewElement(ELEMENT, e + 1, [int(c) + 1 for c in corners], prop)

    # Dirichlet: bit d of fix_mask = DOF d of (ux uy uz rx ry rz); prescribed value 0.
    for i in np.flatnonzero(model.fix_mask):
        node = mp.GetNode(int(i) + 1)
        for d, (var, _) in enumerate(dofs):
            if (int(model.fix_mask[i]) >> d) & 1:
                node.Fix(var)

    loaded = np.flatnonzero(np.any(model.load_force != 0.0, axis=1))
    for k, i in enumerate(loaded):
        mp.CreateNewCondition(CONDITION, k + 1, [int(i) + 1], prop)

    from KratosMultiphysics import python_linear_solver_factory
    solver = python_linear_solver_factory.ConstructSolver(
        KM.Parameters('{"solver_type": "%s"}' % linear_solver))
    builder = KM.ResidualBasedBlockBuilderAndSolver(solver)
    scheme = KM.ResidualBasedIncrementalUpdateStaticScheme()
    criterion = KM.ResidualCriteria(rel_tol, abs_tol)
    criterion.SetEchoLevel(0)
    strategy = KM.ResidualBasedNewtonRaphsonStrategy(mp, scheme, criterion, builder, int(max_iterations),
                                                     False, False, True)   # reactions, reform dofs, move mesh
    strategy.SetEchoLevel(0)
    strategy.Check()
    strategy.Initialize()
    return kmodel, mp, strategy, loaded


def _probe_values(KM, mp, model) -> list[float]:
    out = []
    for p in model.probes:
        vals = np.array([list(mp.GetNode(int(i) + 1).GetSolutionStepValue(KM.DISPLACEMENT))
                         + list(mp.GetNode(int(i) + 1).GetSolutionStepValue(KM.ROTATION)) for i in p.nodes])
        mean = vals.mean(axis=0)
        out += [float(mean[COMPONENTS.index(c)]) for c in p.components]
    return out


def solve_static(scene, mesh=None, model=None, *, load_steps: int | None = None,
                 linear_solver: str = "LinearSolversApplication.sparse_lu", rel_tol: float = 1e-7,
                 abs_tol: float = 1e-12, max_iterations: int = 50, quiet: bool = True) -> dict:
    """Solve the static `scene` (a :class:`taichi_shell_mpm.scene.Scene`) with Kratos.

    `mesh`/`model` default to ``build_mesh(scene.mesh)`` and ``assemble(scene, mesh)``.
    Load levels are ``j / load_steps`` for j = 1 .. load_steps (default
    ``scene.solve.load_steps``, i.e. the same increments as our static driver).  Newton
    stops when the residual norm falls below `rel_tol` times that of the step's first
    iteration or below `abs_tol`; a step hitting `max_iterations` raises
    :class:`KratosSolveError`.

    Returns ``{"probes": (n_steps, n_components) array in our probes.csv column order,
    "header": those column names, "load_factors": (n_steps,), "solve_seconds": wall time of
    the load-step loop only, "setup_seconds": model part + strategy construction,
    "newton_iterations": total, "iterations_per_step": list, "element": ..., "nodes": ...,
    "elements": ..., "kratos_version": ...}``.
    """
    if not available():
        raise ImportError("KratosMultiphysics is not importable: pip install 'taichi_shell_mpm[peers]'")
    from ..mesh import build_mesh
    from ..model.assembly import assemble
    if model is None:
        mesh = mesh if mesh is not None else build_mesh(scene.mesh)
        model = assemble(scene, mesh)
    _check_supported(scene, model)
    KM, SMA = _import(quiet)
    n_steps = int(load_steps or scene.solve.load_steps)

    t0 = time.perf_counter()
    with _quiet_stdout(quiet):
        kmodel, mp, strategy, loaded = _build(KM, SMA, scene, model, linear_solver, rel_tol, abs_tol,
                                              max_iterations)
    setup_seconds = time.perf_counter() - t0

    rows, lambdas, iterations = [], [], []
    t0 = time.perf_counter()
    with _quiet_stdout(quiet):
        for j in range(1, n_steps + 1):
            lam = j / n_steps
            mp.ProcessInfo[KM.STEP] = j
            mp.CloneTimeStep(lam)                  # pseudo-time = load factor
            for i in loaded:
                mp.GetNode(int(i) + 1).SetSolutionStepValue(SMA.POINT_LOAD, 0, (lam * model.load_force[i]).tolist())
            strategy.InitializeSolutionStep()
            strategy.Predict()
            converged = strategy.SolveSolutionStep()
            strategy.FinalizeSolutionStep()
            its = int(mp.ProcessInfo[KM.NL_ITERATION_NUMBER])
            iterations.append(its)
            if not converged:
                raise KratosSolveError(f"Kratos peer: load step {j}/{n_steps} (load factor {lam:.4g}) did not "
                                       f"converge in {max_iterations} Newton iterations")
            rows.append(_probe_values(KM, mp, model))
            lambdas.append(lam)
    solve_seconds = time.perf_counter() - t0
    del kmodel
    return {"probes": np.array(rows, dtype=float).reshape(len(rows), -1), "header": probe_header(model),
            "load_factors": np.array(lambdas), "solve_seconds": solve_seconds, "setup_seconds": setup_seconds,
            "newton_iterations": int(sum(iterations)), "iterations_per_step": iterations,
            "element": " + ".join(n for n, used in ((ELEMENT, (model.elements[:, 3] >= 0).any()),
                                                    (TRIANGLE, (model.elements[:, 3] < 0).any())) if used),
            "linear_solver": linear_solver, "nodes": int(len(model.points)), "elements": int(len(model.elements)),
            "kratos_version": version()}


def compare(scene, result: dict) -> dict:
    """Error of a :func:`solve_static` result against ``scene.reference``: the same dict as
    ``summary.json["reference"]`` of our run (per column ``mean_rel_error``, ``max_rel_error``,
    simulated and reference rows), from :func:`taichi_shell_mpm.reference.compare_with_reference`."""
    from ..reference import compare_with_reference
    if scene.reference is None:
        raise ValueError(f"{scene.source}: the scene has no [reference] table")
    header = ["load_factor"] + list(result["header"])
    rows = [[float(lam)] + [float(v) for v in row] for lam, row in zip(result["load_factors"], result["probes"])]
    return compare_with_reference(scene.reference, header, rows)
