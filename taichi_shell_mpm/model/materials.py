"""Material models at the model level: each scene material becomes one row of the material
table (state.sections.material) that the constitutive updates of stages/material.py read,
plus the stiffnesses and wave speeds the section, the time step and the hourglass control
need.  Pure numpy; the kinds' Taichi code is in :mod:`taichi_shell_mpm.stages.material`.

Columns of a row (COLUMNS, the same for every kind; unused ones stay 0; 32, as the kernels
unroll the row; a plug-in model of laws/ (Hill 1948) adds its own block after them, and the
table is as wide as the widest block among the models a scene uses: row_width):
E, nu, density, the plane-stress stiffness c11 = E / (1 - nu^2), c12 = nu c11 and c33 = G
(the shear modulus), the eigenvalues of the plane-stress return, lambda1 = E / (3 (1 - nu)),
lambda2 = 2 G, lambda_min; then the J2 flow stress sigma_y(ebar) R(rate) (issue 18):

- the hardening law sigma_y(ebar) (``hardening_law``: its index into Features.hardening), the
  yield stress and linear modulus H every law reads, and its own parameters in the 10 columns
  ``hardening_0``.. (its file in laws/hardening/ names them: BLOCK; the tabulated law: its
  curve's first point and point count in the curve table state.sections.curve_strain /
  curve_stress, extrapolated (1) or flat);
- the rate law R (``rate_law``: its index into Features.rate_laws, -1: none), its parameters
  in the 4 columns ``rate_0``.. (laws/rate/), the rate measure (``rate_plastic`` 1: the
  equivalent plastic strain rate, 0: the effective total strain rate) and the filter's time
  constant (0: unfiltered).

An orthotropic material (docs/laminates.md) fills E = E1, nu = nu12, density, its
plane-stress stiffness in its own axes c11 = Q11, c22 = Q22, c12 = Q12, c33 = Q66 = G12, and
the transverse shear moduli shear_13 = G13, shear_23 = G23.

Erosion (issue 18) has a small table of its own (:func:`failure_row`, state.sections.failure,
read only when a scene erodes): the failure criteria's columns (laws/failure/: the failure
strain (0: none), the number of through-thickness points that must reach it, and the
element's failure step (0: none)).
"""
from __future__ import annotations

import math

import numpy as np

from .. import laws
from ..laws.failure import COLUMNS as FAILURE_TABLE
from ..laws.failure import CRITERIA as FAILURE
from ..laws.hardening import BLOCK_WIDTH as HARDENING_BLOCK
from ..laws.hardening import LAWS as HARDENING
from ..laws.rate import BLOCK_WIDTH as RATE_BLOCK
from ..laws.rate import LAWS as RATE

COLUMNS = ("E", "nu", "density", "c11", "c12", "c33", "yield_stress", "hardening",
           "lambda1", "lambda2", "lambda_min",
           "hardening_law", *(f"hardening_{i}" for i in range(HARDENING_BLOCK)),
           "rate_law", *(f"rate_{i}" for i in range(RATE_BLOCK)), "rate_plastic",
           "rate_filter_time", "c22", "shear_13", "shear_23")
COL = {name: i for i, name in enumerate(COLUMNS)}
MATERIAL_PARAMETERS = 32             # width of a row (state.sections.material; the kernels unroll it)
KINDS = ("elastic", "j2", "orthotropic", *laws.MODELS)   # every kind the solver has (stages/material.MODELS)
PLASTIC = {"elastic": False, "j2": True, "orthotropic": False, **{k: True for k in laws.MODELS}}
ORIENTED = {"elastic": False, "j2": False, "orthotropic": True,  # needs material axes (docs/laminates.md)
            **{k: True for k in laws.MODELS}}
BLOCK_OFFSET = MATERIAL_PARAMETERS
"""A plug-in model's parameter block (laws/) starts here in the row."""


