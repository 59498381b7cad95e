"""Linear hardening: sigma_y = sigma_y0 + H ebar (``hardening_law = "linear"``, the default)."""
from __future__ import annotations

NAME = "linear"
DOC = "`linear` σ_y0 + H ε̄ᵖ (`yield_stress`, `hardening`; H = 0: perfectly plastic)"
KEYS: dict = {}
REQUIRED = ("yield_stress",)
OPTIONAL = ("hardening",)
BLOCK: tuple[str, ...] = ()


def block(spec, curve_start: int) -> list[float]:
    return []


def kernel(offset: int, col: dict):
    """`col`: the material row's shared columns (yield_stress, hardening)."""
    import taichi as ti
    SY, H = col["yield_stress"], col["hardening"]

    @ti.data_oriented
    class LinearHardening:
        """sigma_y = sigma_y0 + H ebar."""
        law = NAME

        def __init__(self, state=None):
            pass

        @ti.func
        def flow_stress(self, row, ebar):
            return row[SY] + row[H] * ebar, row[H]

    return LinearHardening
