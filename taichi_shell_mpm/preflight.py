"""Scene file -> scene, mesh and model, with every problem found (:func:`prepare`):
scene and mesh errors, then every assembly-time problem (:func:`assembly_problems`).

Used by ``run`` and ``validate`` (cli.py) and by the Kratos peer's child process of
``bench`` (bench/run.py); it imports neither, so that both import it one way.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path


def _named(scene, messages) -> list[str]:
    """Prefix the scene file's name to lines that do not name a file yet."""
    names = [scene.source.name, str(scene.source)]
    path = getattr(scene.mesh, "path", None)
    if path is not None:
        names += [str(path), Path(path).name]
    return [m if any(m.startswith(n) for n in names) else f"{scene.source.name}: {m}" for m in messages]


def assembly_problems(scene, mesh) -> tuple[list[str], object]:
    """Every assembly-time problem of `scene` on `mesh` (empty node sets, loads on fixed
    nodes, bad symmetry planes, rigid-body conflicts, a grid not covering the mesh ...),
    found by assembling each item on its own; returns (messages, model or None)."""
    from .model.assembly import assemble
    from .nodesets import select_nodes
    from .scene import SceneError
    try:
        return [], assemble(scene, mesh)
    except SceneError as exc:
        first = exc.messages
    errors: list[str] = []
    bad_sets = set()
    names = {x.nodes for group in (scene.boundaries, scene.loads, scene.initial, scene.probes,
                                   scene.rigid_bodies, scene.motions) for x in group if x.nodes is not None}
    for name in sorted(names):
        try:
            select_nodes(scene.nodeset(name), mesh.points)
        except SceneError as exc:
            errors += exc.messages
            bad_sets.add(name)
        except KeyError:
            bad_sets.add(name)
    replace = dataclasses.replace
    keep = lambda items: tuple(x for x in items if x.nodes not in bad_sets)   # noqa: E731
    bare = replace(scene, boundaries=(), loads=(), initial=keep(scene.initial), probes=keep(scene.probes),
                   rigid_bodies=(), walls=(), contact=None, reference=None,
                   motions=tuple(m for m in keep(scene.motions) if m.body is None),
                   method=replace(scene.method, kind="fem"))

    def fails(candidate) -> bool:
        try:
            assemble(candidate, mesh)
        except SceneError as exc:
            errors.extend(exc.messages)
            return True
        return False

    boundaries = tuple(b for b in keep(scene.boundaries) if not fails(replace(bare, boundaries=(b,))))
    loads = tuple(ld for ld in keep(scene.loads) if not fails(replace(bare, boundaries=boundaries, loads=(ld,))))
    bodies: tuple = ()
    for rb in keep(scene.rigid_bodies):
        if not fails(replace(bare, boundaries=boundaries, rigid_bodies=bodies + (rb,))):
            bodies += (rb,)
    names = {rb.name for rb in bodies}
    walls = tuple(w for w in scene.walls if w.moves_with is None or w.moves_with in names)
    final = replace(scene, boundaries=boundaries, loads=loads, initial=keep(scene.initial),
                    probes=keep(scene.probes), rigid_bodies=bodies, walls=walls,
                    motions=tuple(m for m in keep(scene.motions) if m.body is None or m.body in names))
    model = None
    try:
        model = assemble(final, mesh)
    except SceneError as exc:
        errors += exc.messages
    if not errors:              # the isolation found nothing: report what the full assembly said
        errors = list(first)
    unique = list(dict.fromkeys(errors))
    return unique, (model if not unique else None)


def prepare(path: Path, overrides, accept_unread: bool = False) -> tuple:
    """Scene, mesh and model of a scene file (TOML or an LS-DYNA deck; `accept_unread`: run a
    deck whose unread keywords change the physics), or SceneError listing every problem found."""
    from .mesh import build_mesh
    from .scene import SceneError, load_scene
    try:
        scene = load_scene(path, overrides, accept_unread)
    except SceneError as exc:         # the mesh is checked too when its own table is valid
        if exc.mesh is None:
            raise
        try:
            build_mesh(exc.mesh)
        except SceneError as mesh_exc:
            names = tuple(str(n) for n in (path.name, path, getattr(exc.mesh, "path", None)) if n is not None)
            raise SceneError(exc.messages + [m if m.startswith(names) else f"{path.name}: {m}"
                                             for m in mesh_exc.messages]) from None
        raise
    try:
        mesh = build_mesh(scene.mesh)
    except SceneError as exc:
        raise SceneError(_named(scene, exc.messages)) from None
    problems, model = assembly_problems(scene, mesh)
    if problems:
        raise SceneError(_named(scene, problems))
    return scene, mesh, model