def row_width(kinds) -> int:
    """Columns of the material table of a scene whose models are `kinds`: the common row and
    the widest block of its plug-in models (32 without one)."""
    return MATERIAL_PARAMETERS + laws.block_width(kinds)
HARDENING_LAWS = tuple(HARDENING)       # laws/hardening/ (stages/material.HARDENING in this order)
RATE_LAWS = tuple(RATE)                 # laws/rate/


def law_column(law: str, parameter: str) -> int:
    """The row column of a hardening or rate law's parameter (its block, laws/)."""
    if law in HARDENING:
        return COL["hardening_0"] + HARDENING[law].BLOCK.index(parameter)
    return COL["rate_0"] + RATE[law].BLOCK.index(parameter)


def hardening_laws(specs) -> tuple[str, ...]:
    """The hardening laws of the plastic materials among `specs` (HARDENING_LAWS order): Features.hardening."""
    used = {s.hardening_law for s in specs if PLASTIC[s.model]}
    return tuple(law for law in HARDENING_LAWS if law in used)


def rate_laws(specs) -> tuple[str, ...]:
    """The rate laws of the plastic materials among `specs` (RATE_LAWS order): Features.rate_laws."""
    used = {s.rate_law for s in specs if PLASTIC[s.model]}
    return tuple(law for law in RATE_LAWS if law in used)


def rate_filter_time(spec) -> float:
    """The time constant tau of the material's rate filter (0: unfiltered): rate_filter_time,
    or 1 / (2 pi f_c) of rate_cutoff_frequency."""
    if spec.rate_cutoff_frequency > 0.0:
        return 1.0 / (2.0 * math.pi * spec.rate_cutoff_frequency)
    return spec.rate_filter_time


def parameter_row(spec, width: int, hardening: tuple[str, ...] | None = None, rates: tuple[str, ...] | None = None,
                  curve_start: int = 0) -> np.ndarray:
    """The material table row of a scene material (scene.Material, scene.OrthotropicMaterial).
    `hardening` and `rates` are the J2 laws the scene compiles (Features.hardening,
    Features.rate_laws; default: this material's own); `curve_start`: the first point of its
    tabulated curve in the curve table."""
    row = np.zeros(width)
    if spec.model == "orthotropic":
        q = plane_stress_stiffness(spec)
        values = {"E": spec.E1, "nu": spec.nu12, "density": spec.density, "c11": q[0, 0], "c22": q[1, 1],
                  "c12": q[0, 1], "c33": q[2, 2], "shear_13": spec.G13, "shear_23": spec.G23}
    else:
        E, nu = spec.E, spec.nu
        G = E / (2.0 * (1.0 + nu))
        c11 = E / (1.0 - nu * nu)
        values = {"E": E, "nu": nu, "density": spec.density, "c11": c11, "c12": nu * c11, "c33": G}
        if PLASTIC[spec.model]:
            hardening = hardening_laws([spec]) if hardening is None else hardening
            rates = rate_laws([spec]) if rates is None else rates
            lam1, lam2 = E / (3.0 * (1.0 - nu)), 2.0 * G
            values.update(yield_stress=spec.yield_stress, hardening=spec.hardening, lambda1=lam1, lambda2=lam2,
                          lambda_min=min(lam1, lam2), hardening_law=hardening.index(spec.hardening_law),
                          rate_law=rates.index(spec.rate_law) if spec.rate_law in rates else -1,
                          rate_plastic=float(spec.rate_measure == "plastic"), rate_filter_time=rate_filter_time(spec))
            values.update({f"hardening_{i}": x for i, x in
                           enumerate(HARDENING[spec.hardening_law].block(spec, curve_start))})
            if spec.rate_law in RATE:
                values.update({f"rate_{i}": x for i, x in enumerate(RATE[spec.rate_law].block(spec))})
    for name, value in values.items():
        row[COL[name]] = value
    if spec.model in laws.MODELS:
        block = laws.MODELS[spec.model].block(spec.E, spec.nu, spec.parameters)
        row[BLOCK_OFFSET:BLOCK_OFFSET + len(block)] = block
    return row


