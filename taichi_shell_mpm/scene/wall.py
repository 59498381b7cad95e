"""[[wall]]: rigid planar walls."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..keys import Vec3, hint, identifier, key, keys_of, nonzero_vec3, vec3
from .reader import Reader


@dataclass(frozen=True)
class Wall:
    """Rigid planar wall the shell mid-surface cannot approach closer than half the thickness
    from the side `normal` points to (node-level, frictionless, method.md 7.5)."""
    point: Vec3 = key(vec3, "a point of the plane (at t = 0)", unit="length")
    normal: Vec3 = key(nonzero_vec3, "the side the shell stays on")
    moves_with: str | None = key(identifier, default=None, allowed="a `[[rigid_body]]` name",
        doc="the wall translates with that body; none = fixed")


def read_wall(r: Reader, path: str, data: Any) -> Wall | None:
    mark = len(r.messages)
    v = r.read(path, data, keys_of(Wall), Wall)
    if v is None:
        return None
    listed = r.raw.get("rigid_body", [])
    bodies = [b["name"] for b in (listed if isinstance(listed, list) else [])
              if isinstance(b, dict) and isinstance(b.get("name"), str)]
    if v.get("moves_with") is not None and v["moves_with"] not in bodies:
        r.error(f"{path}.moves_with", f"no [[rigid_body]] named {v['moves_with']!r}"
                + hint(v["moves_with"], bodies, "defined"))
    return r.build(mark, Wall, v)
