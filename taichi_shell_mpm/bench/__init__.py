"""Speed against error: ``python -m taichi_shell_mpm bench [--quick] [--out DIR]`` (issue 4).

Runs, one after the other in one sitting (so that the timings compare), a refinement series
of the two static Sze benchmarks in ``mpm`` mode at two grid-cell/element-size ratios and in
``fem`` mode, the square-tube crush at the paper's mesh and at a finer one, and, when the
optional extra ``peers`` is installed, the same static meshes with an established implicit
code (:mod:`taichi_shell_mpm.peers.kratos`).  Each case is a subprocess
``python -m taichi_shell_mpm run SCENE --quiet --out OUT/runs/CASE --set ...`` (the cases
compile different kernels; a fresh process keeps memory and the Taichi runtime clean); its
``summary.json`` gives compile and run wall time, steps, microseconds per element-step and
the errors against the reference table, ``os.wait4`` the peak resident memory of the child.
The cases go through the study executor (:mod:`taichi_shell_mpm.executor`, shared with
``sweep``): one after the other by default, since the timings need a quiet machine;
``--workers N`` runs N at a time on a local Dask cluster, trading the timings for speed (the
``machine`` column and the report say so).

Files, under ``--out`` (default ``outputs/bench``, ``outputs/bench_quick`` with ``--quick``):

``results.csv``
    one row per case, rewritten (atomically) as each case finishes; a re-run case replaces
    its row, ``--resume`` skips cases that already have a row with status ``ok``.
``orders.csv``
    observed order of convergence: least-squares slope of log(mean error) against
    log(element size) per scene, mode and component.
``error_vs_time.png``, ``convergence.png``, ``tube.png``, ``scaling.png``
    error (mean and max, both components) against run wall time; mean error against element
    size; crush force against crush distance and the tube's wall time; time per step against
    elements.
``runs/CASE/``
    each run's own output (frames, tables, summary.json) and its console log ``bench.log``.

The report (``--report``, default ``BENCHMARKS.md`` in the working directory for the full
study, ``OUT/BENCHMARKS.md`` with ``--quick``) is regenerated from ``results.csv`` after
every case, so it always shows everything measured so far and lists the planned cases still
missing, with the machine, the date and the exact command.

Modules, in the order a sitting uses them (each imports only those before it):

``cases``     the cases (:class:`Case`), their scenes and overrides, element sizes, the
              ``--quick`` subset and the ``--cases`` selection;
``results``   results.csv: columns, reading, atomic writing, a row's numbers;
``machine``   the machine the cases run on (report header, ``machine`` column);
``run``       one case in a subprocess: command, timing, peak memory, its row from
              summary.json; the Kratos peer's child process; the cases ``--resume`` leaves;
``fit``       the refinement series and their observed orders of convergence, orders.csv;
``plot``      the PNG figures (matplotlib when it imports, else pyvista's charts);
``report``    BENCHMARKS.md, and :func:`regenerate` (orders.csv, plots, report from
              results.csv);
``cli``       the ``bench`` options (:func:`add_arguments`) and :func:`main`.

The names below are re-exported from those modules.
"""
# ruff: noqa: F401
from .cases import (CANTILEVER_NX, EMPTY_GRID_END_TIME, EMPTY_GRID_PAIRS, HEMISPHERE_N, QUICK_LOAD_STEPS, RATIOS,
                    RELAXATION, RELAXATION_VARIANTS, ROOT, SCALING_END_TIME, SCALING_FLAT, SCENE_FILES, SCENES,
                    STATIC_SCENES, TRIANGLE_ELEMENTS, WIDE_GRID, Case, cantilever_cases, empty_grid_cases,
                    hemisphere_cases, hemisphere_triangle_cases, peers_available, plan, relaxation_cases,
                    relaxation_default, scaling_cases, select, triangle_element, tube_cases)
from .cli import add_arguments, command_line, default_out, default_report, main
from .fit import ORDER_COLUMNS, group_key, observed_orders, series_label, write_orders
from .machine import machine_info, machine_tag
from .plot import (MARKERS, PALETTE, PLOT_FILES, Panel, Series, draw, have_matplotlib, plot_all, plot_convergence,
                   plot_error_vs_time, plot_scaling, plot_tube)
from .report import empty_grid_ratios, error_pair, fmt, known_rows, regenerate, sort_rows, write_report
from .results import COLUMNS, COMPONENT_LABEL, TUBE_KEYS, num, read_results, replace_row, write_results
from .run import case_command, peer_child, pending, row_from_summary, run_case
