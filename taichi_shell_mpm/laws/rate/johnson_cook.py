"""Johnson-Cook rate law: R = 1 + c ln(rate / rate0), not below 1 (``rate_law = "johnson_cook"``)."""
from __future__ import annotations

from ...keys import Key, keys, non_negative, positive

NAME = "johnson_cook"
DOC = ("`johnson_cook` 1 + c ln(ε̇/ε̇₀), not below 1 (so rates at or under ε̇₀, and a zero rate, give the "
       "rate-free answer exactly)")
KEYS = keys(
    Key("c", non_negative, "Johnson–Cook rate coefficient", default=0.0, default_text="required for `johnson_cook`"),
    Key("reference_rate", positive, "ε̇₀, 1/time", default=0.0, unit="1/time",
        default_text="required for `johnson_cook`"))
REQUIRED = ("c", "reference_rate")
BLOCK = ("c", "reference_rate")


def block(spec) -> list[float]:
    return [spec.c, spec.reference_rate]


def kernel(offset: int):
    import taichi as ti
    C, REFERENCE = offset, offset + 1

    @ti.data_oriented
    class JohnsonCookRate:
        """R = 1 + c ln(rate / rate0) above the reference rate rate0, else 1."""
        law = NAME

        @ti.func
        def factor(self, row, rate):
            R, slope = 1.0, 0.0
            c, reference = row[C], row[REFERENCE]
            if rate > reference:
                R, slope = 1.0 + c * ti.log(rate / reference), c / rate
            return R, slope

    return JohnsonCookRate
