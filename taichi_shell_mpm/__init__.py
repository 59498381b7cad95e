"""taichi_shell_mpm: thin shells by CPDI2 double-mapping MPM with Belytschko-Tsay elements.

Pipeline (design notes: method.md section 2): scene (TOML) -> mesh + node sets ->
:mod:`assembly` (numpy model) -> :mod:`state` (the Taichi fields) -> the stages in
:mod:`taichi_shell_mpm.stages` sequenced by :mod:`taichi_shell_mpm.solvers` -> :mod:`output`.
"""
__version__ = "0.1.0"
