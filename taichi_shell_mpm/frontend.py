"""Taichi 1.7's frontend made faster, with the same result [choice, issue 17].

Every process turns each kernel it launches from Python source into Taichi IR (the offline
cache is keyed by that IR, so a cached kernel is built again before it is loaded): for the
tube's step kernel, ~640 inlined ti.func calls and ~48 000 AST nodes, 1.9-2.2 CPU seconds,
most of a cached run's compile time.  Two parts of it repeat work whose result cannot change
within a process, and are remembered here:

* the source of a ti.func is read again at every call site (``inspect.getsourcelines``
  tokenizes the whole module up to it; 0.5-0.7 s for the step kernel);
* the position text of every AST node (``ASTTransformerContext.get_pos_info``, kept with the
  IR for error messages) wraps the source line and a caret line to 80 columns with a new
  ``textwrap.TextWrapper`` (~100 000 wraps of a few thousand distinct lines; 0.4-0.8 s).

The functions Taichi calls are replaced by ones that remember their answers (pure functions
of their arguments, the sources being read once per process).  The IR is the same, and so
are the offline cache's keys (tests/test_frontend.py compares a kernel's key with and
without the patch).

A third is not a kernel's: every field and SNode Taichi creates keeps the whole Python stack
of its declaration as text (``util.get_traceback``: ``traceback.extract_stack`` and the source
line of each frame, read through ``linecache``), shown only in an error about that field (one
that was never placed).  A State makes ~380 fields and ~1 700 such texts; in a fresh process
the first reads every source file on the stack.  :func:`declaration_site` keeps the one frame
that declared it instead (measured: docs/performance.md "Field declarations").

Private names are used only where they were measured [issue 28]: :func:`private_api`
allows them on the exact Taichi release tested (TESTED_WITH) unless the environment sets
``TAICHI_SHELL_MPM_NO_FRONTEND_PATCH=1``; on any other release, or when a private module or
name is missing, Taichi's own public path is taken (the frontend unpatched; in
solvers/stepper.load_kernel, the kernels compiled at their first launch).
"""
from __future__ import annotations

import linecache
import os
import sys
import textwrap

import taichi as ti

TESTED_WITH = (1, 7, 4)       # the Taichi release whose private names are used
NO_PATCH_ENV = "TAICHI_SHELL_MPM_NO_FRONTEND_PATCH"


def private_api() -> bool:
    """Whether Taichi's private names may be used: the tested release, and not switched off
    by ``TAICHI_SHELL_MPM_NO_FRONTEND_PATCH`` (any value but "", "0")."""
    return tuple(ti.__version__) == TESTED_WITH and os.environ.get(NO_PATCH_ENV, "") in ("", "0")


class RememberingWrapper(textwrap.TextWrapper):
    """``textwrap.TextWrapper(width=...)`` whose ``wrap`` remembers its results."""
    memo: dict[tuple[int, str], list[str]] = {}

    def __init__(self, width: int = 70):          # get_pos_info sets the width only
        super().__init__(width=width)

    def wrap(self, text: str) -> list[str]:
        key = (self.width, text)
        lines = self.memo.get(key)
        if lines is None:
            lines = self.memo[key] = super().wrap(text)
        return list(lines)


def remembered_sources(getsourcefile, getsourcelines):
    """``getsourcefile``/``getsourcelines`` that read each function's source once."""
    files, lines = {}, {}

    def sourcefile(func):
        if func not in files:
            files[func] = getsourcefile(func)
        return files[func]

    def sourcelines(func):
        if func not in lines:
            lines[func] = getsourcelines(func)
        src, start = lines[func]
        return list(src), start

    return sourcefile, sourcelines


def declaration_site(stacklevel: int = 1) -> str:
    """What ``taichi.lang.util.get_traceback(stacklevel)`` answers, cut to its last frame (the
    line that declared the field or SNode: its place and source line, as ``traceback`` formats
    them; only that one file is read)."""
    try:
        frame = sys._getframe(stacklevel + 1)
    except ValueError:            # a stack shallower than that: get_traceback's slice is empty
        return ""
    code = frame.f_code
    line = linecache.getline(code.co_filename, frame.f_lineno).strip()
    return f'  File "{code.co_filename}", line {frame.f_lineno}, in {code.co_name}\n' + (f"    {line}\n" if line else "")


TRACEBACK_USERS = ("impl", "snode", "matrix", "_ndarray")   # taichi.lang modules that import get_traceback


def speed_up() -> bool:
    """Install the three in Taichi's frontend (once; returns whether they are installed): only
    when :func:`private_api` allows it and the private modules and names are all there."""
    if not private_api():
        return False
    try:
        import importlib

        from taichi.lang import kernel_impl, util
        from taichi.lang.ast import ast_transformer_utils as utils
        wrapper, sourcefile, sourcelines = utils.TextWrapper, kernel_impl.getsourcefile, kernel_impl.getsourcelines
        users = [importlib.import_module(f"taichi.lang.{name}") for name in TRACEBACK_USERS]
        if not all(getattr(m, "get_traceback", None) in (util.get_traceback, declaration_site) for m in users):
            return False
    except (ImportError, AttributeError):
        return False
    if wrapper is textwrap.TextWrapper:
        utils.TextWrapper = RememberingWrapper
        kernel_impl.getsourcefile, kernel_impl.getsourcelines = remembered_sources(sourcefile, sourcelines)
        for module in users:
            module.get_traceback = declaration_site
    return utils.TextWrapper is RememberingWrapper
