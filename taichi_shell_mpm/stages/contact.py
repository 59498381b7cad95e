"""Penalty node-to-segment self-contact (stage S1; method.md 7.3), compiled only for scenes
with a [contact] table.

Segments are the element faces split into triangles (1,2,3), (1,3,4) (a triangular element
is one segment), both sides active, contact thickness t_c.  Excluded: elements touching the
node's one-ring of nodes, and eroded elements and nodes without mass (stages/masses.py).  Each
node takes its single closest penetrating segment [choice: no double counting where
segments meet]; the force k g + c g' along the closest-point direction (so edges and
vertices are handled too) goes to the node and, with the barycentric weights, back to the
segment's corners.  k = alpha_c m*/dt^2 (stable for any dt, like LS-DYNA SOFT=1), damping
a fraction of critical (at most (2 - alpha_c) / (2 sqrt(alpha_c)): scene.penalty_damping_limit).
Friction [choice]: Coulomb regularised by the tangential slip speed,
mu |F_n| v_t / sqrt(|v_t|^2 + v_eps^2), which needs no per-pair history, capped at
m* |v_t| / dt (:func:`coulomb_friction`).  Contact
energy is the work done against the contact forces (booked at the node update,
:mod:`.constraints`).

Pair thickness (model/contact_pairs.py): node c and face e touch at t_ce = (t_n + t_e) / 2,
t_n the node's thickness (its thickest element's) and t_e the face's, so a 1 mm sheet meets a 3 mm
one at 2 mm; [contact].thickness, when given, is every single-surface pair's.  The node takes
the closest face within its own pair thickness.  A free edge: the closest point of a face
may lie on its edge, so a node beyond a free edge touches it within t_ce, the node's sphere
of radius t_n / 2 against the edge rounded with radius t_e / 2 (LS-DYNA's shell edge).  The
search reaches the largest pair thickness, t_c below (contact.thickness), so no pair is missed.

Interfaces ([[contact_pair]], compiled only for scenes with some): the same lists and law,
with a pair (c, e) allowed only where node_role[c] & segment_role[e] != 0 (filtered when the
lists are built) and the law, thickness overrides and interface of the lowest common bit
(model/contact_pairs.py); each interface's slave-side force is summed in the scatter.

Search [choice, issue 4; replaces a hash query of every node at every step]: candidate
(Verlet) lists.  Each node keeps the elements e with |x_c - centroid_e| - R_e <= t_c + s
(R_e: the largest centroid-corner distance, so the element lies in that ball; s: the
skin), found through a spatial hash of centroids (cell = max R_e + t_c + s, 27-cell query)
and with the one-ring excluded once, at build time.  While no node has moved more than
s/2 since the build, no element outside a node's list can come within t_c of it (node and
segment points each moved at most s/2), so the per-step test runs over the lists only and
finds exactly the pairs the full search would.  Any s > 0 gives the same pairs (up to
which of two equally close segments a node takes: the list order follows the hash cells);
s only trades the per-step test against the rebuilds: :func:`skin_width`.  The skin
is checked at the end of each step (:meth:`SelfContact.check_skin`); the rebuild runs at
the start of the next one, inside the step kernel in the batched launch and as a kernel
of its own, launched only when due, in the parallel ones (solvers/stepper.py), whose
every loop costs a thread-pool dispatch per step.
"""
import numpy as np
import taichi as ti

from ..model.contact_pairs import SELF_BIT
from ..state import STATUS_CONTACT_FULL, STATUS_OK
from .accumulate import Accumulator, serial_loop
from .timestep import contact_approach, impulse_time

SKIN_RANGE = (0.25, 1.0)   # s / t_c, see skin_width
# A side change counts as a crossing of the mid-surface only where the closest point lies
# over the face, i.e. the node-to-segment direction is within 60 deg of the facet normal.
# Near an edge or a vertex that direction turns through the facet plane as the node moves
# around the edge, and the sign alone would read a graze as a crossing and push the node
# through (the 2.5 mm tube at 3.19 ms: penetration 0.5 % -> 200 % of t in one step).
CROSSING_COSINE = 0.5


