"""A capped cylinder tool (radius R, half length L, e3 = its axis) [choice: a solid with flat
ends, the exact signed distance: outside, the distance to the nearest point of the solid, n
along it; inside, the depth below the nearer of the mantle and the cap]."""
from __future__ import annotations

import numpy as np

from ..keys import Key, keys, positive
from .geometry import frame_from

NAME = "cylinder"
KEYS = keys(
    Key("radius", positive, "cylinder, sphere: the radius", default=None, unit="length",
        default_text="required for cylinder, sphere"),
    Key("length", positive, "length along the axis (flat caps)", default=None, unit="length",
        default_text="required for cylinder"))
REQUIRED = ("axis", "radius", "length")
OPTIONAL = ("center",)


def shape(tool) -> tuple[np.ndarray, np.ndarray, float]:
    size = np.array([tool.radius, 0.5 * tool.length, 0.0])
    return frame_from(tool.axis), size, float(np.hypot(*size[:2]))


def kernel(tools, contact):
    import taichi as ti
    g = tools

    @ti.data_oriented
    class Cylinder:
        @ti.func
        def distance(self, k, q):
            radius, half = g.size[k][0], g.size[k][1]
            rho = ti.sqrt(q[0] * q[0] + q[1] * q[1])
            u = ti.Vector([1.0, 0.0, 0.0])
            if rho > 0.0:
                u = ti.Vector([q[0] / rho, q[1] / rho, 0.0])
            side = 1.0 if q[2] >= 0.0 else -1.0
            cap = ti.Vector([0.0, 0.0, side])
            w0, w1 = rho - radius, ti.abs(q[2]) - half
            d, n = 0.0, u
            if w0 > 0.0 or w1 > 0.0:
                e0, e1 = ti.max(w0, 0.0), ti.max(w1, 0.0)
                d = ti.sqrt(e0 * e0 + e1 * e1)
                n = (e0 * u + e1 * cap) / d
            elif w0 > w1:
                d = w0
            else:
                d, n = w1, cap
            return d, n, True

    return Cylinder()
