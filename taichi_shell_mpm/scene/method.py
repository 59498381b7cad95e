"""[method]: mpm or fem, and the grid."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

from ..keys import (
    Vec3,
    choice,
    key,
    keys_of,
    non_negative,
    positive,
    unit_interval,
    vec3,
)
from .reader import Reader


@dataclass(frozen=True)
class Method:
    kind: Literal["mpm", "fem"] = key(choice("mpm", "fem"), default="mpm",
        doc="`mpm`: shell nodes move through the background grid (double mapping); `fem`: the same shells with "
            "the grid switched off (`transfer`, `flip_blend`, `fields`, `field_contact`, `field_friction` set "
            "away from their defaults are then a warning naming the key; `cell_size` and the grid box are kept "
            "quietly, as a scene switched by `--set method.kind=fem` has them)")
    cell_size: float | None = key(
        positive, default=None, unit="length", default_text="half the shortest element edge",
        doc="grid cell size h")
    grid_min: Vec3 | None = key(
        vec3, default=None, unit="length", allowed="both or neither; `grid_min` < `grid_max` in every component; the box must cover the mesh", default_text="none: unbounded",
        doc="optional grid box: a node leaving it stops the run. Without it the grid follows the shell anywhere "
            "(grid nodes exist only around shell nodes, memory in proportion to the shell's nodes, "
            "`stages/grid.py`)")
    grid_max: Vec3 | None = key(
        vec3, default=None, unit="length", allowed="both or neither; `grid_min` < `grid_max` in every component; the box must cover the mesh", default_text="none: unbounded",
        doc="optional grid box: a node leaving it stops the run. Without it the grid follows the shell anywhere "
            "(grid nodes exist only around shell nodes, memory in proportion to the shell's nodes, "
            "`stages/grid.py`)")
    transfer: Literal["apic", "polypic", "pic", "flip"] = key(
        choice("apic", "polypic", "pic", "flip"), default="apic",
        doc="grid ↔ node velocity transfer. `apic`: each node carries its velocity and an affine velocity field "
            "(rigid motion transfers exactly). `polypic`: also the cell's bilinear and trilinear velocity modes "
            "(12 more numbers per node), so that grid → nodes → grid is exact for nodes that stay in their cell; "
            "at one cell per element (h ≈ ℓ) APIC dissipates the node-scale waves of an impact and PolyPIC does "
            "not (the tube at h = ℓ: energy lost by 0.5 ms 8.85 J with APIC, 0.15 J with PolyPIC; with `fields = "
            "\"multi\"` the crush force is then within 0.2 % of h = ℓ/2, docs/grid.md). `pic`: velocity only "
            "(dissipative; enough for dynamic relaxation). `flip`: the grid's velocity change added to the node's"
            " own velocity")
    flip_blend: float = key(unit_interval, "FLIP fraction α_F with `transfer = \"flip\"` (0 = PIC)", default=0.99)
    fields: Literal["single", "multi"] = key(choice("single", "multi"), default="single",
        doc="velocity fields per grid node. `single`: one velocity per grid node, so layers closer than about a "
            "cell move together (they stick); `multi`: each grid node keeps a field per shell layer that reaches "
            "it (a layer: the same part, reference positions within 4 cells, normals on the same side), so "
            "approaching layers keep their own velocities and only `[contact]` (or `field_contact = \"grid\"`) "
            "makes them interact (`tests/test_grid.py`: two sheets within h/4 exchange no momentum before they "
            "touch). At most 4 fields per grid node: a fifth layer shares the last one, and the run warns once "
            "(time, step and grid nodes; summary.json `warnings`, `grid.field_overflow`). Compiled in only when "
            "chosen; costs ×1.3–1.5 per step on the tube. At h = ℓ it halves the tube's energy error; with "
            "`transfer = \"polypic\"` the rest goes too (docs/grid.md)")
    field_contact: Literal["penalty", "grid"] = key(
        choice("penalty", "grid"), default="penalty", allowed="`penalty`, `grid`; `grid` only with `fields = \"multi\"`",
        doc="how the fields of the multi-field grid interact. `penalty`: only through `[contact]` (none without "
            "it); `grid`: also through the grid contact condition (Bardenhagen et al. 2001; `stages/grid.py`): at"
            " a grid node shared by two layers closer than t_c (the `[contact]` thickness, else the thickest "
            "section's), a layer approaching the other loses its normal velocity relative to their centre of mass"
            " (a perfectly plastic impact: no bounce) and its slip is slowed by Coulomb friction; the kinetic "
            "energy removed is the `contact` column. It acts only where the layers' grid nodes overlap; measured "
            "against the penalty in docs/contact.md. Compiled in only when chosen")
    field_friction: float = key(non_negative, default=0.0, allowed=">= 0; only with `field_contact = \"grid\"`",
        doc="Coulomb coefficient μ of the grid contact condition (the slip change at most μ times the normal one)")


def read_method(r: Reader, data: Any) -> Method | None:
    mark = len(r.messages)
    v = r.read("[method]", data, keys_of(Method), Method)
    if v is None:
        return None
    if ("grid_min" in data) != ("grid_max" in data):
        missing = "grid_max" if "grid_min" in data else "grid_min"
        r.error(f"[method].{missing}", "missing required key (grid_min and grid_max come together)")
    r.check_order("[method]", v.get("grid_min"), v.get("grid_max"), ("grid_min", "grid_max"),
                  strict=True)
    if v.get("field_contact") == "grid" and v.get("fields") != "multi":
        r.error("[method].field_contact", '"grid" acts between the fields of a multi-field grid: set fields = "multi"')
    if "field_friction" in data and v.get("field_contact") != "grid":
        r.error("[method].field_friction", 'the friction of the grid contact condition: set field_contact = "grid"')
    return r.build(mark, Method, v)
