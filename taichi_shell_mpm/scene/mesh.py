"""[mesh]: a generated plate, hemisphere or tube, or a mesh file (an LS-DYNA deck among them)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Union

from ..keys import (
    BOX,
    Check,
    Invalid,
    Key,
    Vec3,
    boolean,
    choice,
    integer,
    key,
    keys,
    keys_of,
    non_negative,
    number,
    positive,
    scene_file,
    show,
    vec3,
)
from ..dyna.reader import DYNA_SUFFIXES as DECK_SUFFIXES  # noqa: F401 (the file endings read as decks)
from .reader import Reader

MAX_GENERATED_ELEMENTS = 10_000_000     # a generated mesh larger than this is a typo, not a model


GENERATED_COUNT_KEYS = {"plate": ("nx", "ny"), "hemisphere": ("n_around", "n_meridian"),
                        "tube": ("n_flat", "n_corner", "n_length")}


def generated_elements(kind: str, v: dict) -> int | None:
    """Element count of a generator's table once its count keys are valid, else None."""
    keys = GENERATED_COUNT_KEYS.get(kind)
    if keys is None or not all(isinstance(v.get(k), int) for k in keys):
        return None
    if kind == "tube":
        return 4 * (v["n_flat"] + v["n_corner"]) * v["n_length"]
    count = 1
    for k in keys:
        count *= v[k]
    return count


TriangleSplit = Union[Literal["none", "all"], tuple[Vec3, Vec3]]
"""`triangles` of a generated mesh: "none", "all", or a box (min, max) of quad centroids:
the quads it selects are cut into two triangles each (mesh.split_quads)."""


def _triangle_split(value: Any) -> TriangleSplit:
    if value in ("none", "all"):
        return value
    if isinstance(value, dict) and set(value) == {"min", "max"}:
        lo, hi = vec3(value["min"]), vec3(value["max"])
        if all(a <= b for a, b in zip(lo, hi)):
            return lo, hi
    raise Invalid(f'expected "none", "all" or a box {{min = [x, y, z], max = [x, y, z]}} with min <= max, '
                  f"got {show(value)}")


triangle_split = Check(_triangle_split, "string or table", '`"none"`, `"all"`, `{ min = [x, y, z], max = [x, y, z] }`',
                       {"anyOf": [{"enum": ["none", "all"]}, BOX.schema]})
""""none", "all" or a box {min = [x, y, z], max = [x, y, z]} (min <= max)."""


def triangles_key() -> Any:
    """The `triangles` key every generated mesh has."""
    return key(triangle_split, default="none",
               doc="cut the generated quads into two 3-node triangles each: all of them, or those whose centroid "
                   "lies in the box (bounds included); the diagonals alternate in a checkerboard (below)")


@dataclass(frozen=True)
class PlateMesh:
    """Flat rectangle in the x-y plane, nx x ny quads, normals +z."""
    lx: float = key(positive, "side lengths along x and y", unit="length")
    ly: float = key(positive, "side lengths along x and y", unit="length")
    nx: int = key(integer(1), "elements along x and y")
    ny: int = key(integer(1), "elements along x and y")
    origin: Vec3 = key(vec3, "corner with the smallest x and y", default=(0.0, 0.0, 0.0), unit="length")
    triangles: TriangleSplit = triangles_key()
    kind: Literal["plate"] = "plate"


@dataclass(frozen=True)
class HemisphereMesh:
    """Hemisphere of mid-surface radius `radius` about +z, open within `hole_deg` of the pole.

    Latitude phi in [0, 90-hole_deg] deg (n_meridian uniform rows), longitude theta in
    [0, 360) (full, n_around elements) or [0, 90] (quarter, n_around elements on the
    quarter).  Normals point outward.
    """
    radius: float = key(positive, "mid-surface radius", unit="length")
    hole_deg: float = key(number(0, 90, lo_open=True, hi_open=True), unit="degrees",
        doc="half-angle of the polar hole, degrees")
    n_around: int = key(integer(1), "elements around (on the quarter when `quarter = true`)")
    n_meridian: int = key(integer(1), "element rows from the equator to the hole, uniform in latitude")
    quarter: bool = key(boolean, "model the quarter 0° <= longitude <= 90° instead of the full circle", default=True)
    triangles: TriangleSplit = triangles_key()
    kind: Literal["hemisphere"] = "hemisphere"


