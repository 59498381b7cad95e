"""taichi_shell_mpm: thin shells by CPDI2 double-mapping MPM with Belytschko-Tsay elements.

    import taichi_shell_mpm as tsm
    result = tsm.run(tsm.load_scene("scenes/cantilever.toml"))      # docs/api.md

Pipeline (design notes: method.md section 2): scene (TOML) -> mesh + node sets ->
:mod:`assembly` (numpy model) -> :mod:`state` (the Taichi fields) -> the stages in
:mod:`taichi_shell_mpm.stages` sequenced by :mod:`taichi_shell_mpm.solvers` -> :mod:`output`.
"""
__version__ = "0.1.0"

from .api import Result, RunFailed, RunInterrupted, SceneError, Simulation, load_scene, run  # noqa: E402

__all__ = ["Result", "RunFailed", "RunInterrupted", "SceneError", "Simulation", "load_scene", "run", "__version__"]
