"""Rules across keys that several hardening laws share."""
from __future__ import annotations


def above_yield_stress(r, path: str, data: dict, values: dict, key: str) -> None:
    """values[key] (a cap, a saturation stress) above the initial yield stress, when both are
    given and valid: a flow stress that falls is not supported."""
    limit, sy = values.get(key), values.get("yield_stress")
    if key in data and "yield_stress" in data and limit is not None and sy is not None and limit <= sy:
        r.error(f"{path}.{key}", f"expected a number above yield_stress = {sy:g}, got {limit:g}")
