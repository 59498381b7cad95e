"""The parts of a model: element sets, the part of every element, and the section and material
tables the step reads (numpy)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import laminate
from ..mesh import Mesh
from ..scene import Scene, SceneError
from . import materials
from .deck import deck_element_thickness, deck_specs


@dataclass(frozen=True)
class PartSpec:
    name: str
    elements: np.ndarray                    # element ids
    material: str | None                    # None: a layered section (its plies name their materials)
    section: str


@dataclass(frozen=True)
class ElementData:
    """Each element's section and material data (state.sections), from its part."""
    part: np.ndarray                        # (m,) part index
    section: np.ndarray                     # (m,) section index (into SectionTable)
    thickness: np.ndarray                   # (m,)
    shear_factor: np.ndarray                # (m,) kappa
    wave_speed: np.ndarray                  # (m,) plane-stress c_e of its stiffest material (physical density)
    rotational_frequency: np.ndarray        # (m,) sqrt(12 kappa G / rho) / t with physical rotary inertia, else 0
    shear_wave_speed: np.ndarray            # (m,) sqrt(G_max / rho): the shear wave's speed (the
    #                                         reciprocal mass matrix's step cap, stages/timestep.zigzag_limit)
    # E, G below: the material's; a laminate's or an orthotropic material's effective isotropic
    # moduli (laminate.Layup: membrane E, bending E, mean transverse G)
    hourglass_membrane: np.ndarray          # (m,) r E t / 8      (stages/hourglass.py: x A beta -> C3)
    hourglass_bending: np.ndarray           # (m,) r E t^3 / 192  (x A beta -> C1)
    hourglass_transverse: np.ndarray        # (m,) r kappa G t^3 / 12 (x beta -> C2)
    drilling_factor: np.ndarray             # (m,) alpha E t^3 / 48 (stages/drilling.py: x A beta -> k)
    opt_modulus: np.ndarray                 # (m,) 3/4 beta_0 E t / (1 - nu^2) (stages/opt_membrane.py); 0
    #                                         unless [element].triangle = "opt" (assembly.element_steps)
    opt_poisson: np.ndarray                 # (m,) its nu
    opt_floor: np.ndarray                   # (m,) the hourglass coefficient r: what a yielded section keeps
    density: np.ndarray                     # (m,) mass per volume over the thickness (laminate.Layup)
    rotary_density: np.ndarray              # (m,) 12 I / t^3, I = int rho z^2 dz (= density for one material)
    material_axis: np.ndarray               # (m, 2) cos, sin of the angle from e1 to the section's material axis


def opt_higher_order(section, specs: dict, material: str | None, modulus: float, t):
    """3/4 beta_0 E t / (1 - nu^2) and nu of the OPT triangle's higher-order membrane stiffness
    (stages/opt_membrane.py), beta_0 = max(1/2 (1 - 4 nu^2), 0.01) (Felippa 2003, isotropic):
    E the section's membrane modulus (laminate.Layup), nu the material's; 0.3 for a layered
    section or an orthotropic material [choice: the part is a stabilisation; their effective
    isotropic E is already an approximation]."""
    spec = None if section.layered else specs[material]
    nu = spec.nu if spec is not None and spec.model != "orthotropic" else 0.3
    return 0.75 * max(0.5 * (1.0 - 4.0 * nu * nu), 0.01) * modulus * t / (1.0 - nu * nu), nu


@dataclass(frozen=True)
class SectionTable:
    """Through-thickness rules: point positions zeta in [-1, 1], weights (sum 2) and the
    material and ply angle of each point, per section (padded to the most points of any section)."""
    names: tuple[str, ...]
    point_count: np.ndarray                 # (ns,)
    zeta: np.ndarray                        # (ns, nk)
    weight: np.ndarray                      # (ns, nk)
    point_material: np.ndarray              # (ns, nk) material index
    point_angle: np.ndarray                 # (ns, nk) ply angle from the material axis, radians
    layered: np.ndarray                     # (ns,) bool: the points' materials come from plies

    @property
    def points(self) -> int:
        return self.zeta.shape[1]


