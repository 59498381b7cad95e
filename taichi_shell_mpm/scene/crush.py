"""[crush]: crush post-processing of a dynamic run."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..keys import (
    Check,
    Invalid,
    Vec3,
    boolean,
    hint,
    identifier,
    is_number,
    key,
    keys_of,
    nonzero_vec3,
    positive,
    show,
    window,
)
from .reader import Reader
from .solve import Solve

CRUSH_FORMULAS = ("wierzbicki_abramowicz", "abramowicz_jones")
"""Closed-form mean crush forces of a tube that [crush].mean_force_reference may name (crush.py)."""


def _force_references(value: Any) -> tuple[float | str, ...]:
    if isinstance(value, list) and value and all((is_number(x) and x > 0) or x in CRUSH_FORMULAS for x in value):
        return tuple(x if isinstance(x, str) else float(x) for x in value)
    raise Invalid(f"expected a non-empty list of numbers > 0 and of {' / '.join(map(repr, CRUSH_FORMULAS))}, "
                   f"got {show(value)}")


force_references = Check(_force_references, "list of numbers and names",
                         "numbers > 0, " + ", ".join(f"`{name}`" for name in CRUSH_FORMULAS),
                         {"type": "array", "minItems": 1,
                          "items": {"anyOf": [{"type": "number", "exclusiveMinimum": 0}, {"enum": list(CRUSH_FORMULAS)}]}})
"""A non-empty list of numbers > 0 and names of CRUSH_FORMULAS."""


@dataclass(frozen=True)
class Crush:
    """Crush post-processing of a dynamic run (crush.py, docs/crush.md); present table = on.
    The crush distance is the displacement of `body` along `axis`; the crush force is the
    support reaction (clamped nodes and fixed walls) against `axis`; its mean over the
    crush-distance `window` is the work of the support impulse over that distance."""
    axis: Vec3 = key(nonzero_vec3, "direction in which the crushing body moves")
    window: tuple[float, float] = key(window, unit="length",
        doc="crush distances of the mean force (cut to the distance reached)")
    body: str | None = key(
        identifier, default=None, allowed="a `[[rigid_body]]` name", default_text="the first `[[rigid_body]]`",
        doc="the crushing body")
    folds: bool = key(boolean, default=False,
        doc="count lobes and the fold half-wavelength on the centre lines of the four flat faces of a prismatic "
            "tube along `axis`")
    mean_force_reference: tuple[float | str, ...] = key(
        force_references, default=(), unit="force", allowed="> 0, `\"wierzbicki_abramowicz\"`, `\"abramowicz_jones\"`",
        doc="reference mean forces; a name (tube meshes only) is that closed-form estimate P_m = k σ₀ t^{5/3} "
            "C^{1/3} evaluated with the run's yield stress, thickness and C = (width + depth)/2 "
            "([crush.md](crush.md)); the summary gives `mean_force_reference` (the values), "
            "`mean_force_over_reference` and `specific_energy_absorption_over_reference` for each")
    half_wavelength_reference: float | None = key(positive, default=None, unit="length",
        doc="reference half-wavelength; the summary gives `half_wavelength_over_reference`")


def read_crush(r: Reader, data: Any, solve: Solve | None) -> Crush | None:
    mark = len(r.messages)
    v = r.read("[crush]", data, keys_of(Crush), Crush)
    if v is None:
        return None
    listed = r.raw.get("rigid_body", [])
    bodies = [b["name"] for b in (listed if isinstance(listed, list) else [])
              if isinstance(b, dict) and isinstance(b.get("name"), str)]
    if not bodies:
        r.error("[crush]", "needs a [[rigid_body]] whose motion is the crush")
    elif v.get("body") is not None and v["body"] not in bodies:
        r.error("[crush].body", f"no [[rigid_body]] named {v['body']!r}" + hint(v["body"], bodies, "defined"))
    if solve is not None and solve.kind != "dynamic":
        r.error("[crush]", "crush post-processing needs [solve].kind = \"dynamic\"")
    named = [x for x in v.get("mean_force_reference", ()) if isinstance(x, str)]
    mesh = r.raw.get("mesh")
    if named and not (isinstance(mesh, dict) and mesh.get("kind") == "tube"):
        r.error("[crush].mean_force_reference", f"{named[0]!r} is a formula for a tube: it needs "
                "[mesh].kind = \"tube\" (its width and depth give the size C); give a number instead")
    return r.build(mark, Crush, v)
