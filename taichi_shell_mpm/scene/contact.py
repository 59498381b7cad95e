"""[contact]: penalty self-contact, and the penalty laws' damping bound."""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..keys import key, non_negative, number, positive, unit_interval
from .reader import Reader


def penalty_damping_limit(stiffness: float) -> float:
    """The largest damping fraction the penalty law (stages/contact.py, stages/tools.py) takes
    at `stiffness` alpha: alpha + 2 zeta sqrt(alpha) <= 2 [issue 28 item 4; docs/contact.md,
    "Penalty parameters"].  The damper acts on the lagged velocity v^(n-1/2): a node that
    arrives at the speed v and is found v dt deep gets the impulse (alpha + 2 zeta sqrt(alpha))
    m v in one step, which sends it back faster than it came once it exceeds 2 m v (at alpha =
    zeta = 1: 2 v, booked as negative contact energy).  The 1-DOF model over every arrival
    phase puts the bound there for every alpha in (0, 1] (no damping is refused below
    alpha = 0.536)."""
    return (2.0 - stiffness) / (2.0 * math.sqrt(stiffness))


@dataclass(frozen=True)
class Contact:
    """Penalty node-to-segment self-contact (method.md 7.3); present table = enabled."""
    thickness: float | None = key(
        positive, default=None, unit="length",
        default_text="each pair's (t_node + t_element) / 2 (one section: its thickness)",
        doc="contact thickness t_c of every pair, overriding the per-pair rule (contact begins at this distance "
            "between mid-surfaces)")
    stiffness: float = key(number(0, 1, lo_open=True), default=0.1,
        doc="α_c of the penalty k = α_c m*/Δt² (m*: the node and segment's reduced mass)")
    friction: float = key(non_negative, default=0.0,
        doc="Coulomb coefficient μ (regularised by the slip speed; the force at most m* |v_t| / Δt, what stops "
            "the slip in one step)")
    damping: float = key(
        unit_interval, default=0.1, allowed="[0, 1], and `stiffness` + 2 `damping` √`stiffness` ≤ 2 (at `stiffness` = 1: ≤ 0.5)",
        doc="contact damping as a fraction of critical; the bound keeps a node from bouncing back faster than it "
            "came (docs/contact.md, \"Penalty parameters\")")


def check_penalty_damping(r: Reader, path: str, stiffness: float, damping: float) -> None:
    """A penalty law's damping within penalty_damping_limit(stiffness)."""
    if damping > penalty_damping_limit(stiffness) * (1.0 + 1e-12):
        r.error(f"{path}.damping", f"{damping:g} with stiffness = {stiffness:g}: stiffness + 2 damping "
                f"sqrt(stiffness) must be <= 2, else a node bounces back faster than it came; at most "
                f"{penalty_damping_limit(stiffness):.3g} at this stiffness (docs/contact.md)")