def erodes(spec) -> bool:
    """Whether elements of the material can fail (Features.erosion)."""
    return any(criterion.active(spec) for criterion in FAILURE.values())


FAILURE_COLUMNS = FAILURE_TABLE         # laws/failure/: every criterion's columns


def failure_row(spec) -> np.ndarray:
    """The material's row of the erosion table (FAILURE_COLUMNS; zeros: it never fails)."""
    return np.array([float(getattr(spec, name, 0.0)) for name in FAILURE_COLUMNS])


def plane_stress_stiffness(spec) -> np.ndarray:
    """Q (3x3, Voigt xx, yy, xy with engineering shear) in the material's own axes: isotropic
    E/(1 - nu^2) [[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu)/2]]; orthotropic
    Q11 = E1/(1 - nu12 nu21), Q22 = E2/(1 - nu12 nu21), Q12 = nu12 Q22, Q66 = G12, nu21 = nu12 E2/E1."""
    if spec.model == "orthotropic":
        d = 1.0 - spec.nu12 * spec.nu12 * spec.E2 / spec.E1
        q11, q22 = spec.E1 / d, spec.E2 / d
        return np.array([[q11, spec.nu12 * q22, 0.0], [spec.nu12 * q22, q22, 0.0], [0.0, 0.0, spec.G12]])
    c11 = spec.E / (1.0 - spec.nu ** 2)
    return np.array([[c11, spec.nu * c11, 0.0], [spec.nu * c11, c11, 0.0], [0.0, 0.0, shear_modulus(spec)]])


def transverse_shear_moduli(spec) -> tuple[float, float]:
    """(G13, G23): the transverse shear moduli in the material's axes (isotropic: G, G)."""
    if spec.model == "orthotropic":
        return spec.G13, spec.G23
    G = shear_modulus(spec)
    return G, G


def shear_modulus(spec) -> float:
    return spec.E / (2.0 * (1.0 + spec.nu))


def wave_speed(spec) -> float:
    """Plane-stress wave speed sqrt(E / (rho (1 - nu^2))) (the BT element rule, method.md 5).
    Orthotropic: the fastest in-plane wave, sqrt(max over directions n of the largest
    eigenvalue of the acoustic tensor Q_ijkl n_j n_l / rho), sampled every 0.05 degrees
    (Q11 / rho along the fibres for the usual fibre composites)."""
    if spec.model != "orthotropic":
        return math.sqrt(spec.E / (spec.density * (1.0 - spec.nu ** 2)))
    q = plane_stress_stiffness(spec)
    phi = np.linspace(0.0, np.pi, 3601)
    c, s = np.cos(phi), np.sin(phi)
    g11 = q[0, 0] * c * c + q[2, 2] * s * s
    g22 = q[2, 2] * c * c + q[1, 1] * s * s
    g12 = (q[0, 1] + q[2, 2]) * c * s
    largest = 0.5 * (g11 + g22) + np.sqrt(0.25 * (g11 - g22) ** 2 + g12 * g12)
    return math.sqrt(float(largest.max()) / spec.density)


def dilatational_speed(spec) -> float:
    """sqrt((K + 4G/3) / rho) of the paper's grid rule (eq 38-40).  Orthotropic [choice]:
    1.2 x its in-plane wave speed, the isotropic ratio (1 - nu)/sqrt(1 - 2 nu) = 1.18 at
    nu = 0.3 rounded up.  The scene gives no E3, nu23; with E3 = E2, nu13 = nu12, nu23 = 0.45
    the 3-D P-wave modulus of the CFRP of docs/laminates.md along its fibres is 1.018 Q11,
    so the factor is conservative there."""
    if spec.model == "orthotropic":
        return 1.2 * wave_speed(spec)
    G = shear_modulus(spec)
    K = spec.E / (3.0 * (1.0 - 2.0 * spec.nu))
    return math.sqrt((K + 4.0 * G / 3.0) / spec.density)
