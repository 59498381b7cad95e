"""Penalty node-to-segment contact (stages/contact.py, method.md 7.3), one pair at a time:
a node grazing a segment's edge in the segment's plane, and a node that crossed a face's
mid-surface within one step."""
from __future__ import annotations

import meshio
import numpy as np
import pytest
import taichi as ti

from taichi_shell_mpm.scene import SceneError, load_scene

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
    s.step.dt[None] = s.step.dt_stable[None] = DT

    @ti.kernel
    def contact_forces():
        sim.stepper.contact.build_candidates()
        sim.stepper.contact.forces()

    def force_on_node(x):
        points = POINTS.copy()
        points[NODE] = x
        s.put("nodes.position", points)
        s.contact.rebuild[None] = 1
        contact_forces()
        return s.fetch("contact.pair_force")[NODE], int(s.contact.last_element[NODE])

    m = s.fetch("nodes.mass")
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


def test_skin_keeps_the_search_inside_the_excluded_ring():
    """s = 2 l_min - t_c within [0.25, 1] t_c (stages/contact.skin_width): the full t_c on
    coarse meshes, less where the elements are small against t_c."""
    from taichi_shell_mpm.stages.contact import skin_width
    for edge, expected in [(5.0, 1.0), (0.8, 0.6), (0.5, 0.25), (0.1, 0.25)]:
        assert skin_width(1.0, edge) == pytest.approx(expected, rel=1e-12)
        assert skin_width(2.0, 2.0 * edge) == pytest.approx(2.0 * expected, rel=1e-12)   # scales with t_c


def test_the_skin_changes_the_rebuilds_not_the_contacts(tmp_path, monkeypatch):
    """The candidate lists are exact for any skin (Verlet: nothing outside a list comes
    within t_c before a node has moved s/2): the reduced crush to 2 ms, past its first
    fold contacts, gives the same positions and contact energy with s = t_c and s = t_c / 4
    (four times the rebuilds) to round-off: a candidate list's order follows the hash
    cells, which follow s, and where a node is equally close to two segments (a shared
    edge) the first one found takes it (measured: positions 1.8e-13 mm apart after 6 185
    steps, the same contact energy to 7 digits)."""
    from taichi_shell_mpm.solvers.dynamic import run_dynamic
    from taichi_shell_mpm.stages import contact

    from .conftest import ROOT, simulation
    from .test_crush import SHORT
    runs = []
    for skin in (1.0, 0.25):
        monkeypatch.setattr(contact, "SKIN_RANGE", (skin, skin))
        scene = load_scene(ROOT / "scenes" / "square_tube.toml",
                           [*SHORT[:5], "method.kind=fem", "solve.end_time=2.0", "output.times=[]"])
        sim = simulation(scene, tmp_path / f"skin{skin}")
        assert sim.state.contact.skin[None] == pytest.approx(skin * sim.model.parameters.contact_thickness)
        run_dynamic(sim)
        runs.append((sim.state.fetch("nodes.position"), sim.state.step.contact_energy[None], sim.total_steps))
    (x1, e1, n1), (x2, e2, n2) = runs
    print(f"\ncontact energy {e1:.6g} / {e2:.6g} J, {n1} / {n2} steps, max |dx| {np.abs(x1 - x2).max():.3g} mm")
    assert e1 > 0.0 and n1 == n2
    assert np.abs(x1 - x2).max() <= 1e-9 and e1 == pytest.approx(e2, rel=1e-9)


def test_damping_that_bounces_a_node_back_faster_is_refused(tmp_path):
    """[contact].damping within stiffness + 2 damping sqrt(stiffness) <= 2 (scene.penalty_damping_limit,
    docs/contact.md "Penalty parameters"): 0.8 at stiffness 1 is refused naming the key, 0.5 accepted."""
    meshio.write(tmp_path / "sheets.vtu", meshio.Mesh(POINTS, [("quad", np.array([[0, 1, 2, 3], [4, 5, 6, 7]]))]))
    text = TWO_SHEETS.replace("[contact]\n", "[contact]\nstiffness = 1\ndamping = {}\n")
    with pytest.raises(SceneError) as caught:
        load_scene(write_scene(tmp_path, text.format(0.8)))
    assert any("[contact].damping: 0.8 with stiffness = 1" in m for m in caught.value.messages), caught.value.messages
    assert load_scene(write_scene(tmp_path, text.format(0.5))).contact.damping == 0.5
