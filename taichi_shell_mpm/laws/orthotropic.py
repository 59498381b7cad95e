"""Linear elastic orthotropic plies: ``[material].model = "orthotropic"`` (a fibre composite
ply in plane stress with its own transverse shear moduli, docs/laminates.md).  It has a table
of its own (OrthotropicMaterial: E1, E2, G12, G13, G23, nu12 instead of E, nu); its axes are
the section's material axes turned by the ply angle."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from ..keys import choice, key, number, positive

NAME = "orthotropic"
DOC = "`orthotropic`: the keys of the orthotropic table below instead of `E`, `nu`"
KEYS: dict = {}
PLASTIC = False
ORIENTED = True
BLOCK: tuple[str, ...] = ()


@dataclass(frozen=True)
class OrthotropicMaterial:
    """Linear elastic, orthotropic in plane stress with its own transverse shear moduli
    (docs/laminates.md): 1 = the fibre direction, 2 = across it in the shell's plane,
    3 = the shell normal.  Its axes are the section's material axes turned by the ply angle."""
    E1: float = key(positive, "Young's modulus along the fibres (axis 1)", unit="stress")
    E2: float = key(positive, "Young's modulus across the fibres in the shell plane (axis 2)", unit="stress")
    G12: float = key(positive, "in-plane shear modulus", unit="stress")
    G13: float = key(positive, "transverse shear modulus in the 1-3 plane (3 = the shell normal)", unit="stress")
    G23: float = key(positive, "transverse shear modulus in the 2-3 plane", unit="stress")
    nu12: float = key(number(), allowed="|nu12| < √(E1/E2)",
                      doc="major Poisson ratio: ε₂ = −ν₁₂ σ₁/E₁ (ν₂₁ = ν₁₂E₂/E₁); the bound keeps the plane-stress "
                          "stiffness positive definite")
    density: float = key(positive, "mass density", unit="mass/length³")
    model: Literal["orthotropic"] = key(choice(NAME), "`orthotropic`: this table's keys", default="orthotropic")


TABLE = OrthotropicMaterial
"""The scene table it reads instead of [material]'s keys (scene/material.py)."""


def check(r, path: str, material: OrthotropicMaterial) -> OrthotropicMaterial | None:
    """The bound on nu12 (a positive definite plane-stress stiffness), or None after reporting it."""
    if material.nu12 ** 2 >= material.E1 / material.E2:
        r.error(f"{path}.nu12", f"expected |nu12| < sqrt(E1/E2) = {math.sqrt(material.E1 / material.E2):g} "
                                f"(a positive definite plane-stress stiffness), got {material.nu12:g}")
        return None
    return material


def stiffness(spec) -> np.ndarray:
    """Q in its own axes: Q11 = E1/(1 - nu12 nu21), Q22 = E2/(1 - nu12 nu21), Q12 = nu12 Q22,
    Q66 = G12, nu21 = nu12 E2/E1."""
    d = 1.0 - spec.nu12 * spec.nu12 * spec.E2 / spec.E1
    q11, q22 = spec.E1 / d, spec.E2 / d
    return np.array([[q11, spec.nu12 * q22, 0.0], [spec.nu12 * q22, q22, 0.0], [0.0, 0.0, spec.G12]])


def values(spec, context) -> dict[str, float]:
    """Its columns of the material row: E = E1, nu = nu12, density, Q11, Q22, Q12, Q66 and G13, G23."""
    q = stiffness(spec)
    return {"E": spec.E1, "nu": spec.nu12, "density": spec.density, "c11": q[0, 0], "c22": q[1, 1],
            "c12": q[0, 1], "c33": q[2, 2], "shear_13": spec.G13, "shear_23": spec.G23}


def transverse_shear(spec) -> tuple[float, float]:
    return spec.G13, spec.G23


