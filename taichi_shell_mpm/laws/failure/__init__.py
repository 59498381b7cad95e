"""Failure criteria of erosion (an element fails and leaves the step, stages/masses.py), one
file each.

A criterion's file declares its scene keys (``KEYS``, in [material]; with their rules:
``rules(reader, path, data, values)``), its columns of the failure table (``BLOCK``, in the
order of COLUMNS: state.sections.failure, model/materials.failure_row), whether a material
erodes by it (``active(spec)``) and ``kernel(state, cfg, columns)``: a ``ti.data_oriented``
object whose ``ti.func`` ``fails(e, section, limit)`` says whether element e fails now
(`limit`: its stable step).  An element fails when any criterion says so.
"""
from __future__ import annotations

from . import min_step, plastic_strain

CRITERIA = {criterion.NAME: criterion for criterion in (plastic_strain, min_step)}
"""NAME -> its module."""
COLUMNS = tuple(column for criterion in CRITERIA.values() for column in criterion.BLOCK)
"""The failure table's columns: every criterion's block, in the registry's order."""
