"""Scene keys: how one is declared, and the checks (validators) a declaration names (the
tables of scene/ and the material models of laws/ declare their keys with them).

A key is declared once, as a field of its table's frozen dataclass::

    E: float = key(positive, "Young's modulus", unit="stress")

(or, for a table whose keys are not the fields of what it builds, as a :class:`Key` in a
tuple).  The declaration gives the check, the default (none: required), the unit, the
one-line meaning, an example and, where a cross-key rule says more than the check, the
"allowed" and "default" texts; from it come the parser's checks (scene/reader.py), the key
tables of docs/scenes.md and the JSON Schema (scene/schema.py).  It imports nothing of the
package, so that any layer may declare keys.

A check converts one TOML value (ints -> float for real quantities, arrays -> tuples) or
raises :class:`Invalid` with the ``<problem>`` part of the one-line message; it also says
what it accepts, as the docs' type and allowed columns and as a JSON Schema fragment.
"""
from __future__ import annotations

import difflib
import json
import math
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import MISSING, dataclass, field, fields, make_dataclass, replace
from functools import cache
from typing import Any

import numpy as np

Vec3 = tuple[float, float, float]
DOFS = ("ux", "uy", "uz", "rx", "ry", "rz")

TOML_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")
SAFE_FILE_NAME = re.compile(r"(?!\.+$)[A-Za-z0-9_.-]+")
IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


class Invalid(Exception):
    """A check's complaint: the ``<problem>`` part of one message."""


# ================================================================ checks
@dataclass(frozen=True)
class Check:
    """A validator with what it accepts.

    `convert(value)` returns the value converted or raises Invalid.  A check of a name that
    only the whole scene can resolve (a node set, a curve, a file relative to the scene)
    has `context`: the scene reader's method that does it (its name, scene/reader.py) or a
    function of (reader, value).
    """
    convert: Callable[[Any], Any] | None
    type: str
    """The docs' type column ("number", "integer", "string", "bool", "vector", ...)."""
    allowed: str = ""
    """The docs' allowed column (markdown)."""
    schema: dict = field(default_factory=dict)
    """JSON Schema of the accepted values."""
    context: str | Callable[[Any, Any], Any] | None = None

    def __call__(self, value: Any) -> Any:
        return self.convert(value)


def one_line(text: object) -> str:
    """`text` with its whitespace runs (newlines included) collapsed to single spaces."""
    return " ".join(str(text).split())


def show(value: Any) -> str:
    """A short single-line rendering of a user's value, TOML-flavoured."""
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, bool):
        return "true" if value else "false"
    text = f"[{', '.join(map(show, value))}]" if isinstance(value, list) else repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def key_path(name: str) -> str:
    """`name` as it appears in a key path: bare if TOML allows, else quoted."""
    return name if TOML_BARE_KEY.fullmatch(name) else json.dumps(name)


