"""A solid sphere tool: d = |q| - R, n = q / |q|."""
from __future__ import annotations

import numpy as np

NAME = "sphere"
KEYS: dict = {}
REQUIRED = ("radius",)
OPTIONAL = ("center",)


def shape(tool) -> tuple[np.ndarray, np.ndarray, float]:
    return np.eye(3), np.array([tool.radius, 0.0, 0.0]), float(tool.radius)


def kernel(tools, contact):
    import taichi as ti
    g = tools

    @ti.data_oriented
    class Sphere:
        @ti.func
        def distance(self, k, q):
            r = q.norm()
            n = ti.Vector([0.0, 0.0, 1.0])
            if r > 0.0:
                n = q / r
            return r - g.size[k][0], n, True

    return Sphere()
