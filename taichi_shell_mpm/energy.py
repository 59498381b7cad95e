"""Energy bookkeeping (method.md 8): what is booked where, the totals, the balance and its guards.

Booking.  Each quantity is accumulated where it arises, per entity, so that its total is a
sum in a fixed order (the same bits on any number of threads and across a restart):

* per element (``element_energy``): internal (stress power, method.md 8), of which plastic
  work, hourglass and drilling-spring energy, booked by the shell stage (:meth:`EnergyLedger.element`);
* per node (``node_energy``): work of the external loads, work done against the contact
  forces, energy taken out by rigid walls, work of the prescribed motions (their constraint
  forces, stages/motion.py) (:meth:`EnergyLedger.node`; per prescribed DOF too,
  :meth:`EnergyLedger.motion`, summed per motion on the host);
* per rigid body (``bodies.wall_energy``, ``bodies.external_work``, ``bodies.contact_energy``):
  the work of the walls moving with it on the body, of gravity on its added mass and of loads
  applied to it, and for a rotating body that of the loads and contact forces at its slaves;
* per rigid tool (``tools.energy``, ``tools.work``): its contact energy, of which ``work`` is
  booked at the tool's own motion (stages/tools.py; in the ``contact`` column, and for a tool
  moved by a curve in ``motion_work`` too: the work its driver does);
* damped energy (0-d): kinetic energy removed by dynamic relaxation (batched launch only);
* per element (``elements.mass_energy``, issue 18, stages/masses.py): the kinetic energy of
  its mass shares when it eroded, and the kinetic energy given to its added mass by
  selective mass scaling.  An eroded element's accumulators stop; :func:`totals` reports
  its internal, hourglass and drilling energy with that kinetic energy as the eroded
  energy, the element columns being those of the live elements.

Erosion [issue 28].  An element failing in step n+1 has booked that step's stress power,
U^(n+1), but writes no loads, so its forces f^(n+1) never act on the nodes and it has no
stagger term S_e = -dt/2 P_e (below).  What the nodes did work on it is U^(n+1) + S_e with the
forces it would have written, so that stagger term is booked into its internal energy
(stages/shell.ShellElement.failing_stagger) and is part of its eroded energy.  Without it
the eroded energy was booked above the work: a scene whose elements all fail in the first
step stopped as "energy created" (its first step's U^1 is the whole energy, S_e = -U^1 for
a linear response, and nothing else was absorbed).  Point masses stay at their nodes and
gravity acts on the physical mass that remains (stages/masses.py), so gravity's work is
booked on the mass the kinetic energy is measured with.

The step keeps 0-d running totals of the same increments for its in-kernel decisions
(static convergence, the balance guard); what is reported and written comes from the
per-entity sums (:func:`totals`).

Time-centred work [choice, issue 16]: a node's kinetic energy is measured at half steps,
1/2 m |v^(n+1/2)|^2, and a force f^n acting over the step changes it by exactly
dt f^n . (v^(n-1/2) + v^(n+1/2)) / 2 (central difference: m (v^(n+1/2) - v^(n-1/2)) = dt f^n;
dt/2 for the first update from rest, stages/timestep.impulse_time).
So the work of loads, contact forces and wall impulses is booked with that mid velocity.
Booked with v^(n+1/2) alone (as before), each step mis-books dt^2 |f|^2 / (2 m) per node:
bounded for smooth forces, but it accumulates where a constraint holds the node's velocity
(a wall pushing a plate: the wall column held the spurious term, and the balance read 27-30 %
on a box beam), and at stiff contact (two sheets meeting at 10 t_c per step lost a third of
their kinetic energy from the balance).  Internal forces need no such term: the stress power
booked over the step differs from their time-centred work by bounded, oscillating amounts
(the central difference's shadow energy), which do not accumulate.

Stagger [choice, issue 16].  The kinetic energy lives at half steps and the stored energy
at full steps.  For a linear elastic system the central difference conserves exactly
1/2 v^(n+1/2) M v^(n+1/2) + 1/2 x^n K x^(n+1), and 1/2 x^n K x^(n+1) = U(x^(n+1)) -
dt/2 v^(n+1/2) . f_int(x^(n+1)).  So the balance adds the stagger term
S = -dt/2 sum_e P_e, P_e = sum_a f_a . v_a + m_a . omega_a the element's power with its
forces at the end of the step (hourglass and drilling included); without it the balance
swings by (omega dt / 2)^2 of the energy in the highest modes: 100 % of the absorbed energy
in the first step of a suddenly loaded flap, a factor 1-2.4 in a plate spinning at random
(tests/test_safety.py).  With it the balance is exact to round-off for linear elastic
motion; what remains is nonlinearity, plasticity's dissipation booking, the double
mapping's transfer loss and real errors.

Balance.  E_err = KE + E_int + E_hg + E_drill + E_eroded + S + E_damped + E_wall + E_contact - KE_0
- W_ext - W_motion - E_ms (E_int includes the plastic work; W_motion: the work of the prescribed
motions; E_ms: the kinetic energy given to added mass).  The guard (:meth:`EnergyLedger.guard`, checked every step
in the kernel of a dynamic run) stops a run once E_err (energy created) exceeds ``limit``
times the energy the shell has absorbed, A = E_int + E_hg + E_drill + E_eroded + E_contact +
E_wall + E_damped, or KINETIC_SHARE x the shell's own kinetic energy (the nodes', without rigid
bodies' added masses) where that is larger, or ROUND_OFF_SHARE x the whole kinetic energy
(a rigid body tumbling alone absorbs nothing: its kinetic energy's round-off, 1e-14, is no
instability); the host warns once |E_err| exceeds
WARN_FRACTION x limit of the same scale either way (:func:`balance_ratio`).  The kinetic
floor [choice, measured]: the double mapping's transfer changes the kinetic energy of a
shell moving through the grid by itself (a free plate spinning through the cells, APIC:
+-1.7 % over 1.5 revolutions, nothing absorbed), which is no instability; an instability
grows exponentially past any such floor within a few steps.  The tube's nodes carry
~64 J against the 1.8 kJ it absorbs, so its guard is 5 % of the absorbed energy from the
first millimetres of crush on.
"""
from __future__ import annotations

