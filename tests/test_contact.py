"""Penalty node-to-segment contact (stages/contact.py, method.md 7.3), one pair at a time:
a node grazing a segment's edge in the segment's plane, and a node that crossed a face's
mid-surface within one step."""
from __future__ import annotations

import meshio
import numpy as np
import taichi as ti

from taichi_shell_mpm.scene import load_scene

from .conftest import unwarmed_simulation, write_scene

TWO_SHEETS = """
[scene]
name = "two_sheets"
units = "consistent"
[mesh]
kind = "file"
path = "sheets.vtu"
[material]
E = 1e4
nu = 0.3
density = 1.0
[section]
thickness = 1.0
[contact]
[method]
kind = "fem"
[solve]
kind = "dynamic"
end_time = 1.0
"""

# segment quad A: [0, 4] x [0, 4] in z = 0; quad B, nodes 4-7, lies apart in the same plane
POINTS = np.array([[0, 0, 0], [4, 0, 0], [4, 4, 0], [0, 4, 0],
                   [4.5, 1, 0], [8, 1, 0], [8, 3, 0], [4.5, 3, 0]], dtype=float)
NODE = 4
DT = 1e-3


def contact_simulation(tmp_path):
    meshio.write(tmp_path / "sheets.vtu", meshio.Mesh(POINTS, [("quad", np.array([[0, 1, 2, 3], [4, 5, 6, 7]]))]))
    scene = load_scene(write_scene(tmp_path, TWO_SHEETS))
    sim = unwarmed_simulation(scene, tmp_path)
    s = sim.state
    s.dt[None] = s.dt_stable[None] = DT

    @ti.kernel
    def contact_forces():
        sim.stepper.contact.build_candidates()
        sim.stepper.contact.forces()

    def force_on_node(x):
        points = POINTS.copy()
        points[NODE] = x
        s.position.from_numpy(points)
        s.contact_rebuild[None] = 1
        contact_forces()
        return s.contact_pair_force.to_numpy()[NODE], int(s.contact_last_element[NODE])

    m = s.corner_mass.to_numpy()
    k = sim.scene.contact.stiffness * (m[NODE] * m[0] / (m[NODE] + m[0])) / DT ** 2
    return force_on_node, k


def test_a_node_grazing_an_edge_is_pushed_off_the_edge_not_through_it(tmp_path):
    """Node 4 sits 0.5 from the edge x = 4 of quad A in A's own plane (t_c = 1), first a hair
    above the plane, then a hair below.  The side read from the closest-point direction
    flips, but the node went round the edge, not through the face: the force stays k g =
    0.5 k along +x.  (Read as a crossing, the node was pulled into the edge with 1.5 k.)"""
    force_on_node, k = contact_simulation(tmp_path)
    above, pair = force_on_node([4.5, 1.0, 1e-9])
    below, pair_again = force_on_node([4.5, 1.0, -1e-9])
    print(f"\nabove {above / k}, below {below / k} (units of k)")
    assert pair == pair_again == 0
    for f in (above, below):
        assert f[0] > 0.0
        assert abs(f[0] - 0.5 * k) < 1e-6 * k


def test_a_node_that_crossed_the_mid_surface_is_pushed_back(tmp_path):
    """Node 4 over the interior of quad A, 0.2 above it, then 0.1 below (it crossed within one
    step): pushed back up with k (t_c + 0.1), the side it came from."""
    force_on_node, k = contact_simulation(tmp_path)
    above, _ = force_on_node([2.0, 2.0, 0.2])
    crossed, _ = force_on_node([2.0, 2.0, -0.1])
    print(f"\nabove {above / k}, crossed {crossed / k} (units of k)")
    assert abs(above[2] - 0.8 * k) < 1e-6 * k
    assert abs(crossed[2] - 1.1 * k) < 1e-6 * k
