"""Material models at the model level: each scene material becomes one row of the material
table (state.sections.material) that the constitutive updates of stages/material.py read,
plus the wave speeds the time step needs.  Pure numpy; the kinds' Taichi code is in
:mod:`taichi_shell_mpm.stages.material`.

Columns of a row (COLUMNS, the same for every kind; unused ones stay 0):
E, nu, density, shear modulus G, the plane-stress stiffness c11 = E / (1 - nu^2),
c12 = nu c11, c33 = G, yield stress, hardening modulus, and the eigenvalues of the
plane-stress return, lambda1 = E / (3 (1 - nu)), lambda2 = 2 G, lambda_min.
"""
from __future__ import annotations

import math

import numpy as np

COLUMNS = ("E", "nu", "density", "shear_modulus", "c11", "c12", "c33", "yield_stress", "hardening",
           "lambda1", "lambda2", "lambda_min")
COL = {name: i for i, name in enumerate(COLUMNS)}
MATERIAL_PARAMETERS = 16             # width of a row (state.sections.material)
KINDS = ("elastic", "j2")            # every kind the solver has (stages/material.MODELS in this order)
PLASTIC = {"elastic": False, "j2": True}


def parameter_row(spec, width: int) -> np.ndarray:
    """The material table row of a scene material (scene.Material)."""
    row = np.zeros(width)
    E, nu = spec.E, spec.nu
    G = E / (2.0 * (1.0 + nu))
    c11 = E / (1.0 - nu * nu)
    values = {"E": E, "nu": nu, "density": spec.density, "shear_modulus": G, "c11": c11, "c12": nu * c11,
              "c33": G}
    if spec.model == "j2":
        lam1, lam2 = E / (3.0 * (1.0 - nu)), 2.0 * G
        values.update(yield_stress=spec.yield_stress, hardening=spec.hardening, lambda1=lam1, lambda2=lam2,
                      lambda_min=min(lam1, lam2))
    for name, value in values.items():
        row[COL[name]] = value
    return row


def shear_modulus(spec) -> float:
    return spec.E / (2.0 * (1.0 + spec.nu))


def wave_speed(spec) -> float:
    """Plane-stress wave speed sqrt(E / (rho (1 - nu^2))) (the BT element rule, method.md 5)."""
    return math.sqrt(spec.E / (spec.density * (1.0 - spec.nu ** 2)))


def dilatational_speed(spec) -> float:
    """sqrt((K + 4G/3) / rho) of the paper's grid rule (eq 38-40)."""
    G = shear_modulus(spec)
    K = spec.E / (3.0 * (1.0 - 2.0 * spec.nu))
    return math.sqrt((K + 4.0 * G / 3.0) / spec.density)