import numpy as np
import taichi as ti

from .model.tools import DISPLACEMENT, VELOCITY
from .stages.accumulate import Accumulator
from .state import STATUS_ENERGY, STATUS_OK

ENERGY_COLUMNS = ("kinetic", "internal", "hourglass", "external_work", "damped", "wall", "contact",
                  "plastic_work", "drilling", "stagger", "motion_work", "eroded", "mass_scaling", "balance_error")
ELEMENT_PARTS = ("internal", "plastic_work", "hourglass", "drilling", "stagger")   # element_energy components
NODE_PARTS = ("external_work", "contact", "wall", "motion_work")         # node_energy components

BALANCE_STOP = 0.05          # default limit: |E_err| / absorbed (method.md 8: stop above 5 %)
WARN_FRACTION = 0.2          # warn at 0.2 x the limit (1 % by default)
KINETIC_SHARE = 0.5          # the balance scale is at least this x the shell's kinetic energy
ROUND_OFF_SHARE = 1e-8       # ... and this x the whole kinetic energy (rigid bodies included)


@ti.data_oriented
class EnergyLedger:
    """In-kernel booking of the energy increments and the balance guard (module docstring)."""

    def __init__(self, state, cfg, plastic: bool):
        self.s = state
        self.cfg = cfg
        self.plastic = plastic
        self.acc = Accumulator(cfg.serial)

    @ti.func
    def element(self, e, internal, plastic, hourglass, drilling, stagger):
        """Element e's increments of the step (stages/shell.py), and its stagger term (not
        accumulated: this step's value)."""
        old = self.s.elements.energy[e]
        self.s.elements.energy[e] = ti.Vector([old[0] + internal, old[1] + plastic, old[2] + hourglass,
                                              old[3] + drilling, stagger])
        self.acc.total(self.s.step.stagger_energy, stagger)
        self.acc.total(self.s.step.internal_energy, internal)
        self.acc.total(self.s.step.hourglass_energy, hourglass)
        if ti.static(self.cfg.drilling_spring):
            self.acc.total(self.s.step.drilling_energy, drilling)
        if ti.static(self.plastic):
            self.acc.total(self.s.step.plastic_work, plastic)

    @ti.func
    def node(self, c, external, contact, wall, motion):
        """Node c's increments of the step (stages/constraints.py): external work, work done
        against the contact forces, energy taken out by walls, work of prescribed motion."""
        self.s.nodes.energy[c] += ti.Vector([external, contact, wall, motion])
        self.acc.total(self.s.step.external_work, external)
        if ti.static(self.cfg.loads):
            self.acc.total(self.s.step.motion_work, motion)
        if ti.static(self.cfg.contact or self.cfg.tools or self.cfg.grid_contact):
            self.acc.total(self.s.step.contact_energy, contact)
        if ti.static(self.cfg.walls):
            self.acc.total(self.s.step.wall_energy, wall)

    @ti.func
    def body(self, b, wall):
        """Energy taken out of rigid body b by the walls moving with it (stages/bodies.py);
        serial (end of step)."""
        self.s.bodies.wall_energy[b] += wall
        self.s.step.wall_energy[None] += wall

    @ti.func
    def motion(self, c, d, work):
        """Work of the prescribed motion of DOF d of node c (stages/motion.py), kept per DOF
        for the per-motion totals; the node's sum goes through :meth:`node`."""
        self.s.nodes.motion_work[c, d] += work

    @ti.func
    def body_motion(self, b, d, work):
        """Work of the prescribed motion of DOF d of rigid body b (stages/bodies.py); serial."""
        self.s.bodies.motion_work[b][d] += work
        self.s.step.motion_work[None] += work

    @ti.func
    def body_contact(self, b, work):
        """Work done against the contact forces at rotating body b's slaves (stages/bodies.py); serial."""
        self.s.bodies.contact_energy[b] += work
        self.s.step.contact_energy[None] += work

    @ti.func
    def body_external(self, b, work):
        """Work of gravity on rigid body b's added mass, of the loads applied to it (stages/bodies.py)
        and, rotating, of the loads at its slaves; serial."""
        self.s.bodies.external_work[b] += work
        self.s.step.external_work[None] += work

    @ti.func
    def guard(self, shell_kinetic):
        """Stop (STATUS_ENERGY) when E_err > limit x max(absorbed, floor) (module docstring);
        a limit of 0 turns it off.  Only energy created stops a run: that is what an
        instability does; energy lost (the double mapping's transfer loss, PIC's dissipation of
        a spin) is warned of by the host (Simulation.check_balance).  Reads the 0-d running totals at the end of a step.
        Dynamic runs only: dynamic relaxation's FIRE mixing turns the velocity towards the
        force, which no work term books, so a static run's balance is reported, not guarded."""
        limit = self.s.step.energy_limit[None]
        if ti.static(not self.cfg.static) and limit > 0.0 and self.s.step.status[None] == STATUS_OK:
            absorbed = (self.s.step.internal_energy[None] + self.s.step.hourglass_energy[None] + self.s.step.drilling_energy[None]
                        + self.s.step.contact_energy[None] + self.s.step.wall_energy[None] + self.s.step.damped_energy[None])
            if ti.static(self.cfg.mass_update):      # eroded elements' energy is in the running totals above
                absorbed += self.s.step.eroded_kinetic[None]
            error = (self.s.step.kinetic[None] + absorbed + self.s.step.stagger_energy[None] - self.s.step.kinetic_initial[None]
                     - self.s.step.external_work[None] - self.s.step.motion_work[None])
            if ti.static(self.cfg.mass_update):
                error -= self.s.step.mass_scaling_energy[None]
            scale = ti.max(absorbed, KINETIC_SHARE * shell_kinetic,
                           ROUND_OFF_SHARE * self.s.step.kinetic[None])
            if not (error <= limit * scale) and scale > 0.0:      # also catches NaN
                self.s.step.status[None] = STATUS_ENERGY
                self.s.step.status_index[None] = -1


