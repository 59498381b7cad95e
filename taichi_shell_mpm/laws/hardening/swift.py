"""Swift hardening: sigma_y = K (eps0 + ebar)^n + H ebar (``hardening_law = "swift"``)."""
from __future__ import annotations

from ...keys import Key, keys, positive

NAME = "swift"
DOC = "`swift` K (ε₀ + ε̄ᵖ)ⁿ + H ε̄ᵖ (`K`, `n`, and `eps0` or `yield_stress`, `hardening`)"
KEYS = keys(
    Key("K", positive, "Swift's strength coefficient", default=0.0, unit="stress", default_text="required for `swift`"),
    Key("eps0", positive, "Swift's prestrain ε₀ (the initial yield stress is K ε₀ⁿ)", default=0.0,
        default_text="`swift`: this or `yield_stress`"),
    Key("n", positive, "hardening exponent (`swift`, `ludwik`); `ludwik` with n < 1 has an infinite slope at "
                       "ε̄ᵖ = 0, which the return handles (method below)", default=0.0,
        default_text="required for `swift`, `ludwik`"))
REQUIRED = ("K", "n")
OPTIONAL = ("eps0", "yield_stress", "hardening")
BLOCK = ("K", "eps0", "n")


def rules(r, path: str, data: dict, values: dict) -> None:
    """Exactly one of eps0 and yield_stress; yield_stress sets eps0 = (yield_stress / K)^(1/n)."""
    if ("eps0" in data) == ("yield_stress" in data):
        r.error(f"{path}.eps0", "expected exactly one of eps0 and yield_stress for hardening_law = "
                                "\"swift\" (yield_stress sets eps0 = (yield_stress / K)^(1/n))")
    elif all(k in data and k in values for k in ("yield_stress", "K", "n")):
        values["eps0"] = (values["yield_stress"] / values["K"]) ** (1.0 / values["n"])


def block(spec, curve_start: int) -> list[float]:
    return [spec.K, spec.eps0, spec.n]


def kernel(offset: int, col: dict):
    import taichi as ti
    K, EPS0, N, H = offset, offset + 1, offset + 2, col["hardening"]

    @ti.data_oriented
    class SwiftHardening:
        """sigma_y = K (eps0 + ebar)^n + H ebar (eps0 > 0: a finite slope everywhere)."""
        law = NAME

        def __init__(self, state=None):
            pass

        @ti.func
        def flow_stress(self, row, ebar):
            n, strain, h = row[N], row[EPS0] + ebar, row[H]
            power = row[K] * strain ** n
            return power + h * ebar, n * power / strain + h

    return SwiftHardening
