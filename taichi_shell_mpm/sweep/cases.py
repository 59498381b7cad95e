"""The cases of a sweep: ``--param KEY=V1,V2,...`` (several make a cartesian product, the
first varying slowest), ``--cases FILE`` (a CSV, one column per key, one row per case; an
optional ``case`` column names the cases; an empty cell leaves that key at the scene's
value), or both (each CSV row with each combination of the ``--param`` values).

KEY is any scene key as ``--set`` addresses it (``section.thickness``, ``load.0.force``),
a value any ``--set`` value (``0.8``, ``fem``, ``[0, 0, 2]``; commas inside brackets or
quotes do not split values).

A case's name is its values, ``KEY=VALUE`` joined by ``__``, each key shortened to its
shortest dotted suffix that tells the study's keys apart (``thickness=0.8__yield_stress=0.2``);
characters other than letters, digits and ``._=+-`` become ``_`` and a short hash of the
exact values is then appended, so different cases never share a name.  The name is the
case's folder under ``OUT/cases`` and its key for ``--resume``.
"""
from __future__ import annotations

import csv
import hashlib
import itertools
import re
from dataclasses import dataclass
from pathlib import Path

NAME_COLUMN = "case"
_SAFE = re.compile(r"[^A-Za-z0-9._=+-]")
MAX_NAME = 120


class SweepError(Exception):
    """A mistake in the sweep's options or cases file; one line per problem."""

    def __init__(self, messages):
        self.messages = [messages] if isinstance(messages, str) else list(messages)
        super().__init__("; ".join(self.messages))


@dataclass(frozen=True)
class SweepCase:
    name: str
    params: tuple[tuple[str, str], ...]     # (key, value as written), in the study's key order

    @property
    def overrides(self) -> tuple[str, ...]:
        return tuple(f"{k}={v}" for k, v in self.params)


def split_values(text: str) -> list[str]:
    """`text` split at the commas outside brackets, braces and quotes, each part stripped."""
    parts, depth, quote, current = [], 0, "", []
    for ch in text:
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append("".join(current).strip())
            current = []
            continue
        current.append(ch)
    parts.append("".join(current).strip())
    return parts


def _check_key(key: str, where: str) -> str:
    key = key.strip()
    if not key or not all(part.strip() for part in key.split(".")):
        raise SweepError(f"{where}: expected a scene key such as section.thickness, got {key!r}")
    return key


def parse_param(item: str) -> tuple[str, list[str]]:
    """``KEY=V1,V2,...`` -> (KEY, [V1, V2, ...])."""
    key, sep, text = item.partition("=")
    if not sep:
        raise SweepError(f"--param {item}: expected KEY=V1,V2,..., e.g. section.thickness=0.8,1.0,1.2")
    key = _check_key(key, f"--param {item}")
    values = split_values(text)
    if any(not v for v in values):
        raise SweepError(f"--param {item}: an empty value (two commas, or one at an end)")
    if len(set(values)) != len(values):
        raise SweepError(f"--param {item}: a value is given twice")
    return key, values


def read_cases_file(path: Path) -> tuple[list[str], list[tuple[str | None, dict[str, str]]]]:
    """The keys (columns but ``case``) and rows (name or None, {key: value}) of a cases CSV."""
    try:
        with open(path, newline="") as fh:
            rows = list(csv.reader(fh))
    except OSError as exc:
        raise SweepError(f"--cases {path}: cannot read the file ({exc.strerror or exc})") from None
    except (UnicodeDecodeError, csv.Error) as exc:
        raise SweepError(f"--cases {path}: not a CSV text file ({' '.join(str(exc).split())})") from None
    rows = [r for r in rows if any(cell.strip() for cell in r)]
    if len(rows) < 2:
        raise SweepError(f"--cases {path}: expected a header row of scene keys and at least one case")
    header = [h.strip() for h in rows[0]]
    for h in header:
        if h != NAME_COLUMN:
            _check_key(h, f"--cases {path}: header")
    if len(set(header)) != len(header):
        raise SweepError(f"--cases {path}: a column appears twice in the header")
    keys = [h for h in header if h != NAME_COLUMN]
    out = []
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise SweepError(f"--cases {path}: row {line} has {len(row)} cells, the header {len(header)}")
        cells = {h: c.strip() for h, c in zip(header, row)}
        name = cells.pop(NAME_COLUMN, "") or None
        out.append((name, {k: v for k, v in cells.items() if v}))
    return keys, out


def short_keys(keys: list[str]) -> dict[str, str]:
    """Each key's shortest dotted suffix that no other key ends with."""
    out = {}
    for key in keys:
        parts = key.split(".")
        for n in range(1, len(parts) + 1):
            suffix = ".".join(parts[-n:])
            if not any(k != key and (k == suffix or k.endswith("." + suffix)) for k in keys):
                break
        out[key] = suffix
    return out


def case_name(params: tuple[tuple[str, str], ...], short: dict[str, str]) -> str:
    raw = "__".join(f"{short[k]}={v}" for k, v in params) or "base"
    safe = _SAFE.sub("_", raw)
    if safe != raw or len(safe) > MAX_NAME:
        digest = hashlib.sha1("\n".join(f"{k}={v}" for k, v in params).encode()).hexdigest()[:8]
        safe = f"{safe[:MAX_NAME]}-{digest}"
    return safe


def _given_again(key: str, in_param: int, in_file: bool, cases_file: Path | None) -> str:
    """The error of a key given more than once: where its copies are (a --cases header names
    a column once at most, read_cases_file)."""
    column = f"a column of --cases {cases_file}"
    if in_param == 1:
        return f"{key}: given in --param and as {column}; give it in one of them"
    times = "twice" if in_param == 2 else f"{in_param} times"
    return (f"--param {key}: given {times} in --param" + (f" and as {column}" if in_file else "")
            + f"; give each key once, with all its values (--param {key}=V1,V2,...)")


def plan(params: list[str], cases_file: Path | None = None) -> tuple[list[str], list[SweepCase]]:
    """The study's keys (CSV columns first, then the --param keys) and its cases."""
    grid = [parse_param(p) for p in params]
    file_keys, file_rows = read_cases_file(cases_file) if cases_file is not None else ([], [(None, {})])
    keys = file_keys + [k for k, _ in grid]
    if len(set(keys)) != len(keys):
        raise SweepError([_given_again(k, [g for g, _ in grid].count(k), k in file_keys, cases_file)
                          for k in dict.fromkeys(keys) if keys.count(k) > 1])
    if not keys:
        raise SweepError("nothing to sweep: give --param KEY=V1,V2,... or --cases FILE")
    short = short_keys(keys)
    cases, seen = [], {}
    for name, values in file_rows:
        for combo in itertools.product(*(vals for _, vals in grid)):
            p = tuple((k, values[k]) for k in file_keys if k in values) + tuple(
                (k, v) for (k, _), v in zip(grid, combo))
            label = case_name(p, short)
            if name is not None:
                if _SAFE.search(name):
                    raise SweepError(f"--cases {cases_file}: case name {name!r}: use letters, digits and ._=+- only")
                label = name if not grid else f"{name}__{case_name(p[len(p) - len(grid):], short)}"
            if label in seen:
                raise SweepError(f"case {label}: appears twice (identical values or names)")
            seen[label] = True
            cases.append(SweepCase(label, p))
    return keys, cases