def bodies_kinetic_energy(state, model) -> float:
    """1/2 M_tot |V|^2 + 1/2 L . I^-1 L summed over the rigid bodies (slave nodes, added mass
    and inertia; the rotational part kept by stages/bodies.py)."""
    nb = len(model.rigid_bodies)
    if not nb:
        return 0.0
    v = state.read(state.bodies.velocity, nb)
    rotation = state.read(state.bodies.kinetic_rotation, nb)
    return float(sum(0.5 * b.total_mass * float(v[i] @ v[i]) + (float(rotation[i]) if b.rotates else 0.0)
                     for i, b in enumerate(model.rigid_bodies)))


def node_masses(state, model) -> tuple[np.ndarray, np.ndarray]:
    """The nodes' masses and rotary inertias now (they change with erosion and mass scaling)."""
    if not state.features.mass_update:
        return model.node_mass, model.node_inertia
    return state.read(state.nodes.mass, state.n_nodes), state.read(state.nodes.inertia, state.n_nodes)


def kinetic_energy(state, model) -> float:
    """KE = 1/2 sum m |v~|^2 + 1/2 sum J |omega|^2 over the nodes that are not rigid-body
    slaves, + 1/2 M_tot V^2 of each rigid body (its slaves and added mass move with V), + the
    kinetic energy of selective mass scaling's added mass (:func:`added_kinetic`).  With
    [[tie]] / [[spotweld]], the lumped kinetic energy the step keeps: each active joint's
    slave mass on its masters (stages/joints.py, model/joints.lumped)."""
    m, inertia = node_masses(state, model)
    if model.joints is not None:
        from .model.joints import lumped
        count = len(model.joints)
        m, inertia = lumped(model.joints, state.read(state.joints.active, count) == 1,
                            state.read(state.joints.offset, count), m, inertia)
    free = model.node_body < 0 if model.node_body is not None else np.ones(len(m), bool)
    v = state.read(state.nodes.grid_velocity, state.n_nodes)[free]
    w = state.read(state.nodes.omega, state.n_nodes)[free]
    return float(0.5 * np.sum(m[free] * np.sum(v * v, axis=1)) + 0.5 * np.sum(inertia[free] * np.sum(w * w, axis=1))
                 + bodies_kinetic_energy(state, model) + added_kinetic(state, model).sum())


