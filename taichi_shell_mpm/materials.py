"""Material models at the model level: each scene material becomes one row of the material
table (state.sections.material) that the constitutive updates of stages/material.py read,
plus the wave speeds the time step needs.  Pure numpy; the kinds' Taichi code is in
:mod:`taichi_shell_mpm.stages.material`.

Columns of a row (COLUMNS, the same for every kind; unused ones stay 0):
E, nu, density, shear modulus G, the plane-stress stiffness c11 = E / (1 - nu^2),
c12 = nu c11, c33 = G, the eigenvalues of the plane-stress return, lambda1 = E / (3 (1 - nu)),
lambda2 = 2 G, lambda_min; then the J2 flow stress sigma_y(ebar) R(rate) (issue 18):

- the hardening law sigma_y(ebar) (``hardening_law``: its index into Features.hardening) and
  its parameters: yield stress (linear, Ludwik's A, Voce) and linear modulus H (the linear
  law; the linear term of Swift, Ludwik and Voce),
  Swift's K, eps0 and Swift's and Ludwik's exponent n, Ludwik's B and cap max_stress (0: none),
  Voce's Q and b, the tabulated curve's first point and point count in the curve table
  (state.sections.curve_strain / curve_stress) and whether it is extrapolated beyond its
  last point (1) or flat (0);
- the rate law R (``rate_law``: its index into Features.rate_laws, -1: none) and its
  parameters: Cowper-Symonds C and p, Johnson-Cook c and the reference rate, the rate
  measure (``rate_plastic`` 1: the equivalent plastic strain rate, 0: the effective total
  strain rate) and the filter's time constant (0: unfiltered).
"""
from __future__ import annotations

import math

import numpy as np

COLUMNS = ("E", "nu", "density", "shear_modulus", "c11", "c12", "c33", "yield_stress", "hardening",
           "lambda1", "lambda2", "lambda_min",
           "hardening_law", "K", "eps0", "n", "B", "max_stress", "Q", "b", "curve_start", "curve_points",
           "curve_extrapolate",
           "rate_law", "cowper_symonds_C", "cowper_symonds_p", "johnson_cook_c", "reference_rate", "rate_plastic",
           "rate_filter_time")
COL = {name: i for i, name in enumerate(COLUMNS)}
MATERIAL_PARAMETERS = 32             # width of a row (state.sections.material)
KINDS = ("elastic", "j2")            # every kind the solver has (stages/material.MODELS in this order)
PLASTIC = {"elastic": False, "j2": True}
HARDENING_LAWS = ("linear", "swift", "ludwik", "voce", "tabulated")   # stages/material.HARDENING in this order
RATE_LAWS = ("cowper_symonds", "johnson_cook")                        # stages/material.RATE in this order


def hardening_laws(specs) -> tuple[str, ...]:
    """The hardening laws of the J2 materials among `specs` (HARDENING_LAWS order): Features.hardening."""
    used = {s.hardening_law for s in specs if s.model == "j2"}
    return tuple(law for law in HARDENING_LAWS if law in used)


def rate_laws(specs) -> tuple[str, ...]:
    """The rate laws of the J2 materials among `specs` (RATE_LAWS order): Features.rate_laws."""
    used = {s.rate_law for s in specs if s.model == "j2"}
    return tuple(law for law in RATE_LAWS if law in used)


def rate_filter_time(spec) -> float:
    """The time constant tau of the material's rate filter (0: unfiltered): rate_filter_time,
    or 1 / (2 pi f_c) of rate_cutoff_frequency."""
    if spec.rate_cutoff_frequency > 0.0:
        return 1.0 / (2.0 * math.pi * spec.rate_cutoff_frequency)
    return spec.rate_filter_time


def parameter_row(spec, width: int, hardening: tuple[str, ...] | None = None, rates: tuple[str, ...] | None = None,
                  curve_start: int = 0) -> np.ndarray:
    """The material table row of a scene material (scene.Material).  `hardening` and `rates`
    are the laws the scene compiles (Features.hardening, Features.rate_laws; default: this
    material's own); `curve_start`: the first point of its tabulated curve in the curve table."""
    row = np.zeros(width)
    E, nu = spec.E, spec.nu
    G = E / (2.0 * (1.0 + nu))
    c11 = E / (1.0 - nu * nu)
    values = {"E": E, "nu": nu, "density": spec.density, "shear_modulus": G, "c11": c11, "c12": nu * c11,
              "c33": G}
    if spec.model == "j2":
        hardening = hardening_laws([spec]) if hardening is None else hardening
        rates = rate_laws([spec]) if rates is None else rates
        lam1, lam2 = E / (3.0 * (1.0 - nu)), 2.0 * G
        values.update(yield_stress=spec.yield_stress, hardening=spec.hardening, lambda1=lam1, lambda2=lam2,
                      lambda_min=min(lam1, lam2), hardening_law=hardening.index(spec.hardening_law),
                      K=spec.K, eps0=spec.eps0, n=spec.n, B=spec.B, max_stress=spec.max_stress or 0.0, Q=spec.Q,
                      b=spec.b, rate_law=rates.index(spec.rate_law) if spec.rate_law in rates else -1,
                      cowper_symonds_C=spec.C, cowper_symonds_p=spec.p, johnson_cook_c=spec.c,
                      reference_rate=spec.reference_rate, rate_plastic=float(spec.rate_measure == "plastic"),
                      rate_filter_time=rate_filter_time(spec))
        if spec.hardening_law == "tabulated":
            values.update(curve_start=curve_start, curve_points=len(spec.curve),
                          curve_extrapolate=float(spec.beyond_curve == "extrapolate"))
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
