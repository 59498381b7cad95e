"""Linear elastic, isotropic: ``[material].model = "elastic"`` (the default).  Plane stress in
the element's corotational frame, elastic transverse shear (the shear factor is applied on the
resultants, method.md 3.4-3.5).  Its keys are every material's (E, nu, density:
scene/material.MaterialKeys)."""
from __future__ import annotations

import math

import numpy as np

NAME = "elastic"
DOC = "`elastic`: linear, in the element's corotational frame"
KEYS: dict = {}
TABLE = None
PLASTIC = False
ORIENTED = False
BLOCK: tuple[str, ...] = ()


def shear_modulus(spec) -> float:
    return spec.E / (2.0 * (1.0 + spec.nu))


def values(spec, context) -> dict[str, float]:
    """Its columns of the material row: E, nu, density and the plane-stress stiffness
    c11 = E / (1 - nu^2), c12 = nu c11, c33 = G."""
    E, nu = spec.E, spec.nu
    c11 = E / (1.0 - nu * nu)
    return {"E": E, "nu": nu, "density": spec.density, "c11": c11, "c12": nu * c11, "c33": shear_modulus(spec)}


def stiffness(spec) -> np.ndarray:
    """Q = E/(1 - nu^2) [[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu)/2]] (Voigt, engineering shear)."""
    c11 = spec.E / (1.0 - spec.nu ** 2)
    return np.array([[c11, spec.nu * c11, 0.0], [spec.nu * c11, c11, 0.0], [0.0, 0.0, shear_modulus(spec)]])


def transverse_shear(spec) -> tuple[float, float]:
    """(G13, G23) = (G, G)."""
    G = shear_modulus(spec)
    return G, G


def wave_speed(spec) -> float:
    """Plane-stress wave speed sqrt(E / (rho (1 - nu^2))) (the BT element rule, method.md 5)."""
    return math.sqrt(spec.E / (spec.density * (1.0 - spec.nu ** 2)))


def dilatational_speed(spec) -> float:
    """sqrt((K + 4G/3) / rho) of the paper's grid rule (eq 38-40)."""
    G = shear_modulus(spec)
    K = spec.E / (3.0 * (1.0 - 2.0 * spec.nu))
    return math.sqrt((K + 4.0 * G / 3.0) / spec.density)


def kernel(context):
    """The point update (built on first use: reading a scene does not import Taichi)."""
    import taichi as ti
    COL = context.col

    @ti.data_oriented
    class PlaneStressElastic:
        """Linear elastic, plane stress in plane, elastic transverse shear (tau += G dgamma;
        the shear factor is applied on the resultants, method.md 3.4-3.5)."""

        kind = "elastic"
        plastic = False

        def __init__(self, state=None):
            pass

        @ti.func
        def elastic(self, row, stress, d_strain, d_shear):
            c11, c12, c33 = row[COL["c11"]], row[COL["c12"]], row[COL["c33"]]
            return stress + ti.Vector([
                c11 * d_strain[0] + c12 * d_strain[1],
                c12 * d_strain[0] + c11 * d_strain[1],
                c33 * d_strain[2],
                c33 * d_shear[0],
                c33 * d_shear[1]])

        @ti.func
        def update(self, row, axes, stress, plastic_strain, strain_rate, d_strain, d_shear, dt):
            """stress = (sxx, syy, sxy, txz, tyz); d_strain = (dexx, deyy, dgxy); d_shear = (dgxz, dgyz).
            Returns (new stress, new equivalent plastic strain, new filtered strain rate, plastic
            work per unit volume, whether the update converged).  Isotropic: `axes` is not read."""
            return self.elastic(row, stress, d_strain, d_shear), plastic_strain, strain_rate, 0.0, True

    return PlaneStressElastic