@ti.func
def closest_point_on_triangle(p, a, b, c):
    """Closest point to p on triangle abc and its barycentric weights (Ericson 2005, 5.1.5)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = ab.dot(ap), ac.dot(ap)
    bp = p - b
    d3, d4 = ab.dot(bp), ac.dot(bp)
    cp = p - c
    d5, d6 = ab.dot(cp), ac.dot(cp)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    bary = ti.Vector([0.0, 0.0, 0.0])
    if d1 <= 0.0 and d2 <= 0.0:
        bary = ti.Vector([1.0, 0.0, 0.0])
    elif d3 >= 0.0 and d4 <= d3:
        bary = ti.Vector([0.0, 1.0, 0.0])
    elif vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        bary = ti.Vector([1.0 - v, v, 0.0])
    elif d6 >= 0.0 and d5 <= d6:
        bary = ti.Vector([0.0, 0.0, 1.0])
    elif vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        bary = ti.Vector([1.0 - w, 0.0, w])
    elif va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        bary = ti.Vector([0.0, 1.0 - w, w])
    else:
        denom = 1.0 / (va + vb + vc)
        v = vb * denom
        w = vc * denom
        bary = ti.Vector([1.0 - v - w, v, w])
    return bary[0] * a + bary[1] * b + bary[2] * c, bary


@ti.func
def coulomb_friction(mu, f_n, v_rel, normal, slip_speed, mass, kick):
    """Coulomb friction regularised by the tangential slip speed [choice: needs no per-pair
    history], -mu |F_n| v_t / sqrt(|v_t|^2 + v_eps^2), v_t the relative velocity's part
    normal to `normal`, capped at the force m |v_t| / kick that stops the slip in one step
    (m: the node's mass, or the pair's reduced mass; kick: the step's impulse time) [issue
    28, items 8, 8e]: the explicit law acts on the lagged slip v^(n-1/2), and a larger force
    reverses it, so the next step's force pushes back: a sticking node chattered, and a tool
    at friction = 10, stiffness = 1 created 21 % of the work in 7 steps.  With the cap the
    slip at most stops (the other forces aside), so friction only dissipates.  The
    self-contact's and the rigid tools' (stages/tools.py) law."""
    slip = v_rel - v_rel.dot(normal) * normal
    return -ti.min(mu * f_n / ti.sqrt(slip.norm_sqr() + slip_speed ** 2), mass / kick) * slip


def skin_width(t_c: float, min_edge: float) -> float:
    """The candidate lists' skin s [choice, measured in the note of issue 4]: t_c, unless
    the elements are small against t_c.  A node's excluded one-ring reaches about two
    element lengths l across its own surface; while t_c + s stays inside it, the lists
    hold no elements of the node's own flat surface.  So s = 2 l_min - t_c (l_min: the
    shortest reference edge), kept in [0.25, 1] t_c.  The tube at 0.83 mm elements
    (103 680, t_c = 1 mm, 400 steps from the start) with s = t_c kept 16.6 candidates per
    node, all on its own surface, at 0.431 us per element-step; with this rule (s = 0.31
    t_c) 0.61 and 0.344 us.  A small skin is no gain on coarse meshes: the 5 mm tube
    (the rule gives t_c) took 70.5 s to 15 ms with s = 0.4 t_c against 67.6 s with t_c
    (more rebuilds), with identical results."""
    low, high = SKIN_RANGE
    return float(np.clip(2.0 * min_edge - t_c, low * t_c, high * t_c))


@ti.func
def lowest_bit(bits):
    """The index of the lowest set bit of bits != 0."""
    d = 0
    while (bits >> d) & 1 == 0:
        d += 1
    return d


@ti.data_oriented
class SelfContact:
    def __init__(self, state, cfg, model):
        self.s = state
        self.cfg = cfg
        self.acc = Accumulator(cfg.serial)
        self.scatter_acc = Accumulator(not cfg.atomic_scatter)
        state.contact.skin[None] = skin_width(model.parameters.contact_thickness, model.min_edge)
        if cfg.contact_pairs:
            state.contact.approach[None] = contact_approach(model.contact)

    @ti.func
    def hash(self, cell):
        h = (cell[0] * 73856093) ^ (cell[1] * 19349663) ^ (cell[2] * 83492791)
        return h & (self.s.contact.hash_size[None] - 1)

    @ti.func
    def cell_of(self, x):
        return ti.floor(x / self.s.contact.hash_cell[None], ti.i32)

    @ti.func
    def segment_corners(self, e):
        """Element e's corners, a triangle's 4th read as its 1st (then (x3 - x1) x (x4 - x2) is
        its normal x 2A, and the 4th barycentric weight, always 0, lands on a real node)."""
        c = self.s.elements.corners[e]
        if ti.static(self.cfg.triangles):
            if c[3] < 0:
                c[3] = c[0]
        return c

    @ti.func
    def centroid(self, e):
        c = self.segment_corners(e)
        centre = 0.25 * (self.s.nodes.position[c[0]] + self.s.nodes.position[c[1]] + self.s.nodes.position[c[2]] + self.s.nodes.position[c[3]])
        if ti.static(self.cfg.triangles):
            if c[3] == c[0]:
                centre = (self.s.nodes.position[c[0]] + self.s.nodes.position[c[1]] + self.s.nodes.position[c[2]]) / 3.0
        return centre

    @ti.func
    def excluded(self, c, e):
        """True if element e touches the one-ring of node c (its own or adjacent elements)."""
        corners = self.s.elements.corners[e]
        out = False
        for i in range(self.s.contact.neighbor_start[c], self.s.contact.neighbor_start[c + 1]):
            q = self.s.contact.neighbor_nodes[i]
            for a in ti.static(range(4)):
                if corners[a] == q:
                    out = True
        return out

    @ti.func
    def reach(self):
        """t_c + s: how close an element must be at a build to enter a node's list."""
        return self.s.contact.thickness[None] + self.s.contact.skin[None]

    @ti.func
    def check_skin(self):
        """Ask for a rebuild once some node has moved more than skin/2 since the last one."""
        serial_loop(self.cfg.serial_node_loops)
        for c in range(self.s.nodes.count[None]):
            moved = self.s.nodes.position[c] - self.s.contact.build_position[c]
            if moved.norm_sqr() > (0.5 * self.s.contact.skin[None]) ** 2:
                self.s.contact.rebuild[None] = 1

    @ti.func
    def build_hash(self):
        """Counting sort of element centroids into hash slots (when a rebuild is due); the
        cell size, max R_e + t_c + skin, follows the current configuration."""
        rebuild = self.s.contact.rebuild[None]
        if rebuild:
            self.s.contact.hash_cell[None] = 0.0
        for e in range(self.s.elements.count[None]):
            if rebuild:
                centre = self.centroid(e)
                radius = 0.0
                c = self.segment_corners(e)
                for a in ti.static(range(4)):
                    radius = ti.max(radius, (self.s.nodes.position[c[a]] - centre).norm())
                self.s.contact.element_radius[e] = radius
                self.acc.maximum(self.s.contact.hash_cell, radius)
        if rebuild:
            self.s.contact.hash_cell[None] += self.reach()
        for h in range(self.s.contact.hash_size[None]):
            if rebuild:
                self.s.contact.hash_count[h] = 0
        for e in range(self.s.elements.count[None]):
            if rebuild:
                slot = self.hash(self.cell_of(self.centroid(e)))
                self.s.contact.element_slot[e] = slot
                self.acc.add(self.s.contact.hash_count, slot, 1)
        ti.loop_config(serialize=True)
        for h in range(self.s.contact.hash_size[None]):          # hash_start[0] stays 0
            if rebuild:
                self.s.contact.hash_start[h + 1] = self.s.contact.hash_start[h] + self.s.contact.hash_count[h]
                self.s.contact.hash_count[h] = 0
        for e in range(self.s.elements.count[None]):
            if rebuild:
                slot = self.s.contact.element_slot[e]
                k = 0
                if ti.static(self.cfg.serial):
                    k = self.s.contact.hash_count[slot]
                    self.s.contact.hash_count[slot] = k + 1
                else:
                    k = ti.atomic_add(self.s.contact.hash_count[slot], 1)
                self.s.contact.hash_elements[self.s.contact.hash_start[slot] + k] = e

    @ti.func
    def scan_neighbours(self, c, store: ti.template()):
        """Elements that may come within t_c of node c before the next rebuild; counted, or
        written from candidate_start[c] on when `store`."""
        x = self.s.nodes.position[c]
        home = self.cell_of(x)
        found = 0
        for off in ti.grouped(ti.ndrange((-1, 2), (-1, 2), (-1, 2))):
            slot = self.hash(home + off)
            for i in range(self.s.contact.hash_start[slot], self.s.contact.hash_start[slot + 1]):
                e = self.s.contact.hash_elements[i]
                allowed = True
                if ti.static(self.cfg.contact_pairs):     # an interface's side, or [contact]
                    allowed = self.s.contact.node_role[c] & self.s.contact.segment_role[e] != 0
                if allowed and (x - self.centroid(e)).norm() <= self.s.contact.element_radius[e] + self.reach():
                    if not self.excluded(c, e):
                        if ti.static(store):
                            self.s.contact.candidate_elements[self.s.contact.candidate_start[c] + found] = e
                        found += 1
        return found

    @ti.func
    def build_candidates(self):
        """Rebuild the candidate lists (when asked): hash, count, prefix sum, fill."""
        self.build_hash()
        rebuild = self.s.contact.rebuild[None]
        for c in range(self.s.nodes.count[None]):
            if rebuild:
                self.s.contact.candidate_start[c + 1] = self.scan_neighbours(c, False)
        ti.loop_config(serialize=True)
        for c in range(self.s.nodes.count[None]):      # candidate_start[0] stays 0
            if rebuild:
                self.s.contact.candidate_start[c + 1] += self.s.contact.candidate_start[c]
        full = 0
        n = self.s.nodes.count[None]
        if rebuild and self.s.contact.candidate_start[n] > self.s.contact.candidate_capacity[None]:
            full = 1
            if self.s.step.status[None] == STATUS_OK:
                self.s.step.status[None] = STATUS_CONTACT_FULL
                self.s.step.status_index[None] = self.s.contact.candidate_start[n]
        for c in range(self.s.nodes.count[None]):
            if rebuild and not full:
                self.scan_neighbours(c, True)
                self.s.contact.build_position[c] = self.s.nodes.position[c]
            if full:                         # empty lists: nothing past the capacity is read
                self.s.contact.candidate_start[c + 1] = 0
        self.s.contact.rebuild[None] = 0

    @ti.func
    def forces(self):
        """S1: refresh the candidate lists when a node has used up half the skin (batched
        launch; see the module docstring), find each node's pair and its penalty force at
        x^n (parallel over nodes), then scatter the forces to the nodes and segment corners
        in node order (serial: no atomics, and the same sums on any number of threads)."""
        if ti.static(self.cfg.serial):
            self.build_candidates()
        if ti.static(self.cfg.contact_pairs):
            for k in range(self.s.contact.interface_count[None]):
                self.s.contact.interface_force[k] = ti.Vector([0.0, 0.0, 0.0])
        serial_loop(self.cfg.serial_node_loops)
        for c in range(self.s.nodes.count[None]):
            self.s.contact.force[c] = ti.Vector([0.0, 0.0, 0.0])
            self.pair(c)
        if ti.static(not self.cfg.atomic_scatter):
            ti.loop_config(serialize=True)
        for c in range(self.s.nodes.count[None]):
            e = self.s.contact.last_element[c]
            if e >= 0:
                corners = self.segment_corners(e)
                force = self.s.contact.pair_force[c]
                w = self.s.contact.pair_weight[c]
                self.scatter_acc.add(self.s.contact.force, c, force)
                for a in ti.static(range(4)):
                    self.scatter_acc.add(self.s.contact.force, corners[a], -w[a] * force)
                if ti.static(self.cfg.contact_pairs):    # the force on the interface's slave side
                    d = self.s.contact.pair_direction[c]
                    k = self.s.contact.law_interface[d]
                    if k >= 0:
                        self.scatter_acc.add(self.s.contact.interface_force, k, self.s.contact.law[d][5] * force)

    @ti.func
    def law_of(self, c, e, t_node):
        """The direction d (model/contact_pairs.py) of node c against face e (-1: none) and the
        pair thickness (t_node' + t_e') / 2, each side's override where it has one; without
        interfaces d = SELF_BIT.  Adding the two
        halves, a single-section scene's pairs touch at exactly its t; such a scene compiles
        none of this (Features.pair_thickness: every pair at t_c, the code as before)."""
        t_face = self.s.sections.thickness[e]
        d = SELF_BIT
        t = 0.0
        if ti.static(self.cfg.contact_pairs):
            common = self.s.contact.node_role[c] & self.s.contact.segment_role[e]
            if common == 0:
                d = -1
            else:
                d = lowest_bit(common)
                law = self.s.contact.law[d]
                t = 0.5 * ((law[3] if law[3] > 0.0 else t_node) + (law[4] if law[4] > 0.0 else t_face))
        else:     # [contact].thickness makes every pair's t_c: no per-pair code then
            t = 0.5 * (t_node + t_face)
        return d, t

    @ti.func
    def coefficient(self, d, i: ti.template()):
        """Column i (0 stiffness, 1 damping, 2 friction) of direction d's law; without
        interfaces [contact]'s (read where it is used, which keeps a single-surface scene's
        arithmetic, and its results, bit for bit those before the interfaces)."""
        out = 0.0
        if ti.static(self.cfg.contact_pairs):
            out = self.s.contact.law[d][i]
        else:
            out = ti.static((self.s.contact.stiffness, self.s.contact.damping, self.s.contact.friction)[i])[None]
        return out

    @ti.func
    def pair(self, c):
        """Node c's closest segment within its pair thickness among its candidates, and the penalty force
        (method.md 7.3) in contact_pair_force; contact_last_element[c] = -1 when none."""
        dt = self.s.step.dt[None]
        x = self.s.nodes.position[c]
        t_c = self.s.contact.thickness[None]     # the largest pair thickness; the only one without per_pair
        per_pair = ti.static(self.cfg.pair_thickness)
        t_node = 0.0
        if ti.static(per_pair):
            t_node = self.s.nodes.thickness[c]
        best_dist = t_c
        best_t = t_c
        best_d = SELF_BIT
        best_e = -1
        best_point = ti.Vector([0.0, 0.0, 0.0])
        best_w = ti.Vector([0.0, 0.0, 0.0, 0.0])
        start, stop = self.s.contact.candidate_start[c], self.s.contact.candidate_start[c + 1]
        if ti.static(self.cfg.mass_update):
            if self.s.nodes.mass[c] <= 0.0:     # a node of eroded elements only (stages/masses.py)
                stop = start
        for i in range(start, stop):
            e = self.s.contact.candidate_elements[i]
            if ti.static(self.cfg.erosion):     # an eroded element is no contact segment
                if self.s.elements.eroded[e] != 0:
                    continue
            d = SELF_BIT
            t_ce = t_c
            if ti.static(per_pair):
                d, t_ce = self.law_of(c, e, t_node)
                if d < 0:
                    continue
            corners = self.segment_corners(e)
            p0, p1 = self.s.nodes.position[corners[0]], self.s.nodes.position[corners[1]]
            p2, p3 = self.s.nodes.position[corners[2]], self.s.nodes.position[corners[3]]
            qa, ba = closest_point_on_triangle(x, p0, p1, p2)
            qb, bb = closest_point_on_triangle(x, p0, p2, p3)
            da, db = (x - qa).norm(), (x - qb).norm()
            if ti.static(self.cfg.triangles):
                if corners[3] == corners[0]:     # a triangle: one segment (the second, (1,3,1), is a line)
                    db = 2.0 * t_ce
            closer_a = da < best_dist
            if ti.static(per_pair):
                closer_a = closer_a and da < t_ce
            if closer_a:
                best_dist, best_e, best_point = da, e, qa
                best_w = ti.Vector([ba[0], ba[1], ba[2], 0.0])
                if ti.static(per_pair):
                    best_t, best_d = t_ce, d
            closer_b = db < best_dist
            if ti.static(per_pair):
                closer_b = closer_b and db < t_ce
            if closer_b:
                best_dist, best_e, best_point = db, e, qb
                best_w = ti.Vector([bb[0], 0.0, bb[1], bb[2]])
                if ti.static(per_pair):
                    best_t, best_d = t_ce, d
        if best_e >= 0 and best_dist > 0.0 and dt > 0.0:
            corners = self.segment_corners(best_e)
            normal = (x - best_point) / best_dist
            gap = best_t - best_dist
            facet = (self.s.nodes.position[corners[2]] - self.s.nodes.position[corners[0]]).cross(
                self.s.nodes.position[corners[3]] - self.s.nodes.position[corners[1]]).normalized()
            cosine = normal.dot(facet)
            side = 1.0 if cosine >= 0.0 else -1.0
            if self.s.contact.last_element[c] == best_e and side != self.s.contact.last_side[c] \
                    and ti.abs(cosine) > CROSSING_COSINE:
                # crossed the mid-surface since last step: push back to the side it came from
                normal = -normal
                gap = best_t + best_dist
                side = -side
            self.s.contact.last_element[c] = best_e
            self.s.contact.last_side[c] = side
            m_seg = 0.0
            v_seg = ti.Vector([0.0, 0.0, 0.0])
            for a in ti.static(range(4)):
                m_seg += best_w[a] * self.s.nodes.mass[corners[a]]
                v_seg += best_w[a] * self.s.nodes.grid_velocity[corners[a]]
            m_node = self.s.nodes.mass[c]
            m_eff = m_node * m_seg / (m_node + m_seg)
            # k from the stable step, not the current one: a step shortened to land on an
            # output time would otherwise make the spring arbitrarily stiff
            if ti.static(self.cfg.contact_pairs):
                self.s.contact.pair_direction[c] = best_d
            k = self.coefficient(best_d, 0) * m_eff / (self.s.step.dt_stable[None] ** 2)
            v_rel = self.s.nodes.grid_velocity[c] - v_seg
            closing = -v_rel.dot(normal)
            f_n = ti.max(0.0, k * gap + self.coefficient(best_d, 1) * 2.0 * ti.sqrt(k * m_eff) * closing)
            force = f_n * normal
            if ti.static(self.cfg.friction):
                force += coulomb_friction(self.coefficient(best_d, 2), f_n, v_rel, normal,
                                          self.s.contact.slip_speed[None], m_eff, impulse_time(self.s.step))
            self.s.contact.pair_force[c] = force
            self.s.contact.pair_weight[c] = best_w
            self.acc.maximum(self.s.contact.max_penetration, gap / best_t)
            self.acc.total(self.s.contact.pairs, 1)
        else:
            self.s.contact.last_element[c] = -1
