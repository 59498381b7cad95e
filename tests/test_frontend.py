"""taichi_shell_mpm.frontend: the remembered pieces of Taichi's frontend answer exactly as
Taichi's own (the IR and the offline cache's keys depend on them)."""
from __future__ import annotations

import textwrap

import taichi as ti
from taichi.lang import _wrap_inspect

from taichi_shell_mpm import frontend

LINES = ["        x = self.s.nodes.position[c] + dt * v", "", "   ", "\tif a:\t# tab", "y = 1  " * 30,
         " " * 12 + "^" * 90 + "   ", "word " * 40 + "end"]


def test_remembering_wrapper_wraps_as_textwrap():
    for width in (80, 20):
        for text in LINES * 2:        # the second pass answers from the memo
            got = frontend.RememberingWrapper(width=width).wrap(text)
            assert got == textwrap.TextWrapper(width=width).wrap(text)
            got.append("changed by the caller")
            assert frontend.RememberingWrapper(width=width).wrap(text) == textwrap.TextWrapper(width=width).wrap(text)


def _sample(a, b):          # Taichi reads a ti.func's source from the function it wraps
    c = a + b        # a comment
    return c * 2


def test_remembered_sources_match_inspect():
    sourcefile, sourcelines = frontend.remembered_sources(_wrap_inspect.getsourcefile, _wrap_inspect.getsourcelines)
    for _ in range(2):
        src, start = sourcelines(_sample)
        assert (src, start) == _wrap_inspect.getsourcelines(_sample)
        src.append("changed by the caller")
    assert sourcefile(test_remembered_sources_match_inspect) == _wrap_inspect.getsourcefile(
        test_remembered_sources_match_inspect)


def test_installed_for_the_taichi_it_was_measured_with():
    assert frontend.speed_up() == (ti.__version__[:2] == frontend.MEASURED_WITH)
    assert frontend.speed_up() == (ti.__version__[:2] == frontend.MEASURED_WITH)     # idempotent
