"""[section] and [sections.NAME]: one material over the thickness, or layered (plies)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

from ..keys import (
    Check,
    Vec3,
    choice,
    field_defaults,
    fraction,
    integer,
    key,
    keys_of,
    nonempty,
    nonzero_vec3,
    number,
    positive,
    show,
    unit_interval,
)
from .reader import Reader


@dataclass(frozen=True)
class Ply:
    """One layer of a layered section (docs/laminates.md)."""
    material: str = key(nonempty, allowed="a `[materials.NAME]`",
        doc="the ply's material: `elastic`, `j2` or `orthotropic`")
    thickness: float = key(positive, "the ply's thickness", unit="length")
    angle: float = key(number(-360, 360), default=0.0, unit="degrees", allowed="[−360, 360]",
        doc="degrees from the section's material axis (`reference_direction` projected) to the ply's 1-axis, "
            "counter-clockwise about e₃")


MAX_PLIES = 64
PLIES = Check(None, "array of tables", f"1 to {MAX_PLIES} plies",
              {"type": "array", "minItems": 1, "maxItems": MAX_PLIES, "items": {"$ref": "#/definitions/ply"}},
              context=lambda r, value: read_plies(r, "plies", value))
"""A layered section's plies (read by read_section with their own paths; declared for the
docs and the schema)."""


@dataclass(frozen=True)
class Section:
    thickness: float = key(positive, unit="length",
        doc="shell thickness (above the shortest edge of one of its elements: a warning naming the key, the count"
            " and one element, as t ≫ element size is no thin shell)")
    points: int = key(integer(1, 10), default=3, allowed="lobatto: 2..10, gauss: 1..10",
        doc="integration points through the thickness")
    rule: Literal["lobatto", "gauss"] = key(choice("lobatto", "gauss"), default="lobatto",
        doc="through-thickness quadrature (Lobatto includes the surfaces)")
    shear_factor: float = key(fraction, default=5.0 / 6.0, default_text="`0.8333…` (5/6)",
        doc="transverse shear correction factor κ")
    hourglass: float | None = key(unit_interval, default=None, default_text="`[element].hourglass`",
        doc="hourglass coefficient r of this section's elements")
    drilling_stiffness: float | None = key(positive, default=None, default_text="`[element].drilling_stiffness`",
        doc="drilling-spring α of this section's elements")
    plies: tuple[Ply, ...] = key(
        PLIES, default=(), default_text="none",
        doc="a layered section (laminate) instead of `thickness`, `points`, `rule`: see *Layered sections* below")
    points_per_ply: int = key(integer(1, 5), default=2, allowed="1..5",
        doc="Gauss points through each ply of a layered section (below)")
    reference_direction: Vec3 | None = key(
        nonzero_vec3, default=None, allowed="not 0", default_text="none: edge 1-2 of each element",
        doc="the material axis of an `orthotropic` material: this vector projected onto each element in the "
            "reference configuration (an error names an element whose normal lies within 1° of it); "
            "[laminates.md](laminates.md)")

    @property
    def layered(self) -> bool:
        return bool(self.plies)


SINGLE_ONLY = ("thickness", "points", "rule")        # a layered section derives them from its plies
LAYERED_ONLY = ("plies", "points_per_ply")


def layered_table(data: Any) -> bool:
    """Whether the raw section table `data` is a layered section (has plies)."""
    return isinstance(data, dict) and "plies" in data


def read_section(r: Reader, data: Any, path: str = "[section]") -> Section | None:
    """A section: one material over the thickness (`thickness`, `points`, `rule`), or
    layered (`plies`, `points_per_ply`; docs/laminates.md)."""
    mark = len(r.messages)
    if not layered_table(data):
        spec = {name: k for name, k in keys_of(Section).items() if name not in LAYERED_ONLY}
        v = r.read(path, data, spec, Section, extra=LAYERED_ONLY)
        if v is None:
            return None
        for key in LAYERED_ONLY[1:]:
            if key in data:
                r.error(f"{path}.{key}", "only for a layered section (with plies)")
        if v.get("rule") == "lobatto" and v.get("points") == 1:
            r.error(f"{path}.points", "expected an integer in [2, 10] for rule = lobatto, got 1")
        return r.build(mark, Section, v)
    spec = {name: k for name, k in keys_of(Section).items() if name not in (*SINGLE_ONLY, "plies")}
    v = r.read(path, data, spec, extra=("plies", *SINGLE_ONLY))
    defaults = field_defaults(Section)
    for key in SINGLE_ONLY:
        if key in data:
            r.error(f"{path}.{key}", "a layered section takes it from its plies (thickness: their sum; "
                                     "points: points_per_ply Gauss points in each): leave it out")
    plies = read_plies(r, f"{path}.plies", data["plies"])
    if plies is None:
        return None
    v = {**defaults, **v, "plies": plies, "thickness": math.fsum(p.thickness for p in plies), "rule": "gauss"}
    v["points"] = len(plies) * v["points_per_ply"]
    return r.build(mark, Section, v)


def read_plies(r: Reader, path: str, value: Any) -> tuple[Ply, ...] | None:
    """The `plies` array of a layered section: tables {material, thickness, angle}, bottom to top."""
    if not (isinstance(value, list) and 0 < len(value) <= MAX_PLIES):
        r.error(path, f"expected an array of 1 to {MAX_PLIES} ply tables "
                      f"{{material = \"NAME\", thickness = t, angle = degrees}}, got {show(value)}")
        return None
    plies = [r.table_object(f"{path}[{i}]", item, Ply) for i, item in enumerate(value)]
    return tuple(plies) if all(p is not None for p in plies) else None
