"""The package's modules import one another one way only: no import cycles (issue 17).

The import graph is read from the source with :mod:`ast` (nothing is imported): every
``import`` and ``from ... import`` of a module of ``taichi_shell_mpm``, at module level
and inside functions and methods alike (a function-level import closes a cycle just as
well, only later: ``bench`` <-> ``cli`` and ``crush`` <-> ``simulation`` were such).
Imports under ``if TYPE_CHECKING:`` never run and are left out.

Edges: ``import P.Q`` is an edge to ``P.Q``; ``from P import n`` to ``P.n`` when that is a
module, else to ``P`` (n is a name defined or re-exported by P).  Importing a module runs
the packages above it first: those are edges too, except the packages that contain the
importing module itself (they are initialised before it anyway), so a package's
``__init__`` may re-export from its own submodules, and they may import one another with
``from . import x`` or ``from .x import n``, but not take a name from the package's
``__init__`` (``from taichi_shell_mpm.bench import plan`` inside bench/ is a cycle).
"""
from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = "taichi_shell_mpm"
ROOT = Path(__file__).resolve().parents[1] / PACKAGE


def module_files(root: Path = ROOT) -> dict[str, Path]:
    """Dotted module name -> source file, for every module and package of the package `root`."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


def _is_package(name: str, files: dict[str, Path]) -> bool:
    return name in files and files[name].name == "__init__.py"


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    """ids of the nodes inside ``if TYPE_CHECKING:`` blocks."""
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If):
            test = node.test
            name = test.id if isinstance(test, ast.Name) else test.attr if isinstance(test, ast.Attribute) else ""
            if name == "TYPE_CHECKING":
                for child in node.body:
                    skip.update(id(n) for n in ast.walk(child))
    return skip


def imports_of(name: str, files: dict[str, Path]) -> set[str]:
    """The modules of the package that module `name` imports (anywhere in its source)."""
    tree = ast.parse(files[name].read_text(), filename=str(files[name]))
    skip = _type_checking_nodes(tree)
    package = name if _is_package(name, files) else name.rpartition(".")[0]
    ancestors = {".".join(name.split(".")[:k]) for k in range(1, name.count(".") + 1)}
    if _is_package(name, files):
        ancestors.add(name)
    out: set[str] = set()

    def add(module: str) -> None:       # the module, and the packages above it that `name` is not in
        parts = module.split(".")
        for k in range(1, len(parts)):
            m = ".".join(parts[:k])
            if m in files and m not in ancestors:
                out.add(m)
        out.add(module)

    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name in files:
                    add(a.name)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target not in files:
                continue
            for a in node.names:
                submodule = f"{target}.{a.name}"
                add(submodule if submodule in files else target)
            if target not in ancestors:         # `from P import submodule` runs P too
                add(target)
    out.discard(name)
    return out


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """Module -> the modules of the package it imports."""
    files = module_files(root)
    return {name: imports_of(name, files) for name in files}


def find_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan), each as one
    cycle through it, e.g. ['a', 'b', 'a']."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                components.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return [_cycle_in(comp, graph) for comp in components]


def _cycle_in(component: list[str], graph: dict[str, set[str]]) -> list[str]:
    """One cycle through the first module of a strongly connected component (breadth first)."""
    members = set(component)
    start = component[0]
    parent: dict[str, str] = {}
    frontier = [start]
    while frontier:
        nxt = []
        for v in frontier:
            for w in sorted(graph[v] & members):
                if w == start:
                    path = [v]
                    while path[-1] != start:
                        path.append(parent[path[-1]])
                    return path[::-1] + [start]
                if w not in parent:
                    parent[w] = v
                    nxt.append(w)
        frontier = nxt
    return component


def test_the_graph_sees_function_level_imports():
    graph = import_graph()
    assert f"{PACKAGE}.cli" in graph and f"{PACKAGE}.simulation" in graph
    assert f"{PACKAGE}.bench" in graph[f"{PACKAGE}.cli"]             # `from .bench import ...` in _parser()
    assert f"{PACKAGE}.api" in graph[f"{PACKAGE}.cli"]               # inside _run()
    assert f"{PACKAGE}.solvers.static" in graph[f"{PACKAGE}.api"]    # inside _execute()
    assert f"{PACKAGE}.solvers" in graph[f"{PACKAGE}.api"]           # the package above it runs first
    assert f"{PACKAGE}.bench.cases" in graph[f"{PACKAGE}.bench"]     # __init__ re-exports its submodules ...
    assert f"{PACKAGE}.bench" not in graph[f"{PACKAGE}.bench.report"]  # ... which import one another,
    assert f"{PACKAGE}.bench.cases" in graph[f"{PACKAGE}.bench.report"]  # not it
    assert PACKAGE not in graph[f"{PACKAGE}.simulation"]                 # `from . import energy`


def test_a_name_taken_from_the_own_package_is_an_edge(tmp_path):
    pkg = tmp_path / PACKAGE
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("from .a import f\n")
    (pkg / "sub" / "a.py").write_text("def f():\n    from . import b\n")
    (pkg / "sub" / "b.py").write_text("def g():\n    from taichi_shell_mpm.sub import f\n")
    graph = import_graph(pkg)
    assert graph[f"{PACKAGE}.sub.a"] == {f"{PACKAGE}.sub.b"} and graph[f"{PACKAGE}.sub.b"] == {f"{PACKAGE}.sub"}
    assert find_cycles(graph) == [[f"{PACKAGE}.sub", f"{PACKAGE}.sub.a", f"{PACKAGE}.sub.b", f"{PACKAGE}.sub"]]


def test_find_cycles_reports_a_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert find_cycles(graph) == [["a", "b", "c", "a"]]
    assert find_cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycles():
    cycles = find_cycles(import_graph())
    text = "\n".join(" -> ".join(c) for c in cycles)
    print(f"import cycles in {PACKAGE}:\n{text}" if cycles else f"{PACKAGE}: no import cycles")
    assert not cycles, f"import cycles in {PACKAGE}:\n{text}"
