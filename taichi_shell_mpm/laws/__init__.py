"""Material models, hardening laws, rate laws and failure criteria: one file each.

A material model's file (elastic.py, j2.py, orthotropic.py, hill48.py) declares, for a
``[material].model`` value NAME:

* ``DOC`` (its line in the docs of ``model``), ``KEYS`` (its own keys in [material];
  given with another model they are an error) or ``TABLE`` (a scene table of its own that
  replaces [material]'s keys: orthotropic's, with ``check(reader, path, material)``);
* ``PLASTIC`` and ``ORIENTED`` (it needs the section's material axes);
* the host side, numpy: ``values(spec, context)`` its columns of the material row
  (model/materials.COLUMNS; context: the scene's compiled hardening and rate laws and the
  material's curve start), ``BLOCK`` and ``block(spec)`` its own columns from BLOCK_OFFSET
  (the table is as wide as the widest block among the models a scene uses), and
  ``stiffness``, ``transverse_shear``, ``wave_speed``, ``dilatational_speed`` (sections,
  laminates, the time step);
* ``kernel(context)``: its ``ti.data_oriented`` point update (stages/material.py builds them
  in the registry's order; context.models holds those built before it, so j2 extends elastic
  and hill48 j2).  Built on first use: reading a scene imports this package but not Taichi.

Hardening laws, rate laws and failure criteria: hardening/, rate/, failure/ (their own
``__init__`` says what a file declares).
"""
from __future__ import annotations

from . import elastic, hill48, j2, orthotropic

MODELS = {module.NAME: module for module in (elastic, j2, orthotropic, hill48)}
"""NAME -> its module, in the registry's order (model/materials.KINDS)."""


def block_width(kinds) -> int:
    """Columns the material table needs past BLOCK_OFFSET for the models `kinds`."""
    return max((len(MODELS[k].BLOCK) for k in kinds if k in MODELS), default=0)
