"""The refinement series of the static benchmarks and their observed order of convergence:
which rows form a series (:func:`group_key`), the least-squares slope of log(mean error)
against log(element size) per scene, series and component (:func:`observed_orders`), and
``orders.csv``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..tables import write_table
from .cases import STATIC_SCENES, triangle_element
from .results import num

ORDER_COLUMNS = ["scene", "series", "meshes", "comp1", "order1", "points1", "comp2", "order2", "points2"]


def observed_orders(rows: list[dict]) -> list[dict]:
    """Least-squares slope of log(mean error) vs log(element size), per scene/series/component."""
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        if r.get("status") != "ok" or r["scene"] not in STATIC_SCENES:
            continue
        groups.setdefault((r["scene"], group_key(r)), []).append(r)
    out = []
    for (scene, series), rs in sorted(groups.items()):
        if len({r["mesh"] for r in rs}) < 2:
            continue
        rs = sorted(rs, key=lambda r: -num(r, "element_size"))
        entry = {"scene": scene, "series": series, "meshes": " ".join(r["mesh"] for r in rs)}
        for k in (1, 2):
            ell = np.array([num(r, "element_size") for r in rs])
            err = np.array([num(r, f"err{k}_mean") for r in rs])
            ok = np.isfinite(ell) & np.isfinite(err) & (ell > 0) & (err > 0)
            entry[f"comp{k}"] = rs[0].get(f"comp{k}", "")
            entry[f"order{k}"] = (float(np.polyfit(np.log(ell[ok]), np.log(err[ok]), 1)[0])
                                  if ok.sum() >= 2 and np.ptp(ell[ok]) > 0 else float("nan"))
            entry[f"points{k}"] = int(ok.sum())
        out.append(entry)
    return out


def series_label(row: dict) -> str:
    if row["mode"] == "mpm":
        return f"mpm h={num(row, 'cell_ratio'):g}l"
    return row["mode"]


def group_key(row: dict) -> str:
    """Series label plus any load-step tag of the case name (quick runs use fewer steps), after
    the triangle element of a triangle series."""
    tag = row["case"].rsplit("_", 1)[-1]
    element = triangle_element(row["case"])
    return ((f"{element} " if element else "") + series_label(row)
            + (f" ({tag})" if tag.startswith("ls") else ""))


def write_orders(path: Path, orders: list[dict]) -> None:
    """orders.csv: one row per series of :func:`observed_orders`."""
    write_table(path, orders, ORDER_COLUMNS)