@dataclass(frozen=True)
class MaterialTable:
    """One row of parameters per scene material (materials.py); ``kind`` indexes ``kinds``,
    the material models the scene uses (registry order); ``hardening`` and ``rate_laws``, the
    J2 flow-stress laws it uses; the tabulated hardening curves of all materials, one after
    the other (each row holds its curve's first point and count)."""
    names: tuple[str, ...]
    kinds: tuple[str, ...]
    kind: np.ndarray                        # (nm,)
    rows: np.ndarray                        # (nm, materials.row_width(kinds))
    dilatational_speed: float               # the largest of the paper's grid-rule speeds
    hardening: tuple[str, ...]              # materials.HARDENING_LAWS used (Features.hardening)
    rate_laws: tuple[str, ...]              # materials.RATE_LAWS used (Features.rate_laws)
    rate_filter: bool                       # some material filters its rate (Features.rate_filter)
    curve_strain: np.ndarray                # (points,) plastic strain of each curve point
    curve_stress: np.ndarray                # (points,) its yield stress
    erosion: bool = False                   # some material's elements can fail (Features.erosion)
    failure: np.ndarray | None = None       # (nm, 3) materials.failure_row of each (state.sections.failure)

    @property
    def plastic(self) -> bool:
        return any(materials.PLASTIC[k] for k in self.kinds)


def element_selection(name: str, scene: Scene, mesh: Mesh, points: np.ndarray, elements: np.ndarray,
                       path: str) -> np.ndarray:
    """The element ids `name` selects: "all", an [elementsets.NAME], or a set of the mesh file."""
    m = len(elements)
    if name == "all":
        return np.arange(m)
    where = f"{scene.source.name}: {path}.elements"
    sets = {s.name: s for s in scene.elementsets}
    if name in sets:
        spec = sets[name]
        where = f"{scene.source.name}: [elementsets.{name}]"
        if spec.kind == "all":
            ids = np.arange(m)
        elif spec.kind == "ids":
            ids = np.unique(np.asarray(spec.ids, dtype=np.int64))
            if ids.max() >= m:
                raise SceneError(f"{where}.ids: element {int(ids.max())} out of range (the mesh has {m} elements)")
        elif spec.kind == "box":
            x = points[np.where(elements >= 0, elements, elements[:, :1])]
            count = np.where(elements[:, 3] >= 0, 4, 3)
            centroid = np.where(elements[:, 3:4] >= 0, x.sum(axis=1), x[:, :3].sum(axis=1)) / count[:, None]
            inside = np.all((centroid >= np.asarray(spec.box_min) - 1e-12) & (centroid <= np.asarray(spec.box_max) + 1e-12),
                            axis=1)
            ids = np.flatnonzero(inside)
        else:
            ids = mesh_set(spec.mesh_set, mesh, f"{where}.mesh")
        if not len(ids):
            raise SceneError(f"{where}: selects no element")
        return ids
    return mesh_set(name, mesh, where, extra=tuple(sets))


def mesh_set(name: str, mesh: Mesh, where: str, extra: tuple = ()) -> np.ndarray:
    if name in mesh.element_sets:
        return np.asarray(mesh.element_sets[name], dtype=np.int64)
    known = sorted(mesh.element_sets) + list(extra)
    hint = f" (sets: {', '.join(known[:12])}{' ...' if len(known) > 12 else ''})" if known else \
        " (the mesh has no element sets)"
    raise SceneError(f"{where}: no element set or mesh set named {name!r}{hint}")