def eroded_elements(state) -> np.ndarray:
    """(m,) bool: the elements that have failed (stages/masses.py; none without erosion)."""
    if not state.features.erosion:
        return np.zeros(state.n_elements, bool)
    return state.read(state.elements.eroded, state.n_elements) != 0


def mass_energies(state) -> np.ndarray:
    """(m, 2) per element: the kinetic energy its erosion took out of the nodes, and that
    its added mass was given (stages/masses.py); zeros without either."""
    if not state.features.mass_update:
        return np.zeros((state.n_elements, 2))
    return state.read(state.elements.mass_energy, state.n_elements)


def totals(state, model, initial_kinetic: float) -> dict[str, float]:
    """Every column of ENERGY_COLUMNS from the per-entity accumulators (a fixed summation
    order: restart-exact and independent of the number of threads).  The element columns
    (internal, plastic work, hourglass, drilling) are those of the live elements; an eroded
    element's internal, hourglass and drilling energy, and the kinetic energy of its mass
    shares, are the eroded energy (stages/masses.py); mass_scaling is the kinetic energy
    given to the added mass."""
    per_element = state.read(state.elements.energy, state.n_elements)
    gone = eroded_elements(state)
    element = per_element[~gone].sum(axis=0)
    node = state.read(state.nodes.energy, state.n_nodes).sum(axis=0)
    e = {name: float(element[i]) for i, name in enumerate(ELEMENT_PARTS)}
    e.update({name: float(node[i]) for i, name in enumerate(NODE_PARTS)})
    moved = mass_energies(state)
    e["eroded"] = float(per_element[gone][:, [0, 2, 3]].sum() + moved[:, 0].sum())
    e["mass_scaling"] = float(moved[:, 1].sum())
    if model.rigid_bodies:
        e["wall"] += float(state.read(state.bodies.wall_energy, len(model.rigid_bodies)).sum())
        e["external_work"] += float(state.read(state.bodies.external_work, len(model.rigid_bodies)).sum())
        if state.features.loads and model.loading.body_motion_mask.any():
            e["motion_work"] += float(state.read(state.bodies.motion_work, len(model.rigid_bodies)).sum())
        if state.features.body_rotation and state.features.contact:
            e["contact"] += float(state.read(state.bodies.contact_energy, len(model.rigid_bodies)).sum())
    if model.tools is not None:        # the tools' work at their own motion (stages/tools.py)
        work = state.read(state.tools.work, len(model.tools.names))
        e["contact"] += float(work.sum())
        prescribed = (model.tools.motion == VELOCITY) | (model.tools.motion == DISPLACEMENT)
        e["motion_work"] += float(work[prescribed].sum())
    e["kinetic"] = kinetic_energy(state, model)
    e["kinetic_bodies"] = bodies_kinetic_energy(state, model)      # (not a column: the guard's scale)
    e["damped"] = float(state.step.damped_energy[None])
    e["balance_error"] = (e["kinetic"] + absorbed(e) + e["stagger"] - initial_kinetic - e["external_work"]
                          - e["motion_work"] - e["mass_scaling"])
    return e


