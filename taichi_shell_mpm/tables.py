"""What the command line and the studies (``bench``, ``sweep``) share: the positive-integer
option type and the CSV tables they write (results.csv, orders.csv, sweep.csv), written
atomically with their numbers to a given number of significant digits."""
from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1 (argparse turns the error into its usage line, exit 2)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value}")
    return value


def cell(v, digits: int = 6) -> str:
    """A value as a CSV cell: floats to `digits` significant digits, empty for None and
    non-finite numbers."""
    if v is None:
        return ""
    if isinstance(v, float):
        return "" if not math.isfinite(v) else f"{v:.{digits}g}"
    return str(v)


def write_table(path: Path, rows: list[dict], columns: list[str], digits: int = 6) -> None:
    """`rows` as a CSV table of `columns` (other keys ignored, missing ones empty), written
    atomically (output.atomic_write, imported only here: output.py imports meshio)."""
    from .output import atomic_write

    def write(p: Path):
        with open(p, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=columns, extrasaction="ignore")
            w.writeheader()
            for row in rows:
                w.writerow({k: cell(row.get(k), digits) for k in columns})
    atomic_write(path, write)
