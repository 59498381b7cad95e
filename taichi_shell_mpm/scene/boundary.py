"""[[boundary]]: fixed DOFs and symmetry planes."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

from ..keys import choice, dof_list, key, keys_of, node_set
from .reader import Reader


@dataclass(frozen=True)
class Boundary:
    nodes: str = key(node_set, "nodes concerned")
    fix: tuple[str, ...] = key(dof_list(allow_all=True), "DOFs held at zero", default=())
    symmetry: Literal["x", "y", "z"] | None = key(choice("x", "y", "z"), default=None,
        doc="symmetry plane normal to this axis through the nodes: fixes the normal displacement and the two "
            "in-plane rotations (in `mpm` mode the plane must be a grid plane)")


def read_boundary(r: Reader, path: str, data: Any) -> Boundary | None:
    mark = len(r.messages)
    v = r.read(path, data, keys_of(Boundary), Boundary)
    if v is None:
        return None
    if "fix" not in data and "symmetry" not in data:
        r.error(path, "expected fix and/or symmetry")
    return r.build(mark, Boundary, v)