PART_COLUMNS = ("kinetic", "internal", "plastic_work", "hourglass", "drilling", "eroded", "mass_scaling")
"""The energies of each part (parts.csv, with its added mass; summary.json)."""


def part_names(model) -> list[str]:
    """Rows of :func:`part_energies`: the parts, the added mass of each rigid body, then each
    [[point_mass]]."""
    return ([p.name for p in model.parts] + [f"rigid_body:{b.name}" for b in model.rigid_bodies]
            + [f"point_mass:{p.name}" for p in model.point_masses])


def part_energies(state, model) -> np.ndarray:
    """(parts + bodies + point masses, PART_COLUMNS) energies per part, whose column sums are
    the totals of :func:`totals`: an element's internal, plastic, hourglass and drilling energy
    belong to its part; a node's kinetic energy is split among the elements around it in the
    shares they gave its mass and rotary inertia (Model.corner_mass, corner_inertia), a rigid
    body's slave node moving with the body (V + omega x r, omega); the kinetic energy of a
    body's added mass (and of point masses on its slaves) is the body's own row -- of a
    rotating body, what its kinetic energy has beyond its slaves' shares; a [[point_mass]]'s
    row is that of its mass and rotary inertia at its free nodes. With erosion and mass scaling, as :func:`totals`: the element columns of
    the live elements, the eroded and mass-scaling energy of each element to its part, and a
    node's mass shares of the live elements times their density factors (a slave node's
    mass is the body's and does not change); under selective scaling the lumped shares are
    physical and each element's part also has its added mass's kinetic energy."""
    element = state.read(state.elements.energy, state.n_elements)
    gone = eroded_elements(state)
    moved = mass_energies(state)
    part = model.element.part
    nb, n_parts = len(model.rigid_bodies), len(model.parts)
    out = np.zeros((n_parts + nb + len(model.point_masses), len(PART_COLUMNS)))
    for j, name in enumerate(PART_COLUMNS[1:5], start=1):
        out[:n_parts, j] = np.bincount(part, weights=np.where(gone, 0.0, element[:, ELEMENT_PARTS.index(name)]),
                                       minlength=n_parts)
    eroded = np.where(gone, element[:, 0] + element[:, 2] + element[:, 3], 0.0) + moved[:, 0]
    out[:n_parts, 5] = np.bincount(part, weights=eroded, minlength=n_parts)
    out[:n_parts, 6] = np.bincount(part, weights=moved[:, 1], minlength=n_parts)
    v = state.read(state.nodes.grid_velocity, state.n_nodes).copy()     # a slave's velocity is the body's
    w = state.read(state.nodes.omega, state.n_nodes).copy()
    if nb:
        speed = state.read(state.bodies.velocity, nb)
        slave = model.node_body >= 0
        body = model.node_body[slave]
        spin = state.read(state.bodies.omega, nb)
        center = state.read(state.bodies.center0, nb) + state.read(state.bodies.displacement, nb)
        positions = state.read(state.nodes.position, state.n_nodes)[slave]
        v[slave] = speed[body] + np.cross(spin[body], positions - center[body])
        w[slave] = spin[body]
    v2, w2 = np.sum(v ** 2, axis=1), np.sum(w ** 2, axis=1)
    corners = np.where(model.elements >= 0, model.elements, 0)
    share = inertia_share = np.ones(model.corner_mass.shape)
    if state.features.mass_update:            # slaves: the shares of the assembly
        live = mass_factors(state, model) * ~gone
        slave = model.node_body[corners] >= 0
        share = inertia_share = np.where(slave, model.mass_factor[:, None], live[:, None])
        if state.features.selective_mass:     # the lumped masses and inertias stay physical
            share = inertia_share = np.where(slave, 1.0, (~gone)[:, None].astype(float))
    corner_kinetic = 0.5 * (model.corner_mass * share * v2[corners] + model.corner_inertia * inertia_share * w2[corners])
    out[:n_parts, 0] = np.bincount(part, weights=corner_kinetic.sum(axis=1) + added_kinetic(state, model),
                                   minlength=n_parts)
    node_body = model.node_body if model.node_body is not None else np.full(len(v2), -1)
    for k, p in enumerate(model.point_masses):
        free = p.nodes[node_body[p.nodes] < 0]
        out[n_parts + nb + k, 0] = 0.5 * float(np.sum(p.mass * v2[free] + p.inertia * w2[free]))
    if nb:
        rotation = state.read(state.bodies.kinetic_rotation, nb)
    for i, b in enumerate(model.rigid_bodies):
        if b.rotates:       # the body's kinetic energy less its slaves' shares of the parts'
            mine = np.isin(corners, b.nodes) & (model.elements >= 0)
            shares = float(np.sum(corner_kinetic[mine]))
            out[n_parts + i, 0] = 0.5 * b.total_mass * float(speed[i] @ speed[i]) + float(rotation[i]) - shares
        else:
            on_slaves = sum(p.mass * int(np.count_nonzero(node_body[p.nodes] == i)) for p in model.point_masses)
            out[n_parts + i, 0] = 0.5 * (b.added_mass + on_slaves) * float(speed[i] @ speed[i])
    return out


