"""Scene files: TOML (+ ``--set`` overrides) parsed once into frozen, validated dataclasses.

Each table has its module, named after it (scene/material.py is ``[material]`` and
``[materials.NAME]``, scene/tool.py ``[[tool]]``, ...): its dataclass declares every key
once (taichi_shell_mpm/keys.py: the check, default, unit, meaning, example), and its reader adds the
rules across keys.  From the declarations come the parser's checks (scene/reader.py), the
key tables of docs/scenes.md and the JSON Schema (scene/schema.py,
``python -m taichi_shell_mpm schema``).  Everything downstream (mesh, nodesets, state,
solvers, output) reads only these objects, never the raw TOML.

Errors in a scene are collected (all of them, not just the first) and raised as one
:class:`SceneError`, whose ``messages`` are single lines of the form
``scene.toml: [[boundary]][2].fix: expected ... , got ...``.
"""
from __future__ import annotations

from typing import Any

from ..keys import DOFS, Invalid, Vec3, hint, inertia_tensor, keys_of
from .boundary import Boundary
from .contact import Contact, penalty_damping_limit
from .crush import CRUSH_FORMULAS, Crush
from .curves import CURVE_SHAPES, MAX_CURVES, Curve
from .document import Scene, SceneError, apply_overrides, load_scene, parse_scene
from .element import ElementOptions
from .gravity import Gravity
from .info import SceneInfo
from .initial import InitialVelocity
from .load import Load
from .material import MODEL_KEYS, AnyMaterial, Material, OrthotropicMaterial
from .mesh import DECK_SUFFIXES, FileMesh, HemisphereMesh, MeshSpec, PlateMesh, TubeMesh
from .joints import SpotWeld, Tie
from .method import Method
from .motion import MAX_MOTIONS, MOTION_KINDS, Motion
from .nodesets import NodeSet
from .output import Output
from .parts import ElementSet, Part
from .point_mass import PointMass
from .pressure import Pressure
from .probe import Probe
from .reference import Reference, ReferenceColumn
from .rigid_body import MAX_BODIES, RigidBody
from .section import Ply, Section
from .solve import Solve
from .tool import TOOL_KINDS, Tool
from .wall import Wall

__all__ = [
    "AnyMaterial", "Boundary", "CRUSH_FORMULAS", "CURVE_SHAPES", "Contact", "Crush", "Curve", "DECK_SUFFIXES",
    "DOFS", "ElementOptions", "ElementSet", "FileMesh", "Gravity", "HemisphereMesh", "InitialVelocity", "Load",
    "MAX_BODIES", "MAX_CURVES", "MAX_MOTIONS", "MOTION_KINDS", "Material", "MeshSpec", "Method", "Motion",
    "NodeSet", "OrthotropicMaterial", "Output", "Part", "PlateMesh", "Ply", "PointMass", "Pressure", "Probe",
    "Reference", "ReferenceColumn", "RigidBody", "Scene", "SceneError", "SceneInfo", "Section", "Solve", "SpotWeld", "Tie",
    "TOOL_KINDS", "Tool", "TubeMesh", "Vec3", "Wall", "apply_overrides", "inertia_tensor", "load_scene",
    "name_hint", "parse_scene", "penalty_damping_limit", "value_problem"]


def value_problem(table: str, key: str, value: Any) -> str | None:
    """What is wrong with `value` as the key `key` of [material] or [section] (`table`), or
    None: an LS-DYNA deck's values are checked by the scene's own declarations
    (model/deck.deck_specs), so a deck value is held to the same range as the scene key."""
    declared = {"material": {**keys_of(Material), **MODEL_KEYS}, "section": keys_of(Section)}[table]
    try:
        declared[key].check(value)
    except Invalid as exc:
        return str(exc)
    return None


def name_hint(word: str, options: list[str] | tuple[str, ...], label: str) -> str:
    """`` (did you mean 'x'?)``, or else `` (label: a, b, ...)``: the scene's hint, for other modules."""
    return hint(word, options, label)
