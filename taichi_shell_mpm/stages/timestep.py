"""Stable time step (stage S0; paper eq 38-40; method.md section 5).

The element rule (:func:`element_limit`: BT alpha L_e / c_e with L_e = area / longest
diagonal, and with physical rotary inertia the rotational limit) is evaluated inside the
element pass (:mod:`.shell`) into ``dt_next``; here it is combined with the paper's grid
rule alpha h / (c_dil + max|v_d|) when ``dt_rule = "both"``, with the contact limit
(:meth:`TimeStep.contact_limit`) and the rigid tools' (stages/tools.py), fitted to the next output time, and checked for
collapse.  :func:`initial_dt` is the host twin of all of it for the first step.

Landing on output times [choice, issue 4]: within LANDING_STEPS steps of the next output
time the step is remaining / ceil(remaining / dt_stable), the same for every step up to
it, so an output every k steps costs a constant dt a little below the stable one.  Clipping
only the last one or two steps (as before) modulated dt periodically; a central difference
near its stability limit is not stable under that: an 8x8 plate ringing in all its modes
with an output every 5.3 steps turned inside out within 500 steps
(tests/test_stability.py), and the 5 mm tube (an output every 0.01 ms) pumped its
rotational modes with the drilling spring, 200 J by 6 ms.
"""

import math

import numpy as np
import taichi as ti

from ..state import STATUS_DT_COLLAPSE, STATUS_OK, State

DT_UNSET = 1.0e300
CONTACT_STEP = 0.2      # approach per step / t_c at contact stiffness 0.1 (TimeStep.contact_limit)
LANDING_STEPS = 1000
# The most a body turns in a step, as dt |L| / J_min (>= dt |omega|; J_min its smallest principal
# inertia about the free axes; held or constrained rotations: dt |omega|) [choice, issue 28 item 7]:
# the Simo-Wong map W -> J^-1 (Pi + exp(-dt W^) Pi) / 2 has the Lipschitz constant
# dt |Pi| / (2 J_min), so at 1/2 it contracts by 1/4 per iteration (to 1e-15 in < 25 of the 50),
# and the slaves' Cayley factor tan(phi / 2) / (phi / 2), which blows up at phi = pi, stays below
# 1.021 (phi = dt |omega|).  A thin rod (J = [1, 1, 1e-4]) tumbling at the elements' step had a
# Lipschitz constant of ~70: the iteration diverged and the body gained energy
# (tests/test_bodies.py; stages/bodies.py).  The step is limited to it; the bound only binds on such bodies.
MAX_TURN = 0.5


def landing_step(remaining: float, dt_stable: float) -> float:
    """The first dt of an output interval (host twin of TimeStep.next_step's rule)."""
    if remaining >= LANDING_STEPS * dt_stable:
        return dt_stable
    return remaining / math.ceil(remaining / dt_stable - 1e-9) if remaining > 1e-9 * dt_stable else 0.0


@ti.func
def element_limit(s: ti.template(), cfg: ti.template(), e, area, longest):
    """Stable step of one element (method.md 5): alpha L_e / c_e, L_e = area / longest
    diagonal (triangles: :func:`triangle_limit`), and with the physical rotary inertia
    (m t^2 / 12) also the rotational limit alpha 2 / omega_rot, omega_rot = sqrt(12 kappa G / rho) / t: the transverse-shear-rotation
    mode of an element whose corners rotate together (shear stiffness kappa G t A against
    the rotary inertia rho t^3 A / 12; method.md 2.3), the highest frequency of a thin shell
    with that inertia (5x c_e / L_e on the tube).  Scaled rotary inertia (the default,
    max(t^2/12, A/8)) keeps every rotational frequency below c_e / L_e, so only the first
    rule applies.

    The two limits are combined by their minimum [choice, measured]: a free 4x4 plate
    (element side 0.25) with a random angular velocity at every node kept its
    central-difference energy invariant to 1e-4 over 10 000 steps at alpha = 0.9 for
    t = 0.01, 0.1, 0.165 (where the two limits are equal), 0.3, and diverged within 40 steps
    at alpha = 1.0 for t = 0.1 and 0.165; adding the two frequencies as squares (an upper
    bound of the coupled modes) was 29 % more conservative than needed where they are
    equal (tests/test_safety.py).  c_e and omega_rot are element e's (state.sections).
    With uniform_dt mass scaling (statics) c_e stays the physical one: every element then
    has the smallest element's step (assembly.uniform_dt_mass_factor)."""
    inv = s.sections.wave_speed[e] * longest / area
    if ti.static(cfg.physical_rotary_inertia):
        inv = ti.max(inv, 0.5 * s.sections.rotational_frequency[e])
    return s.step.dt_safety[None] / inv


