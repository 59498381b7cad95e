"""Rigid tool kinds ([[tool]].kind), one file each.

A kind's file declares, for a ``kind`` value NAME:

* ``KEYS``: its own scene keys (a key declared by one kind may be taken by another: a
  sphere's ``radius`` is the cylinder's); ``REQUIRED`` and ``OPTIONAL``: the shape keys it
  takes (another kind's is an error), and ``rules(reader, path, data, values)`` if it has
  rules across keys;
* ``shape(tool) -> (frame, size, bound)``: its pose frame (rows e1, e2, e3: the step works in
  the tool's frame q = F (x - c)), the three numbers of its size and the radius of a ball about
  its centre that holds it (inf: unbounded) -- numpy, tools.build_tools;
* ``kernel(tools, contact)``: a ``ti.data_oriented`` object whose ``ti.func``
  ``distance(k, q) -> (d, n, hit)`` is the signed distance of q (tool frame) to tool k's
  surface, the outward normal and whether the tool can touch q (`tools`: state.tools;
  `contact`: stages/contact, its geometry helpers).  Built on first use (reading a scene does
  not import Taichi).

A kind with a triangulated surface (mesh.py) also has ``surface(tool, reach, cell)``.  The
step (stages/tools.py) dispatches with ``ti.static`` over the kinds a scene uses.
"""
from __future__ import annotations

from . import cylinder, mesh, plane, rectangle, sphere

KINDS = {kind.NAME: kind for kind in (plane, rectangle, cylinder, sphere, mesh)}
"""NAME -> its module, in the registry's order (state.tools.kind indexes it)."""
