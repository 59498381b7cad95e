"""taichi_shell_mpm.frontend: the remembered pieces of Taichi's frontend answer exactly as
Taichi's own (the IR and the offline cache's keys depend on them); the patch is installed
only on the tested Taichi release and not with TAICHI_SHELL_MPM_NO_FRONTEND_PATCH=1; a
kernel's offline-cache key is the same with and without it."""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

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


def test_installed_only_on_the_tested_taichi(monkeypatch):
    tested = tuple(ti.__version__) == frontend.TESTED_WITH
    monkeypatch.setenv(frontend.NO_PATCH_ENV, "1")
    assert not frontend.private_api()
    monkeypatch.delenv(frontend.NO_PATCH_ENV)
    assert frontend.private_api() == tested
    assert frontend.speed_up() == tested
    assert frontend.speed_up() == tested     # idempotent
    monkeypatch.setattr(ti, "__version__", (1, 7, 5))
    assert not frontend.private_api()        # another release: Taichi's own path


KERNEL = """
import os, sys
import taichi as ti
from taichi.lang import kernel_impl
from taichi_shell_mpm import frontend
print("patched", frontend.speed_up())
if os.environ.get("CHANGE_SOURCE"):          # the control: another source, another IR
    read = kernel_impl.getsourcelines
    kernel_impl.getsourcelines = lambda f: ([line.replace("a + a", "a * 3") for line in read(f)[0]], read(f)[1])
ti.init(arch=ti.cpu, offline_cache=True, offline_cache_file_path=sys.argv[1], log_level=ti.ERROR)
x = ti.field(ti.f64, shape=4)

@ti.func
def twice(a):
    b = a + a   # a comment
    return b

@ti.kernel
def fill():
    for i in x:
        x[i] = twice(i * 1.5)

fill()
ti.reset()                                  # writes the offline cache
"""


def cache_keys(tmp_path: Path, name: str, **env: str) -> tuple[str, set[str]]:
    """Run KERNEL in a new process (the patch is per process) with the offline cache in a
    folder of its own: its stdout and the keys of the kernels cached there."""
    folder, script = tmp_path / name, tmp_path / "kernel.py"      # Taichi reads the source from a file
    script.write_text(KERNEL)
    proc = subprocess.run([sys.executable, str(script), str(folder)], capture_output=True, text=True, timeout=300,
                          env={**os.environ, "ENABLE_TAICHI_HEADER_PRINT": "false", **env})
    assert proc.returncode == 0, proc.stderr
    return proc.stdout, {f.stem for f in folder.glob("*.tic")}


def test_offline_cache_key_is_the_same_with_and_without_the_patch(tmp_path):
    """A kernel with a ti.func is cached under one key (the file name of its .tic) with the
    patch and with TAICHI_SHELL_MPM_NO_FRONTEND_PATCH=1; the control, a changed source,
    gets another key (the key follows the source the frontend reads)."""
    with_patch, keys = cache_keys(tmp_path, "patched")
    without, keys_without = cache_keys(tmp_path, "unpatched", TAICHI_SHELL_MPM_NO_FRONTEND_PATCH="1")
    _, keys_changed = cache_keys(tmp_path, "changed", TAICHI_SHELL_MPM_NO_FRONTEND_PATCH="1", CHANGE_SOURCE="1")
    print(with_patch, without, keys, keys_without, keys_changed)
    assert f"patched {tuple(ti.__version__) == frontend.TESTED_WITH}" in with_patch and "patched False" in without
    assert len(keys) == 1 and keys == keys_without
    assert keys_changed and keys_changed != keys


def test_ir_optimization_runs_have_a_kernel_cache_of_their_own(monkeypatch):
    """$TAICHI_SHELL_MPM_IR_OPTIMIZATION=1 turns Taichi's IR optimizations back on for the CPU
    (docs/performance.md "Cold compile"); their kernels are cached beside, not over, the others."""
    from taichi_shell_mpm.runtime import ir_optimization, kernel_cache_dir
    monkeypatch.delenv("TAICHI_SHELL_MPM_IR_OPTIMIZATION", raising=False)
    plain = kernel_cache_dir()
    assert not ir_optimization() and not plain.endswith("-ir")
    monkeypatch.setenv("TAICHI_SHELL_MPM_IR_OPTIMIZATION", "1")
    assert ir_optimization() and kernel_cache_dir() == plain + "-ir"


def _declare(stacklevel):
    from taichi.lang import util
    return util.get_traceback(stacklevel), frontend.declaration_site(stacklevel)


def test_declaration_site_is_the_last_frame_of_the_traceback():
    """Taichi keeps the stack of each field's declaration as text (util.get_traceback); the
    patch keeps its last frame, the declaring line, in the same format; a stack shallower
    than asked gives nothing, as Taichi's slice does."""
    for level in (1, 2, 4):
        full, site = _declare(level)
        last = full[full.rindex('  File "'):].splitlines()
        assert site.splitlines() == last[:2] and len(last[0]) > 20, (site, last)
    assert frontend.declaration_site(10_000) == ""
    if frontend.speed_up():
        from taichi.lang import impl, snode
        assert impl.get_traceback is frontend.declaration_site is snode.get_traceback
