"""[[contact_pair]]: penalty contact between two element sets (an interface), or a node set
and an element set, each with its own force in force.csv; LS-DYNA's
*CONTACT_AUTOMATIC_SURFACE_TO_SURFACE (symmetric) and *CONTACT_AUTOMATIC_NODES_TO_SURFACE
(one-way; its slave side a node set with SSTYP = 4)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..keys import boolean, identifier, key, keys_of, node_set, non_negative, nonempty, number, positive, unit_interval
from .contact import check_penalty_damping
from .parts import check_element_set
from .reader import Reader

MAX_CONTACT_PAIRS = 15
"""At most this many interfaces: each takes two bits (its two directions) of the node and
segment role masks of stages/contact.py, whose bit 30 is the single-surface [contact]."""

SETS = "an `[elementsets.NAME]`, a set of the mesh file (an LS-DYNA part `\"part:2\"` or its heading, see *Parts*), or `\"all\"`"


@dataclass(frozen=True)
class ContactPair:
    """An interface: the slave set's nodes against the master set's element faces (and, when
    symmetric, the master's nodes against the slave's faces) with the [contact] penalty law
    (stages/contact.py) and its own parameters; touching at the distance (t_node + t_segment) / 2."""
    name: str = key(identifier, "force.csv columns `<name>.force_x/y/z` (the force on the slave side)",
                    allowed="an identifier, unique")
    master: str = key(nonempty, "the master side: its faces (and, symmetric, its nodes)", allowed=SETS)
    slave: str | None = key(nonempty, "the slave side: its nodes (and, symmetric, its faces)", default=None,
        allowed=SETS + "; one of `slave`, `slave_nodes`", default_text="none")
    slave_nodes: str | None = key(node_set, default=None, default_text="none",
        allowed="a defined node set or `all`; one of `slave`, `slave_nodes`; not `symmetric`",
        doc="the slave side as nodes (LS-DYNA's SSTYP = 4): they touch the master faces, one-way")
    symmetric: bool = key(boolean, default=True,
        default_text="`true`; `false` with `slave_nodes`",
        doc="both directions (LS-DYNA's automatic surface to surface); false: the slave nodes against the master "
            "faces only (nodes to surface)")
    stiffness: float = key(number(0, 1, lo_open=True), default=0.1,
        doc="α_c of the penalty k = α_c m*/Δt² (as `[contact].stiffness`)")
    friction: float = key(non_negative, default=0.0, doc="Coulomb coefficient μ (LS-DYNA's FS; as `[contact].friction`)")
    damping: float = key(
        unit_interval, default=0.1, allowed="[0, 1], and `stiffness` + 2 `damping` √`stiffness` ≤ 2",
        doc="contact damping as a fraction of critical (as `[contact].damping`)")
    slave_thickness: float | None = key(
        positive, default=None, unit="length", default_text="each node's and element's shell thickness",
        doc="contact thickness of the slave side (LS-DYNA's SST): its nodes and faces count this thick")
    master_thickness: float | None = key(
        positive, default=None, unit="length", default_text="each node's and element's shell thickness",
        doc="contact thickness of the master side (LS-DYNA's MST)")


def read_contact_pair(r: Reader, path: str, data: Any, mesh, elementsets) -> ContactPair | None:
    mark = len(r.messages)
    v = r.read(path, data, keys_of(ContactPair), ContactPair)
    if v is None:
        return None
    names = [s.name for s in elementsets]
    if isinstance(data, dict) and ("slave" in data) == ("slave_nodes" in data):
        r.error(f"{path}.slave", "give one of slave (an element set) or slave_nodes (a node set)")
    if isinstance(data, dict) and "slave_nodes" in data:
        if data.get("symmetric") is True:
            r.error(f"{path}.symmetric", "a slave side of nodes has no faces: the interface is one-way "
                                         "(symmetric = false)")
        v["symmetric"] = False
    for side in ("slave", "master"):
        if side in v:
            check_element_set(r, f"{path}.{side}", v[side], names, mesh)
    if "stiffness" in v and "damping" in v:
        check_penalty_damping(r, path, v["stiffness"], v["damping"])
    return r.build(mark, ContactPair, v)
