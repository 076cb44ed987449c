"""The package's structure: every module imports alone, and the imports form no cycle.

A module that imports only because some other module happened to be imported first breaks the
first user who imports it directly; an import cycle makes the result depend on which module is
imported first, and shows two modules that are one concern or a layer that reaches back up.
"""

from __future__ import annotations

import ast
import functools
import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import sizefx

#: The installed packages whose modules are checked (the tests run against the installed copy,
#: which conftest.py checks is the source).
PACKAGES = {
    "sizefx": Path(sizefx.__file__).resolve().parent,
    "sizefx_cli": Path(importlib.util.find_spec("sizefx_cli").submodule_search_locations[0]).resolve(),
}

_IMPORT_EACH_ALONE = """
import importlib, importlib.machinery, json, pkgutil, sys

# Each source file is compiled once and its code object reused when the module is imported again
# below: what a __pycache__ .pyc file does, which this environment may forbid (PYTHONDONTWRITEBYTECODE).
# Without it every module compiles again the dozens of sizefx modules it imports: two thirds of this
# check's time. The modules' code still runs afresh at every import.
_compiled = {}
_get_code = importlib.machinery.SourceFileLoader.get_code


def _get_code_once(self, fullname):
    path = self.get_filename(fullname)
    if path not in _compiled:
        _compiled[path] = _get_code(self, fullname)
    return _compiled[path]


importlib.machinery.SourceFileLoader.get_code = _get_code_once

import sizefx, sizefx_cli

names = ["sizefx", "sizefx_cli"] + sorted(
    m.name for pkg in (sizefx, sizefx_cli) for m in pkgutil.walk_packages(pkg.__path__, pkg.__name__ + "."))
failures = []
for name in names:
    for key in [k for k in sys.modules if k.startswith("sizefx")]:  # sizefx and sizefx_cli, and below
        del sys.modules[key]
    try:
        importlib.import_module(name)
    except BaseException as exc:  # report every module, not the first failure
        failures.append(f"{name}: {type(exc).__name__}: {' '.join(str(exc).split())}")
print(json.dumps({"modules": names, "failures": failures, "sizefx": sizefx.__file__}))
"""


def test_every_module_imports_alone(tmp_path):
    """Each module of sizefx and sizefx_cli, imported into an interpreter that holds no sizefx module."""
    # run outside the clone: `python -c` puts the working folder first on sys.path (the source tree)
    proc = subprocess.run(
        [sys.executable, "-c", _IMPORT_EACH_ALONE], capture_output=True, text=True, timeout=300, cwd=tmp_path
    )
    assert proc.returncode == 0, proc.stderr
    found = json.loads(proc.stdout.strip().splitlines()[-1])
    assert Path(found["sizefx"]).resolve() == Path(sizefx.__file__).resolve()  # the installed copy
    assert {"sizefx.io.telemetry", "sizefx.io.reader", "sizefx_cli.main"} <= set(found["modules"]), found["modules"]
    assert found["failures"] == [], "modules that do not import alone:\n" + "\n".join(found["failures"])


# --------------------------------------------------------------------------- the import graph


def _module_names(packages: dict) -> dict:
    """Dotted module name -> its file, for every ``.py`` file of the packages (``{name: folder}``)."""
    out = {}
    for top, folder in packages.items():
        for path in sorted(folder.rglob("*.py")):
            parts = [top, *path.relative_to(folder).with_suffix("").parts]
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(parts)] = path
    return out


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _imports(tree: ast.AST):
    """Every Import and ImportFrom node, at module level and inside functions and classes, except
    those under ``if TYPE_CHECKING:`` (never executed)."""
    stack = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            stack.extend(node.orelse)
            continue
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        stack.extend(ast.iter_child_nodes(node))


