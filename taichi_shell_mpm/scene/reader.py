"""The scene reader: reports problems as one-line messages and checks the keys a table declares."""
from __future__ import annotations

import csv
from collections.abc import Callable, Sequence
from dataclasses import MISSING, fields
from functools import partial
from pathlib import Path
from typing import Any

from ..keys import (
    DOFS,
    TOML_BARE_KEY,
    Check,
    Invalid,
    Key,
    Vec3,
    field_defaults,
    hint,
    key_path,
    keys_of,
    nonempty,
    one_line,
    show,
)

TABLES = ("scene", "mesh", "material", "section", "materials", "sections", "elementsets", "part", "element",
          "method", "nodesets", "boundary", "load", "initial", "probe", "reference", "solve", "output",
          "rigid_body", "point_mass", "wall", "tool", "contact", "crush",
          "contact_pair", "curves", "motion", "pressure", "gravity", "tie", "spotweld")
"""The top-level tables of a scene (each read by its module, scene/<table>.py)."""
REQUIRED_TABLES = ("scene", "mesh", "solve")


class Reader:
    """Validates one raw scene document, collecting every problem as a message line.

    The table readers (scene/<table>.py) return the built dataclass, or None when the table
    had a problem (already reported); cross-checks only look at values that passed their own
    check, so one mistake is reported once.
    """

    def __init__(self, raw: dict, source: Path):
        self.raw = raw
        self.source = source.resolve()
        self.file_name = source.name
        self.messages: list[str] = []
        sets = raw.get("nodesets")
        self.nodeset_names = sorted({"all", *(sets if isinstance(sets, dict) else ())})
        curves = raw.get("curves")
        self.curve_names = sorted(curves) if isinstance(curves, dict) else []
        self.recorded: dict[str, tuple[str, ...] | None] = {}
        """Probe name -> recorded components (None when those were invalid)."""

    def error(self, path: str, problem: str) -> None:
        self.messages.append(f"{self.file_name}: {path}: {problem}")

    def check(self, path: str, validator: Check | Key | Callable[[Any], Any], value: Any) -> Any:
        """validator(value), or None after reporting its problem at `path`.  A declared key's
        check that needs the scene (its `context`) is this reader's method of that name."""
        if isinstance(validator, Key):
            validator = validator.check
        if isinstance(validator, Check) and validator.context is not None:
            context = validator.context
            validator = getattr(self, context) if isinstance(context, str) else partial(context, self)
        try:
            return validator(value)
        except Invalid as exc:
            self.error(path, str(exc))
            return None

    def read(self, path: str, data: Any, spec: dict[str, Key], cls: type | None = None,
             required: Sequence[str] = (), extra: Sequence[str] = ()) -> dict | None:
        """Check the table `data` at `path` against the declared keys `spec` (keys_of(cls), or
        a table's own declarations).

        Reports unknown keys (in neither `spec` nor `extra`, which the caller reads) and
        missing required keys: `required`, or with `cls` its fields without a default.
        Returns the valid values over `cls`'s defaults (an invalid key is left out), or
        None if `data` is not a table.
        """
        if not isinstance(data, dict):
            self.error(path, f"expected a table, got {show(data)}")
            return None
        values = {}
        if cls is not None:
            values = field_defaults(cls)
            required = [f.name for f in fields(cls) if f.default is MISSING and f.name in spec]
        for key, value in data.items():
            if key in spec:
                result = self.check(f"{path}.{key_path(key)}", spec[key], value)
                if result is None:
                    values.pop(key, None)
                else:
                    values[key] = result
            elif key not in extra:
                self.error(f"{path}.{key_path(key)}", "unknown key" + hint(key, [*spec, *extra], "allowed"))
        for key in required:
            if key not in data:
                self.error(f"{path}.{key}", "missing required key")
        return values

    def build(self, mark: int, cls: type, values: dict) -> Any:
        """cls(**values) if nothing was reported since message count `mark`, else None."""
        return cls(**values) if len(self.messages) == mark else None

    def table_object(self, path: str, data: Any, cls: type, spec: dict[str, Any] | None = None) -> Any:
        """A table without cross-checks, read straight into `cls` (its declared keys, or `spec`)."""
        mark = len(self.messages)
        values = self.read(path, data, keys_of(cls) if spec is None else spec, cls)
        return None if values is None else self.build(mark, cls, values)

    def entries(self, path: str, value: Any) -> list[tuple[str, Any]]:
        """(path, entry) pairs of the array of tables `value` (``[[x]][0]``, ...)."""
        if isinstance(value, list):
            return [(f"{path}[{i}]", item) for i, item in enumerate(value)]
        self.error(path, f"expected an array of tables ({path} sections), got {show(value)}")
        return []

    def part(self, key: str, reader: Callable[[Any], Any]) -> Any:
        """reader(the top-level table `key`); an absent optional table reads as {}."""
        if key in self.raw:
            return reader(self.raw[key])
        if key in REQUIRED_TABLES:
            self.error(f"[{key}]", "missing required table")
            return None
        return reader({})

    def array(self, key: str, reader: Callable[[str, Any], Any]) -> list:
        """reader(path, entry) for each entry of the top-level array of tables `key`."""
        return [reader(path, entry) for path, entry in self.entries(f"[[{key}]]", self.raw.get(key, []))]

    def check_order(self, path: str, lo: Vec3 | None, hi: Vec3 | None, names: tuple[str, str],
                    strict: bool) -> None:
        """Report unless lo < hi (`strict`) or lo <= hi in every component (skipped if unset)."""
        if lo is None or hi is None:
            return
        if any(a >= b if strict else a > b for a, b in zip(lo, hi)):
            relation = "<" if strict else "<="
            self.error(path, f"expected {names[0]} {relation} {names[1]} in every component, "
                             f"got {names[0]} = {show(list(lo))}, {names[1]} = {show(list(hi))}")

    def set_name(self, path: str, name: str, what: str, every: str) -> None:
        """A node or element set's NAME: not the predefined 'all' (`every` what it selects),
        letters, digits, '_' and '-' only."""
        if name == "all":
            self.error(path, f"the name 'all' is predefined ({every}); choose another name")
        elif not TOML_BARE_KEY.fullmatch(name):
            self.error(path, f"{what} name may contain only letters, digits, '_' and '-'")

    def named(self, key: str, reader) -> dict:
        """The [key.NAME] tables read by reader(path, data), by name (invalid ones left out)."""
        data = self.raw.get(key, {})
        if not isinstance(data, dict):
            self.error(f"[{key}]", f"expected tables [{key}.NAME], got {show(data)}")
            return {}
        out = {}
        for name, value in data.items():
            path = f"[{key}.{key_path(name)}]"
            if not TOML_BARE_KEY.fullmatch(name):
                self.error(path, "a name may contain only letters, digits, '_' and '-'")
                continue
            item = reader(path, value)
            if item is not None:
                out[name] = item
        return out

    def file(self, value: Any) -> Path:
        """An existing file, relative to the scene file's folder; returned absolute."""
        if not isinstance(value, str) or not value:
            raise Invalid(f"expected a file path (relative to the scene file), got {show(value)}")
        try:
            path = (self.source.parent / value).resolve()
            found, folder = path.is_file(), path.is_dir()
        except (OSError, ValueError):
            found = folder = False
        if folder:
            raise Invalid(f"expected a file, got the directory {str(self.source.parent / value)!r}")
        if not found:
            raise Invalid(f"file not found: {str(self.source.parent / value)!r}")
        return path

    def nodes(self, value: Any) -> str:
        """The name of a node set defined in [nodesets], or 'all'."""
        if not isinstance(value, str):
            raise Invalid(f"expected a node set name, got {show(value)}")
        if value not in self.nodeset_names:
            raise Invalid(f"unknown node set {value!r}" + hint(value, self.nodeset_names, "defined"))
        return value

    def curve_name(self, value: Any) -> str:
        """The name of a curve defined in [curves]."""
        if not isinstance(value, str):
            raise Invalid(f"expected a curve name, got {show(value)}")
        if value not in self.curve_names:
            raise Invalid(f"no [curves.{key_path(value)}]" + hint(value, self.curve_names, "defined"))
        return value

    def probe_component(self, value: Any) -> str:
        """'<probe>.<component>' naming a component that this probe records."""
        if not isinstance(value, str) or "." not in value:
            raise Invalid(f"expected '<probe>.<component>' (e.g. 'tip.uz'), got {show(value)}")
        name, _, component = value.rpartition(".")
        if name not in self.recorded:
            raise Invalid(f"unknown probe {name!r}" + hint(name, sorted(self.recorded), "defined"))
        if component not in DOFS:
            raise Invalid(f"unknown component {component!r} (expected one of {', '.join(DOFS)})")
        recorded = self.recorded[name]
        if recorded is not None and component not in recorded:
            raise Invalid(f"probe {name!r} does not record {component!r} "
                           f"(it records {', '.join(recorded)})")
        return value

    def csv_column(self, file: Path | None) -> Callable[[Any], str]:
        """Validator for a column name in the header row of the CSV `file`.

        Only non-emptiness is checked when `file` is None (already reported) or its
        header cannot be read (reported here, once).
        """
        if file is None:
            return nonempty
        try:
            with file.open(newline="", encoding="utf-8-sig") as f:
                header = [one_line(name) for name in next(csv.reader(f), [])]
        except (OSError, UnicodeDecodeError, csv.Error) as exc:
            self.error("[reference].file", f"cannot read its header row ({one_line(exc)})")
            return nonempty

        def check(value: Any) -> str:
            name = nonempty(value)
            if name not in header:
                raise Invalid(f"no column {name!r} in the header of {file.name}"
                               + hint(name, header, "columns"))
            return name
        return check
