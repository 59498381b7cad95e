"""``*PARAMETER`` and ``*PARAMETER_EXPRESSION``: named values that other cards use as ``&name``.

A ``*PARAMETER`` card holds up to four pairs PRMRi VALi of 10 columns each (free format: the
pairs at the commas); PRMR is the type letter (R real, I integer, C character) followed by the
name (``R termt`` or ``Rtermt``).  A ``*PARAMETER_EXPRESSION`` card is PRMR (10 columns) and
an expression (columns 11-80; free format: after the comma) of numbers, other parameters (by
name, with or without ``&``), + - * / ** (and ^), parentheses and the functions below.  Names
are case-insensitive.  Every parameter of the deck (and of its includes) is known everywhere
in it [choice: LS-DYNA's *PARAMETER_LOCAL scoping is read as global; a name defined twice is
an error, so no card depends on which definition it would see].  A field ``&name`` (or
``-&name``) of any card is replaced by the value before the field is read (dyna/reader.read_card).

Expressions are evaluated with Python's ``ast`` restricted to those operations (never
``eval``); one that refers to itself through others (``a = b + 1``, ``b = 2 a``) is an error
naming its line.
"""
from __future__ import annotations

import ast
import math
import operator
from contextlib import contextmanager
from contextvars import ContextVar

from ..problems import SceneError

PARAMETER_KEYWORDS = ("PARAMETER", "PARAMETER_LOCAL", "PARAMETER_EXPRESSION", "PARAMETER_EXPRESSION_LOCAL")
"""The keywords read here (their blocks are not kept for the scene reader)."""

FUNCTIONS = {"sin": math.sin, "cos": math.cos, "tan": math.tan, "asin": math.asin, "acos": math.acos,
             "atan": math.atan, "atan2": math.atan2, "exp": math.exp, "log": math.log, "log10": math.log10,
             "sqrt": math.sqrt, "abs": abs, "min": min, "max": max, "int": int, "aint": math.trunc,
             "nint": round, "sign": math.copysign, "mod": math.fmod, "pi": None}
_OPERATORS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
              ast.Pow: operator.pow, ast.USub: operator.neg, ast.UAdd: operator.pos}

_VALUES: ContextVar[dict] = ContextVar("dyna_parameters", default={})


@contextmanager
def using(values: dict):
    """Cards read inside this block see the parameters `values` (name -> value)."""
    token = _VALUES.set(values)
    try:
        yield
    finally:
        _VALUES.reset(token)


def _at(line, keyword: str) -> str:
    return f"{line.file}:{line.number}: *{keyword}"


def substitute(text: str, line, keyword: str) -> str:
    """`text` with a reference ``&name`` / ``-&name`` replaced by the parameter's value."""
    if "&" not in text:
        return text
    negative = text.startswith("-")
    name = text.lstrip("+-").strip()
    if not name.startswith("&"):
        raise SceneError(f"{_at(line, keyword)}: {text!r}: a parameter reference is written &name (or -&name)")
    values = _VALUES.get()
    key = name[1:].strip().upper()
    if key not in values:
        known = ", ".join(sorted(values)[:8]) or "none defined"
        raise SceneError(f"{_at(line, keyword)}: parameter &{name[1:].strip()} is not defined by a *PARAMETER "
                         f"card (defined: {known})")
    value = values[key]
    if isinstance(value, str):
        raise SceneError(f"{_at(line, keyword)}: parameter &{name[1:].strip()} is a character parameter "
                         f"({value!r}); a number is expected here")
    return repr(-value if negative else value)


