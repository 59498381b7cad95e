"""Hill (1948) anisotropic plasticity in plane stress: ``[material].model = "hill48"``.

Yield function in the material axes (1 = the rolling direction, the section's material axis
turned by the ply angle; 2 across it in the sheet; 3 the normal), normalised to the yield
stress sigma_y along the rolling direction (G + H = 1; Hill 1948, Proc. R. Soc. A 193;
LS-DYNA *MAT_036 with M = 2 and *MAT_037):

    sigma_bar^2 = G s11^2 + F s22^2 + H (s11 - s22)^2 + 2 N s12^2 = s.A.s,
    A = [[G + H, -H, 0], [-H, F + H, 0], [0, 0, 2 N]],

with the Lankford coefficients r0, r45, r90 (width over thickness plastic strain rate in
uniaxial tension at 0, 45, 90 degrees to the rolling direction):

    G = 1/(1 + r0), H = r0/(1 + r0), F = r0/(r90 (1 + r0)), N = (r0 + r90)(1 + 2 r45)/(2 r90 (1 + r0)),

so that r(theta) = [H + (2N - F - G - 4H) sin^2 cos^2] / [F sin^2 + G cos^2] (r0 = r45 = r90 = 1:
von Mises).  The flow is associated, d eps_p = dlambda P s with P = 2/3 A (Voigt, engineering
shear: the J2 model's P = [[2, -1, 0], [-1, 2, 0], [0, 0, 6]]/3 at r = 1), and the equivalent
plastic strain is work-conjugate to sigma_bar: d ebar = dlambda (2/3) sigma_bar.  The flow
stress is that of any hardening and rate law (the J2 model's; failure as J2's).

Return map (backward Euler, as method.md 3.4 for J2): s = (I + dlambda C P)^-1 s_trial.  C
(isotropic elasticity) and P do not commute, but C P is similar to the symmetric
S = C^(1/2) P C^(1/2) = Q diag(lambda_i) Q^T, so with z = Q^T C^(-1/2) s_trial
(the block's T s_trial) s(dlambda) = C^(1/2) Q diag(1/(1 + lambda_i dlambda)) z (the block's
B), and xi = s.P.s = sum lambda_i z_i^2 / (1 + lambda_i dlambda)^2: J2's scalar consistency
equation with three eigenvalues instead of two (J2: lambda = E/(3(1 - nu)), 2G, 2G).  T, B and
the lambda_i are per material, computed here once (numpy).
"""
from __future__ import annotations

import numpy as np

from . import elastic, j2
from ..keys import Key, keys, positive

NAME = "hill48"
DOC = ("`hill48`: Hill (1948) anisotropic plasticity in plane stress, the rolling direction along the "
       "section's material axis (`reference_direction`, turned by a ply's angle), with `r0`, `r45`, `r90` "
       "and any hardening and rate law of `j2` (LS-DYNA *MAT_036 with M = 2, *MAT_037); "
       "`yield_stress` (or the hardening curve) is the yield stress along the rolling direction")
KEYS = keys(
    Key("r0", positive, "Lankford coefficient (plastic width / thickness strain ratio in uniaxial tension) along "
                        "the rolling direction", default=1.0, example=2.1),
    Key("r45", positive, "Lankford coefficient at 45° to the rolling direction", default=1.0, example=1.6),
    Key("r90", positive, "Lankford coefficient across the rolling direction", default=1.0, example=2.7))
"""`hill48`'s keys in [material] (r0 = r45 = r90 = 1: von Mises)."""
TABLE = None
PLASTIC = True
ORIENTED = True                   # the rolling direction: the section's material axes
stiffness, transverse_shear = elastic.stiffness, elastic.transverse_shear          # its elastic part
wave_speed, dilatational_speed = elastic.wave_speed, elastic.dilatational_speed
values = j2.values                # the J2 return's columns; its block below
BLOCK = (*(f"T{i}{j}" for i in range(3) for j in range(3)), *(f"B{i}{j}" for i in range(3) for j in range(3)),
         "lambda0", "lambda1", "lambda2", "lambda_min")
"""Its parameter block: T = Q^T C^(-1/2), B = C^(1/2) Q (row by row), the eigenvalues of
C^(1/2) P C^(1/2) and the smallest of them."""


def coefficients(r0: float, r45: float, r90: float) -> tuple[float, float, float, float]:
    """Hill's F, G, H, N of the Lankford coefficients (G + H = 1)."""
    G, H = 1.0 / (1.0 + r0), r0 / (1.0 + r0)
    F = r0 / (r90 * (1.0 + r0))
    N = (r0 + r90) * (1.0 + 2.0 * r45) / (2.0 * r90 * (1.0 + r0))
    return F, G, H, N


