"""[[probe]]: recorded histories of node sets."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..keys import DOFS, dof_list, identifier, key, keys_of, node_set
from .reader import Reader


@dataclass(frozen=True)
class Probe:
    name: str = key(
        identifier, allowed="an identifier (letters, digits, `_`, not starting with a digit), unique among probes",
        doc="probe name")
    nodes: str = key(node_set, "nodes averaged")
    components: tuple[str, ...] = key(dof_list(allow_all=False), default=DOFS, default_text="all six",
        doc="recorded components: `ux`–`uz` the displacement; `rx`–`rz` the node's rotation vector (axis × angle,"
            " global axes) as the *accumulated* angle, the same in every solver: it goes on past a full turn (a "
            "strip rolled up by 1.25 M_max reads ry = −5π/2 at the tip, relaxation and Newton alike), continued "
            "from the last value read (each record, frame or history row), so a node must turn by less than half "
            "a turn between two of them (`Simulation.displacements`)")


def read_probe(r: Reader, path: str, data: Any) -> Probe | None:
    mark = len(r.messages)
    v = r.read(path, data, keys_of(Probe), Probe)
    if v is None:
        return None
    name = v.get("name")
    if name in r.recorded:
        r.error(f"{path}.name", f"duplicate probe name {name!r}")
    elif name is not None:
        r.recorded[name] = v.get("components")
    return r.build(mark, Probe, v)