def part_data(scene: Scene, mesh: Mesh, points: np.ndarray, elements: np.ndarray):
    """The parts (PartSpec: element ids, material and section names), the materials and the
    sections by name.  [[part]] assigns them; without it the scene's one material and section
    cover the mesh, or an LS-DYNA deck's *PART cards assign its own (scene tables of the same
    name -- mat_<mid>, sec_<secid> -- replace the deck's; a [[part]] may name the deck's).
    Every element belongs to exactly one part: overlaps and orphans are errors naming the
    parts and elements.  With a deck, a scene table no part uses (an override of nothing) is
    an error, and so is a value of a deck card some part uses that the same scene key would
    refuse (deck_specs)."""
    m = len(elements)
    materials, sections = dict(scene.materials), dict(scene.sections)
    notes: list[str] = []
    thickness = None
    if not scene.parts and scene.material is not None:
        if mesh.deck is not None and mesh.deck.parts:
            notes.append(f"{scene.source.name}: [material] and [section] cover every element: the deck's "
                         f"{len(mesh.deck.parts)} *PART cards and their sections and materials are not used (leave "
                         "[material] and [section] out to use them; [materials.mat_<mid>] or "
                         "[sections.sec_<secid>] replaces one)")
        return (PartSpec("all", np.arange(m), "material", "section"),), {"material": scene.material}, \
            {"section": scene.section}, thickness, notes
    if not scene.parts and mesh.deck is None:
        (sname, sec), = sections.items()
        if sec.layered:
            used = {ply.material: materials[ply.material] for ply in sec.plies}
            return (PartSpec("all", np.arange(m), None, sname),), used, {sname: sec}, thickness, notes
        (mname, mat), = materials.items()
        return (PartSpec("all", np.arange(m), mname, sname),), {mname: mat}, {sname: sec}, thickness, notes
    deck_problems = {}
    if mesh.deck is not None:                    # the deck's materials and sections, by scene name
        deck_materials, deck_sections, notes, deck_problems = deck_specs(mesh.deck, scene.source.name)
        materials = {**deck_materials, **materials}
        sections = {**deck_sections, **sections}
        thickness = deck_element_thickness(mesh.deck, scene, notes)
    if not scene.parts:                          # an LS-DYNA deck's parts
        from ..scene import Part
        entries = tuple(Part(name=(p.title if p.title and p.title in mesh.element_sets else f"part:{pid}"),
                             material=f"mat_{p.mid}", section=f"sec_{p.secid}", elements=f"part:{pid}")
                        for pid, p in sorted(mesh.deck.parts.items()) if f"part:{pid}" in mesh.element_sets)
    else:
        entries = scene.parts
    errors = []
    owner = np.full(m, -1)
    parts = []
    for i, part in enumerate(entries):
        path = f"[[part]][{i}]" if scene.parts else f"part {part.name}"
        section = sections.get(part.section)
        if section is None:
            errors.append(f"{scene.source.name}: {path}.section: no section named {part.section!r}")
        elif section.layered:
            errors += [f"{scene.source.name}: section {part.section}.plies[{j}].material: no material named "
                       f"{ply.material!r}" for j, ply in enumerate(section.plies) if ply.material not in materials]
        elif part.material not in materials:
            errors.append(f"{scene.source.name}: {path}.material: no material named {part.material!r}")
        try:
            ids = element_selection(part.elements, scene, mesh, points, elements, path)
        except SceneError as exc:
            errors += exc.messages
            continue
        taken = ids[owner[ids] >= 0]
        if len(taken):
            other = entries[int(owner[taken[0]])].name
            errors.append(f"{scene.source.name}: {path} '{part.name}': {len(taken)} elements also in part '{other}' "
                          f"(e.g. {', '.join(map(str, taken[:5]))}): every element belongs to one part")
        owner[ids] = i
        parts.append(PartSpec(part.name, ids, None if section is not None and section.layered else part.material,
                              part.section))
    orphans = np.flatnonzero(owner < 0)
    if len(orphans) and not errors:
        errors.append(f"{scene.source.name}: [[part]]: {len(orphans)} elements belong to no part "
                      f"(e.g. {', '.join(map(str, orphans[:5]))})")
    if errors:
        raise SceneError(errors)
    used_s = {p.section for p in parts}
    used_m = {p.material for p in parts} | {ply.material for name in used_s for ply in sections[name].plies}
    if mesh.deck is not None:
        from ..scene import name_hint
        for label, table, used, deck_names in (("materials", scene.materials, used_m, sorted(deck_materials)),
                                               ("sections", scene.sections, used_s, sorted(deck_sections))):
            for name in table:
                if name not in used:
                    errors.append(f"{scene.source.name}: [{label}.{name}]: replaces nothing: no part of the deck "
                                  f"or [[part]] uses {name!r}" + name_hint(name, deck_names, "the deck's"))
        errors += [line for name in sorted(used_s | used_m) if name not in scene.materials
                   and name not in scene.sections for line in deck_problems.get(name, ())]
        if thickness is not None:                # a scene section's thickness wins over the deck's
            for p in parts:
                if p.section in scene.sections:
                    thickness[p.elements] = np.nan
        if errors:
            raise SceneError(errors)
    return tuple(parts), {k: v for k, v in materials.items() if k in used_m}, \
        {k: v for k, v in sections.items() if k in used_s}, thickness, notes


