"""The import graph of the package, read from the source with ``ast`` (imports at module level, inside
functions and under ``if TYPE_CHECKING`` alike): no cycle among modules, and no module importing a layer above
its own.

Layers, lowest first (data flows models → integrators → bench → reports): ``models`` <
``integrators`` < ``bench`` < ``reports``, and on top the command line, ``bench.commands`` and ``bench.cli``,
which may import everything. The repository's top-level folders are installed as ``foucault_bench.{bench,
models,integrators,reports}`` (pyproject.toml ``package-dir``); a file maps to the module of that name.
"""

from __future__ import annotations

import ast
from functools import lru_cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NAMESPACE = "foucault_bench"
TOP_LEVEL_FOLDERS = ("models", "integrators", "bench", "reports")
LAYERS = {"models": 0, "integrators": 1, "bench": 2, "reports": 3}
COMMAND_LINE = ("foucault_bench.bench.commands", "foucault_bench.bench.cli")
COMMAND_LINE_LAYER = 4

LAYER_EXCEPTIONS: dict[tuple[str, str], str] = {
    ("foucault_bench.bench.perf.startup", "foucault_bench.bench.cli"):
        "times the command line's own start-up, which is importing it (inside the timed function)",
    ("foucault_bench.bench.perf.startup", "foucault_bench.bench.commands"):
        "times the command line's own start-up: parsing with the command table",
}
"""(importer, imported) pairs allowed to break the layering today, with why; to shrink, never to grow."""
CYCLE_EXCEPTIONS: frozenset[frozenset[str]] = frozenset()
"""Sets of modules allowed to form a cycle today; to shrink, never to grow."""


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join((NAMESPACE, *parts))


@lru_cache(maxsize=None)
def source_modules() -> dict[str, Path]:
    modules = {}
    for folder in TOP_LEVEL_FOLDERS:
        for path in sorted((ROOT / folder).rglob("*.py")):
            modules[module_name(path)] = path
    return modules


def imported_modules(name: str, path: Path) -> set[str]:
    """The package's modules that ``name`` imports anywhere in its source. ``from P import X`` counts as an
    import of the submodule ``P.X`` when there is one, else of ``P``; relative imports are resolved."""
    modules = source_modules()
    is_package = path.name == "__init__.py"
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                package = name.split(".") if is_package else name.split(".")[:-1]
                base = ".".join(package[: len(package) - node.level + 1] + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base for alias in node.names]
        else:
            continue
        for target in targets:
            while target and target not in modules:  # import a.b.c of a module a.b (an attribute c)
                target = target.rpartition(".")[0]
            if target and target != name:
                found.add(target)
    return found


@lru_cache(maxsize=None)
def import_graph() -> dict[str, frozenset[str]]:
    return {name: frozenset(imported_modules(name, path)) for name, path in source_modules().items()}


def layer(name: str) -> int:
    if any(name == top or name.startswith(top + ".") for top in COMMAND_LINE):
        return COMMAND_LINE_LAYER
    return LAYERS[name.split(".")[1]]


def strongly_connected_components(graph: dict[str, frozenset[str]]) -> list[set[str]]:
    """Tarjan's algorithm (Tarjan, SIAM J. Comput. 1, 146-160, 1972), iterative; components of two or more."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, successors = work[-1]
            advanced = False
            for successor in successors:
                if successor not in index:
                    index[successor] = low[successor] = counter
                    counter += 1
                    stack.append(successor)
                    on_stack.add(successor)
                    work.append((successor, iter(sorted(graph[successor]))))
                    advanced = True
                    break
                if successor in on_stack:
                    low[node] = min(low[node], index[successor])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = set()
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.add(member)
                    if member == node:
                        break
                if len(component) > 1:
                    components.append(component)
    return components


def test_the_graph_is_read_from_every_module() -> None:
    graph = import_graph()
    assert "foucault_bench.models.base" in graph and "foucault_bench.bench.cli" in graph
    # a known edge at module level and one inside a function body (a deferred import) are both seen
    assert "foucault_bench.models.jit" in graph["foucault_bench.models.base"]
    assert "foucault_bench.bench.verdicts.turning_points" in graph["foucault_bench.bench.problems.reference"]


def test_the_cycle_finder_finds_a_cycle() -> None:
    graph = {"a": frozenset({"b"}), "b": frozenset({"c"}), "c": frozenset({"a"}), "d": frozenset({"a"})}
    assert strongly_connected_components(graph) == [{"a", "b", "c"}]
    assert strongly_connected_components({"a": frozenset({"b"}), "b": frozenset()}) == []


def test_no_import_cycle_among_modules() -> None:
    cycles = [component for component in strongly_connected_components(dict(import_graph()))
              if frozenset(component) not in CYCLE_EXCEPTIONS]
    assert not cycles, "import cycles: " + "; ".join(" ↔ ".join(sorted(component)) for component in cycles)


def test_no_module_imports_a_layer_above_its_own() -> None:
    upward = [f"{importer} (layer {layer(importer)}) imports {imported} (layer {layer(imported)})"
              for importer, imports in sorted(import_graph().items()) for imported in sorted(imports)
              if layer(imported) > layer(importer) and (importer, imported) not in LAYER_EXCEPTIONS]
    assert not upward, "\n".join(upward)


@pytest.mark.parametrize("exception", sorted(LAYER_EXCEPTIONS))
def test_every_layer_exception_is_still_needed(exception: tuple[str, str]) -> None:
    importer, imported = exception
    assert imported in import_graph()[importer], f"{importer} no longer imports {imported}: remove the exception"
