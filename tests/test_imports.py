"""The modules of this repository import each other without a cycle.

A static walk (``ast``, nothing is imported): every ``import`` and ``from ... import`` anywhere in a
file counts, at module level, inside functions and under ``if TYPE_CHECKING:``, because a cycle that
only bites at call time, or only for the type checker, is still a cycle in the design.
"""

from __future__ import annotations

import ast
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
SOURCES = ("contactmpc", "analysis", "launch.py", "sweep_summary.py")


def repo_modules() -> dict[str, Path]:
    """Dotted module name -> file, for every module of :data:`SOURCES` (a package is its ``__init__``)."""
    modules = {}
    for source in SOURCES:
        path = REPO_ROOT / source
        for file in sorted(path.rglob("*.py")) if path.is_dir() else [path]:
            parts = file.relative_to(REPO_ROOT).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            modules[".".join(parts)] = file
    return modules


def imported_modules(module: str, file: Path, modules: dict[str, Path]) -> set[str]:
    """The repository modules that ``module`` (in ``file``) imports, anywhere in the file.

    ``import a.b`` names ``a.b``; ``from a.b import c`` names ``a.b.c`` when that is a module, else
    ``a.b``; relative imports are resolved against ``module``'s package.
    """
    package = module if file.name == "__init__.py" else module.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(file.read_text(), str(file))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                name = alias.name
                while name and name not in modules:  # import a.b.missing -> a.b
                    name = name.rpartition(".")[0]
                found.add(name)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                base = ".".join(base + ([node.module] if node.module else []))
            else:
                base = node.module
            for alias in node.names:
                candidate = f"{base}.{alias.name}"
                found.add(candidate if candidate in modules else base)
    return {name for name in found if name in modules and name != module}


def import_graph() -> dict[str, set[str]]:
    """Module -> the repository modules it imports."""
    modules = repo_modules()
    return {module: imported_modules(module, file, modules) for module, file in modules.items()}


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Import cycles as chains ``[a, b, ..., a]``: in each strongly connected component (Tarjan's
    algorithm), a shortest cycle through each of its modules, each cycle once, starting at its first
    module in sorted order. Deterministic.
    """
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    found = []
    for component in sorted(components):
        for start in component:  # a shortest cycle through each module, each cycle once
            cycle = _cycle_through(graph, set(component), start)
            first = cycle.index(min(cycle))
            cycle = cycle[first:-1] + cycle[:first] + [cycle[first]]
            if cycle not in found:
                found.append(cycle)
    return found


def _cycle_through(graph: dict[str, set[str]], component: set[str], start: str) -> list[str]:
    """A shortest cycle from ``start`` back to itself inside ``component`` (breadth-first)."""
    parent: dict[str, str] = {}
    frontier = [start]
    while frontier:
        nxt = []
        for v in frontier:
            for w in sorted(graph[v] & component):
                if w == start:
                    path = [v]
                    while path[-1] != start:
                        path.append(parent[path[-1]])
                    return [start, *reversed(path[:-1]), start]
                if w not in parent:
                    parent[w] = v
                    nxt.append(w)
        frontier = nxt
    raise AssertionError(f"{start} is on no cycle")  # unreachable for a strongly connected component


def test_graph_sees_the_imports():
    """Sanity: the walk finds known edges of this repository."""
    graph = import_graph()
    assert "contactmpc.config" in graph["launch"]
    assert "sweep_summary" in graph["launch"] and "contactmpc.runs" in graph["sweep_summary"]
    assert "contactmpc.tasks.apple" in graph["contactmpc.tasks"]  # a package's __init__ counts
    assert "analysis.report" in graph["analysis.__main__"]  # imported inside main()


def test_every_kind_of_import_is_an_edge(tmp_path):
    (tmp_path / "pkg" / "sub").mkdir(parents=True)
    source = """
from typing import TYPE_CHECKING

import numpy
from . import a
from .a import name_in_a
from .b import helper
from .. import outside
import pkg.sub.b as bb
if TYPE_CHECKING:
    from pkg.sub import c

def f():
    from pkg.sub.d import thing
"""
    (tmp_path / "pkg" / "sub" / "m.py").write_text(source)
    modules = {m: tmp_path for m in ("pkg", "pkg.a", "pkg.sub", "pkg.sub.a", "pkg.sub.b", "pkg.sub.c")}
    modules |= {"pkg.sub.d": tmp_path, "pkg.sub.m": tmp_path / "pkg" / "sub" / "m.py"}
    found = imported_modules("pkg.sub.m", tmp_path / "pkg" / "sub" / "m.py", modules)
    assert found == {"pkg.sub.a", "pkg.sub.b", "pkg", "pkg.sub.c", "pkg.sub.d"}


def test_cycle_report_is_a_chain():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert cycles(graph) == [["a", "b", "c", "a"]]
    graph = {"x": {"s"}, "s": {"x", "g"}, "g": {"s"}}
    assert cycles(graph) == [["g", "s", "g"], ["s", "x", "s"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycle():
    found = cycles(import_graph())
    assert not found, "import cycles:\n" + "\n".join(" -> ".join(c) for c in found)
