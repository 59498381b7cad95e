"""Material models that plug into the solver, one file each (laws/hill48.py).

A model file declares, for a ``[material].model`` value NAME:

* ``KEYS``: its own scene keys (taichi_shell_mpm.keys declarations; given with another model
  they are an error), documented and in the JSON Schema with the rest of ``[material]``;
* ``BLOCK``: the names of its parameter block, columns from ``BLOCK_OFFSET`` of the material
  table (model/materials.py: the table is as wide as the widest block among the models a scene
  uses), and ``block(spec)``: their values for a scene material;
* ``kernel(base)``: its ``ti.data_oriented`` point update, built on the J2 model ``base``
  (stages/material.PlaneStressJ2: the hardening, rate and failure laws, and the return's
  bracketed Newton iteration), so that a model is one yield function and its return.

Reading a scene imports this package but not Taichi (``kernel`` imports it when the solver
asks).  The plug-in models are plastic and oriented (their axes are the section's material
axes) like J2 with anisotropy; the built-in elastic, j2 and orthotropic models stay in
stages/material.py.
"""
from __future__ import annotations

from . import hill48

MODELS = {module.NAME: module for module in (hill48,)}
"""NAME -> its module, in the registry's order (materials.KINDS after the built-in models)."""


def block_width(kinds) -> int:
    """Columns the material table needs past BLOCK_OFFSET for the models `kinds`."""
    return max((len(MODELS[k].BLOCK) for k in kinds if k in MODELS), default=0)
