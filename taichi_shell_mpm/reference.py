"""Comparison of recorded probes with a reference table (e.g. Sze, Liu & Lo 2004).

Relative error of row i: e_i = |sim_i - ref_i| / max(|ref_i|, floor * max_j |ref_j|)
(issue 2: the floor keeps the 3-decimal rounding of tiny first-row values from dominating).
"""
from __future__ import annotations

import csv

import numpy as np

from .scene import Reference


def read_reference(ref: Reference) -> dict[str, np.ndarray]:
    with open(ref.file, newline="") as fh:
        rows = list(csv.DictReader(fh))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def relative_errors(sim: np.ndarray, ref: np.ndarray, floor: float) -> np.ndarray:
    return np.abs(sim - ref) / np.maximum(np.abs(ref), floor * np.max(np.abs(ref)))


def compare_with_reference(ref: Reference, header: list[str], rows: list[list[float]]) -> dict:
    """Per compared column: mean and max relative error over the reference rows, the rows'
    values side by side, and the reference rows that had no matching load level."""
    table = read_reference(ref)
    data = np.array(rows, dtype=float).reshape(len(rows), len(header))
    keys = data[:, 0]
    levels = table[ref.load_column]
    match = [int(np.argmin(np.abs(keys - lv))) if len(keys) and np.min(np.abs(keys - lv)) < 1e-9 * max(1, abs(lv))
             else -1 for lv in levels]
    missing = [float(lv) for lv, i in zip(levels, match) if i < 0]
    result = {"file": str(ref.file), "rows": len(levels), "missing_levels": missing, "columns": {}}
    ok = np.array([i >= 0 for i in match])
    for comp in ref.compare:
        col = header.index(comp.probe)
        sim = np.array([data[i, col] * comp.scale if i >= 0 else np.nan for i in match])
        err = relative_errors(sim[ok], table[comp.column][ok], ref.floor)
        result["columns"][comp.column] = {
            "probe": comp.probe, "mean_rel_error": float(err.mean()) if len(err) else None,
            "max_rel_error": float(err.max()) if len(err) else None,
            "simulated": sim.tolist(), "reference": table[comp.column].tolist()}
    return result
