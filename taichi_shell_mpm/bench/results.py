"""results.csv, one row per case: its columns, reading it, writing it (atomically), and
reading a number out of a row; the atomic writers the other files of the study use too."""
from __future__ import annotations

import csv
from pathlib import Path

from ..tables import write_table

COLUMNS = ["case", "scene", "mesh", "mode", "cell_ratio", "cell_size", "element_size", "elements",
           "steps", "wall_s", "compile_s", "run_s", "us_per_element_step", "peak_mem_MB",
           "comp1", "err1_mean", "err1_max", "comp2", "err2_mean", "err2_max", "rows_compared",
           "crush", "mean_force", "peak_force", "half_wavelength", "balance", "hg_ratio", "penetration",
           "status", "date", "machine", "overrides"]
COMPONENT_LABEL = {"W_tip": "W_tip", "minus_U_tip": "-U_tip",
                   "radial_disp_outward_loaded_point": "d_out",
                   "radial_disp_inward_loaded_point_magnitude": "d_in"}
"""Short names of the reference table's compared columns (comp1, comp2)."""
TUBE_KEYS = {"crush": "crush_distance", "mean_force": "mean_crush_force", "peak_force": "peak_support_force",
             "half_wavelength": "half_wavelength", "balance": "energy_balance_error_max",
             "hg_ratio": "hourglass_over_internal", "penetration": "max_penetration_over_thickness"}
"""results.csv column -> key of summary.json's ``crush`` entry."""


def atomic_write(path, write) -> None:      # output.py imports meshio: only when writing
    from ..output import atomic_write as aw
    aw(path, write)


def write_text(path, text: str) -> None:
    from ..output import write_text as wt
    wt(path, text)


def read_results(path: Path) -> list[dict]:
    if not path.exists():
        return []
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def write_results(path: Path, rows: list[dict]) -> None:
    write_table(path, rows, COLUMNS)


def replace_row(path: Path, row: dict) -> None:
    """Write `row` into results.csv in place of the earlier row of its case, if any (a re-run
    case replaces its row)."""
    write_results(path, [r for r in read_results(path) if r["case"] != row["case"]] + [row])


def num(row: dict, key: str) -> float:
    """The cell `key` of a results.csv row as a float (nan when empty, missing or not a number)."""
    try:
        return float(row.get(key) or "nan")
    except ValueError:
        return float("nan")
