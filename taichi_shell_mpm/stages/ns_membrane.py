"""Node-smoothed membrane strain for the C0 triangle (``[element].triangle = "ns"``, issue 33;
docs/element.md, "The node-smoothed triangle").

Why [measured].  On a doubly curved shell in bending a mesh of flat facets cannot follow the
surface's inextensional modes: a convex triangulated polyhedron is rigid for fixed edge
lengths, so bending strains every facet's constant-strain membrane (membrane locking).  With
one membrane strain per triangle a mesh has ~6 membrane constraints per node (2 triangles per
node, 3 each) against 3 translations; the one-point quad has ~3.  Sze's pinched hemisphere in
C0 triangles (16x16, fem) is 8.69 / 13.65 % stiff, and no element-local membrane fixed that
(OPT: 4.36 / 6.87 %).  Smoothing the membrane strain over the triangles around each node (the
node-based smoothed FEM of G. R. Liu et al. 2009, "A node-based smoothed finite element method
(NS-FEM) for upper bound solutions to solid mechanics problems", Comput. Struct. 87:14-26,
here on a faceted shell) leaves ~3 constraints per node, as the quad: 1.24 / 0.18 % at 16x16.

What.  Three passes around the element pass (stages/shell.ShellElement.element_pass):

1. each live triangle e writes its constant-strain membrane rate as a global tensor,
   G_e = R_e^T [[eps_xx, gamma/2], [gamma/2, eps_yy]] R_e (R_e the 2x3 rows e1, e2 of its
   mid-step frame), times w_e = A_e / 3, and w_e (:meth:`rates`);
2. each node a takes the weighted mean S_a = sum_e w_e G_e / sum_e w_e over its triangles,
   gathered through the node -> corner slots in ascending element order (deterministic in
   serial and parallel launches) (:meth:`node_means`); the triangle's membrane rate is then
   eps_e' = R_e (1/3 sum_(a in e) S_a) R_e^T (:meth:`smoothed_rate`) -- the node strains
   brought back to the element, so the stress stays at the element's through-thickness
   points (plasticity, layered sections and the energy ledger as before);
3. the loads are the exact transpose: each triangle writes T_e = (A_e / 3) R_e^T N_e R_e (its
   membrane resultant, end-of-step frame) and A_e / 3 (:meth:`stresses`), the nodes take the
   weighted means as in 2, and each triangle applies the constant-strain triangle's loads of
   N_e* = R_e (1/3 sum_a T_a / W_a) R_e^T (:meth:`loads`).  So sum f.v = sum_e A_e N_e : eps_e'
   over the mesh (the power identity holds for the mesh, not for an element alone).

The element's own constant-strain membrane loads are applied only for its share next to quads
(below; otherwise the smoothed ones replace them); bending, transverse shear and the drilling spring are the C0 triangle's.  A rigid motion
gives eps = 0 on every triangle, hence 0 everywhere; a uniform strain on a flat patch is
smoothed to itself (the patch test).

Blend [choice, measured; ``[element].ns_blend`` = alpha, default 0].  Each node mean enters in
the share s_a = 1 - alpha and the triangle keeps k_e = 1 - 1/3 sum_a s_a of its own strain and
loads (alpha-FEM, Liu et al. 2008): alpha = 0 is pure node smoothing, 1 the C0 triangle (the smoothed
parts are exact zeros then: the cantilever in triangles gives the C0 run's probes to the bit).  The default 0 follows the constraint count
(any alpha > 0 puts the triangles' own ~6 constraints per node back with weight alpha);
alpha > 0 stiffens the in-plane bending of a strip two triangles wide, where pure smoothing is
soft (docs/element.md, "Blend": the twisted beam and the hemisphere against alpha).

Next to quads [choice, measured].  Quads take no part (their membrane is unchanged).  At a node
that also belongs to a quad the triangles keep their own strain (nodes.ns_share = 0 there): the
triangle's rate is R (1/3 sum_a S_a) R^T + k_e eps_e with k_e = (its corners next to a quad) / 3
(alpha = 0), and its own loads k_e B^T N are applied with the smoothed ones (still the exact
transpose).  Averaging over the triangles alone at such nodes let two triangles at the edge of
the 6 ms square tube's band of triangles collapse in the first fold (their step length 0.47
against 2.27 for the C0 triangles; 43 604 steps against 23 386, mean force 9.437 kN); with the
rule 29 193 steps and 9.480 kN (all quads 9.509; docs/element.md).

Time step [argued, measured].  The smoothed strain (next to quads too) is a weighted mean of
the triangles' strains, so by convexity (flat patch: exactly) the membrane energy of any motion is at most the
constant-strain triangle's and the highest frequency at most the C0 triangle's: the C0
triangle's step rule is kept (tests/test_triangle_ns.py compares the two patches' largest
frequencies on a random curved patch).

Newton.  Its tangent cannot be element by element: a node's translation reaches forces three
element edges away through passes 1-3, so solvers/tangent.py differentiates coloured copies of
the whole mesh (tangent.Colouring).

Erosion [choice, measured].  An eroded triangle is out of both means (weight 0, no loads),
from the step it fails in: a triangle failing now (stages/masses.py; after pass 2) zeroes its
resultant's weight (TriangleElement.update), so like a failing quad it writes no loads, and
its own would-be loads' stagger term goes to its eroded energy (shell.ShellElement.failing_stagger).
The smoothed loads it would have had are not booked: the feature matrix's sheet in triangles
with 16 elements failing (tests/test_matrix.py, failure strain 0.005) closes its balance to
2.3e-5 of the absorbed energy (C0 triangles 1.7e-5); kept in pass 3 for its failing step
(its membrane loads written, their stagger term in its eroded energy) it read 1.6e-4.

Selective mass scaling: as the C0 triangle (its corner blocks, its zigzag cap).
"""

