"""[reference]: reference data to compare a static run with."""
from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from ..keys import (
    Check,
    choice,
    contextual,
    fraction,
    key,
    keys_of,
    nonempty,
    nonzero,
    one_line,
    scene_file,
)
from .reader import Reader

PROBE_COMPONENT = contextual("probe_component", "string", "", {"type": "string", "pattern": r"^.+\..+$"})
COMPARE = Check(None, "array of tables", "at least one",
                {"type": "array", "minItems": 1, "items": {"$ref": "#/definitions/reference_compare"}})
"""[[reference.compare]] (read by read_reference with the table's header)."""


@dataclass(frozen=True)
class ReferenceColumn:
    column: str = key(nonempty, "reference values", allowed="a column of the header")
    probe: str = key(PROBE_COMPONENT, "simulated values",
                     allowed="`'<probe>.<component>'`, a component the probe records")
    scale: float = key(nonzero, default=1.0, allowed="finite, non-zero",
        doc="the probe value times `scale` is compared with `column` (e.g. -1 for a column of −u_x)")


@dataclass(frozen=True)
class Reference:
    file: Path = key(scene_file, allowed="an existing CSV file with a header row",
        doc="reference table, relative to the scene file's folder")
    load_column: str = key(nonempty, "the column with each row's load level", allowed="a column of the header")
    compare: tuple[ReferenceColumn, ...] = key(COMPARE, "`[[reference.compare]]` entries below")
    floor: float = key(fraction, default=0.1,
        doc="relative-error floor: e_i = |sim − ref_i| / max(|ref_i|, floor · max|ref|)")
    along: Literal["load", "path"] = key(choice("load", "path"), default="load",
        doc="`load`: rows matched by load level (above); `path`: for a path with limit points (the load goes up "
            "and down: arc length or displacement control), each row (x_i, λ_i) of a compared column x against "
            "the simulated path, e_i = the distance from (x_i/X, λ_i/Λ) to the polyline through the origin and "
            "the converged points (X, Λ: the table's largest |x|, |λ|); rows whose x the path did not reach are "
            "`missing_levels`; `render` draws the whole path (`reference.py`, `scenes/hinged_roof.toml`)")


def read_reference(r: Reader, data: Any) -> Reference | None:
    mark = len(r.messages)
    v = r.read("[reference]", data, {k: d for k, d in keys_of(Reference).items() if k != "compare"},
               Reference, extra=("compare",))
    if v is None:
        return None
    column = r.csv_column(v.get("file"))
    if "load_column" in v:
        r.check("[reference].load_column", column, v["load_column"])
    if "compare" not in data:
        r.error("[reference].compare", "missing required key (add [[reference.compare]] tables)")
    elif data["compare"] == []:
        r.error("[reference].compare", "expected at least one [[reference.compare]] table")
    spec = {**keys_of(ReferenceColumn), "column": column}
    compare = [r.table_object(p, d, ReferenceColumn, spec)
               for p, d in r.entries("[[reference.compare]]", data.get("compare", []))]
    if len(r.messages) == mark and v.get("file") is not None:
        # the columns the comparison reads: every cell a finite number (the run reads them at its end)
        from ..reference import table_problems
        try:
            problems = table_problems(v["file"], [v["load_column"], *(c.column for c in compare)])
        except (OSError, UnicodeDecodeError, csv.Error) as exc:
            problems = [f"cannot read {v['file'].name} ({one_line(exc)})"]
        for problem in problems:
            r.error("[reference].file", problem)
    return r.build(mark, Reference, {**v, "compare": tuple(compare)})
