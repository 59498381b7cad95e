"""The meshes of the Newton path-following scenes (issue 19), written to scenes/data/:

    python benchmarks/newton_meshes.py

* ``hinged_roof_<n>x<n>q.vtu``: a quarter of Sze, Liu & Lo's (2004, s. 3.8) hinged cylindrical
  roof, R = 2540, half-angle 0.1 rad, half-length 254; the crown line (x = 0) and the
  mid-span (y = 0) are symmetry planes, the straight edge x = R sin 0.1 is hinged; n x n quads,
  crown at z = 0, normals up (+z at the crown).
* ``slit_annular_<nr>x<nt>.vtu``: Sze et al.'s (2004, s. 3.3) slit annular plate, radii 6 and
  10 in the plane z = 0, nr quads across and nt around from theta = 0 to 2 pi - SLIT_GAP: the
  slit is a gap of SLIT_GAP radians (at most 1e-3 at r = 10, a thirtieth of the thickness) so
  that coordinate node sets tell its two faces apart: y = 0 (theta = 0, clamped) and the
  face just below it (theta = 2 pi - gap, loaded).
"""
from __future__ import annotations

import math
from pathlib import Path

import meshio
import numpy as np

DATA = Path(__file__).resolve().parents[1] / "scenes" / "data"
ROOF_RADIUS, ROOF_ANGLE, ROOF_HALF_LENGTH = 2540.0, 0.1, 254.0
INNER, OUTER = 6.0, 10.0
SLIT_GAP = 1e-4


def grid_quads(n_u: int, n_v: int) -> np.ndarray:
    """Quads of an (n_u + 1) x (n_v + 1) node grid, node (i, j) = j (n_u + 1) + i, counter-
    clockwise in (u, v)."""
    i, j = np.meshgrid(np.arange(n_u), np.arange(n_v), indexing="xy")
    a = (j * (n_u + 1) + i).ravel()
    return np.stack([a, a + 1, a + n_u + 2, a + n_u + 1], axis=1)


def roof(n: int) -> meshio.Mesh:
    phi, y = np.meshgrid(np.linspace(0.0, ROOF_ANGLE, n + 1), np.linspace(0.0, ROOF_HALF_LENGTH, n + 1), indexing="xy")
    points = np.stack([ROOF_RADIUS * np.sin(phi), y, ROOF_RADIUS * (np.cos(phi) - 1.0)], axis=-1).reshape(-1, 3)
    return meshio.Mesh(points, [("quad", grid_quads(n, n))])


def slit_annulus(n_radial: int, n_around: int) -> meshio.Mesh:
    r, theta = np.meshgrid(np.linspace(INNER, OUTER, n_radial + 1),
                           np.linspace(0.0, 2.0 * math.pi - SLIT_GAP, n_around + 1), indexing="xy")
    points = np.stack([r * np.cos(theta), r * np.sin(theta), np.zeros_like(r)], axis=-1).reshape(-1, 3)
    return meshio.Mesh(points, [("quad", grid_quads(n_radial, n_around))])


def main() -> None:
    for n in (8, 16):
        meshio.write(DATA / f"hinged_roof_{n}x{n}q.vtu", roof(n), binary=False)
    for nr, nt in ((6, 30), (10, 80)):
        meshio.write(DATA / f"slit_annular_{nr}x{nt}.vtu", slit_annulus(nr, nt), binary=False)


if __name__ == "__main__":
    main()
