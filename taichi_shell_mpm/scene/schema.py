"""What the key declarations give besides the parser: the key tables of docs/scenes.md and a
JSON Schema of scene files (for TOML editors: Taplo / Even Better TOML; docs/scenes.md,
"Editor support").

    python -m taichi_shell_mpm schema > scene.schema.json
    python -m taichi_shell_mpm schema --docs docs/scenes.md     # rewrite the generated tables

The schema checks what one key or one table can check (types, ranges, choices, unknown and
missing keys); the rules across keys and tables (a law's own keys, a node set that must
exist, a file that must be there) are the parser's: `validate` says everything.
"""
from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

from ..keys import REQUIRED, Key, keys_of, shown_default
from .boundary import Boundary
from .contact import Contact
from .contact_pair import ContactPair
from .crush import Crush
from .curves import CURVE_KEYS
from .element import ElementOptions
from .gravity import Gravity
from .info import SceneInfo
from .initial import InitialVelocity
from .load import Load
from .material import HARDENING, LAW_KEYS, MODEL_KEYS, RATE, Material, OrthotropicMaterial
from .mesh import MESH_KIND_KEYS, MESHES
from .method import Method
from .motion import Motion
from .nodesets import NODE_SET_KEYS
from .output import Output
from .parts import ELEMENT_SET_KEYS, Part
from .joints import SpotWeld, Tie
from .point_mass import PointMass
from .pressure import Pressure
from .probe import Probe
from .reader import REQUIRED_TABLES
from .reference import Reference, ReferenceColumn
from .rigid_body import RigidBody
from .section import Ply, Section
from .solve import Solve
from .tool import KINDS, Tool
from .wall import Wall


def _grouped(cls: type, groups: dict[str, dict]) -> dict[str, Key]:
    """`cls`'s keys with the keys its plug-ins declare (each module's KEYS) placed after the
    key that picks them: groups = {that key: {name: module}}."""
    own = {name for modules in groups.values() for module in modules.values() for name in module.KEYS}
    out: dict[str, Key] = {}
    for name, k in keys_of(cls).items():
        if name in own:
            continue
        out[name] = k
        for module in groups.get(name, {}).values():
            out.update({n: keys_of(cls)[n] for n in module.KEYS})
    return out


def _layered() -> dict[str, Key]:
    section = keys_of(Section)
    plies = {f"plies[i].{name}": k for name, k in keys_of(Ply).items()}
    return {"plies": section["plies"], **plies, "points_per_ply": section["points_per_ply"]}


DOC_TABLES: dict[str, Any] = {
    "scene": lambda: keys_of(SceneInfo),
    "mesh": lambda: MESH_KIND_KEYS,
    **{f"mesh.{kind}": (lambda cls=cls: keys_of(cls)) for kind, cls in MESHES.items()},
    "material": lambda: _grouped(Material, {"hardening_law": HARDENING, "rate_law": RATE}),
    "material.orthotropic": lambda: {n: k for n, k in keys_of(OrthotropicMaterial).items() if n != "model"},
    **{f"material.{name}": (lambda keys=keys: keys) for name, keys in LAW_KEYS.items() if keys},
    "section": lambda: keys_of(Section),
    "section.layered": _layered,
    "elementsets": lambda: ELEMENT_SET_KEYS,
    "part": lambda: keys_of(Part),
    "element": lambda: keys_of(ElementOptions),
    "method": lambda: keys_of(Method),
    "nodesets": lambda: NODE_SET_KEYS,
    "boundary": lambda: keys_of(Boundary),
    "load": lambda: keys_of(Load),
    "curves": lambda: CURVE_KEYS,
    "motion": lambda: keys_of(Motion),
    "pressure": lambda: keys_of(Pressure),
    "gravity": lambda: keys_of(Gravity),
    "initial": lambda: keys_of(InitialVelocity),
    "probe": lambda: keys_of(Probe),
    "reference": lambda: keys_of(Reference),
    "reference.compare": lambda: keys_of(ReferenceColumn),
    "solve": lambda: keys_of(Solve),
    "output": lambda: keys_of(Output),
    "rigid_body": lambda: keys_of(RigidBody),
    "point_mass": lambda: keys_of(PointMass),
    "wall": lambda: keys_of(Wall),
    "tool": lambda: _grouped(Tool, {"kind": KINDS}),
    "contact": lambda: keys_of(Contact),
    "contact_pair": lambda: keys_of(ContactPair),
    "crush": lambda: keys_of(Crush),
    "tie": lambda: keys_of(Tie),
    "spotweld": lambda: keys_of(SpotWeld),
}
"""The generated key tables of docs/scenes.md, by the name in their markers
``<!-- keys: NAME -->`` ... ``<!-- /keys -->``."""


# ================================================================ docs tables
def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def _toml(value: Any) -> str:
    """`value` as a TOML value (an example)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return repr(value)


def key_row(name: str, k: Key) -> str:
    """One row | key | type | default | allowed | meaning | of a declared key."""
    kind = k.check.type + (f" [{k.unit}]" if k.unit else "")
    default = k.default_text if k.default_text is not None else shown_default(k.default)
    allowed = k.allowed if k.allowed is not None else k.check.allowed
    meaning = k.doc + (f"; e.g. `{name} = {_toml(k.example)}`" if k.example is not None else "")
    return f"| `{name}` | {_cell(kind)} | {_cell(default)} | {_cell(allowed)} | {_cell(meaning)} |"


def key_table(name: str) -> str:
    """The markdown table of DOC_TABLES[name]."""
    rows = [key_row(n, k) for n, k in DOC_TABLES[name]().items()]
    return "\n".join(["| key | type | default | allowed | meaning |", "|---|---|---|---|---|", *rows])


_MARKED = re.compile(r"(<!-- keys: ([\w.]+) -->\n)(.*?)(<!-- /keys -->)", re.S)


def generated_docs(text: str) -> str:
    """`text` (docs/scenes.md) with every marked key table generated anew."""
    def table(match: re.Match) -> str:
        return f"{match.group(1)}{key_table(match.group(2))}\n{match.group(4)}"
    return _MARKED.sub(table, text)


def marked_tables(text: str) -> list[str]:
    return [m.group(2) for m in _MARKED.finditer(text)]


# ================================================================ JSON Schema
def _json_default(value: Any) -> Any:
    if isinstance(value, tuple):
        return [_json_default(v) for v in value]
    return value if isinstance(value, (bool, int, float, str)) else None


def _plain(doc: str) -> str:
    """A meaning without markdown backticks, for an editor's tooltip."""
    return doc.replace("`", "")


