"""[elementsets.NAME] and [[part]], and how a scene's materials and sections make its parts."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

from ..keys import (
    BOX,
    BOX_KEYS,
    Key,
    Vec3,
    element_ids,
    hint,
    identifier,
    key,
    key_path,
    keys,
    nonempty,
    show,
    true,
)
from .material import read_material
from .mesh import DECK_SUFFIXES, FileMesh
from .reader import Reader
from .section import layered_table, read_section


@dataclass(frozen=True)
class ElementSet:
    """A selection of elements. Exactly one selector kind."""
    name: str
    kind: Literal["all", "box", "ids", "mesh"]
    box_min: Vec3 | None = None
    box_max: Vec3 | None = None
    """box: the elements whose centroid (reference configuration) lies inside."""
    ids: tuple[int, ...] = ()
    mesh_set: str | None = None
    """mesh: a set of the mesh file (a Gmsh physical group, an ELSET, an LS-DYNA part ...)."""


@dataclass(frozen=True)
class Part:
    """A group of elements with one section and, unless the section is layered (its plies
    name their materials), one material."""
    name: str = key(identifier, "the part's name (parts.csv, summary.json)", allowed="an identifier, unique")
    section: str = key(nonempty, "the part's section", allowed="a `[sections.NAME]`")
    material: str | None = key(nonempty, "the part's material", default=None, allowed="a `[materials.NAME]`",
                               default_text="required unless the section is layered (its plies name their materials)")
    elements: str = key(nonempty, "the part's elements", default="all",
                        allowed="an `[elementsets.NAME]`, a set of the mesh file by its name (*Element sets* "
                                "above), or `\"all\"`")


ELEMENT_SET_KEYS = keys(
    Key("all", true, "every element", default_text="one selector", example=True),
    Key("box", BOX, default_text="one selector", doc="elements whose centroid (reference configuration) is inside the box (boundaries "
                    "included, to 10⁻¹²)", example={"min": [0.0, -1.0, -1.0], "max": [5.0, 2.0, 1.0]}),
    Key("ids", element_ids, default_text="one selector", doc="these element indices (0-based, in mesh order; for a generated plate, row by row "
                            "along x)", example=[0, 5, 7]),
    Key("mesh", nonempty, default_text="one selector", doc="a set of the mesh file (a Gmsh physical group, an Abaqus ELSET, `\"part:2\"` of an "
                          "LS-DYNA deck, `\"block:1\"`, ...)", example="roof"))
"""[elementsets.NAME]: exactly one selector."""


def lone_layered_section(data: Any) -> bool:
    """Whether the raw [sections] `data` is one layered section (its plies name the materials:
    no [[part]] needed)."""
    return isinstance(data, dict) and len(data) == 1 and layered_table(next(iter(data.values())))


def read_parts(r: Reader, mesh):
    """[material]/[section] (one part), or [materials.NAME], [sections.NAME], [elementsets.NAME]
    and [[part]]; an LS-DYNA deck may supply all of them (model/parts.py)."""
    raw = r.raw
    deck = isinstance(mesh, FileMesh) and mesh.path.suffix.lower() in DECK_SUFFIXES
    legacy = [k for k in ("material", "section") if k in raw]
    named = [k for k in ("materials", "sections", "part") if k in raw]
    material = read_material(r, "[material]", raw["material"]) if "material" in raw else None
    section = read_section(r, raw["section"]) if "section" in raw else None
    if section is not None and section.layered:
        r.error("[section].plies", "a layered section is a [sections.NAME] table: its plies name "
                                   "[materials.NAME] tables")
    materials = r.named("materials", lambda path, data: read_material(r, path, data))
    sections = r.named("sections", lambda path, data: read_section(r, data, path))
    elementsets = [read_elementset(r, name, value) for name, value in
                   (raw.get("elementsets") if isinstance(raw.get("elementsets"), dict) else {}).items()]
    if "elementsets" in raw and not isinstance(raw["elementsets"], dict):
        r.error("[elementsets]", f"expected tables [elementsets.NAME], got {show(raw['elementsets'])}")
    parts = r.array("part", lambda path, data: read_part(r, path, data))
    if legacy and named:
        r.error(f"[{legacy[0]}]", f"a scene has either [material] and [section] (one part) or "
                f"[materials.NAME], [sections.NAME] and [[part]], not both (found [{named[0]}])")
    elif not legacy and not named and not deck:
        for key in ("material", "section"):
            r.error(f"[{key}]", f"missing required table (or [{key}s.NAME] tables with [[part]])")
    elif legacy:
        for key in ("material", "section"):
            if key not in raw:
                r.error(f"[{key}]", "missing required table")
    elif "part" not in raw and not deck and ("materials" in raw or "sections" in raw) \
            and (len(raw.get("materials", {})) != 1 or len(raw.get("sections", {})) != 1) \
            and not lone_layered_section(raw.get("sections")):
        r.error("[[part]]", "missing: with several [materials.NAME] or [sections.NAME], [[part]] entries "
                            "say which elements get which")
    defined = list(raw["materials"]) if isinstance(raw.get("materials"), dict) else []   # valid or not
    for name, sec in sections.items():        # the plies' materials (a deck's are checked in model/parts.py)
        for i, ply in enumerate(sec.plies):
            if ply.material not in defined and not deck:
                r.error(f"[sections.{key_path(name)}].plies[{i}].material", f"no [materials.{ply.material}]"
                        + hint(ply.material, defined, "defined"))
    if "part" in raw:
        names = [p.name for p in parts if p is not None]
        for i, name in enumerate(names):
            if name in names[:i]:
                r.error("[[part]]", f"duplicate part name {name!r}")
        for key in ("materials", "sections"):
            if key not in raw and not deck:
                r.error(f"[{key}]", f"missing: [[part]] needs [{key}.NAME] tables")
        # names as written, valid or not: an invalid table is reported once, by its own check
        set_names = list(raw["elementsets"]) if isinstance(raw.get("elementsets"), dict) else []
        written = {key: list(raw[key]) if isinstance(raw.get(key), dict) else [] for key in ("materials", "sections")}
        for i, part in enumerate(parts):
            if part is None:
                continue
            for key, table, label in (("material", written["materials"], "materials"),
                                      ("section", written["sections"], "sections")):
                value = getattr(part, key)
                if value is not None and table and value not in table and not deck:
                    r.error(f"[[part]][{i}].{key}", f"no [{label}.{value}]" + hint(value, list(table), "defined"))
            section_of = sections.get(part.section)
            if section_of is not None and section_of.layered and part.material is not None:
                r.error(f"[[part]][{i}].material", f"section {part.section!r} is layered (its plies name "
                                                   "their materials): leave material out")
            elif section_of is not None and not section_of.layered and part.material is None:
                r.error(f"[[part]][{i}].material", f"missing required key (section {part.section!r} "
                                                   "is not layered)")
            check_element_set(r, f"[[part]][{i}].elements", part.elements, set_names, mesh)
    return material, section, materials, sections, [s for s in elementsets if s is not None], parts


def check_element_set(r: Reader, path: str, value: str, names: list[str], mesh) -> None:
    """A key naming an element set: "all", an [elementsets.NAME] (`names`), or on a mesh file
    one of the file's sets (those are checked when the mesh is read, model/parts.py)."""
    if value != "all" and value not in names and not isinstance(mesh, FileMesh):
        r.error(path, f"no [elementsets.{value}]" + hint(value, names + ["all"], "defined"))


def read_elementset(r: Reader, name: str, data: Any) -> ElementSet | None:
    path = f"[elementsets.{key_path(name)}]"
    mark = len(r.messages)
    r.set_name(path, name, "an element set", "every element")
    v = r.read(path, data, {k: d for k, d in ELEMENT_SET_KEYS.items() if k != "box"}, extra=("box",))
    if v is None:
        return None
    given = [key for key in ELEMENT_SET_KEYS if key in data]
    if len(given) != 1:
        r.error(path, f"expected exactly one selector (all, box, ids, mesh), got {', '.join(given) or 'none'}")
        return None
    values = {"name": name, "kind": given[0]}
    if given[0] == "box":
        box = r.read(f"{path}.box", data["box"], BOX_KEYS, required=("min", "max"))
        if box:
            r.check_order(f"{path}.box", box.get("min"), box.get("max"), ("min", "max"), strict=False)
            values.update(box_min=box.get("min"), box_max=box.get("max"))
    elif given[0] == "ids":
        values["ids"] = v.get("ids")
    elif given[0] == "mesh":
        values["mesh_set"] = v.get("mesh")
    return r.build(mark, ElementSet, values)


def read_part(r: Reader, path: str, data: Any) -> Part | None:
    return r.table_object(path, data, Part)