@ti.func
def zigzag_limit(s: ti.template(), e, width):
    """The step of element e's shear zigzags, alpha h / c_s, c_s = sqrt(G / rho), h its
    narrowest width (a quad: area / longest side; a triangle: its smallest altitude): an
    element tilted rigidly against its neighbours with its nodes' rotations still (the
    transverse shear strain 2 w / h against the lumped mass: omega = 2 sqrt(kappa G / rho) / h),
    and one spinning about its normal against its neighbours (in-plane shear, G without
    kappa: the higher of the two).  The reciprocal mass matrix of selective mass scaling leaves
    both at the lumped mass (stages/selective_mass.py, Reciprocal), so they cap the step it
    reaches (stages/masses.py) [measured, docs/mass_scaling.md: with kappa G the plate's highest
    in-plane mode sat at omega dt / 2 = 0.90 and the strip broke at 1.1 times that cap]."""
    return s.step.dt_safety[None] * width / s.sections.shear_wave_speed[e]


@ti.func
def triangle_limit(s: ti.template(), cfg: ti.template(), e, length, gain):
    """Stable step of triangle e (stages/triangle.py): alpha L_e / c_e with the triangle's
    L_e = 4A / sqrt(3 sum l^2), and with the physical rotary inertia
    alpha / sqrt((c_e / L_e)^2 + g omega_rot^2 / 4) [choice, measured]: its edge shear ties
    the corner rotations to the shear g times as stiffly as the quad's mean rotation (g =
    assembly.triangle_shear_gain, 1.25 equilateral, 1.5 right isosceles, without bound on a
    sliver), and the two frequencies are added as squares, the bound of the coupled modes.
    On 4000 random triangles (angles down to 0.1 deg, t from 1e-3 to 2 sqrt(A), nu in
    [0, 0.49]) the largest omega dt / 2 of one element was then alpha x 1.0000 (eigenvalues of
    its stiffness with its lumped masses); the quad's minimum of the two limits, with g,
    reached alpha x 1.27 where they are equal, and without g a 1 deg sliver alpha x 880."""
    inv = s.sections.wave_speed[e] / length
    if ti.static(cfg.physical_rotary_inertia):
        rot = 0.5 * s.sections.rotational_frequency[e]
        inv = ti.sqrt(inv * inv + gain * rot * rot)
    return s.step.dt_safety[None] / inv


def contact_step(stiffness: float) -> float:
    """Largest approach per step, in contact thicknesses, for the penalty stiffness
    k = alpha_c m* / dt^2 (issue 16, item 2).  The contact is found once a node is within
    t_c of a segment; a spring met at the relative speed v stops it within
    v sqrt(m*/k) = v dt / sqrt(alpha_c).  Without a limit on dt, a node that crossed the
    other layer's mid-surface in one step was taken to be on the far side and pushed
    through (two sheets at 2.4 t_c per step).  CONTACT_STEP t_c sqrt(alpha_c / 0.1) per
    step keeps that distance near 0.6 t_c [choice, measured on two 2x2 sheets, t = t_c,
    meeting at 0.24-10 t_c per shell step (tests/test_safety.py): largest penetration 54 %
    of t_c with 0.2, 81 % with 0.3, 143 % with 0.5 (they bounced back only through the side
    memory)].  On the tube (v_rel <= ~40 m/s, t_c = 1 mm) it allows ~5e-3 ms, 8x the shell
    step: it never binds there."""
    return CONTACT_STEP * math.sqrt(stiffness / 0.1)


def contact_approach(laws) -> float:
    """The largest approach per step of any contact law: the smallest contact_step(alpha) t
    over the laws (model/contact_pairs.ContactTable.step_terms), t a law's smallest pair
    thickness."""
    return min(contact_step(alpha) * t for alpha, t in laws.step_terms)


@ti.func
def approach_step(stiffness):
    """contact_step in a kernel: the largest approach per step, in thicknesses, of a penalty
    of stiffness alpha (the self-contact's and each tool's, stages/tools.py)."""
    return CONTACT_STEP * ti.sqrt(stiffness / 0.1)


@ti.func
def impulse_time(step: ti.template()):
    """dt of the velocity kick v^(n+1/2) = v^(n-1/2) + dt a^n, halved on a restart from rest:
    dt^(n+1/2) (step.dt), or under selective mass scaling (step.averaged_kick, compiled in from
    the features by state.py) (dt^(n-1/2) + dt^(n+1/2)) / 2 with step.dt_last.
    Outside selective scaling the kick stays dt^(n+1/2): the equal landing steps (next_step)
    keep dt constant between outputs, so the two agree wherever outputs are dense, and the
    average was tried (issue 4) and dropped: where dt shrinks fast (an element collapsing) its
    longer kick let a node run away before the time-step guard fired
    (tests/test_reliability.py, dt_collapse).  Under selective mass scaling [choice, issue 29,
    docs/mass_scaling.md] the deformation modes carry most of the kinetic energy (T_add), and a
    step that varies (set by contact or a tool) with the one-sided kick lost it: the matrix's
    sheet with self-contact at 10x its step, balance -0.128 J of 0.90 J (51 steps); with the
    average -0.0083 J (0.0087 J without contact at its constant step)."""
    kick = step.dt[None]
    if ti.static(step.averaged_kick):
        kick += 0.5 * (step.dt_last[None] - step.dt[None])
    return step.restart_factor[None] * kick


