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

from types import SimpleNamespace

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
KINDS = tuple(laws.MODELS)              # every model the solver has (laws/; stages/material.MODELS)
PLASTIC = {k: m.PLASTIC for k, m in laws.MODELS.items()}
ORIENTED = {k: m.ORIENTED for k, m in laws.MODELS.items()}    # needs material axes (docs/laminates.md)
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
    """The time constant tau of the material's rate filter (0: unfiltered; laws/j2.py)."""
    return laws.j2.rate_filter_time(spec)


def parameter_row(spec, width: int, hardening: tuple[str, ...] | None = None, rates: tuple[str, ...] | None = None,
                  curve_start: int = 0) -> np.ndarray:
    """The material table row of a scene material (scene.Material, scene.OrthotropicMaterial):
    its model's columns and block (laws/<model>.py).  `hardening` and `rates` are the laws
    the scene compiles (Features.hardening, Features.rate_laws; default: this material's
    own); `curve_start`: the first point of its tabulated curve in the curve table."""
    row = np.zeros(width)
    model = laws.MODELS[spec.model]
    if model.PLASTIC:
        hardening = hardening_laws([spec]) if hardening is None else hardening
        rates = rate_laws([spec]) if rates is None else rates
    context = SimpleNamespace(hardening=hardening, rates=rates, curve_start=curve_start)
    for name, value in model.values(spec, context).items():
        row[COL[name]] = value
    if model.BLOCK:
        block = model.block(spec)
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
    """Q (3x3, Voigt xx, yy, xy with engineering shear) in the material's own axes (its model's)."""
    return laws.MODELS[spec.model].stiffness(spec)


def transverse_shear_moduli(spec) -> tuple[float, float]:
    """(G13, G23): the transverse shear moduli in the material's axes (isotropic: G, G)."""
    return laws.MODELS[spec.model].transverse_shear(spec)


def wave_speed(spec) -> float:
    """The fastest plane-stress wave (the BT element rule, method.md 5; its model's)."""
    return laws.MODELS[spec.model].wave_speed(spec)


def dilatational_speed(spec) -> float:
    """The wave speed of the paper's grid rule (eq 38-40; its model's)."""
    return laws.MODELS[spec.model].dilatational_speed(spec)
