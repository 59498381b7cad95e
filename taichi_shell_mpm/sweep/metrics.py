"""What a sweep tabulates from each case's ``summary.json``: ``--metrics`` paths, and the
defaults for each kind of scene.

A path is the dotted way down the JSON: ``crush.mean_crush_force``, ``energies.internal``;
an integer picks an entry of a list (``crush.mean_force_over_reference.1``, ``-1`` the last)
and ``*`` every key of a table or entry of a list, one column each
(``reference.columns.*.max_rel_error``).  A value that is not a number (a list, a table, a
string) goes into the cell as JSON text; a path the summary does not have leaves the cell
empty.

Defaults (when no ``--metrics`` is given), by the scene:

* a ``[crush]`` table: the crush figures (docs/crush.md), with the specific energy absorption;
* a static scene with a ``[reference]`` table: the mean and max error of each compared
  column and its last simulated value;
* otherwise the final energies (internal and external work; dynamic: internal, plastic,
  kinetic and the balance error).
"""
from __future__ import annotations

import json

CRUSH = ["crush.mean_crush_force", "crush.specific_energy_absorption", "crush.absorbed_energy",
         "crush.crush_distance", "crush.peak_support_force", "crush.mean_force_over_reference.*",
         "crush.folds", "crush.half_wavelength", "crush.energy_balance_error_max", "crush.hourglass_over_internal"]
REFERENCE = ["reference.columns.*.mean_rel_error", "reference.columns.*.max_rel_error",
             "reference.columns.*.simulated.-1"]
STATIC = ["energies.internal", "energies.external_work"]
DYNAMIC = ["energies.internal", "energies.plastic_work", "energies.kinetic", "energies.balance_error"]
RUN_COLUMNS = {"steps": "steps", "compile_s": "compile_seconds", "run_s": "run_seconds"}
"""Columns of every case: sweep.csv column -> summary.json key."""


def default_metrics(scene) -> list[str]:
    if scene.crush is not None:
        return list(CRUSH)
    if scene.reference is not None and scene.solve.kind == "static":
        return list(REFERENCE)
    return list(STATIC if scene.solve.kind == "static" else DYNAMIC)


def parse_metrics(items: list[str]) -> list[str]:
    """``--metrics A,B --metrics C`` -> [A, B, C]; raises ValueError naming a bad path."""
    out = []
    for item in items:
        for path in (p.strip() for p in item.split(",")):
            if not path or not all(path.split(".")):
                raise ValueError(f"--metrics {item}: expected dotted summary.json paths such as "
                                 "crush.mean_crush_force, separated by commas")
            out.append(path)
    return out


def _children(node, part: str):
    """(label, child) pairs that `part` selects in `node`."""
    if isinstance(node, dict):
        if part == "*":
            return list(node.items())
        return [(part, node[part])] if part in node else []
    if isinstance(node, list):
        if part == "*":
            return [(str(i), v) for i, v in enumerate(node)]
        try:
            i = int(part)
        except ValueError:
            return []
        return [(part, node[i])] if -len(node) <= i < len(node) else []
    return []


def lookup(summary: dict, path: str) -> list[tuple[str, object]]:
    """(column, value) for each place `path` selects in `summary` (the column is the path
    with each ``*`` replaced by the key or index it stands for)."""
    found = [("", summary)]
    for part in path.split("."):
        found = [(f"{label}.{key}" if label else key, child)
                 for label, node in found for key, child in _children(node, part)]
    return [(label, cell_value(v)) for label, v in found]


def cell_value(v):
    if isinstance(v, bool):
        return int(v)
    if isinstance(v, (int, float)) or v is None:
        return v
    return json.dumps(v, separators=(",", ":")) if not isinstance(v, str) else v


def extract(summary: dict, paths: list[str]) -> dict:
    """The metric columns of one case: {column: value}, in the order of `paths`; a path not
    found gives its own column, empty."""
    out = {}
    for path in paths:
        found = lookup(summary, path)
        if not found and "*" not in path:
            out[path] = None
        out.update(found)
    return out
