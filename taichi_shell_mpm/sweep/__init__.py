"""Parameter studies: ``python -m taichi_shell_mpm sweep SCENE.toml --param KEY=V1,V2,...``
(issue 21).

Every case is a normal run of the scene with its values as ``--set`` overrides, in its own
folder ``OUT/cases/CASE/``; the cases run on Dask (:mod:`taichi_shell_mpm.executor`): a local
cluster of one single-threaded worker process per core by default (``--workers N``), or an
existing cluster (``--scheduler ADDRESS``).  A failing case is recorded with its exit code
and message and the others go on; ``--resume`` runs only the cases without an ``ok`` row;
Ctrl-C cancels the cases left and closes the cluster.  Results: ``sweep.csv``, ``sweep.md``
and ``plots/`` (docs/sweep.md).

Modules, in the order a study uses them (each imports only those before it):

``cases``     the cases: --param grids, --cases CSV files, case names;
``metrics``   what is tabulated from each summary.json (--metrics paths, defaults by scene);
``task``      one case in a worker: the run in the worker's process, its log, its result;
``results``   sweep.csv and sweep.md, a case's row;
``plot``      the figures (matplotlib);
``cli``       the ``sweep`` options (:func:`add_arguments`) and :func:`main`.
"""
# ruff: noqa: F401
from .cases import SweepCase, SweepError, parse_param, plan, read_cases_file, short_keys, split_values
from .cli import add_arguments, command_line, main
from .metrics import default_metrics, extract, lookup, parse_metrics
from .plot import plot_all, plot_metric
from .results import case_row, columns, metric_columns, read_study, retabulate, write_csv, write_markdown
from .task import run_case