def read_parameters(blocks) -> dict:
    """name -> value of every *PARAMETER and *PARAMETER_EXPRESSION card of `blocks` (the
    deck's keyword blocks), expressions evaluated in the order they need."""
    plain, expressions, where = {}, {}, {}
    for block in blocks:
        if block.name not in PARAMETER_KEYWORDS:
            continue
        expression = "EXPRESSION" in block.name
        for line in block.cards:
            text = line.text.rstrip()
            if not text.strip():
                continue
            if "," in text:
                items = [t.strip() for t in text.split(",")]
            elif expression:
                items = [text[:10].strip(), text[10:80].strip()]
            else:
                items = [text[k:k + 10].strip() for k in range(0, min(len(text), 80), 10)]
            if expression:
                items = [items[0], ",".join(items[1:])]
            if len(items) % 2:
                items.append("")
            for k in range(0, len(items), 2):
                head, value = items[k], items[k + 1]
                if not head and not value:
                    continue
                kind, name = head[:1].upper(), head[1:].strip().upper()
                if kind not in ("R", "I", "C") or not name:
                    raise SceneError(f"{_at(line, block.name)}: {head!r}: expected a type letter R, I or C and a "
                                     "name (e.g. 'R termt')")
                if name in where:
                    raise SceneError(f"{_at(line, block.name)}: parameter {name} is defined twice (also on "
                                     f"{where[name].file}:{where[name].number})")
                where[name] = line
                if expression and kind != "C":
                    expressions[name] = (kind, value, line, block.name)
                elif kind == "C":
                    plain[name] = value
                else:
                    try:
                        number = float(value.replace("d", "e").replace("D", "e"))
                    except ValueError:
                        raise SceneError(f"{_at(line, block.name)}: parameter {name}: expected a number, "
                                         f"got {value!r}") from None
                    if not math.isfinite(number):
                        raise SceneError(f"{_at(line, block.name)}: parameter {name}: {value!r} is not finite")
                    plain[name] = _typed(kind, number, name, line, block.name)
    values = dict(plain)
    for name in expressions:
        _evaluate(name, expressions, values, ())
    return values


def _typed(kind: str, number: float, name: str, line, keyword: str):
    if kind == "I":
        if not float(number).is_integer():
            raise SceneError(f"{_at(line, keyword)}: integer parameter {name} = {number:g} is not a whole number")
        return int(number)
    return float(number)


def _evaluate(name: str, expressions: dict, values: dict, chain: tuple):
    if name in values:
        return values[name]
    kind, text, line, keyword = expressions[name]
    if name in chain:
        loop = " -> ".join((*chain[chain.index(name):], name))
        raise SceneError(f"{_at(line, keyword)}: parameter {name} refers to itself ({loop})")
    try:
        tree = ast.parse(text.replace("^", "**").replace("&", ""), mode="eval")
    except SyntaxError:
        raise SceneError(f"{_at(line, keyword)}: parameter {name}: cannot read the expression {text!r}") from None

    def value(node):
        if isinstance(node, ast.Expression):
            return value(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
            return node.value
        if isinstance(node, ast.BinOp) and type(node.op) in _OPERATORS:
            return _OPERATORS[type(node.op)](value(node.left), value(node.right))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _OPERATORS:
            return _OPERATORS[type(node.op)](value(node.operand))
        if isinstance(node, ast.Name):
            other = node.id.upper()
            if other == "PI":
                return math.pi
            if other in values or other in expressions:
                got = _evaluate(other, expressions, values, (*chain, name))
                if isinstance(got, str):
                    raise SceneError(f"{_at(line, keyword)}: parameter {name}: {node.id} is a character parameter")
                return got
            raise SceneError(f"{_at(line, keyword)}: parameter {name}: {node.id} is not a defined parameter")
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and \
                FUNCTIONS.get(node.func.id.lower()) is not None and not node.keywords:
            return FUNCTIONS[node.func.id.lower()](*(value(a) for a in node.args))
        raise SceneError(f"{_at(line, keyword)}: parameter {name}: {ast.unparse(node)!r} is not a number, a "
                         "parameter, + - * / ** or one of " + ", ".join(f for f in FUNCTIONS if f != "pi"))
    try:
        result = float(value(tree))
    except (ArithmeticError, ValueError, TypeError) as exc:
        raise SceneError(f"{_at(line, keyword)}: parameter {name}: {text!r} cannot be evaluated ({exc})") from None
    if not math.isfinite(result):
        raise SceneError(f"{_at(line, keyword)}: parameter {name}: {text!r} is not finite")
    values[name] = _typed(kind, result, name, line, keyword)
    return values[name]