def r_value(theta: float, r0: float, r45: float, r90: float) -> float:
    """The closed-form Lankford coefficient in uniaxial tension at `theta` (radians) to the
    rolling direction."""
    F, G, H, N = coefficients(r0, r45, r90)
    s2, c2 = np.sin(theta) ** 2, np.cos(theta) ** 2
    return (H + (2.0 * N - F - G - 4.0 * H) * s2 * c2) / (F * s2 + G * c2)


def yield_matrix(r0: float, r45: float, r90: float) -> np.ndarray:
    """A of sigma_bar^2 = s.A.s (Voigt s11, s22, s12)."""
    F, G, H, N = coefficients(r0, r45, r90)
    return np.array([[G + H, -H, 0.0], [-H, F + H, 0.0], [0.0, 0.0, 2.0 * N]])


def block(spec) -> np.ndarray:
    """The parameter block (BLOCK) of a material of Young's modulus E, Poisson's ratio nu and
    the Lankford coefficients of its model_parameters (r0, r45, r90)."""
    E, nu, parameters = spec.E, spec.nu, spec.parameters
    c11 = E / (1.0 - nu * nu)
    C = np.array([[c11, nu * c11, 0.0], [nu * c11, c11, 0.0], [0.0, 0.0, E / (2.0 * (1.0 + nu))]])
    P = 2.0 / 3.0 * yield_matrix(parameters["r0"], parameters["r45"], parameters["r90"])
    c_values, c_vectors = np.linalg.eigh(C)
    root = c_vectors @ np.diag(np.sqrt(c_values)) @ c_vectors.T
    inverse_root = c_vectors @ np.diag(1.0 / np.sqrt(c_values)) @ c_vectors.T
    lam, Q = np.linalg.eigh(root @ P @ root)
    return np.concatenate([(Q.T @ inverse_root).ravel(), (root @ Q).ravel(), lam, [lam.min()]])


def kernel(context):
    """The point update (a ti.data_oriented class) on the J2 model (context.models["j2"]); the
    block's columns start at context.block_offset of the material row.  Built on first use:
    reading a scene does not import Taichi."""
    import taichi as ti
    base, offset = context.models["j2"], context.block_offset
    T, B, L = offset, offset + 9, offset + 18

    @ti.data_oriented
    class Hill48(base):
        """Hill (1948) plane-stress plasticity (module docstring): the J2 return with the
        yield function's own trial, eigenvalues and returned stress, in the material axes
        `axes` = (cos, sin) of the angle from e1 to the rolling direction."""
        kind = NAME

        @ti.func
        def trial(self, row, axes, trial):
            """sigma_bar of the trial stress and z = T s_trial (s_trial in the material axes)."""
            c, s = axes[0], axes[1]
            cc, ss, cs = c * c, s * s, c * s
            sxx, syy, sxy = trial[0], trial[1], trial[2]
            m = ti.Vector([cc * sxx + ss * syy + 2.0 * cs * sxy, ss * sxx + cc * syy - 2.0 * cs * sxy,
                           cs * (syy - sxx) + (cc - ss) * sxy])
            z = ti.Vector([0.0, 0.0, 0.0])
            xi = 0.0
            for i in ti.static(range(3)):
                for j in ti.static(range(3)):
                    z[i] += row[T + 3 * i + j] * m[j]
                xi += row[L + i] * z[i] * z[i]
            return ti.sqrt(1.5 * xi), z

        @ti.func
        def smallest_eigenvalue(self, row):
            return row[L + 3]

        @ti.func
        def xi(self, row, terms, dlam):
            """xi = sum lambda_i z_i^2 / (1 + lambda_i dlambda)^2 and its derivative."""
            xi, dxi = 0.0, 0.0
            for i in ti.static(range(3)):
                lam = row[L + i]
                u = 1.0 / (1.0 + lam * dlam)
                w = lam * terms[i] * terms[i] * u * u
                xi += w
                dxi -= 2.0 * lam * w * u
            return xi, dxi

        @ti.func
        def returned(self, row, axes, stress, terms, dlam):
            """s = B diag(1/(1 + lambda_i dlambda)) z, turned back from the material axes."""
            m = ti.Vector([0.0, 0.0, 0.0])
            for i in ti.static(range(3)):
                for j in ti.static(range(3)):
                    m[i] += row[B + 3 * i + j] * terms[j] / (1.0 + row[L + j] * dlam)
            c, s = axes[0], axes[1]
            cc, ss, cs = c * c, s * s, c * s
            out = stress
            out[0] = cc * m[0] + ss * m[1] - 2.0 * cs * m[2]
            out[1] = ss * m[0] + cc * m[1] + 2.0 * cs * m[2]
            out[2] = cs * (m[0] - m[1]) + (cc - ss) * m[2]
            return out

    return Hill48