import taichi as ti


@ti.func
def in_plane_rows(rot):
    """The 2x3 rows e1, e2 of a frame (3x3, rows e1 e2 e3)."""
    return ti.Matrix([[rot[0, 0], rot[0, 1], rot[0, 2]], [rot[1, 0], rot[1, 1], rot[1, 2]]])


@ti.func
def to_global(rot, xx, yy, xy):
    """R^T [[xx, xy], [xy, yy]] R: an in-plane tensor of the frame `rot` as a global 3x3 tensor."""
    r2 = in_plane_rows(rot)
    return r2.transpose() @ ti.Matrix([[xx, xy], [xy, yy]]) @ r2


@ti.func
def to_local(rot, g):
    """(xx, yy, xy) of R g R^T: a global 3x3 tensor in the plane of the frame `rot`."""
    r2 = in_plane_rows(rot)
    loc = r2 @ g @ r2.transpose()
    return ti.Vector([loc[0, 0], loc[1, 1], loc[0, 1]])


@ti.data_oriented
class NodeSmoothedMembrane:
    """The smoothing passes of the triangles' membrane; ``triangle`` (triangle.TriangleElement)
    lends the geometry, the quad's gather and the loads."""

    def __init__(self, triangle):
        self.s = triangle.s
        self.cfg = triangle.cfg
        self.tri = triangle

    @ti.func
    def node_means(self):
        """S_a = s_a sum w_e X_e / sum w_e over node a's triangles (elements.ns_tensor holds w_e X_e,
        elements.ns_weight w_e), gathered through the node -> corner slots, e ascending, and its
        share s_a (nodes.ns_share): 1 - alpha (step.ns_blend; module docstring, "Blend"), or 0 at a
        node that also has a quad, whose triangles keep their own strain there ("Next to quads")."""
        for c in range(self.s.nodes.count[None]):
            total = ti.Matrix.zero(ti.f64, 3, 3)
            weight = 0.0
            share = 1.0
            for i in range(self.s.elements.node_slot_start[c], self.s.elements.node_slot_start[c + 1]):
                e = self.s.elements.node_slots[i] // 4
                if self.s.elements.corners[e][3] < 0:
                    total += self.s.elements.ns_tensor[e]
                    weight += self.s.elements.ns_weight[e]
                else:
                    share = 0.0
            share *= 1.0 - self.s.step.ns_blend[None]
            if weight > 0.0 and share > 0.0:
                total = (total / weight) * share      # share 1: to the bit as the plain mean
            else:
                total = ti.Matrix.zero(ti.f64, 3, 3)
            self.s.nodes.ns_mean[c] = total
            self.s.nodes.ns_share[c] = share

    @ti.func
    def corner_mean(self, c):
        """1/3 sum of the node means at the corners c[0..2], each in its share (0 from a node next to a
        quad)."""
        return (self.s.nodes.ns_mean[c[0]] + self.s.nodes.ns_mean[c[1]] + self.s.nodes.ns_mean[c[2]]) / 3.0

    @ti.func
    def own_share(self, c):
        """k_e = 1 - 1/3 sum_a s_a: the share of the triangle's own strain (alpha, plus 1/3 (1 - alpha)
        for each corner next to a quad)."""
        return (3.0 - self.s.nodes.ns_share[c[0]] - self.s.nodes.ns_share[c[1]] - self.s.nodes.ns_share[c[2]]) / 3.0

    @ti.func
    def rates(self):
        """Pass 1: each triangle's membrane rate (mid-step frame) as w_e G_e, then the node means."""
        for e in range(self.s.elements.count[None]):
            c = self.s.elements.corners[e]
            if c[3] < 0:
                if self.eroded(e):        # out of both means (module docstring, "Erosion")
                    self.s.elements.ns_tensor[e] = ti.Matrix.zero(ti.f64, 3, 3)
                    self.s.elements.ns_weight[e] = 0.0
                else:
                    rot_m, area_m, rate = self.tri.membrane_rate(e)
                    self.s.elements.ns_tensor[e] = (area_m / 3.0) * to_global(rot_m, rate[0], rate[1], 0.5 * rate[2])
                    self.s.elements.ns_weight[e] = area_m / 3.0
        self.node_means()

    @ti.func
    def eroded(self, e):
        """Whether triangle e eroded in an earlier step (stages/masses.py; False without erosion)."""
        out = False
        if ti.static(self.cfg.erosion):
            out = self.s.elements.eroded[e] != 0
        return out

    @ti.func
    def smoothed_rate(self, c, rot_m, own):
        """Pass 2 (in the element update): the triangle's smoothed membrane rate (xx, yy, 2 xy),
        R (1/3 sum_a S_a) R^T + k_e eps_e (`own`: its constant-strain rate)."""
        local = to_local(rot_m, self.corner_mean(c))
        return ti.Vector([local[0], local[1], 2.0 * local[2]]) + self.own_share(c) * own

    @ti.func
    def stresses(self, e, rot, area, b1, b2, n_res):
        """Pass 2 (in the element update): the triangle's membrane resultant N (end frame) as w_e T_e,
        and for pass 3 its normal e3 and h_a = A grad N_a (global, rows a) at x^(n+1)."""
        self.s.elements.ns_tensor[e] = (area / 3.0) * to_global(rot, n_res[0], n_res[1], n_res[2])
        self.s.elements.ns_weight[e] = area / 3.0
        h = ti.Matrix.zero(ti.f64, 3, 3)
        for a, d in ti.static(ti.ndrange(3, 3)):
            h[a, d] = area * (b1[a] * rot[0, d] + b2[a] * rot[1, d])
        self.s.elements.ns_gradient[e] = h
        self.s.elements.ns_normal[e] = ti.Vector([rot[2, 0], rot[2, 1], rot[2, 2]])

    @ti.func
    def loads(self):
        """Pass 3: the node means of the resultants, and each triangle's constant-strain loads of
        N* (the transpose of passes 1-2) added to its corners, with their stagger term (energy.py).
        With M = 1/3 sum_a T_a / W_a (global) the local loads A (B_a^T R M R^T) in global axes are
        f_a = P M h_a, P = I - e3 e3^T the in-plane projector (h_a is in the plane): no geometry
        is recomputed here."""
        self.node_means()
        for e in range(self.s.elements.count[None]):
            c = self.s.elements.corners[e]
            live = True
            if ti.static(self.cfg.erosion):         # weight 0: eroded (before or in this step)
                live = self.s.elements.ns_weight[e] > 0.0
            if c[3] < 0 and live:
                mean = self.corner_mean(c)
                h = self.s.elements.ns_gradient[e]
                n3 = self.s.elements.ns_normal[e]
                power = 0.0
                for a in ti.static(range(3)):
                    q = mean @ ti.Vector([h[a, 0], h[a, 1], h[a, 2]])
                    force = q - n3.dot(q) * n3
                    power += force.dot(self.s.nodes.grid_velocity[c[a]])
                    if ti.static(self.cfg.serial):
                        self.s.nodes.force_int[c[a]] = self.s.nodes.force_int[c[a]] + force
                    else:                               # the element's own slots, before the gather
                        slot = self.s.elements.corner_loads[e, a]
                        self.s.elements.corner_loads[e, a] = slot + ti.Vector([force[0], force[1], force[2], 0.0, 0.0,
                                                                               0.0, 0.0, 0.0, 0.0, 0.0])
                stagger = -0.5 * self.s.step.dt[None] * power
                old = self.s.elements.energy[e]
                self.s.elements.energy[e] = ti.Vector([old[0], old[1], old[2], old[3], old[4] + stagger])
                self.tri.quad.energy.acc.total(self.s.step.stagger_energy, stagger)
