"""[[tie]] and [[spotweld]]: parts joined as real assemblies are joined (model/joints.py sets
them up at t = 0, stages/joints.py holds them during the run; docs/scenes.md)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..keys import Check, Invalid, boolean, identifier, is_int, key, keys_of, node_set, nonempty, positive, show
from .parts import check_element_set
from .reader import Reader


def _pairs(value: Any) -> tuple[tuple[int, int], ...]:
    if (isinstance(value, list) and value
            and all(isinstance(p, list) and len(p) == 2 and all(is_int(i) and i >= 0 for i in p) for p in value)):
        out = tuple((int(p[0]), int(p[1])) for p in value)
        for a, b in out:
            if a == b:
                raise Invalid(f"a weld joins two different nodes, got [{a}, {b}]")
        return out
    raise Invalid(f"expected a non-empty list of [node, node] index pairs (>= 0), got {show(value)}")


pairs = Check(_pairs, "list of [node, node]", "node indices >= 0, two different nodes",
              {"type": "array", "minItems": 1,
               "items": {"type": "array", "minItems": 2, "maxItems": 2, "items": {"type": "integer", "minimum": 0}}})


@dataclass(frozen=True)
class Tie:
    """Tied contact (LS-DYNA *CONTACT_TIED_NODES_TO_SURFACE; with `rotations`,
    *CONTACT_TIED_SHELL_EDGE_TO_SURFACE): each slave node is held at its place on the nearest
    segment of `surface` found at t = 0 (stages/joints.py)."""
    name: str = key(identifier, "tie name (summary.json `ties`)")
    nodes: str = key(node_set, allowed="a defined node set or `all`; none fixed, moved, in a rigid body or "
                                       "in another joint", doc="the slave nodes")
    surface: str = key(
        nonempty, default="all",
        allowed="an `[elementsets.NAME]`, a set of the mesh file (`\"part:2\"`), or `\"all\"`",
        doc="the master segments (elements); a slave's own elements never count")
    tolerance: float | None = key(
        positive, default=None, unit="length", default_text="the thickest shell among the slaves' and the surface's",
        doc="search distance: a slave farther than this from every segment is not tied")
    rotations: bool = key(boolean, default=False,
        doc="also tie the slave's rotations to the segment's (shell edge to surface); `false`: translations "
            "only (nodes to surface), the slave's rotations stay free")
    strict: bool = key(boolean, default=False,
        doc="a slave without a segment within `tolerance` is an error (`false`: a warning naming them)")


@dataclass(frozen=True)
class SpotWeld:
    """Spot welds (LS-DYNA *CONSTRAINED_SPOTWELD): node pairs moving as rigid links until the
    force criterion (|f_n| / SN)^n + (|f_s| / SS)^m >= 1 (stages/joints.py)."""
    name: str = key(identifier, "weld group name (force.csv `<name>.*` columns, summary.json `spotwelds`)")
    pairs: tuple[tuple[int, int], ...] = key(
        pairs, example=[[12, 57], [14, 59]],
        doc="the welded node pairs `[N1, N2]` (node indices, as `ids` node sets); the weld axis runs N1 → N2")
    normal_strength: float = key(positive, "SN: normal force at failure (tension)", unit="force")
    shear_strength: float = key(positive, "SS: shear force at failure", unit="force")
    n: float = key(positive, "exponent of the normal term", default=2.0)
    m: float = key(positive, "exponent of the shear term", default=2.0)
    failure_time: float | None = key(positive, default=None, unit="time", default_text="never",
        doc="TF: the welds fail at this time whatever their force")


def read_tie(r: Reader, path: str, data: Any, mesh, elementsets) -> Tie | None:
    mark = len(r.messages)
    v = r.read(path, data, keys_of(Tie), Tie)
    if v is None:
        return None
    if "surface" in v:
        check_element_set(r, f"{path}.surface", v["surface"], [s.name for s in elementsets], mesh)
    return r.build(mark, Tie, v)


def read_spotweld(r: Reader, path: str, data: Any) -> SpotWeld | None:
    mark = len(r.messages)
    v = r.read(path, data, keys_of(SpotWeld), SpotWeld)
    if v is None:
        return None
    return r.build(mark, SpotWeld, v)
