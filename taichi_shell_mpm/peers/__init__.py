"""Established external codes solving our static benchmark scenes, for side-by-side tables.

Each peer is optional (``pip install taichi_shell_mpm[peers]``) and imported lazily: nothing
here imports a peer at module import time, and every peer module has ``available()``.

- :mod:`taichi_shell_mpm.peers.kratos`: KratosMultiphysics ``ShellThinElementCorotational3D4N``
  with a static Newton-Raphson solve over the scene's load steps.
"""
