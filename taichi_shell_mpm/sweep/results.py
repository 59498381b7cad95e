"""The sweep's tables: ``sweep.csv`` (one row per case: its values, status, exit code, wall
time, steps, compile and run time, the metrics, the worker, the error message) and the
Markdown table ``sweep.md``; the row of a case from its result.

Both files are rewritten (atomically) after every case, so they show every case finished
so far; ``--resume`` reads sweep.csv back (:func:`read_study`, which refuses a file whose
rows the study would lose) and skips the cases whose status is ``ok``.
"""
from __future__ import annotations

import csv
import datetime
import math
import os
from pathlib import Path

from ..tables import write_table
from .cases import SweepError
from .metrics import RUN_COLUMNS, extract

FRONT = ["case"]
MIDDLE = ["status", "exit_code", "wall_s", *RUN_COLUMNS]
BACK = ["worker", "message"]


def case_row(case, keys: list[str], result: dict | None, metrics: list[str], error: str | None = None,
             exit_code: int | None = None) -> dict:
    """The sweep.csv row of `case` from what :func:`task.run_case` returned (`result`), or
    from `error` (and `exit_code`) when it could not run (a scene error found before, a
    worker that died)."""
    row = {"case": case.name, **{k: "" for k in keys}, **dict(case.params)}
    if result is None:
        row.update(status="failed", exit_code=exit_code, message=error or "")
        return row
    summary = result.get("summary") if isinstance(result.get("summary"), dict) else {}
    ok = result["exit_code"] == 0 and bool(summary) and not summary.get("error")
    row.update(status="ok" if ok else "failed", exit_code=result["exit_code"], wall_s=result["wall_s"])
    row.update({col: summary.get(src) for col, src in RUN_COLUMNS.items()})
    row.update(extract(summary, metrics) if summary else {})
    row.update(worker=result.get("worker"), message=result.get("message") or "")
    return row


def retabulate(row: dict, keys: list[str], summary: dict, metrics: list[str]) -> dict:
    """`row` (read back from sweep.csv) with its metric columns taken anew from the case's
    `summary` (``--resume`` with other ``--metrics``)."""
    fixed = set(FRONT + keys + MIDDLE + BACK)
    return {**{k: v for k, v in row.items() if k in fixed}, **extract(summary, metrics)}


def columns(rows: list[dict], keys: list[str]) -> list[str]:
    """sweep.csv's columns: case, the keys, status ... run_s, the metric columns in order of
    first appearance, worker, message."""
    fixed = set(FRONT + keys + MIDDLE + BACK)
    metric = []
    for r in rows:
        metric += [c for c in r if c not in fixed and c not in metric]
    return FRONT + keys + MIDDLE + metric + BACK


def metric_columns(rows: list[dict], keys: list[str]) -> list[str]:
    """The metric columns of `rows`, in order of first appearance."""
    fixed = set(FRONT + keys + MIDDLE + BACK)
    return [c for c in columns(rows, keys) if c not in fixed]


def write_csv(path: Path, rows: list[dict], keys: list[str]) -> None:
    write_table(path, rows, columns(rows, keys), digits=10)


