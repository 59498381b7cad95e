"""The optional parts of the install (pyproject's extras) and the one-line error when a
command needs one that is missing.

The core (taichi, numpy, scipy, meshio) runs, validates and checks scenes; ``render`` needs
pyvista and matplotlib (``[render]``), ``sweep`` Dask (``[sweep]``), the Python API's tables
as DataFrames pandas (``[data]``): a lean HPC install leaves out VTK and Dask.
"""
from __future__ import annotations

import importlib

EXTRAS = {"render": ("pyvista", "matplotlib"), "sweep": ("dask", "distributed", "matplotlib"), "data": ("pandas",)}
"""extra -> the modules it installs (pyproject.toml [project.optional-dependencies])."""


class MissingExtra(ImportError):
    """A command or call needs an extra that is not installed (one line: what to install)."""


def require(extra: str, what: str) -> None:
    """Raise MissingExtra naming `extra` when one of its modules cannot be imported."""
    missing = []
    for module in EXTRAS[extra]:
        try:
            importlib.import_module(module)
        except ImportError:
            missing.append(module)
    if missing:
        raise MissingExtra(f"{what} needs {' and '.join(missing)}, which this install lacks: "
                           f"pip install \"taichi_shell_mpm[{extra}]\" (or [all])")
