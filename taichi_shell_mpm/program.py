"""The live Taichi program: one run's state and step kernels, kept for the next run in the same
process when that run would build the very same kernels [choice, issue 32].

A run in a fresh program spends most of its start (1-2 s on 2 cores, the kernels cached) on
Taichi building each kernel's IR from its Python source again and loading the cached code
(frontend.py, docs/performance.md): the runs of a test file, an optimisation loop or a study
in one process mostly differ in values, not in what they compile.  So a run started with
``keep`` (api.py: explicit and relaxation runs; Newton builds fields of its own and always
starts afresh) leaves its program, its State and its Stepper alive, and the next such run

1. asks for the same program (runtime.init_taichi: same arch, threads, IR options); a
   different one starts afresh;
2. has the same features (config.Features);
3. has the same :meth:`State.layout` (every field's place, type and shape, the host's sizes:
   its State planned without making a field); a different layout starts afresh;
4. zeroes the live State (:meth:`State.clear`: the state Taichi allocates) and loads its model
   into it, then builds its Stepper on it and compares every Python value the kernels could
   read as a compile-time constant with those of the live Stepper when it was built, which
   its run must not have changed either (:func:`constants`); equal: the live Stepper, its
   kernels already built, steps the new model.

Anything unequal starts a fresh program, exactly as without reuse, so a run's results do not
depend on what ran before it in the process (tests/test_program.py: a run after another model's
run is byte-identical to the same run in a fresh program).  One State lives at a time: an
earlier :class:`~taichi_shell_mpm.simulation.Simulation` of the process is stale once a later
one starts, with or without reuse (a fresh program frees its fields).
"""
from __future__ import annotations

import hashlib
import sys
from dataclasses import dataclass

import numpy as np
import taichi as ti

from .config import Features
from .runtime import restart_taichi
from .solvers.stepper import Stepper
from .state import Group, State


@dataclass
class Live:
    """The kept run: the Taichi program it ran in, its features, its state and stepper, and the
    stepper's compile-time constants when it was built (:func:`constants`)."""
    program: object
    features: Features
    state: State
    stepper: Stepper
    constants: tuple


_live: Live | None = None
generation = 0          # counts the states handed out (api.Simulation: a stale one says so)


def current_program():
    return ti.lang.impl.get_runtime().prog


def reuse(cfg: Features, model) -> tuple[State, Stepper] | None:
    """The live state (cleared, `model` loaded) and stepper when the run of `model` with
    `cfg` would build the same kernels (module docstring), else None."""
    live = _live
    if live is None or live.program is not current_program() or live.features != cfg:
        return None
    if (len(model.points), len(model.elements)) != (live.state.n_nodes, live.state.n_elements):
        return None                 # (another mesh: another layout, State.layout)
    if constants(live.stepper) != live.constants:       # its run changed a value its kernels read
        return None
    if State(model, cfg, allocate=False).layout() != live.state.layout():     # (no field made)
        return None
    live.state.clear()
    live.state.load(model)
    if constants(Stepper(live.state, cfg, model)) != live.constants:
        return None
    return live.state, live.stepper


def release() -> None:
    """A fresh program for a run that cannot reuse the live one, unless Taichi's program holds
    no fields yet: in place of the live run's (its state and kernels freed, as every run did
    before reuse), and in place of one that another run left without keeping it (a Newton
    run, a Simulation made without `keep`).  Kernels built over fields a program already
    holds see other SNode ids than the offline cache keeps them under, and compile cold: in
    the test suite, 38 feature sets compiled again moments after their first compile (the
    rigid body of test_selective_mass's restart test 11.0 s instead of 3.4 s)."""
    if current_program().get_snode_tree_size() > 0:
        restart_taichi()


def keep(cfg: Features, state: State, stepper: Stepper) -> None:
    """Remember this run's program, state and stepper for the next run (module docstring)."""
    global _live
    _live = Live(current_program(), cfg, state, stepper, constants(stepper))


SIMPLE = (bool, int, float, complex, str, bytes, type(None))


def constants(stepper) -> tuple:
    """Every value a kernel of `stepper` could read as a compile-time constant: the attributes
    of its stage objects, nested (numbers, strings, tuples, arrays by content), their classes'
    and the package's modules' constants (UPPER_CASE; a test or a user may change one between runs),
    every Taichi field and other object by identity."""
    stack: list[int] = []

    def walk(a):
        if isinstance(a, SIMPLE):
            return type(a).__name__, a
        if isinstance(a, np.ndarray):
            return "array", a.dtype.str, a.shape, hashlib.sha1(np.ascontiguousarray(a).tobytes()).hexdigest()
        if isinstance(a, (tuple, list)):
            return type(a).__name__, tuple(walk(x) for x in a)
        if isinstance(a, dict):
            return "dict", tuple((repr(k), walk(v)) for k, v in a.items())
        if hasattr(a, "__self__") and hasattr(a, "__func__"):        # a bound method
            return "method", id(a.__func__), walk(a.__self__)
        if (not hasattr(a, "__dict__") or isinstance(a, (type, State, Group))
                or type(a).__module__.split(".")[0] == "taichi"):
            return "object", id(a)          # the state: compared by State.layout
        if id(a) in stack:
            return "cycle", stack.index(id(a))
        stack.append(id(a))
        out = type(a).__qualname__, class_values(type(a)), tuple((k, walk(v)) for k, v in vars(a).items())
        stack.pop()
        return out

    def class_values(klass):
        return tuple((k, v) for c in klass.__mro__ if c.__module__.split(".")[0] == __package__
                     for k, v in sorted(vars(c).items()) if isinstance(v, SIMPLE) and not k.startswith("__"))

    objects = walk(stepper)
    modules = tuple((name, tuple((k, v) for k, v in sorted(vars(m).items())
                                 if isinstance(v, SIMPLE) and k.isupper() and not k.startswith("_")))
                    for name, m in sorted(sys.modules.items()) if name.split(".")[0] == __package__)
    return objects, modules
