"""Cowper-Symonds rate law: R = 1 + (rate / C)^(1/p) (``rate_law = "cowper_symonds"``)."""
from __future__ import annotations

from ...keys import Key, keys, positive

NAME = "cowper_symonds"
DOC = "`cowper_symonds` 1 + (ε̇/C)^(1/p)"
KEYS = keys(
    Key("C", positive, "Cowper–Symonds rate constant, 1/time in the scene's units (D = 40.4 /s is 0.0404 /ms in "
                       "kN-mm-ms)", default=0.0, unit="1/time", default_text="required for `cowper_symonds`"),
    Key("p", positive, "Cowper–Symonds exponent (q = 5 for mild steel)", default=0.0,
        default_text="required for `cowper_symonds`"))
REQUIRED = ("C", "p")
BLOCK = ("C", "p")


def block(spec) -> list[float]:
    return [spec.C, spec.p]


def kernel(offset: int):
    import taichi as ti
    C, P = offset, offset + 1

    @ti.data_oriented
    class CowperSymonds:
        """R = 1 + (rate / C)^(1/p).  At rate 0, R = 1 and the slope, infinite for p > 1, is
        taken as 0 (as Ludwik's at ebar = 0)."""
        law = NAME

        @ti.func
        def factor(self, row, rate):
            R, slope = 1.0, 0.0
            if rate > 0.0:
                p = row[P]
                x = (rate / row[C]) ** (1.0 / p)
                R, slope = 1.0 + x, x / (p * rate)
            return R, slope

    return CowperSymonds
