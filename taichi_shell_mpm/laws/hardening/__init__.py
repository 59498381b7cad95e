"""Hardening laws sigma_y(ebar) of the plastic models, one file each.

A law file declares, for a ``[material].hardening_law`` value NAME:

* ``KEYS``: its own scene keys (``yield_stress`` and ``hardening`` are every law's and stay in
  scene/material.py; a key declared by one law may be required by another: ``n``);
  ``REQUIRED`` and ``OPTIONAL``: the keys, own or shared, that it takes (another law's key is
  an error); ``rules(reader, path, data, values)``: its rules across keys, if any;
* ``BLOCK``: the names of its parameters, in the material row from COL["hardening_0"]
  (model/materials.py; at most BLOCK_WIDTH), and ``block(spec, curve_start)``: their values;
* ``kernel(offset)``: a ``ti.data_oriented`` class with ``law = NAME`` and the ``ti.func``
  ``flow_stress(row, ebar) -> (sigma_y, d sigma_y / d ebar)``; its ``__init__`` takes the
  state (the tabulated law reads its curve table there).  Built on first use (reading a
  scene does not import Taichi).

The flow stress never falls with ebar (the scene's checks), which the return map's bracket
needs.  The J2 model (stages/material.py) dispatches over the laws a scene uses.
"""
from __future__ import annotations

from . import hockett_sherby, linear, ludwik, swift, tabulated, voce

LAWS = {law.NAME: law for law in (linear, swift, ludwik, voce, tabulated, hockett_sherby)}
"""NAME -> its module (materials.HARDENING_LAWS order)."""
BLOCK_WIDTH = 10
"""Columns of the material row for a law's parameters."""
