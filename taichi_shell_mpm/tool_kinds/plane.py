"""An infinite plane tool: d = q3 in its frame (e3 = the normal), one-sided: a node behind the
plane is pushed out, however deep."""
from __future__ import annotations

import numpy as np

from ..keys import Key, keys, nonzero_vec3
from .geometry import frame_from

NAME = "plane"
KEYS = keys(Key("normal", nonzero_vec3, "plane, rectangle: the side the shell stays on", default=None,
                default_text="required for plane, rectangle"))
REQUIRED = ("normal",)
OPTIONAL = ("center",)


def shape(tool) -> tuple[np.ndarray, np.ndarray, float]:
    return frame_from(tool.normal), np.zeros(3), np.inf


def kernel(tools, contact):
    import taichi as ti

    @ti.data_oriented
    class Plane:
        @ti.func
        def distance(self, k, q):
            return q[2], ti.Vector([0.0, 0.0, 1.0]), True

    return Plane()
