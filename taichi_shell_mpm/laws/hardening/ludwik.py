"""Ludwik hardening (Johnson-Cook's strain term): sigma_y = sigma_y0 + B ebar^n + H ebar,
capped at max_stress (``hardening_law = "ludwik"``)."""
from __future__ import annotations

from ...keys import Key, keys, non_negative, positive
from .rules import above_yield_stress

NAME = "ludwik"
DOC = ("`ludwik` σ_y0 + B (ε̄ᵖ)ⁿ + H ε̄ᵖ, Johnson–Cook's strain term, capped at `max_stress` when given "
       "(`yield_stress` = A, `B`, `n`, `hardening`, `max_stress`)")
KEYS = keys(
    Key("B", non_negative, "Ludwik's (Johnson–Cook's) hardening coefficient", default=0.0, unit="stress",
        default_text="required for `ludwik`"),
    Key("max_stress", positive, "`ludwik`: σ_y is capped here", default=None, unit="stress",
        allowed="> `yield_stress`"))
REQUIRED = ("yield_stress", "B", "n")
OPTIONAL = ("max_stress", "hardening")
BLOCK = ("B", "n", "max_stress")


def rules(r, path: str, data: dict, values: dict) -> None:
    """The cap above the initial yield stress."""
    above_yield_stress(r, path, data, values, "max_stress")


def block(spec, curve_start: int) -> list[float]:
    return [spec.B, spec.n, spec.max_stress or 0.0]


def kernel(offset: int, col: dict):
    import taichi as ti
    B, N, CAP, SY, H = offset, offset + 1, offset + 2, col["yield_stress"], col["hardening"]

    @ti.data_oriented
    class LudwikHardening:
        """sigma_y = sigma_y0 + B ebar^n + H ebar, capped at max_stress when that is set (0:
        none).  For n < 1 the slope n B ebar^(n-1) is infinite at ebar = 0; it is taken as 0
        there [choice]: Newton's first step from a virgin point is then the perfectly plastic
        one, which overshoots the root (the flow stress rises above sigma_y0) and becomes the
        upper end of the bracket, and the iterates that follow have ebar > 0 and a finite slope."""
        law = NAME

        def __init__(self, state=None):
            pass

        @ti.func
        def flow_stress(self, row, ebar):
            n, b, h, cap = row[N], row[B], row[H], row[CAP]
            sy, slope = row[SY] + h * ebar, h
            if ebar > 0.0:
                power = ebar ** n
                sy += b * power
                slope += n * b * power / ebar
            elif n == 1.0:
                slope += b
            if cap > 0.0 and sy > cap:
                sy, slope = cap, 0.0
            return sy, slope

    return LudwikHardening
