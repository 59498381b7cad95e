"""Scene file -> scene, mesh and model, with every problem found (:func:`prepare`):
scene and mesh errors, then every assembly-time problem (:func:`assembly_problems`); and
the set-ups that run but are probably not what the user wants (:func:`setup_warnings`).

Used by ``run`` and ``validate`` (cli.py) and by the Kratos peer's child process of
``bench`` (bench/run.py); it imports neither, so that both import it one way.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np


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
    return (scene, *mesh_and_model(scene))


def mesh_and_model(scene) -> tuple:
    """The mesh and the model of a loaded scene, or SceneError listing every problem found."""
    from .mesh import build_mesh
    from .scene import SceneError
    try:
        mesh = build_mesh(scene.mesh)
    except SceneError as exc:
        raise SceneError(_named(scene, exc.messages)) from None
    problems, model = assembly_problems(scene, mesh)
    if problems:
        raise SceneError(_named(scene, problems))
    return mesh, model


# ---------------------------------------------------------------- set-ups that run but may surprise
STICKING_CELL_RATIO = 0.75    # contact scenes: grid cell / longest edge above this sticks (docs/crush.md)


GRID_TRANSFER_KEYS = ("transfer", "flip_blend", "fields", "field_contact", "field_friction")
"""[method] keys of the grid transfer: set away from their default in fem mode, a warning."""
THICK_SHELL_RATIO = 1.0      # thickness / shortest edge of an element above this: not a thin shell


def thickness_warnings(scene, model) -> list[str]:
    """A section whose thickness is above THICK_SHELL_RATIO x the shortest edge of some of its
    elements: a shell element is a thin-shell model (plane stress through t, Reissner-Mindlin
    shear over the element), so t >> element size is a unit mistake or a solid modelled as a
    shell (a 1e9 thickness passed every check before)."""
    import numpy as np
    points, elements = model.points, model.elements
    nxt = np.roll(elements, -1, axis=1)
    tri = elements[:, 3] < 0
    nxt[tri, 2] = elements[tri, 0]
    valid = (elements >= 0) & (nxt >= 0)
    edge = np.linalg.norm(points[np.where(valid, elements, 0)] - points[np.where(valid, nxt, 0)], axis=2)
    shortest = np.where(valid, edge, np.inf).min(axis=1)
    lines, seen = [], set()
    for part in model.parts:
        ids = part.elements
        thick = ids[model.element.thickness[ids] > THICK_SHELL_RATIO * shortest[ids]]
        if not len(thick) or part.section in seen:
            continue
        seen.add(part.section)
        e = int(thick[np.argmax(model.element.thickness[thick] / shortest[thick])])
        key = "[section].thickness" if part.section == "section" else (
            f"[sections.{part.section}].thickness" if part.section in scene.sections else
            f"the deck's {part.section} (T1 or *ELEMENT_SHELL_THICKNESS)")
        lines.append(f"{scene.source.name}: {key}: {model.element.thickness[e]:g} is above the shortest edge of "
                     f"{len(thick)} elements of part '{part.name}' (e.g. element {e}: {shortest[e]:.3g}): a shell "
                     "element models a thin shell (t below its size); check the units or model a solid")
    return lines


def unused_key_warnings(scene) -> list[str]:
    """Keys that the scene sets but its kind of run does not read: [method] transfer keys in
    fem mode (not the grid's size and box, which a scene switched to fem by --set keeps),
    [output].times after a dynamic run's end_time; and mass_scaling = "selective", whose
    meaning changed (issue 29: the old one is "conventional")."""
    lines = []
    method = scene.method
    if method.kind == "fem":
        default = type(method)()
        for key in GRID_TRANSFER_KEYS:
            if getattr(method, key) == getattr(default, key):
                continue
            lines.append(f"{scene.source.name}: [method].{key}: not used with kind = \"fem\" (no grid: it is "
                         "for kind = \"mpm\")")
    if scene.solve.kind == "dynamic" and scene.solve.mass_scaling == "selective":
        lines.append(f"{scene.source.name}: [solve].mass_scaling = \"selective\" is selective mass scaling since "
                     "issue 29 (added mass on the deformation modes only); the per-element density scaling it "
                     "meant before is \"conventional\"")
    if scene.solve.kind == "dynamic":
        late = [t for t in scene.output.times if t > scene.solve.end_time]
        if late:
            lines.append(f"{scene.source.name}: [output].times: {', '.join(f'{t:g}' for t in late)} "
                         f"after [solve].end_time = {scene.solve.end_time:g}: no frame is written there")
    return lines


def closed_coincident_pairs(model) -> np.ndarray:
    """The pairs (k, 2) of coincident nodes that an mpm grid moves together: both take the
    grid velocity at the same point, so they part only where their motions are prescribed
    differently.  A pair stays closed when both nodes have the same fixed translations (not
    all three: a pair held in place is closed in fem too), no translation prescribed by a
    [[motion]] and the same rigid body (or none).  One side
    clamped (or moved, or on a body) and the other free: the free one follows the grid and
    the slit opens (the slit annular plate clamped on one face matched Newton's fem to
    0.01 %)."""
    import numpy as np
    from .mesh import coincident_pairs
    pairs = coincident_pairs(model.points)
    n = len(model.points)
    translations = model.fix_mask & 0b111
    moved = (model.loading.motion_mask & 0b111) != 0 if model.loading is not None else np.zeros(n, bool)
    body = model.node_body if model.node_body is not None else np.full(n, -1)
    a, b = pairs[:, 0], pairs[:, 1]
    closed = ((translations[a] == translations[b]) & (translations[a] != 0b111) & ~moved[a] & ~moved[b]
              & (body[a] == body[b]))
    return pairs[closed]


def setup_warnings(scene, model) -> list[str]:
    """Set-ups that run but are probably not what the user wants: loads whose set includes
    nodes with all translations fixed (that share of the force does nothing; a set of only
    such nodes is an error, see assembly.assemble), coincident nodes that move together in
    mpm mode (:func:`closed_coincident_pairs`: a slit modelled by them stays closed), and self-contact on a
    grid as coarse as the elements without both the multi-field grid and PolyPIC (layers
    stick through one field, and the other transfers filter node-scale waves: the tube at
    h = l gave +18.9 % mean force on one field, +11.4 % on multi fields with APIC, -0.2 %
    with PolyPIC; docs/grid.md)."""
    from .loading import load_shares
    from .nodesets import select_nodes
    lines = list(scene.notes) + list(model.notes) + unused_key_warnings(scene) + thickness_warnings(scene, model)
    fixed = (model.fix_mask & 0b111) == 0b111
    for i, ld in enumerate(scene.loads):
        if not any(ld.force) and not any(ld.force_per_length):
            continue
        ids = select_nodes(scene.nodeset(ld.nodes), model.points)
        share = load_shares(ld.distribute, ids, model.node_area, model.points, model.elements)
        lost = float(share[fixed[ids]].sum() / share.sum())
        if lost > 0.0:
            lines.append(f"{scene.source.name}: [[load]][{i}] on '{ld.nodes}': {int(fixed[ids].sum())} of "
                         f"{len(ids)} nodes have all translations fixed; the {100 * lost:.3g}% of the force "
                         "spread onto them does nothing")
    if model.grid is not None:
        pairs = len(closed_coincident_pairs(model))
        if pairs:
            lines.append(f"{scene.source.name}: [method].kind = \"mpm\": the {pairs} pair{'s' if pairs != 1 else ''} "
                         "of coincident nodes move together (every node moves with the grid velocity at its "
                         "position), so a slit or crack there does not open; use kind = \"fem\" to let it open")
    if scene.contact is not None and model.grid is not None and model.grid.h > STICKING_CELL_RATIO * model.max_edge:
        coarse = (f"{scene.source.name}: [method].cell_size: {model.grid.h:g} is more than "
                  f"{STICKING_CELL_RATIO:g} x the longest element edge ({model.max_edge:.3g}); with [contact], ")
        advice = "use fields = \"multi\" with transfer = \"polypic\", or about half the element size"
        if scene.method.fields == "single":
            lines.append(coarse + "shell layers within two cells stick through the grid (docs/crush.md, "
                         "sticking check): " + advice)
        elif scene.method.transfer != "polypic" and scene.solve.kind == "dynamic":
            lines.append(coarse + f"the {scene.method.transfer} transfer dissipates the waves of a crush "
                         "(docs/grid.md): " + advice)
    return lines


def reference_note(scene) -> str | None:
    """Why the scene's [reference] comparison will be skipped (a dynamic run), or None."""
    from .reference import skip_reason
    if scene.reference is None:
        return None
    reason = skip_reason(scene.reference, scene.solve.kind)
    return None if reason is None else f"{scene.source.name}: {reason}"
