"""Sections at the model level (pure numpy; docs/laminates.md): the through-thickness points
of a section with the material and ply angle of each, the section's mass and rotary inertia,
its fastest wave, the effective isotropic moduli that scale its artificial stiffnesses, and
each element's material axis.

A section without plies is one material over the thickness: its points follow its rule and
its values are the material's own (E, G, rho: the numbers of the isotropic code before
laminates, bit for bit).  A layered section integrates ply by ply, with `points_per_ply`
Gauss points in each ply [choice: two integrate a linear elastic ply's contribution to A,
B and D exactly, and no point sits on an interface, where the stress jumps].
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .model import materials
from .quadrature import through_thickness_rule

AXIS_TOLERANCE_DEG = 1.0
"""A reference direction within this angle of an element's normal leaves the element's
material axis undefined (its projection flips with any small change): an error [choice]."""


@dataclass(frozen=True)
class Layup:
    """A section with its materials."""
    zeta: np.ndarray                     # (nk,) point positions in [-1, 1] (z = zeta t / 2, toward +e3)
    weight: np.ndarray                   # (nk,) weights, sum 2
    point_material: tuple[str, ...]      # (nk,) material of each point
    point_angle: np.ndarray              # (nk,) ply angle of each point, radians
    density: float                       # mass per volume over the thickness, sum rho_i t_i / t
    rotary_density: float                # 12 I / t^3, I = int rho z^2 dz (= rho for one material)
    wave_speed: float                    # the fastest of its materials' plane-stress waves
    membrane_modulus: float              # effective isotropic E of the membrane stiffness A
    bending_modulus: float               # ... of the bending stiffness D
    transverse_shear_modulus: float      # thickness mean of (G13 + G23)/2
    transverse_shear_max: float          # thickness mean of max(G13, G23)
    oriented: bool                       # a material needs axes (orthotropic)


def invariants(q: np.ndarray) -> tuple[float, float]:
    """Tsai-Pagano invariants U1 = (3 Q11 + 3 Q22 + 2 Q12 + 4 Q66)/8 and
    U4 = (Q11 + Q22 + 6 Q12 - 4 Q66)/8 of a plane-stress stiffness: the angle-independent
    part of Q_bar(theta), i.e. the stiffness of a quasi-isotropic stack of the material,
    whose E = (U1^2 - U4^2)/U1 (nu = U4/U1).  For an isotropic Q: E/(1 - nu^2), nu E/(1 - nu^2)."""
    return ((3.0 * q[0, 0] + 3.0 * q[1, 1] + 2.0 * q[0, 1] + 4.0 * q[2, 2]) / 8.0,
            (q[0, 0] + q[1, 1] + 6.0 * q[0, 1] - 4.0 * q[2, 2]) / 8.0)


def _quasi_isotropic_modulus(u1: float, u4: float) -> float:
    return (u1 * u1 - u4 * u4) / u1


def layup(section, specs: dict, material: str | None) -> Layup:
    """The Layup of `section` (scene.Section) with the scene materials `specs` by name;
    `material` is the part's (None for a layered section)."""
    if not section.layered:
        spec = specs[material]
        zeta, weight = through_thickness_rule(section.rule, section.points)
        g13, g23 = materials.transverse_shear_moduli(spec)
        if spec.model == "orthotropic":
            modulus = _quasi_isotropic_modulus(*invariants(materials.plane_stress_stiffness(spec)))
        else:
            modulus = spec.E
        return Layup(zeta=zeta, weight=weight, point_material=(material,) * len(zeta),
                     point_angle=np.zeros(len(zeta)), density=spec.density, rotary_density=spec.density,
                     wave_speed=materials.wave_speed(spec), membrane_modulus=modulus, bending_modulus=modulus,
                     transverse_shear_modulus=0.5 * (g13 + g23), transverse_shear_max=max(g13, g23),
                     oriented=materials.ORIENTED[spec.model])
    t = section.thickness
    plies = section.plies
    bounds = -0.5 * t + np.concatenate([[0.0], np.cumsum([p.thickness for p in plies])])
    bounds[-1] = 0.5 * t
    gauss, gauss_weight = through_thickness_rule("gauss", section.points_per_ply)
    zeta, weight, names, angle = [], [], [], []
    density = rotary = 0.0
    membrane, bending = np.zeros(2), np.zeros(2)
    shear_mean = shear_max = 0.0
    for ply, lo, hi in zip(plies, bounds[:-1], bounds[1:]):
        spec = specs[ply.material]
        centre, half = (lo + hi) / t, (hi - lo) / t                      # in zeta = 2 z / t
        zeta += list(centre + half * gauss)
        weight += list(half * gauss_weight)
        names += [ply.material] * len(gauss)
        angle += [math.radians(ply.angle)] * len(gauss)
        share, moment = (hi - lo) / t, 4.0 * (hi ** 3 - lo ** 3) / t ** 3   # sums to 1 over the plies
        density += spec.density * share
        rotary += spec.density * moment
        u = np.array(invariants(materials.plane_stress_stiffness(spec)))
        membrane += share * u
        bending += moment * u
        g13, g23 = materials.transverse_shear_moduli(spec)
        shear_mean += share * 0.5 * (g13 + g23)
        shear_max += share * max(g13, g23)
    return Layup(zeta=np.array(zeta), weight=np.array(weight), point_material=tuple(names),
                 point_angle=np.array(angle), density=density, rotary_density=rotary,
                 wave_speed=max(materials.wave_speed(specs[p.material]) for p in plies),
                 membrane_modulus=_quasi_isotropic_modulus(*membrane),
                 bending_modulus=_quasi_isotropic_modulus(*bending),
                 transverse_shear_modulus=shear_mean, transverse_shear_max=shear_max,
                 oriented=any(materials.ORIENTED[specs[p.material].model] for p in plies))


def material_axis(e1: np.ndarray, e2: np.ndarray, direction) -> tuple[np.ndarray, np.ndarray]:
    """(cos, sin) of the angle from each element's e1 (edge 1-2; e1, e2: (m, 3), the BT frame
    in the reference configuration) to the projection of `direction` onto its plane,
    counter-clockwise about e3; and the mask of the elements whose normal is within
    AXIS_TOLERANCE_DEG of `direction` (undefined there).  The BT frame turns with the element,
    so the angle is fixed once here."""
    d = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    x, y = e1 @ d, e2 @ d
    length = np.hypot(x, y)
    undefined = length < math.sin(math.radians(AXIS_TOLERANCE_DEG))
    safe = np.where(undefined, 1.0, length)
    return np.column_stack([np.where(undefined, 1.0, x / safe), np.where(undefined, 0.0, y / safe)]), undefined