def mass_factors(state, model) -> np.ndarray:
    """(m,) the elements' factors f_e of mass scaling now (1 without; stages/masses.py)."""
    if not state.features.mass_scaling:
        return model.mass_factor
    return state.read(state.elements.mass_factor, state.n_elements)


def deformation_mass(state, model) -> np.ndarray:
    """(m,) (f_e - 1) m_e: the mass conventional scaling has added to each element, or the
    mass selective scaling gives its deformation modes beyond the lumped one (beta_e m_e)."""
    return (mass_factors(state, model) - 1.0) * model.corner_mass.sum(axis=1)


def added_mass(state, model) -> np.ndarray:
    """(m,) the mass mass scaling has added to each element: (f_e - 1) m_e under conventional
    scaling, none under selective scaling (its added mass matrix is zero on translations)."""
    if state.features.selective_mass:
        return np.zeros(state.n_elements)
    return deformation_mass(state, model)


def added_kinetic(state, model) -> np.ndarray:
    """(m,) the kinetic energy of each element's added mass under selective scaling
    (stages/selective_mass.py; zeros without): beta_e / 2 (sum_a m_a |d_a|^2 +
    sum_a m_a rho_e^2 |P_e (omega_a - Omega_e)|^2) with the geometry the step kept; with the
    reciprocal mass matrix, the running sum each element keeps (state.elements.sms_excess)."""
    if not state.features.selective_mass:
        return np.zeros(state.n_elements)
    if state.features.reciprocal_mass:       # the running sum the step keeps (no matrix to evaluate)
        return state.read(state.elements.sms_excess, state.n_elements)
    m_e = state.n_elements
    beta = (mass_factors(state, model) - 1.0) * ~eroded_elements(state)
    arm = state.read(state.elements.sms_arm, m_e)
    inverse_inertia = state.read(state.elements.sms_inverse_inertia, m_e)
    normal = state.read(state.elements.sms_normal, m_e)
    radius_sq = state.read(state.elements.sms_radius_sq, m_e)
    valid = model.elements >= 0
    m = model.corner_mass * valid
    corners = np.where(valid, model.elements, 0)
    v = state.read(state.nodes.grid_velocity, state.n_nodes)[corners]
    w = state.read(state.nodes.omega, state.n_nodes)[corners]
    mean = np.einsum("ea,eak->ek", m, v) / m.sum(axis=1)[:, None]
    spin = np.einsum("ekl,el->ek", inverse_inertia, np.einsum("ea,eak->ek", m, np.cross(arm, v)))
    d = v - mean[:, None] - np.cross(spin[:, None], arm)
    rel = w - spin[:, None]
    rel -= np.einsum("eak,ek->ea", rel, normal)[..., None] * normal[:, None]
    unit = 0.5 * np.einsum("ea,ea->e", m, np.sum(d ** 2, axis=2) + radius_sq[:, None] * np.sum(rel ** 2, axis=2))
    return np.where(beta > 0.0, beta * unit, 0.0)


def absorbed(e: dict) -> float:
    """Energy taken up by the shell and its constraints: internal (incl. plastic), hourglass,
    drilling, eroded, contact, walls and dynamic-relaxation damping."""
    return e["internal"] + e["hourglass"] + e["drilling"] + e["eroded"] + e["contact"] + e["wall"] + e["damped"]


def balance_ratio(e: dict) -> float:
    """|E_err| / max(absorbed, KINETIC_SHARE x the shell's kinetic energy): the guard's ratio
    (host twin of :meth:`EnergyLedger.guard`)."""
    scale = max(absorbed(e), KINETIC_SHARE * (e["kinetic"] - e["kinetic_bodies"]), ROUND_OFF_SHARE * e["kinetic"])
    return abs(e["balance_error"]) / scale if scale > 0.0 else 0.0