@dataclass(frozen=True)
class TubeMesh:
    """Rectangular tube along +z from z=0 to `length`, section width x depth (mid-surface),
    corner fillets of radius `corner_radius`, n_flat elements per flat side, n_corner per
    fillet, n_length along z. Normals point outward."""
    width: float = key(positive, "mid-surface section sizes", unit="length")
    depth: float = key(positive, "mid-surface section sizes", unit="length")
    corner_radius: float = key(non_negative, unit="length", allowed=">= 0 and < min(width, depth)/2",
        doc="corner fillet radius")
    length: float = key(positive, "tube length", unit="length")
    n_flat: int = key(integer(1), "elements across each flat side")
    n_corner: int = key(integer(0), "elements around each fillet", allowed=">= 0, and >= 1 when `corner_radius` > 0")
    n_length: int = key(integer(1), "elements along z")
    trigger_amplitude: float = key(non_negative, default=0.0, unit="length",
        doc="geometric trigger (benchmarks.md 3.1) a₀: each flat side's nodes move along its normal by a₀ sin(π(z"
            " − z₀)/L) sin(πs/b) for z₀ <= z <= z₀ + L (s: position across the flat, b its width between the "
            "fillets), inward on the two faces normal to x and outward on the two normal to y; corners untouched;"
            " 0 = no trigger")
    trigger_start: float = key(non_negative, "z₀ of the trigger", default=5.0, unit="length")
    trigger_length: float = key(positive, "L of the trigger (one fold half-wavelength)", default=15.0, unit="length")
    triangles: TriangleSplit = triangles_key()
    kind: Literal["tube"] = "tube"


@dataclass(frozen=True)
class FileMesh:
    """Any quad surface mesh meshio reads (.msh, .vtk, .vtu, .inp, ...)."""
    path: Path = key(scene_file, allowed="an existing file (not a directory)",
        doc="mesh file, relative to the scene file's folder")
    scale: float = key(positive, default=1.0,
        doc="factor applied to the file's node coordinates (only: an LS-DYNA deck's thicknesses and material "
            "values are read as written)")
    merge_nodes: bool = key(boolean, default=False,
        doc="join coincident nodes (closer than 10⁻⁹ of the bounding-box diagonal) into the lowest-numbered of "
            "them, then renumber the nodes (`ids = [...]` node sets and the ids in messages refer to the merged "
            "mesh); `false`: they stay distinct, so a slit, a crack or a seam modelled with two faces at the same"
            " coordinates (Sze's slit annular plate) stays open")
    kind: Literal["file"] = "file"


MeshSpec = Union[PlateMesh, HemisphereMesh, TubeMesh, FileMesh]




MESHES = {"plate": PlateMesh, "hemisphere": HemisphereMesh, "tube": TubeMesh, "file": FileMesh}
MESH_KIND_KEYS = keys(Key("kind", choice(*MESHES), "mesh generator"))
"""[mesh]: `kind` picks the generator; only that kind's keys are allowed."""


def read_mesh(r: Reader, data: Any) -> MeshSpec | None:
    if not isinstance(data, dict):
        r.error("[mesh]", f"expected a table, got {show(data)}")
        return None
    if "kind" not in data:
        r.error("[mesh].kind", f"missing required key (one of {', '.join(MESHES)})")
        return None
    kind = r.check("[mesh].kind", choice(*MESHES), data["kind"])
    if kind is None:
        return None
    cls = MESHES[kind]
    mark = len(r.messages)
    v = r.read("[mesh]", data, keys_of(cls), cls, extra=("kind",))
    count = generated_elements(kind, v)
    if count is not None and count > MAX_GENERATED_ELEMENTS:
        product = {"plate": "nx x ny", "hemisphere": "n_around x n_meridian",
                "tube": "4 (n_flat + n_corner) x n_length"}[kind]
        r.error(f"[mesh].{max(GENERATED_COUNT_KEYS[kind], key=v.get)}",
                f"expected at most {MAX_GENERATED_ELEMENTS:,} elements ({product}), got {count:,}")
    if kind == "tube":
        if {"width", "depth", "corner_radius"} <= v.keys():
            limit = min(v["width"], v["depth"]) / 2
            if v["corner_radius"] >= limit:
                r.error("[mesh].corner_radius", "expected a number < min(width, depth)/2 = "
                                                f"{limit:g}, got {v['corner_radius']:g}")
        if v.get("corner_radius", 0) > 0 and v.get("n_corner") == 0:
            r.error("[mesh].n_corner", "expected an integer >= 1 when corner_radius > 0, got 0")
    return r.build(mark, cls, v)