def wave_speed(spec) -> float:
    """The fastest in-plane wave, sqrt(max over directions n of the largest eigenvalue of the
    acoustic tensor Q_ijkl n_j n_l / rho), sampled every 0.05 degrees (Q11 / rho along the
    fibres for the usual fibre composites)."""
    q = stiffness(spec)
    phi = np.linspace(0.0, np.pi, 3601)
    c, s = np.cos(phi), np.sin(phi)
    g11 = q[0, 0] * c * c + q[2, 2] * s * s
    g22 = q[2, 2] * c * c + q[1, 1] * s * s
    g12 = (q[0, 1] + q[2, 2]) * c * s
    largest = 0.5 * (g11 + g22) + np.sqrt(0.25 * (g11 - g22) ** 2 + g12 * g12)
    return math.sqrt(float(largest.max()) / spec.density)


def dilatational_speed(spec) -> float:
    """[choice] 1.2 x its in-plane wave speed (the paper's grid rule, eq 38-40): the isotropic
    ratio (1 - nu)/sqrt(1 - 2 nu) = 1.18 at nu = 0.3 rounded up.  The scene gives no E3, nu23;
    with E3 = E2, nu13 = nu12, nu23 = 0.45 the 3-D P-wave modulus of the CFRP of
    docs/laminates.md along its fibres is 1.018 Q11, so the factor is conservative there."""
    return 1.2 * wave_speed(spec)


def kernel(context):
    """The point update (built on first use)."""
    import taichi as ti
    COL = context.col

    @ti.data_oriented
    class PlaneStressOrthotropic:
        """Linear elastic orthotropic ply in plane stress with elastic transverse shear
        (docs/laminates.md).  The strain increment is turned into the material axes (1 at the
        angle theta from e1, counter-clockwise about e3; c = cos, s = sin), met by the ply's own
        stiffness, and the stress increment turned back:
        de11 = c^2 dexx + s^2 deyy + c s dgxy, de22 = s^2 dexx + c^2 deyy - c s dgxy,
        dg12 = 2 c s (deyy - dexx) + (c^2 - s^2) dgxy; ds = Q de (Q11, Q22, Q12, Q66 = G12);
        dsxx = c^2 ds11 + s^2 ds22 - 2 c s dt12, dsyy = s^2 ds11 + c^2 ds22 + 2 c s dt12,
        dsxy = c s (ds11 - ds22) + (c^2 - s^2) dt12: the increment of Q_bar = T^-1 Q T^-T.
        Transverse shear: dg13 = c dgxz + s dgyz, dg23 = -s dgxz + c dgyz, dt13 = G13 dg13,
        dt23 = G23 dg23, dtxz = c dt13 - s dt23, dtyz = s dt13 + c dt23."""

        kind = "orthotropic"
        plastic = False

        def __init__(self, state=None):
            pass

        @ti.func
        def update(self, row, axes, stress, plastic_strain, strain_rate, d_strain, d_shear, dt):
            """As PlaneStressElastic.update, in the material axes `axes` = (cos, sin)."""
            c, s = axes[0], axes[1]
            cc, ss, cs = c * c, s * s, c * s
            e11 = cc * d_strain[0] + ss * d_strain[1] + cs * d_strain[2]
            e22 = ss * d_strain[0] + cc * d_strain[1] - cs * d_strain[2]
            g12 = 2.0 * cs * (d_strain[1] - d_strain[0]) + (cc - ss) * d_strain[2]
            s11 = row[COL["c11"]] * e11 + row[COL["c12"]] * e22
            s22 = row[COL["c12"]] * e11 + row[COL["c22"]] * e22
            t12 = row[COL["c33"]] * g12
            t13 = row[COL["shear_13"]] * (c * d_shear[0] + s * d_shear[1])
            t23 = row[COL["shear_23"]] * (c * d_shear[1] - s * d_shear[0])
            return stress + ti.Vector([
                cc * s11 + ss * s22 - 2.0 * cs * t12,
                ss * s11 + cc * s22 + 2.0 * cs * t12,
                cs * (s11 - s22) + (cc - ss) * t12,
                c * t13 - s * t23,
                s * t13 + c * t23]), plastic_strain, strain_rate, 0.0, True

    return PlaneStressOrthotropic
