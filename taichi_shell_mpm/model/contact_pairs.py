"""The contact laws of a scene as run-time data (stages/contact.py): which node may touch which
element face, under which law, at which thickness.

Each law has a *direction* d, a bit of two role masks: node c may touch face e when
node_role[c] & segment_role[e] != 0, under the law of the lowest common bit [choice: an
interface listed first wins over later ones and over the single-surface [contact], so a node
of two interfaces books its force on one].  Interface k takes bit 2k (its slave nodes against
its master faces; the force on the slave side is the force on the node) and, when
symmetric, bit 2k + 1 (its master nodes against its slave faces; the force on the slave side
is the reaction on the face, minus the force on the node); the single-surface [contact] takes
SELF_BIT on every node and face.  A law's row: stiffness, damping, friction, the node
side's and the face side's thickness overrides (0: the shell's own), and that sign.

Pair thickness [choice]: a node c and a face e touch at (t_c + t_e) / 2, t_e the element's
thickness and t_c the node's, the thickest of its elements (as the walls and tools use it):
where a thin and a thick sheet share a node, the thick sheet's surface reaches furthest, and
the mean would let the thick sheet's faces be entered there.  [contact].thickness overrides
both sides of every single-surface pair, so that each touches at it (as before).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..nodesets import select_nodes
from ..scene import Scene, SceneError
from .parts import element_selection, mesh_set

SELF_BIT = 30
"""The single-surface [contact]'s direction (scene/contact_pair.MAX_CONTACT_PAIRS interfaces
take bits 0-29)."""
DIRECTIONS = SELF_BIT + 1
LAW_COLUMNS = ("stiffness", "damping", "friction", "node_thickness", "segment_thickness", "sign")


@dataclass(frozen=True)
class ContactTable:
    names: tuple[str, ...]          # the interfaces, in scene order
    slave_elements: tuple[int, ...]   # elements of each interface's slave and master sets (0: a node side)
    slave_nodes: tuple[int, ...]      # nodes of each interface's slave side
    master_elements: tuple[int, ...]
    node_role: np.ndarray           # (n,) int32 direction bits of each node
    segment_role: np.ndarray        # (m,) int32 direction bits of each face
    law: np.ndarray                 # (DIRECTIONS, 6) LAW_COLUMNS
    law_interface: np.ndarray       # (DIRECTIONS,) int32 the interface of each direction, -1: none
    thickness_max: float            # the largest pair thickness: the candidate search's reach
    thickness_min: float            # the smallest
    step_terms: tuple               # (stiffness, smallest pair thickness) of each law: the contact step
    #                                 limit (stages/timestep.contact_approach)
    friction: bool                  # some law has friction

    @property
    def pairs(self) -> bool:
        return bool(self.names)


def _side(scene: Scene, mesh, points, elements, name: str, path: str) -> np.ndarray:
    """The element ids the set `name` at `path` selects (the message names the key)."""
    if name == "all" or name in {s.name for s in scene.elementsets}:
        return element_selection(name, scene, mesh, points, elements, path)
    return mesh_set(name, mesh, f"{scene.source.name}: {path}", extra=tuple(s.name for s in scene.elementsets))


def contact_table(scene: Scene, mesh, points: np.ndarray, elements: np.ndarray, element_thickness: np.ndarray,
                  node_thickness: np.ndarray) -> ContactTable | None:
    """The laws of [contact] and [[contact_pair]] (None: neither)."""
    if scene.contact is None and not scene.contact_pairs:
        return None
    n, m = len(points), len(elements)
    node_role = np.zeros(n, np.int64)
    segment_role = np.zeros(m, np.int64)
    law = np.zeros((DIRECTIONS, len(LAW_COLUMNS)))
    law_interface = np.full(DIRECTIONS, -1, np.int32)
    reach: list[tuple] = []          # (smallest, largest) pair thickness and stiffness of each direction

    def direction(bit, nodes, faces, parameters, t_node, t_face, sign, interface):
        node_role[nodes] |= 1 << bit
        segment_role[faces] |= 1 << bit
        law[bit] = (*parameters, t_node or 0.0, t_face or 0.0, sign)
        law_interface[bit] = interface
        if len(nodes) and len(faces):
            tn = (t_node, t_node) if t_node else (node_thickness[nodes].min(), node_thickness[nodes].max())
            tf = (t_face, t_face) if t_face else (element_thickness[faces].min(), element_thickness[faces].max())
            reach.append((0.5 * (tn[0] + tf[0]), 0.5 * (tn[1] + tf[1]), parameters[0]))

    slaves, slave_counts, masters = [], [], []
    for k, pair in enumerate(scene.contact_pairs):
        path = f"[[contact_pair]][{k}]"
        if pair.slave_nodes is not None:         # a node side (one-way): no faces
            slave = np.zeros(0, np.int64)
            slave_nodes = np.asarray(select_nodes(scene.nodeset(pair.slave_nodes), points), np.int64)
        else:
            slave = _side(scene, mesh, points, elements, pair.slave, f"{path}.slave")
            slave_nodes = np.unique(elements[slave][elements[slave] >= 0])
        master = _side(scene, mesh, points, elements, pair.master, f"{path}.master")
        slaves.append(len(slave))
        slave_counts.append(len(slave_nodes))
        masters.append(len(master))
        parameters = (pair.stiffness, pair.damping, pair.friction)
        master_nodes = np.unique(elements[master][elements[master] >= 0])
        direction(2 * k, slave_nodes, master, parameters, pair.slave_thickness, pair.master_thickness, 1.0, k)
        if pair.symmetric:
            direction(2 * k + 1, master_nodes, slave, parameters, pair.master_thickness, pair.slave_thickness,
                      -1.0, k)
    c = scene.contact
    if c is not None:
        direction(SELF_BIT, np.arange(n), np.arange(m), (c.stiffness, c.damping, c.friction), c.thickness,
                  c.thickness, 1.0, -1)
    if not reach:
        raise SceneError(f"{scene.source.name}: [[contact_pair]]: no interface has both a node and a face")
    return ContactTable(
        names=tuple(p.name for p in scene.contact_pairs), slave_elements=tuple(slaves),
        slave_nodes=tuple(slave_counts), master_elements=tuple(masters), node_role=node_role.astype(np.int32), segment_role=segment_role.astype(np.int32),
        law=law, law_interface=law_interface, thickness_max=float(max(r[1] for r in reach)),
        thickness_min=float(min(r[0] for r in reach)),
        step_terms=tuple((float(r[2]), float(r[0])) for r in reach),
        friction=bool((law[:, 2] > 0.0).any()))
