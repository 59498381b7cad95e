"""Rigid bodies, point masses and walls of a model: their specs, masses, inertias and the step
a body allows (numpy)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scene import DOFS, Scene, SceneError, inertia_tensor


@dataclass(frozen=True)
class RigidBodySpec:
    name: str
    nodes: np.ndarray
    added_mass: float
    direction: tuple[float, float, float] | None   # unit: translation along it only (rotations held)
    total_mass: float                       # added + slave nodes (or the scene's, mass_from_nodes = false)
    velocity0: np.ndarray                   # (3,) initial centre velocity
    center: np.ndarray                      # (3,) reference centre X_c (the mass centre unless given)
    inertia: np.ndarray                     # (3, 3) about X_c, global axes at t = 0 (= the body frame)
    added_inertia: np.ndarray               # (3, 3) the scene's share of it
    spin0: np.ndarray                       # (3,) initial angular velocity
    translation_free: np.ndarray            # (3, 3) projector on the free translations (d d^T along a direction)
    rotation_free: np.ndarray               # (3, 3) projector on the free rotations (diagonal 0/1)
    turned: bool = False                    # a [[motion]] prescribes its rotations
    stable_step: float = math.inf           # the step its mass and inertia allow on its elements (body_step)

    @property
    def rotates(self) -> bool:
        return bool(self.rotation_free.any()) or self.turned

    @property
    def turns_freely(self) -> bool:
        """All three rotations free (stages/bodies.py's Simo-Wong drift)."""
        return bool(np.diag(self.rotation_free).all())

    @property
    def inertia_min(self) -> float:
        """The smallest principal inertia about the free rotation axes (0: none free)."""
        free = np.diag(self.rotation_free) > 0
        return float(np.linalg.eigvalsh(self.inertia[np.ix_(free, free)]).min()) if free.any() else 0.0


@dataclass(frozen=True)
class PointMassSpec:
    name: str
    nodes: np.ndarray
    mass: float                             # per node
    inertia: float                          # rotary, per node


@dataclass(frozen=True)
class WallSpec:
    point: tuple[float, float, float]
    normal: tuple[float, float, float]      # unit
    body: int                               # index of the rigid body it moves with, -1 = fixed


def node_point_masses(point_masses, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(n,) the mass and rotary inertia the [[point_mass]] entries put at each node (their sum
    at a node, in entry order): added to the elements' shares here and by the per-step mass
    rebuild of erosion and mass scaling (stages/masses.py, state.nodes.point_mass)."""
    mass, inertia = np.zeros(n), np.zeros(n)
    for p in point_masses:
        mass[p.nodes] += p.mass
        inertia[p.nodes] += p.inertia
    return mass, inertia


def rigid_body(scene: Scene, rb, ids: np.ndarray, points: np.ndarray, node_mass: np.ndarray,
                node_inertia: np.ndarray, velocity0: np.ndarray, min_edge: float) -> RigidBodySpec:
    """Mass, centre and inertia of a [[rigid_body]] (stages/bodies.py): the slave nodes' masses
    m_c at X_c and rotary inertias J_c, I = sum m_c (|r|^2 1 - r r^T) + J_c 1 (r = X_c - X_centre),
    plus the added mass (at the scene's `center`, else at the mass centre) and inertia (about
    that point); or the scene's mass and inertia alone (mass_from_nodes = false).  The initial
    velocity is the scene's, or the mean of the slaves' [[initial]] velocities; the free DOFs'
    projectors.

    The centre it turns about [choice, issue 28 item 2]: Newton-Euler in the form of
    stages/bodies.py (M dV/dt = F, dL/dt = M about the centre) holds about the mass centre G,
    or about a point held still.  So a rotating body whose `center` C is not its mass centre
    turns about G (I moved to G by its own sum) when its translations are free, about C when
    they are all fixed (a pivot), and is refused otherwise (some translations free: the
    coupling terms m (C - G) x a_C are not modelled); about C with free translations, a free
    body spinning changed its linear momentum with no force.  A body that does not rotate may
    have any centre."""
    where = f"{scene.source.name}: [[rigid_body]] '{rb.name}'"
    m = node_mass[ids] if rb.mass_from_nodes else np.zeros(len(ids))
    total = rb.mass + float(m.sum())
    if rb.center is not None:
        given = np.asarray(rb.center, dtype=float)
        mass_centre = (rb.mass * given + (m[:, None] * points[ids]).sum(axis=0)) / total if total > 0.0 else given
    elif m.sum() > 0.0:
        given = mass_centre = (m[:, None] * points[ids]).sum(axis=0) / m.sum()
    else:
        given = mass_centre = points[ids].mean(axis=0)
    rotation_free, translation_free, d, moved = free_dofs(scene, rb)
    turned = any(m.body == rb.name and set(m.dofs) & set(DOFS[3:]) for m in scene.motions)
    size = max(float(np.linalg.norm(points[ids] - given, axis=1).max(initial=0.0)), min_edge)
    center = given
    if (rotation_free.any() or turned) and np.linalg.norm(given - mass_centre) > 1e-9 * size:
        held = not translation_free.any()
        if d is None and np.diag(translation_free).all() and not moved & set(DOFS[:3]):
            center = mass_centre                           # free: about the mass centre
        elif not held:
            raise SceneError(f"{where}: center: {_vector(given)} is not its mass centre {_vector(mass_centre)}: a "
                             "rotating body may turn about another point only as a pivot (fixed = [\"ux\", \"uy\", "
                             "\"uz\"]); with all translations free it turns about its mass centre")
    r = points[ids] - center
    added = inertia_tensor(rb.inertia) + rb.mass * _arms((given - center)[None])[0]   # moved from `center` to the centre
    rotary = float(node_inertia[ids].sum()) if rb.mass_from_nodes else 0.0
    inertia = added + rotary * np.eye(3) + np.einsum("c,cij->ij", m, _arms(r))
    start = np.mean(velocity0[ids], axis=0) if len(ids) else np.zeros(3)     # (without nodes: at rest)
    if d is not None:
        v0 = float(start @ d) * d if rb.velocity is None else translation_free @ rb.velocity
    else:
        v0 = translation_free @ (start if rb.velocity is None else np.asarray(rb.velocity))
    spin = rotation_free @ np.asarray(rb.spin if rb.spin is not None else (0.0, 0.0, 0.0))
    if rb.velocity is not None:                  # given at `center`: the mass centre's is V + omega x (G - C)
        v0 = v0 + translation_free @ np.cross(spin, center - given)
    if translation_free.any() and not total > 0.0:
        raise SceneError(f"{where}: the body has no mass (its nodes carry none): give mass")
    free = np.diag(rotation_free) > 0
    scale = max(float(np.abs(inertia).max()), 1e-300)
    if free.any():
        smallest = float(np.linalg.eigvalsh(inertia[np.ix_(free, free)]).min())
        if not smallest > 1e-12 * scale:
            raise SceneError(f"{where}: the inertia about its free rotation axes is singular: give inertia")
        # near-singular against the body's own scale, M l^2 (l: its size, at least an element's):
        # it passed the relative test above and failed at step 2 as "time step too large"
        if smallest < NEAR_SINGULAR * total * size ** 2:
            raise SceneError(f"{where}: inertia: {smallest:.3g} about a free axis is near-singular (below "
                             f"{NEAR_SINGULAR:g} M l^2 = {NEAR_SINGULAR * total * size ** 2:.3g}, M = {total:.3g} its "
                             f"mass, l = {size:.3g} its size): give its physical inertia")
    return RigidBodySpec(rb.name, ids, rb.mass, None if d is None else tuple(d), total, v0, center, inertia,
                         added, spin, translation_free, rotation_free, turned)


def body_step_notes(scene: Scene, body: RigidBodySpec, element_step: float) -> list[str]:
    """A body that sets the step (body_step) is named in a warning; one that would need a step
    below STEP_COLLAPSE of its elements' (the run's dt-collapse guard) is refused."""
    if not body.stable_step < element_step:
        return []
    where = f"{scene.source.name}: [[rigid_body]] '{body.name}'"
    if body.stable_step < STEP_COLLAPSE * element_step:
        raise SceneError(f"{where}: mass, inertia: far too small for the elements it carries: they would need a "
                         f"step of {body.stable_step:.3g}, {body.stable_step / element_step:.1e} of the elements' "
                         f"{element_step:.3g}: give its physical mass and inertia")
    return [f"{where} limits the time step to {body.stable_step:.3g} (its elements allow {element_step:.3g}): its "
            "mass or inertia is small against the stiffness of the elements it carries"]


def _vector(v: np.ndarray) -> str:
    return "[" + ", ".join(f"{x:.6g}" for x in v) + "]"


def _arms(r: np.ndarray) -> np.ndarray:
    """|r|^2 1 - r r^T of each row of r: the inertia of a unit mass at r."""
    return np.einsum("ck,ck->c", r, r)[:, None, None] * np.eye(3) - r[:, :, None] * r[:, None, :]


def free_dofs(scene: Scene, rb):
    """Projectors on a body's free rotations and translations, its unit direction (or None)
    and the DOFs its [[motion]]s prescribe."""
    moved = {d for m in scene.motions if m.body == rb.name for d in m.dofs}   # prescribed: held + set
    if rb.direction is not None:
        d = np.asarray(rb.direction) / np.linalg.norm(rb.direction)
        return np.zeros((3, 3)), np.outer(d, d), d, moved
    translation_free = np.diag([0.0 if dof in rb.fixed else 1.0 for dof in DOFS[:3]])
    rotation_free = np.diag([0.0 if dof in rb.fixed or dof in moved else 1.0 for dof in DOFS[3:]])
    return rotation_free, translation_free, None, moved


STEP_COLLAPSE = 1e-3     # = stages/timestep.py's collapse guard (dt < 1e-3 of the first step)


NEAR_SINGULAR = 1e-9     # smallest principal inertia / (M l^2) a body may have (a needle of radius 1e-4 l: 1e-8)


def body_step(index: int, body: RigidBodySpec, points: np.ndarray, elements: np.ndarray, node_body: np.ndarray,
              steps: np.ndarray, corner_mass: np.ndarray, corner_inertia: np.ndarray, dt_safety: float) -> float:
    """The stable step a body's own mass and inertia allow on the elements it carries
    [issue 28 item 7]: alpha 2 / omega_b with omega_b^2 = max(k / M, k_r / I_min) over its free
    DOFs.  Each element with corners on the body and off it ties each of its slave corners c to
    the rest by a stiffness k_ec = m_ec omega_e^2 / 2 (omega_e = 2 alpha / dt_e its highest
    frequency, m_ec its corner mass: the two-node bar's exact ratio), k = sum k_ec, and turns it
    with k_r = sum k_ec |x_c - x_b|^2 + J_ec omega_e^2 / 2 (J_ec the corner's rotary inertia);
    M, I_min: its mass and smallest principal inertia about its free axes.  A body no lighter
    than a corner's share of its elements' mass gets a step above theirs (the bar: sqrt 2 x),
    so the rule binds only where the body is the light part; inf where no element ties it."""
    valid = elements >= 0
    on = valid & (node_body[np.where(valid, elements, 0)] == index)
    tied = on.any(axis=1) & (valid & ~on).any(axis=1)
    if not tied.any():
        return math.inf
    omega_sq = (2.0 * dt_safety / steps[tied]) ** 2
    k = 0.5 * np.where(on[tied], corner_mass[tied], 0.0) * omega_sq[:, None]
    arms = np.linalg.norm(points[np.where(on[tied], elements[tied], 0)] - body.center, axis=2)
    rates = []
    free_t = np.diag(body.translation_free) > 0 if body.direction is None else np.ones(3, bool)
    if free_t.any() and body.total_mass > 0.0:
        rates.append(float(k.sum()) / body.total_mass)
    free_r = np.diag(body.rotation_free) > 0
    if free_r.any():
        k_r = float((k * arms ** 2).sum() + 0.5 * (np.where(on[tied], corner_inertia[tied], 0.0) * omega_sq[:, None]).sum())
        rates.append(k_r / float(np.linalg.eigvalsh(body.inertia[np.ix_(free_r, free_r)]).min()))
    return 2.0 * dt_safety / math.sqrt(max(rates)) if rates and max(rates) > 0.0 else math.inf