def did_you_mean(word: str, options: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest of `options`, or ""."""
    close = difflib.get_close_matches(word, list(options), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def hint(word: str, options: Sequence[str], label: str) -> str:
    """A did-you-mean for `word`, or else the list of `options` under `label`."""
    if not options:
        return f" (none {label})"
    shown = [o if o.isprintable() else repr(o) for o in options]      # a mistyped name stays on one line
    return did_you_mean(word, options) or f" ({label}: {', '.join(shown)})"


def is_number(value: Any) -> bool:
    """A finite TOML integer or float (booleans are not numbers)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


NUMBER_ARRAY = {"type": "array", "items": {"type": "number"}}


def _ranged(what: str, kind: str, accepts: Callable[[Any], bool], convert: Callable[[Any], Any],
            lo: float | None, hi: float | None, lo_open: bool, hi_open: bool) -> Check:
    """A check of `what` (e.g. 'a number') within [lo, hi], ends open as flagged."""
    if lo is not None and hi is not None:
        bounds = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
    elif lo is not None:
        bounds = f"{'>' if lo_open else '>='} {lo:g}"
    elif hi is not None:
        bounds = f"{'<' if hi_open else '<='} {hi:g}"
    else:
        bounds = ""
    schema: dict[str, Any] = {"type": kind}
    if lo is not None:
        schema["exclusiveMinimum" if lo_open else "minimum"] = lo
    if hi is not None:
        schema["exclusiveMaximum" if hi_open else "maximum"] = hi
    suffix = f" in {bounds}" if lo is not None and hi is not None else f" {bounds}" if bounds else ""

    def check(value: Any) -> Any:
        if accepts(value) and (lo is None or value > lo or (value == lo and not lo_open)) \
                and (hi is None or value < hi or (value == hi and not hi_open)):
            return convert(value)
        raise Invalid(f"expected {what}{suffix}, got {show(value)}")
    return Check(check, kind, bounds, schema)


def number(lo: float | None = None, hi: float | None = None, *,
           lo_open: bool = False, hi_open: bool = False) -> Check:
    """Finite real number (ints accepted, returned as float) within the given bounds."""
    what = "a number" if lo is not None or hi is not None else "a finite number"
    return _ranged(what, "number", is_number, float, lo, hi, lo_open, hi_open)


def integer(lo: int, hi: int | None = None) -> Check:
    """Integer in [lo, hi] (floats such as 3.0 are rejected)."""
    return _ranged("an integer", "integer", is_int, int, lo, hi, False, False)


positive = number(0, lo_open=True)
non_negative = number(0)
fraction = number(0, 1, lo_open=True)        # (0, 1]
unit_interval = number(0, 1)                  # [0, 1]


def _target_dt(value: Any) -> float | str:
    if value == "auto" or (is_number(value) and value > 0):
        return value if isinstance(value, str) else float(value)
    raise Invalid(f'expected a number > 0 or "auto", got {show(value)}')


target_dt = Check(_target_dt, "number or string", '> 0, or `"auto"`',
                  {"anyOf": [{"type": "number", "exclusiveMinimum": 0}, {"const": "auto"}]})
"""A step > 0, or "auto" (mass scaling's target step)."""


def _nonzero(value: Any) -> float:
    if is_number(value) and value != 0:
        return float(value)
    raise Invalid(f"expected a non-zero finite number, got {show(value)}")


nonzero = Check(_nonzero, "number", "≠ 0", {"type": "number", "not": {"const": 0}})


def _bool(value: Any) -> bool:
    if isinstance(value, bool):
        return value
    raise Invalid(f"expected true or false, got {show(value)}")


boolean = Check(_bool, "bool", "", {"type": "boolean"})


def _true(value: Any) -> bool:
    if value is True:
        return value
    raise Invalid(f"expected true, got {show(value)}")


true = Check(_true, "bool", "`true`", {"const": True})


def _text(value: Any) -> str:
    if isinstance(value, str):
        return value
    raise Invalid(f"expected a string, got {show(value)}")


text = Check(_text, "string", "", {"type": "string"})


def _nonempty(value: Any) -> str:
    if isinstance(value, str) and value.strip():
        return value
    raise Invalid(f"expected a non-empty string, got {show(value)}")


nonempty = Check(_nonempty, "string", "non-empty", {"type": "string", "minLength": 1})


def matching(pattern: re.Pattern, what: str, allowed: str) -> Check:
    """String that fully matches `pattern`, described as `what` in messages."""
    def check(value: Any) -> str:
        if isinstance(value, str) and pattern.fullmatch(value):
            return value
        raise Invalid(f"expected {what}, got {show(value)}")
    return Check(check, "string", allowed, {"type": "string", "pattern": f"^{pattern.pattern}$"})


file_name = matching(SAFE_FILE_NAME, "a file name made of letters, digits, '_', '.', '-'",
                     "letters, digits, `_ . -` (not only dots)")
identifier = matching(IDENTIFIER, "an identifier (letters, digits, '_'; not starting with a digit)",
                      "an identifier")


def choice(*options: str) -> Check:
    """One of the strings `options`."""
    def check(value: Any) -> str:
        if isinstance(value, str) and value in options:
            return value
        suggestion = did_you_mean(value, options) if isinstance(value, str) else ""
        raise Invalid(f"expected one of {', '.join(options)}, got {show(value)}{suggestion}")
    return Check(check, "string", ", ".join(f"`{o}`" for o in options), {"enum": list(options)})


def _vec3(value: Any) -> Vec3:
    if isinstance(value, list) and len(value) == 3 and all(map(is_number, value)):
        return tuple(float(c) for c in value)
    raise Invalid(f"expected 3 finite numbers [x, y, z], got {show(value)}")


VEC3_SCHEMA = {**NUMBER_ARRAY, "minItems": 3, "maxItems": 3}
vec3 = Check(_vec3, "vector", "", VEC3_SCHEMA)
"""Exactly three finite numbers, as a float tuple."""


def _nonzero_vec3(value: Any) -> Vec3:
    vec = _vec3(value)
    if not any(vec):
        raise Invalid("expected a non-zero vector, got [0, 0, 0]")
    return vec


nonzero_vec3 = Check(_nonzero_vec3, "vector", "non-zero", VEC3_SCHEMA)


def _size2(value: Any) -> tuple[float, float]:
    if not (isinstance(value, list) and len(value) == 2 and all(is_number(x) and x > 0 for x in value)):
        raise Invalid(f"expected two positive numbers [a, b], got {show(value)}")
    return float(value[0]), float(value[1])


size2 = Check(_size2, "[a, b]", "> 0 each",
              {"type": "array", "items": {"type": "number", "exclusiveMinimum": 0}, "minItems": 2, "maxItems": 2})


def dof_list(allow_all: bool) -> Check:
    """Non-empty list of distinct DOF names (or the string "all" when `allow_all`)."""
    expected = f"a non-empty list of DOFs (some of {', '.join(DOFS)})" + (' or "all"' if allow_all else "")

    def check(value: Any) -> tuple[str, ...]:
        if allow_all and value == "all":
            return DOFS
        if not isinstance(value, list) or not value:
            raise Invalid(f"expected {expected}, got {show(value)}")
        for i, dof in enumerate(value):
            if dof not in DOFS:
                raise Invalid(f"unknown DOF {show(dof)} (expected some of {', '.join(DOFS)})")
            if dof in value[:i]:
                raise Invalid(f"DOF {dof!r} is given twice")
        return tuple(value)
    listed = {"type": "array", "items": {"enum": list(DOFS)}, "minItems": 1, "uniqueItems": True}
    return Check(check, "list of DOFs" + (', or `"all"`' if allow_all else ""),
                 "distinct DOFs" + ('; `"all"` = all six' if allow_all else ""),
                 {"anyOf": [listed, {"const": "all"}]} if allow_all else listed)


def inertia_tensor(entries: Sequence[float]) -> np.ndarray:
    """The 3 x 3 tensor of a scene's inertia entries (see `inertia`); () is zero."""
    out = np.zeros((3, 3))
    if entries:
        out[np.diag_indices(3)] = entries[:3]
    if len(entries) == 6:
        for (i, j), c in zip(((0, 1), (1, 2), (2, 0)), entries[3:]):
            out[i, j] = out[j, i] = c
    return out


def _inertia(value: Any) -> tuple[float, ...]:
    if not (isinstance(value, list) and len(value) in (3, 6) and all(map(is_number, value))):
        raise Invalid(f"expected 3 numbers [Ixx, Iyy, Izz] or 6 [Ixx, Iyy, Izz, Ixy, Iyz, Izx], got {show(value)}")
    out = tuple(float(c) for c in value)
    if float(np.linalg.eigvalsh(inertia_tensor(out)).min()) < -1e-12 * max(abs(c) for c in out):
        raise Invalid(f"not positive semi-definite: {show(value)}")
    return out


inertia = Check(_inertia, "list of 3 or 6 numbers", "positive semi-definite",
                {**NUMBER_ARRAY, "minItems": 3, "maxItems": 6})
"""An inertia tensor: [Ixx, Iyy, Izz] or [Ixx, Iyy, Izz, Ixy, Iyz, Izx] (its entries, so
Ixy = -sum m x y), symmetric positive semi-definite."""


def _indices(what: str) -> Check:
    def check(value: Any) -> tuple[int, ...]:
        if isinstance(value, list) and value and all(is_int(i) and i >= 0 for i in value):
            return tuple(value)
        raise Invalid(f"expected a non-empty list of {what} indices >= 0, got {show(value)}")
    return Check(check, "list of integers", ">= 0",
                 {"type": "array", "items": {"type": "integer", "minimum": 0}, "minItems": 1})


element_ids = _indices("element")
node_ids = _indices("node")


def _window(value: Any) -> tuple[float, float]:
    if isinstance(value, list) and len(value) == 2 and all(map(is_number, value)) and 0 <= value[0] < value[1]:
        return (float(value[0]), float(value[1]))
    raise Invalid(f"expected [from, to] with 0 <= from < to, got {show(value)}")


window = Check(_window, "[from, to]", "0 <= from < to", {**NUMBER_ARRAY, "minItems": 2, "maxItems": 2})


def _numbers(value: Any) -> tuple[float, ...]:
    if is_number(value):
        return (float(value),)
    if isinstance(value, list) and value and all(map(is_number, value)):
        return tuple(float(x) for x in value)
    raise Invalid(f"expected a finite number or a non-empty list of them, got {show(value)}")


numbers = Check(_numbers, "number or list", "",
                {"anyOf": [{"type": "number"}, {**NUMBER_ARRAY, "minItems": 1}]})
"""A finite number or a non-empty list of them, as a tuple."""


def increasing(points: tuple[tuple[float, float], ...]) -> tuple[tuple[float, float], ...]:
    for (t0, _), (t1, _) in zip(points, points[1:]):
        if t1 <= t0:
            raise Invalid(f"expected strictly increasing t, got t = {t0:g} then {t1:g}")
    return points


PAIRS = {"type": "array", "items": {**NUMBER_ARRAY, "minItems": 2, "maxItems": 2}, "minItems": 1}


def _time_curve_points(value: Any) -> tuple[tuple[float, float], ...]:
    if not (isinstance(value, list) and value and all(isinstance(p, list) and len(p) == 2 and all(map(is_number, p))
                                                      for p in value)):
        raise Invalid(f"expected a non-empty list of [t, f] pairs of finite numbers, got {show(value)}")
    return increasing(tuple((float(t), float(f)) for t, f in value))


time_curve_points = Check(_time_curve_points, "list of `[t, f]`", "t strictly increasing", PAIRS)


def _times(value: Any) -> tuple[float, ...]:
    if not (isinstance(value, list) and all(is_number(t) and t >= 0 for t in value)):
        raise Invalid(f"expected a list of numbers >= 0, got {show(value)}")
    if any(a >= b for a, b in zip(value, value[1:])):
        raise Invalid(f"expected strictly increasing times, got {show(value)}")
    return tuple(float(t) for t in value)


times = Check(_times, "list of numbers", ">= 0, strictly increasing",
              {"type": "array", "items": {"type": "number", "minimum": 0}})


def curve_points(points: Sequence[tuple[float, float]], where: Callable[[int], str]) -> tuple[tuple[float, float], ...]:
    """A hardening curve's (plastic strain, yield stress) points, checked: from plastic strain 0,
    strictly increasing, yield stress > 0 and non-decreasing (the return map brackets its root
    with a flow stress that does not fall, method.md 3.4).  `where(i)` names point i in messages."""
    if not points:
        raise Invalid("expected at least one [plastic strain, yield stress] point, got none")
    if points[0][0] != 0.0:
        raise Invalid(f"{where(0)}: expected plastic strain 0 (the initial yield stress), got {points[0][0]:g}")
    for i, (eps, sig) in enumerate(points):
        if sig <= 0.0:
            raise Invalid(f"{where(i)}: expected a yield stress > 0, got {sig:g}")
        if i and eps <= points[i - 1][0]:
            raise Invalid(f"{where(i)}: expected a plastic strain above the previous point's {points[i - 1][0]:g}, "
                          f"got {eps:g}")
        if i and sig < points[i - 1][1]:
            raise Invalid(f"{where(i)}: the yield stress falls ({points[i - 1][1]:g} -> {sig:g}): softening "
                          "curves are not supported")
    return tuple(points)


def _hardening_curve(value: Any) -> tuple[tuple[float, float], ...]:
    if not (isinstance(value, list) and value and all(isinstance(row, list) and len(row) == 2
                                                      and all(map(is_number, row)) for row in value)):
        raise Invalid(f"expected a list of [plastic strain, yield stress] pairs, got {show(value)}")
    return curve_points([(float(a), float(b)) for a, b in value], lambda i: f"point {i + 1}")


hardening_curve = Check(_hardening_curve, "list of `[ε̄ᵖ, σ_y]`", "see below", PAIRS)
"""A list of [plastic strain, yield stress] pairs (curve_points)."""


def contextual(name: str, type_: str, allowed: str, schema: dict) -> Check:
    """A check that the scene reader's method `name` does (it needs the whole scene)."""
    return Check(None, type_, allowed, schema, context=name)


node_set = contextual("nodes", "string", "a defined node set or `all`", {"type": "string"})
curve_name = contextual("curve_name", "string", "a `[curves.NAME]`", {"type": "string"})
scene_file = contextual("file", "string", "an existing file", {"type": "string"})


# ================================================================ declarations
class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED: Any = _Required()
"""The default of a key without one (dataclasses' own MISSING cannot be a field default)."""


@dataclass(frozen=True)
class Key:
    """One scene key: its check, default (REQUIRED: none), unit, meaning and example;
    `allowed` and `default_text` replace the docs' columns the check and the default would
    give, where a cross-key rule says more (e.g. "required for `swift`")."""
    name: str
    check: Check
    doc: str
    default: Any = REQUIRED
    unit: str = ""
    example: Any = None
    allowed: str | None = None
    default_text: str | None = None

    @property
    def required(self) -> bool:
        return self.default is REQUIRED


def key(check: Check, doc: str, *, default: Any = REQUIRED, unit: str = "", example: Any = None,
        allowed: str | None = None, default_text: str | None = None) -> Any:
    """A dataclass field that is a scene key (see the module docstring)."""
    declared = Key("", check, doc, default, unit, example, allowed, default_text)
    if default is REQUIRED:
        return field(metadata={"key": declared})
    return field(default=default, metadata={"key": declared})


@cache
def keys_of(cls: type) -> dict[str, Key]:
    """The scene keys declared as fields of the dataclass `cls`, by name, in order."""
    return {f.name: replace(f.metadata["key"], name=f.name) for f in fields(cls) if "key" in f.metadata}


def extended(base: type, name: str, module: str, declared: dict[str, Key], doc: str) -> type:
    """The frozen dataclass `name` (of `module`): `base`'s fields and one more per key of
    `declared` (keys that plug-ins declare in their own files: a law's, a tool kind's), each
    with its default; a key read by keys_of like any other."""
    cls = make_dataclass(name, [(n, Any, field(default=k.default, metadata={"key": k})) for n, k in declared.items()],
                         bases=(base,), frozen=True)
    cls.__module__, cls.__qualname__, cls.__doc__ = module, name, doc
    return cls


def keys(*declared: Key) -> dict[str, Key]:
    """A table's keys declared apart from a dataclass (its values build something else)."""
    return {k.name: k for k in declared}


def field_defaults(cls: type) -> dict[str, Any]:
    """The defaults of `cls`'s fields that have one."""
    return {f.name: f.default for f in fields(cls) if f.default is not MISSING}




def number_text(value: float) -> str:
    """A default as the docs write it: 0.05, 500000, 1e-4."""
    if isinstance(value, float) and value != 0 and abs(value) < 0.01:
        mantissa, exponent = f"{value:e}".split("e")
        return f"{float(mantissa):g}e{int(exponent)}"
    return repr(value)


def shown_default(value: Any) -> str:
    """The docs' default column for a declared default."""
    if value is REQUIRED:
        return "required"
    if value is None:
        return "none"
    if isinstance(value, bool):
        return f"`{'true' if value else 'false'}`"
    if isinstance(value, str):
        return f'`"{value}"`'
    if isinstance(value, (int, float)):
        return f"`{number_text(value)}`"
    if isinstance(value, tuple):
        return "`[" + ", ".join(f"{x:g}" if isinstance(x, float) else str(x) for x in value) + "]`"
    return f"`{value}`"


BOX_KEYS = keys(Key("min", vec3, "the corner with the smallest coordinates", unit="length"),
                Key("max", vec3, "the corner with the largest coordinates", unit="length"))
"""A box {min = [x, y, z], max = [x, y, z]} (node and element sets): its keys."""
BOX = Check(None, "table", "`{min = [x, y, z], max = [x, y, z]}`, `min` <= `max` in every component",
            {"type": "object", "properties": {"min": VEC3_SCHEMA, "max": VEC3_SCHEMA}, "required": ["min", "max"],
             "additionalProperties": False})
"""A box as the value of a selector key (read with BOX_KEYS by its table's reader)."""