def tables(scene: Scene, parts, material_specs: dict, section_specs: dict, frames,
            element_thickness: np.ndarray | None = None):
    """SectionTable, MaterialTable and ElementData of the parts.  A row of the section table
    is a (section, material) pair of some part (a layered section's material is None): its
    through-thickness points, and the material and ply angle of each (laminate.layup).
    `frames` = (e1, e2) of every element (element_frames) for the material axes.
    `element_thickness` (NaN: the section's) overrides the section's thickness element by
    element (an LS-DYNA deck's *ELEMENT_SHELL_THICKNESS)."""
    e1, e2 = frames
    m = len(e1)
    material_names = tuple(material_specs)
    specs = [material_specs[n] for n in material_names]
    kinds = tuple(k for k in materials.KINDS if any(spec.model == k for spec in specs))
    hardening, rates = materials.hardening_laws(specs), materials.rate_laws(specs)
    curves = [spec.curve if materials.PLASTIC[spec.model] and spec.hardening_law == "tabulated" else ()
              for spec in specs]
    starts = np.concatenate([[0], np.cumsum([len(c) for c in curves])]).astype(int)
    points = np.array([point for c in curves for point in c]).reshape(-1, 2)
    material_table = MaterialTable(
        names=material_names, kinds=kinds,
        kind=np.array([kinds.index(spec.model) for spec in specs], dtype=np.int32),
        rows=np.array([materials.parameter_row(spec, materials.row_width(kinds), hardening, rates, start)
                       for spec, start in zip(specs, starts)]),
        dilatational_speed=max(materials.dilatational_speed(spec) for spec in specs),
        hardening=hardening, rate_laws=rates,
        rate_filter=any(materials.PLASTIC[spec.model] and spec.rate_law != "none"
                        and materials.rate_filter_time(spec) > 0
                        for spec in specs),
        curve_strain=points[:, 0].copy(), curve_stress=points[:, 1].copy(),
        erosion=any(materials.erodes(spec) for spec in specs),
        failure=np.array([materials.failure_row(spec) for spec in specs]))
    if material_table.erosion and scene.solve.kind == "static":
        name = next(n for n, spec in zip(material_names, specs) if materials.erodes(spec))
        raise SceneError(f"{scene.source.name}: material {name!r}: erosion (failure_strain, failure_min_dt; a deck's "
                         "FAIL, TDEL) needs [solve].kind = \"dynamic\"")
    pairs = tuple(dict.fromkeys((p.section, p.material) for p in parts))
    for sec, mat in pairs:                    # a layered section (mat None): each ply's material
        section = section_specs[sec]
        for name in dict.fromkeys([mat] if mat is not None else [ply.material for ply in section.plies]):
            spec = material_specs[name]
            if getattr(spec, "failure_strain", 0.0) > 0.0 and spec.failure_points > section.points:
                label = "[material]" if name == "material" else f"[materials.{name}]"
                where = "[section]" if sec == "section" else f"section '{sec}'"
                raise SceneError(f"{scene.source.name}: {label}.failure_points: expected at most the "
                                 f"{section.points} through-thickness points of {where}, got {spec.failure_points}")
    layups = [laminate.layup(section_specs[sec], material_specs, mat) for sec, mat in pairs]
    nk = max(len(lay.zeta) for lay in layups)
    zeta, weight, angle = (np.zeros((len(pairs), nk)) for _ in range(3))
    point_material = np.zeros((len(pairs), nk), dtype=np.int32)
    for i, lay in enumerate(layups):
        n = len(lay.zeta)
        zeta[i, :n], weight[i, :n], angle[i, :n] = lay.zeta, lay.weight, lay.point_angle
        point_material[i] = [material_names.index(name) for name in lay.point_material] \
            + [material_names.index(lay.point_material[0])] * (nk - n)
    section_table = SectionTable(names=tuple(sec if mat is None else f"{sec}/{mat}" for sec, mat in pairs),
                                 point_count=np.array([len(lay.zeta) for lay in layups], np.int32),
                                 zeta=zeta, weight=weight, point_material=point_material, point_angle=angle,
                                 layered=np.array([section_specs[sec].layered for sec, _ in pairs]))
    el = scene.element
    columns = {name: np.zeros(m) for name in ("thickness", "shear_factor", "wave_speed", "rotational_frequency",
                                              "shear_wave_speed",
                                              "hourglass_membrane", "hourglass_bending", "hourglass_transverse",
                                              "drilling_factor", "opt_modulus", "opt_poisson", "opt_floor", "density",
                                              "rotary_density")}
    material_axis = np.tile([1.0, 0.0], (m, 1))
    part_of = np.zeros(m, dtype=np.int32)
    section_of = np.zeros(m, dtype=np.int32)
    errors = []
    for i, part in enumerate(parts):
        sec = section_specs[part.section]
        row = pairs.index((part.section, part.material))
        lay = layups[row]
        ids = part.elements
        t = np.full(len(ids), sec.thickness)
        if element_thickness is not None:
            t = np.where(np.isfinite(element_thickness[ids]), element_thickness[ids], t)
        kappa = sec.shear_factor
        part_of[ids] = i
        section_of[ids] = row
        r = sec.hourglass if sec.hourglass is not None else el.hourglass
        alpha = sec.drilling_stiffness if sec.drilling_stiffness is not None else el.drilling_stiffness
        # artificial stiffnesses of a laminate: the effective isotropic moduli of laminate.Layup
        values = {"thickness": t, "shear_factor": kappa, "wave_speed": lay.wave_speed,
                  "rotational_frequency": (np.sqrt(12.0 * kappa * lay.transverse_shear_max / lay.rotary_density) / t
                                           if scene.solve.physical_rotary_inertia else 0.0),
                  "shear_wave_speed": np.sqrt(lay.transverse_shear_max / lay.density),
                  "hourglass_membrane": r * lay.membrane_modulus * t / 8.0,
                  "hourglass_bending": r * lay.bending_modulus * t ** 3 / 192.0,
                  "hourglass_transverse": r * kappa * lay.transverse_shear_modulus * t ** 3 / 12.0,
                  "drilling_factor": alpha * lay.bending_modulus * t ** 3 / 48.0 if el.drilling == "penalty" else 0.0,
                  "density": lay.density, "rotary_density": lay.rotary_density}
        if el.triangle == "opt":
            values["opt_modulus"], values["opt_poisson"] = opt_higher_order(sec, material_specs, part.material,
                                                                            lay.membrane_modulus, t)
            values["opt_floor"] = r
        for name, value in values.items():
            columns[name][ids] = value
        if lay.oriented and sec.reference_direction is not None:
            axis, undefined = laminate.material_axis(e1[ids], e2[ids], sec.reference_direction)
            material_axis[ids] = axis
            bad = ids[undefined]
            if len(bad):
                where = "[section]" if scene.section is not None else f"[sections.{part.section}]"
                errors.append(f"{scene.source.name}: {where}.reference_direction: "
                              f"{list(sec.reference_direction)} is within {laminate.AXIS_TOLERANCE_DEG:g} degree of "
                              f"the normal of element {int(bad[0])}"
                              + (f" (and {len(bad) - 1} more)" if len(bad) > 1 else "")
                              + ", where the material axis is undefined: choose a direction further from the normals")
    if errors:
        raise SceneError(errors)
    return section_table, material_table, ElementData(part=part_of, section=section_of, material_axis=material_axis,
                                                      **columns)