def import_graph(packages: dict) -> dict:
    """Module -> the set of modules of ``packages`` it imports, from the import statements of the source."""
    modules = _module_names(packages)
    graph = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        edges = set()
        for node in _imports(ast.parse(path.read_text("utf-8"), str(path))):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            else:
                base = node.module or ""
                if node.level:
                    up = package.split(".")
                    up = up[: len(up) - (node.level - 1)]
                    base = ".".join(up + ([node.module] if node.module else []))
                # `from pkg import sub` imports the module pkg.sub; `from mod import name` the module mod
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names]
            for target in targets:
                while target and target not in modules:  # `import a.b.c` of a name inside a module
                    target = target.rpartition(".")[0]
                if target and target != name:
                    edges.add(target)
        graph[name] = edges
    return graph


def cycles(graph: dict) -> list[list[str]]:
    """The import cycles: one cycle (``[a, b, ..., a]``) for each group of modules that import each
    other (strongly connected component of more than one module; Tarjan's algorithm, iterative)."""
    index, low, on_stack, stack, groups = {}, {}, set(), [], []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.get(root, ()))))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                group = []
                while True:
                    top = stack.pop()
                    on_stack.discard(top)
                    group.append(top)
                    if top == node:
                        break
                if len(group) > 1:
                    groups.append(_a_cycle_in(sorted(group), graph))
    return groups


def _a_cycle_in(group: list, graph: dict) -> list[str]:
    """A path ``[a, ..., a]`` through the modules of one strongly connected group (breadth first from
    its first module back to it, so the printed cycle is a shortest one)."""
    start, members = group[0], set(group)
    previous = {start: None}
    queue = [start]
    while queue:
        node = queue.pop(0)
        for child in sorted(graph[node] & members):
            if child == start:
                path = [node]
                while previous[path[-1]] is not None:
                    path.append(previous[path[-1]])
                return [start, *reversed(path[:-1]), start]  # path runs node -> ... -> start
            if child not in previous:
                previous[child] = node
                queue.append(child)
    raise AssertionError(f"no cycle through {group}")  # a strongly connected group always has one


def _described(found: list) -> str:
    return "\n".join(" -> ".join(c) for c in found)


@functools.cache
def _package_graph() -> dict:
    return import_graph(PACKAGES)


def test_import_graph_has_no_cycle():
    graph = _package_graph()
    assert "sizefx.io.reader" in graph["sizefx.io.telemetry"]  # the graph sees the imports at all
    found = cycles(graph)
    assert found == [], f"import cycles:\n{_described(found)}"


def test_a_planted_cycle_is_found_and_printed(tmp_path):
    """The check on a package written here: a cycle through a function-level import is found, one
    under ``if TYPE_CHECKING:`` is not (it never runs), and the cycle is printed in import order."""
    pkg = tmp_path / "planted"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("from .c import C\n")
    (pkg / "a.py").write_text(
        "from typing import TYPE_CHECKING\n\nfrom .sub import c\n\nif TYPE_CHECKING:\n    from . import d\n"
    )
    (pkg / "sub" / "c.py").write_text("def f():\n    from ..b import g\n    return g\n")
    (pkg / "b.py").write_text("import planted.a\n")
    (pkg / "d.py").write_text("from .a import X\n")  # a -> d only for the type checker: no cycle
    graph = import_graph({"planted": pkg})
    assert graph["planted.a"] == {"planted.sub.c"} and graph["planted.d"] == {"planted.a"}
    assert graph["planted.sub"] == {"planted.sub.c"}
    found = cycles(graph)
    assert found == [["planted.a", "planted.sub.c", "planted.b", "planted.a"]], found
    # and on a graph given by hand: two separate cycles, a self-contained tail that is none
    assert cycles({"x": {"y"}, "y": {"x"}, "p": {"q"}, "q": {"r"}, "r": {"p", "s"}, "s": set()}) == [
        ["p", "q", "r", "p"],
        ["x", "y", "x"],
    ]
    assert cycles({"x": {"y"}, "y": {"z"}, "z": set()}) == []