@ti.data_oriented
class TimeStep:
    def __init__(self, state: State, cfg):
        self.s = state
        self.cfg = cfg

    @ti.func
    def grid_limit(self):
        return self.s.step.dt_safety[None] * self.s.grid.h[None] / (self.s.step.dilatational_speed[None] + self.s.step.max_speed[None])

    @ti.func
    def contact_limit(self):
        """Contact: dt <= contact_step(alpha_c) t / v_rel, v_rel = the norm of the
        per-axis spread of the nodal velocities, an upper bound of any two nodes' approach
        speed (Galilean invariant: a shell flying as a whole does not pay).  t: the smallest
        pair thickness [choice: the thinnest pair's contact zone is the one a node must not
        cross in a step; one bound, not one per pair, since v_rel is one bound too]; with
        [[contact_pair]] laws of their own stiffness, the smallest of contact_step(alpha) t
        over the laws (contact_approach)."""
        spread = (self.s.contact.velocity_high[None] - self.s.contact.velocity_low[None]).norm()
        length = 0.0
        if ti.static(self.cfg.contact_pairs):
            length = self.s.contact.approach[None]
        elif ti.static(self.cfg.pair_thickness):
            length = approach_step(self.s.contact.stiffness[None]) * self.s.contact.step_thickness[None]
        else:      # one pair thickness t_c (as before the per-pair rule)
            length = approach_step(self.s.contact.stiffness[None]) * self.s.contact.thickness[None]
        return length / ti.max(spread, 1e-300)

    @ti.func
    def next_step(self):
        """Set dt for the next step from this step's element, grid, contact and tool limits
        (the tools': stages/tools.RigidTools.node_force, this step's closest approach)."""
        dt = self.s.step.dt_next[None]
        if ti.static(self.cfg.grid_rule):
            dt = ti.min(dt, self.grid_limit())
        if ti.static(self.cfg.contact):
            dt = ti.min(dt, self.contact_limit())
        if ti.static(self.cfg.tools):
            dt = ti.min(dt, self.s.tools.step_limit[None])
        if dt < 1e-3 * self.s.step.dt_first[None] and self.s.step.status[None] == STATUS_OK:   # the first problem wins
            self.s.step.status[None] = STATUS_DT_COLLAPSE
            self.s.step.status_index[None] = -1   # the limiting element is found on the host (Simulation.check_status)
        self.s.step.dt_stable[None] = dt
        remaining = self.s.step.time_limit[None] - self.s.step.time[None]
        if remaining < LANDING_STEPS * dt:   # equal steps that land on the output time
            dt = remaining / ti.ceil(remaining / dt - 1e-9) if remaining > 1e-9 * dt else 0.0
        self.s.step.dt_last[None] = self.s.step.dt[None]
        self.s.step.dt[None] = dt
        self.s.step.dt_next[None] = DT_UNSET


def initial_dt(model, velocity: np.ndarray, cfg) -> float:
    """The same rules evaluated on the initial configuration of `model` (numpy, before the
    first step; the element rule: assembly.element_steps, with the initial mass factors of
    selective mass scaling)."""
    from ..model.assembly import element_steps
    p = model.parameters
    dt = float(np.min(element_steps(model.points, model.elements, model.element, p.dt_safety)
                      * np.sqrt(model.mass_factor)))
    if cfg.grid_rule:
        dt = min(dt, p.dt_safety * model.grid.h / (model.materials.dilatational_speed
                                                   + float(np.max(np.abs(velocity)))))
    for b in model.rigid_bodies:      # RigidBodies.step_limit
        rate = float(np.linalg.norm(b.spin0))
        if b.turns_freely:
            rate = max(rate, float(np.linalg.norm(b.inertia @ b.spin0)) / b.inertia_min)
        dt = min(dt, b.stable_step, MAX_TURN / rate if rate > 0.0 else math.inf)
    if cfg.contact:
        spread = float(np.linalg.norm(velocity.max(axis=0) - velocity.min(axis=0)))
        if spread > 0.0:
            dt = min(dt, contact_approach(model.contact) / spread)
    if cfg.tools:
        from ..model.tools import first_step_limit
        tt = model.tools
        dt = min(dt, first_step_limit(tt, model.points, model.node_thickness, velocity, model.node_body,
                                      np.array([contact_step(a) for a in tt.coefficients[:, 0]])))
    return dt