def read_study(path: Path, keys: list[str], cases) -> list[dict]:
    """``--resume``: the rows of `path` (a study's sweep.csv; none when there is no file),
    refused with a :class:`SweepError` naming the difference, before anything is written,
    when rewriting the file would lose rows: not a UTF-8 CSV file, not the table of a study
    with these keys (other --param or --cases keys, or none), or rows of cases that are not
    among `cases` (other values)."""
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            header, rows = list(reader.fieldnames or []), list(reader)
    except FileNotFoundError:
        return []
    except OSError as exc:
        raise SweepError(f"--resume: {path}: cannot read the file ({exc.strerror or exc})") from None
    except (UnicodeDecodeError, csv.Error) as exc:
        raise SweepError(f"--resume: {path}: not a sweep.csv table (not a UTF-8 CSV file: "
                         f"{' '.join(str(exc).split())}); give another --out, or move the file away") from None
    expected = FRONT + keys
    if header[:len(expected)] != expected or not set(MIDDLE) <= set(header):
        got = ", ".join(header[:len(expected)]) or "nothing"
        raise SweepError(f"--resume: {path}: not the table of this study: its first columns are {got}, this "
                         f"study's are {', '.join(expected)} followed by {', '.join(MIDDLE[:2])}, ... (other "
                         "--param or --cases keys?); give the same keys, or another --out")
    planned = {c.name: dict(c.params) for c in cases}
    foreign = [r.get("case") or "" for r in rows
               if r.get("case") not in planned or any(r.get(k, "") != planned[r["case"]].get(k, "") for k in keys)]
    if foreign:
        raise SweepError(f"--resume: {path}: {len(foreign)} of its {len(rows)} rows are not cases of this study "
                         f"(first: {foreign[0]!r}; other --param values or --cases rows?) and would be lost; "
                         "give the same values, or another --out")
    return rows


def number(v) -> float:
    """A cell as a float (nan when empty or not a number)."""
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return float(v)
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")


def fmt(v) -> str:
    """A cell for the Markdown table: 4 significant digits, whole numbers in full."""
    x = number(v)
    if math.isfinite(x) and not (isinstance(v, str) and not v.strip()):
        return f"{int(x)}" if x == int(x) and abs(x) < 1e9 else f"{x:.4g}"
    return "" if v is None else str(v).replace("|", "\\|")


def write_markdown(path: Path, rows: list[dict], keys: list[str], cases, title: str, command: str,
                   where: str, plots: dict[str, Path]) -> None:
    """sweep.md: how the study was run, the table of every planned case (not run yet: its
    values and "not run"), the failures' messages and the plots."""
    from ..output import write_text
    from .cases import short_keys
    short = short_keys(keys)
    metric = metric_columns(rows, keys)
    label = short_keys(metric)
    by_name = {r["case"]: r for r in rows}
    ok = sum(1 for r in rows if r.get("status") == "ok")
    failed = [r for r in rows if r.get("status") not in (None, "ok")]
    missing = [c for c in cases if c.name not in by_name]
    now = datetime.datetime.now().isoformat(timespec="seconds")
    rel = lambda p: Path(os.path.relpath(p, path.parent)).as_posix()   # noqa: E731
    L = [f"# Sweep: {title}", "",
         f"Generated {now} by `{command}` ({where}).  {len(cases)} cases: {ok} ok, {len(failed)} failed, "
         f"{len(missing)} not run.  Each case is a run of the scene with its values as `--set` overrides, "
         f"in `{rel(path.parent / 'cases')}/CASE/` (its console log is `run.log` there); every number is in "
         f"`{rel(path.parent / 'sweep.csv')}` with 10 digits, its metric columns under their full summary.json paths.",
         "",
         "| " + " | ".join(["case", *(short[k] for k in keys), "status", "wall s", "steps",
                            *(label[m] for m in metric)]) + " |",
         "|" + "---|" * (len(keys) + 4 + len(metric))]
    for case in cases:
        r = by_name.get(case.name, {"case": case.name, **dict(case.params), "status": "not run"})
        status = r.get("status", "")
        if status == "failed" and r.get("exit_code") not in (None, ""):
            status = f"failed (exit {r['exit_code']})"
        cells = [case.name] + [str(r.get(k, "")) for k in keys] + [status, fmt(r.get("wall_s")),
                                                                     fmt(r.get("steps"))]
        cells += [fmt(r.get(c)) for c in metric]
        L.append("| " + " | ".join(cells) + " |")
    L.append("")
    if failed:
        L += ["Failed cases:", ""] + [f"* `{r['case']}`: {r.get('message') or 'no message'}" for r in failed] + [""]
    for name, png in plots.items():
        L += [f"![{name}]({rel(png)})", ""]
    write_text(path, "\n".join(L))