def key_schema(k: Key) -> dict:
    schema = dict(k.check.schema)
    unit = f" [{k.unit}]" if k.unit else ""
    schema["description"] = _plain(k.doc) + unit
    default = _json_default(k.default) if k.default is not REQUIRED else None
    if default is not None and default != []:
        schema["default"] = default
    if k.example is not None:
        schema["examples"] = [k.example]
    return schema


def table_schema(keys: dict[str, Key], required: bool = True, description: str = "") -> dict:
    """An object of the declared `keys` (unknown keys refused; required ones listed)."""
    out: dict[str, Any] = {"type": "object", "properties": {n: key_schema(k) for n, k in keys.items()},
                           "additionalProperties": False}
    needed = [n for n, k in keys.items() if k.required and k.default_text is None]
    if required and needed:
        out["required"] = needed
    if description:
        out["description"] = description
    return out


def _array(schema: dict) -> dict:
    return {"type": "array", "items": schema}


def _named(schema: dict, what: str) -> dict:
    return {"type": "object", "description": f"{what} by name (letters, digits, _ and -)",
            "propertyNames": {"pattern": "^[A-Za-z0-9_-]+$"}, "additionalProperties": schema}


def scene_schema() -> dict:
    """The JSON Schema of a scene file: draft 7, which Taplo and the common editors read."""
    material = {"anyOf": [table_schema({**keys_of(Material), **MODEL_KEYS}),
                          {**table_schema(keys_of(OrthotropicMaterial)),
                           "required": [*table_schema(keys_of(OrthotropicMaterial))["required"], "model"]}]}
    section = table_schema(keys_of(Section), required=False)
    mesh = {"type": "object", "required": ["kind"], "oneOf": []}
    for kind, cls in MESHES.items():
        table = table_schema(keys_of(cls))
        table["properties"] = {"kind": {"const": kind, "description": _plain(MESH_KIND_KEYS["kind"].doc)},
                               **table["properties"]}
        table["required"] = ["kind", *table.get("required", [])]
        mesh["oneOf"].append(table)
    properties = {
        "scene": table_schema(keys_of(SceneInfo)), "mesh": mesh, "material": material, "section": section,
        "materials": _named(material, "[materials.NAME]: materials"),
        "sections": _named(section, "[sections.NAME]: sections"),
        "elementsets": _named(table_schema(ELEMENT_SET_KEYS, required=False), "[elementsets.NAME]: element sets"),
        "part": _array(table_schema(keys_of(Part))), "element": table_schema(keys_of(ElementOptions)),
        "method": table_schema(keys_of(Method)),
        "nodesets": _named(table_schema(NODE_SET_KEYS, required=False), "[nodesets.NAME]: node sets"),
        "boundary": _array(table_schema(keys_of(Boundary))), "load": _array(table_schema(keys_of(Load))),
        "curves": _named(table_schema(CURVE_KEYS, required=False), "[curves.NAME]: time functions"),
        "motion": _array(table_schema(keys_of(Motion))),
        "pressure": _array(table_schema(keys_of(Pressure))), "gravity": table_schema(keys_of(Gravity)),
        "initial": _array(table_schema(keys_of(InitialVelocity))), "probe": _array(table_schema(keys_of(Probe))),
        "reference": table_schema(keys_of(Reference)), "solve": table_schema(keys_of(Solve)),
        "output": table_schema(keys_of(Output)), "rigid_body": _array(table_schema(keys_of(RigidBody))),
        "point_mass": _array(table_schema(keys_of(PointMass))),
        "wall": _array(table_schema(keys_of(Wall))), "tool": _array(table_schema(keys_of(Tool))),
        "contact": table_schema(keys_of(Contact)), "crush": table_schema(keys_of(Crush)),
        "contact_pair": _array(table_schema(keys_of(ContactPair))),
        "tie": _array(table_schema(keys_of(Tie))), "spotweld": _array(table_schema(keys_of(SpotWeld))),
    }
    return {"$schema": "http://json-schema.org/draft-07/schema#",
            "title": "taichi_shell_mpm scene",
            "description": "A scene file of taichi_shell_mpm (docs/scenes.md). Checks each key and table; "
                           "`python -m taichi_shell_mpm validate` checks the rules across them.",
            "type": "object", "required": list(REQUIRED_TABLES), "additionalProperties": False,
            "properties": properties,
            "definitions": {"ply": table_schema(keys_of(Ply)), "reference_compare": table_schema(keys_of(ReferenceColumn))}}


def write_docs(path: Path) -> bool:
    """Regenerate the marked key tables of `path`; whether it changed."""
    text = path.read_text(encoding="utf-8")
    new = generated_docs(text)
    if new != text:
        path.write_text(new, encoding="utf-8")
    return new != text
