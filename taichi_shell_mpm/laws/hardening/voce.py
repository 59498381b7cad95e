"""Voce hardening: sigma_y = sigma_y0 + Q (1 - exp(-b ebar)) + H ebar (``hardening_law = "voce"``)."""
from __future__ import annotations

from ...keys import Key, keys, non_negative

NAME = "voce"
DOC = "`voce` σ_y0 + Q (1 − e^(−b ε̄ᵖ)) + H ε̄ᵖ (`yield_stress`, `Q`, `b`, `hardening`)"
KEYS = keys(
    Key("Q", non_negative, "Voce's saturation stress increase", default=0.0, unit="stress",
        default_text="required for `voce`"),
    Key("b", non_negative, "Voce's saturation rate (1 / strain)", default=0.0, default_text="required for `voce`"))
REQUIRED = ("yield_stress", "Q", "b")
OPTIONAL = ("hardening",)
BLOCK = ("Q", "b")


def block(spec, curve_start: int) -> list[float]:
    return [spec.Q, spec.b]


def kernel(offset: int, col: dict):
    import taichi as ti
    Q, B, SY, H = offset, offset + 1, col["yield_stress"], col["hardening"]

    @ti.data_oriented
    class VoceHardening:
        """sigma_y = sigma_y0 + Q (1 - exp(-b ebar)) + H ebar."""
        law = NAME

        def __init__(self, state=None):
            pass

        @ti.func
        def flow_stress(self, row, ebar):
            q, b, h = row[Q], row[B], row[H]
            decay = ti.exp(-b * ebar)
            return row[SY] + q * (1.0 - decay) + h * ebar, q * b * decay + h

    return VoceHardening
