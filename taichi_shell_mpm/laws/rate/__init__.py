"""Strain-rate laws R(rate) >= 1 of the plastic models' flow stress, one file each.

A law file declares, for a ``[material].rate_law`` value NAME: ``KEYS`` (its own scene keys),
``REQUIRED`` (its keys that must be given), ``BLOCK`` and ``block(spec)`` (its parameters in
the material row from COL["rate_0"], at most BLOCK_WIDTH), and ``kernel(offset)``: a
``ti.data_oriented`` class with ``law = NAME`` and the ``ti.func`` ``factor(row, rate) ->
(R, dR / d rate)``.  R = 1 exactly at rates that have no effect, so those give the rate-free
answer bit for bit.  Every rate law also takes the shared keys OPTIONAL (the rate measure and
its filter, scene/material.py).
"""
from __future__ import annotations

from . import cowper_symonds, johnson_cook

LAWS = {law.NAME: law for law in (cowper_symonds, johnson_cook)}
"""NAME -> its module (materials.RATE_LAWS order)."""
BLOCK_WIDTH = 4
OPTIONAL = ("rate_measure", "rate_filter_time", "rate_cutoff_frequency")
