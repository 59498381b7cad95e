"""Hockett-Sherby hardening (Hockett & Sherby 1975, J. Mech. Phys. Solids 23; a saturating law
used for sheet metal at large strains): sigma_y = s_sat - (s_sat - sigma_y0) exp(-m ebar^p)
+ H ebar (``hardening_law = "hockett_sherby"``)."""
from __future__ import annotations

from ...keys import Key, keys, positive
from .rules import above_yield_stress

NAME = "hockett_sherby"
DOC = ("`hockett_sherby` σ_sat − (σ_sat − σ_y0) e^(−m (ε̄ᵖ)^p) + H ε̄ᵖ (`yield_stress`, `saturation_stress`, "
       "`saturation_rate`, `saturation_exponent`, `hardening`)")
KEYS = keys(
    Key("saturation_stress", positive, "Hockett–Sherby's saturation stress σ_sat", default=0.0, unit="stress",
        allowed="> `yield_stress`", default_text="required for `hockett_sherby`"),
    Key("saturation_rate", positive, "Hockett–Sherby's m (how fast σ_y saturates)", default=0.0,
        default_text="required for `hockett_sherby`"),
    Key("saturation_exponent", positive, "Hockett–Sherby's exponent p (p < 1: an infinite slope at ε̄ᵖ = 0, "
                                         "handled as Ludwik's)", default=0.0,
        default_text="required for `hockett_sherby`"))
REQUIRED = ("yield_stress", "saturation_stress", "saturation_rate", "saturation_exponent")
OPTIONAL = ("hardening",)
BLOCK = ("saturation_stress", "saturation_rate", "saturation_exponent")


def rules(r, path: str, data: dict, values: dict) -> None:
    """The saturation stress above the initial yield stress (a falling flow stress is not supported)."""
    above_yield_stress(r, path, data, values, "saturation_stress")


def block(spec, curve_start: int) -> list[float]:
    return [spec.saturation_stress, spec.saturation_rate, spec.saturation_exponent]


def kernel(offset: int, col: dict):
    import taichi as ti
    SAT, M, P, SY, H = offset, offset + 1, offset + 2, col["yield_stress"], col["hardening"]

    @ti.data_oriented
    class HockettSherbyHardening:
        """sigma_y = s_sat - (s_sat - sigma_y0) exp(-m ebar^p) + H ebar; slope (s_sat -
        sigma_y0) m p ebar^(p-1) exp(-m ebar^p) + H, taken at ebar = 0 as m (s_sat - sigma_y0)
        for p = 1 and 0 otherwise [choice: Ludwik's, for the same reason]."""
        law = NAME

        def __init__(self, state=None):
            pass

        @ti.func
        def flow_stress(self, row, ebar):
            sat, m, p, h = row[SAT], row[M], row[P], row[H]
            gap = sat - row[SY]
            sy, slope = row[SY] + h * ebar, h
            if ebar > 0.0:
                power = ebar ** p
                decay = ti.exp(-m * power)
                sy = sat - gap * decay + h * ebar
                slope += gap * m * p * power / ebar * decay
            elif p == 1.0:
                slope += gap * m
            return sy, slope

    return HockettSherbyHardening
