"""A finite rectangular plate tool (half sides a, b in its frame; e3 = the normal, e1 along
its first side).  Over it (|q1| <= a, |q2| <= b) it is the plane down to ``reach`` behind it
(the mesh's depth: a node deeper behind a finite plate came from its back, and pulling it
through to the front is wrong; issue 28 item 3); beside it, on the front side (q3 >= 0), the
distance to the nearest rim point (a rounded rim); behind and beside it, no contact [choice:
a finite plate has a front only]."""
from __future__ import annotations

import math

import numpy as np

from ..keys import Key, keys, nonzero_vec3, size2
from .geometry import frame_from

NAME = "rectangle"
KEYS = keys(
    Key("axis", nonzero_vec3, "cylinder: its axis; rectangle: the direction of the first side (projected on the "
                              "plane; default: any)", default=None, allowed="non-zero; not along `normal`",
        default_text="cylinder: required; rectangle: optional"),
    Key("size", size2, "side lengths (a along `axis`)", default=None, unit="length", allowed="> 0",
        default_text="required for rectangle"))
REQUIRED = ("normal", "size")
OPTIONAL = ("center", "axis")


def rules(r, path: str, data: dict, values: dict, clean: bool) -> None:
    """The first side's direction not along the normal (whatever else is wrong: `clean` unused)."""
    if values.get("axis") is not None and values.get("normal") is not None:
        (a1, a2, a3), (n1, n2, n3) = values["axis"], values["normal"]
        cross = math.hypot(a2 * n3 - a3 * n2, a3 * n1 - a1 * n3, a1 * n2 - a2 * n1)
        if cross <= 1e-9 * math.hypot(a1, a2, a3) * math.hypot(n1, n2, n3):
            r.error(f"{path}.axis", "is parallel to normal (it gives the direction of the first side, "
                                    "in the rectangle's plane)")


def shape(tool) -> tuple[np.ndarray, np.ndarray, float]:
    half = np.array([0.5 * tool.size[0], 0.5 * tool.size[1], 0.0])
    return frame_from(tool.normal, tool.axis), half, float(np.hypot(*half[:2]))


def kernel(tools, contact):
    import taichi as ti
    g = tools

    @ti.data_oriented
    class Rectangle:
        @ti.func
        def distance(self, k, q):
            a, b = g.size[k][0], g.size[k][1]
            d, n, hit = q[2], ti.Vector([0.0, 0.0, 1.0]), q[2] > -g.reach[None]
            if ti.abs(q[0]) > a or ti.abs(q[1]) > b:
                r = q - ti.Vector([ti.min(ti.max(q[0], -a), a), ti.min(ti.max(q[1], -b), b), 0.0])
                d = r.norm()
                hit = q[2] >= 0.0
                n = r / ti.max(d, 1e-300)
            return d, n, hit

    return Rectangle()
