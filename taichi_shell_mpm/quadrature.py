"""Through-thickness integration rules (method.md 3.3): points zeta in [-1, 1], weights sum to 2."""
from __future__ import annotations

import numpy as np
from numpy.polynomial import legendre


def through_thickness_rule(rule: str, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre (n >= 1) or Gauss-Lobatto (n >= 2) points and weights on [-1, 1].

    Lobatto: the end points plus the roots of P'_{n-1}; weights 2 / (n (n-1) P_{n-1}(zeta)^2).
    Lobatto 3 (the paper's rule) is zeta = -1, 0, 1 with w = 1/3, 4/3, 1/3.
    """
    if rule == "gauss":
        zeta, w = legendre.leggauss(n)
        return zeta, w
    if rule == "lobatto":
        if n < 2:
            raise ValueError("Lobatto needs at least 2 points")
        p = legendre.Legendre.basis(n - 1)
        inner = np.sort(p.deriv().roots().real) if n > 2 else np.array([])
        zeta = np.concatenate(([-1.0], inner, [1.0]))
        w = 2.0 / (n * (n - 1) * p(zeta) ** 2)
        return zeta, w
    raise ValueError(f"unknown through-thickness rule {rule!r}")
