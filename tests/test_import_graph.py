"""The import graph of the package, read from the source with ``ast`` (imports at module level, inside
functions and under ``if TYPE_CHECKING`` alike): no cycle among modules, no cycle among the sub-packages of
``bench`` (``problems``, ``run``, ``verdicts``, ``gate``, ``perf``, ``commands``, and its single modules), and no
module importing a layer above its own. Each check also runs on a synthetic package with planted violations.

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


def module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join((NAMESPACE, *parts))


def source_modules(root: Path) -> dict[str, Path]:
    modules = {}
    for folder in TOP_LEVEL_FOLDERS:
        for path in sorted((root / folder).rglob("*.py")):
            modules[module_name(path, root)] = path
    return modules


def imported_modules(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The package's modules that ``name`` imports anywhere in its source (``ast.walk``: module level, function
    bodies, ``if TYPE_CHECKING``). ``from P import X`` counts as an import of the submodule ``P.X`` when there is
    one, else of ``P``; relative imports are resolved."""
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


def read_import_graph(root: Path) -> dict[str, frozenset[str]]:
    modules = source_modules(root)
    return {name: frozenset(imported_modules(name, path, modules)) for name, path in modules.items()}


@lru_cache(maxsize=None)
def import_graph() -> dict[str, frozenset[str]]:
    """The package's own graph: module → the package's modules it imports."""
    return read_import_graph(ROOT)


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


def upward_imports(graph: dict[str, frozenset[str]]) -> list[str]:
    """Every import of a module of a higher layer than the importer's, one line each."""
    return [f"{importer} (layer {layer(importer)}) imports {imported} (layer {layer(imported)})"
            for importer, imports in sorted(graph.items()) for imported in sorted(imports)
            if layer(imported) > layer(importer)]


def import_cycles(graph: dict[str, frozenset[str]]) -> list[str]:
    return [" ↔ ".join(sorted(component)) for component in strongly_connected_components(graph)]


def bench_part(name: str) -> str | None:
    """The sub-package of ``bench`` (or module directly in it, e.g. ``bench.schema``, ``bench.cli``) that a module
    belongs to; None outside ``bench``."""
    parts = name.split(".")
    if parts[1] != "bench" or len(parts) < 3:
        return None
    return ".".join(parts[:3])


def bench_part_graph(graph: dict[str, frozenset[str]]) -> dict[str, frozenset[str]]:
    """The graph of ``bench``'s sub-packages: an edge where any module of one imports any module of another."""
    edges: dict[str, set[str]] = {}
    for importer, imports in graph.items():
        source = bench_part(importer)
        if source is None:
            continue
        edges.setdefault(source, set())
        for imported in imports:
            target = bench_part(imported)
            if target is not None and target != source:
                edges[source].add(target)
                edges.setdefault(target, set())
    return {part: frozenset(targets) for part, targets in edges.items()}


def test_the_graph_is_read_from_every_module() -> None:
    graph = import_graph()
    assert "foucault_bench.models.base" in graph and "foucault_bench.bench.cli" in graph
    # a known edge at module level and one inside a function body (a deferred import) are both seen
    assert "foucault_bench.models.jit" in graph["foucault_bench.models.base"]
    assert "foucault_bench.bench.problems.turning_points" in graph["foucault_bench.bench.problems.reference"]


def test_the_cycle_finder_finds_a_cycle() -> None:
    graph = {"a": frozenset({"b"}), "b": frozenset({"c"}), "c": frozenset({"a"}), "d": frozenset({"a"})}
    assert strongly_connected_components(graph) == [{"a", "b", "c"}]
    assert strongly_connected_components({"a": frozenset({"b"}), "b": frozenset()}) == []


def test_no_import_cycle_among_modules() -> None:
    cycles = import_cycles(import_graph())
    assert not cycles, "import cycles: " + "; ".join(cycles)


def test_no_module_imports_a_layer_above_its_own() -> None:
    upward = upward_imports(import_graph())
    assert not upward, "\n".join(upward)


def test_no_cycle_between_the_sub_packages_of_bench() -> None:
    cycles = import_cycles(bench_part_graph(import_graph()))
    assert not cycles, "sub-packages of bench importing each other: " + "; ".join(cycles)


PLANTED_SOURCES = {
    "models/__init__.py": "",
    "models/base.py": "def draw():\n    from foucault_bench.reports.charts import save  # deferred, upward\n",
    "reports/__init__.py": "",
    "reports/charts.py": "from foucault_bench.models import base\n\nsave = None\n",
    "bench/__init__.py": "",
    "bench/problems/__init__.py": "",
    "bench/problems/scenes.py": "from foucault_bench.bench.run import store\n",
    "bench/problems/reference.py": "",
    "bench/run/__init__.py": "",
    "bench/run/store.py": "from ..problems import reference\n",
    "bench/run/runner.py": "from foucault_bench.bench.verdicts.columns import x\n",
    "bench/verdicts/__init__.py": "",
    "bench/verdicts/columns.py": (
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from foucault_bench.bench.run.runner import y\n"),
    "bench/cli.py": "import foucault_bench.reports.charts\n",
}
"""A synthetic package with planted violations: a deferred upward import (models.base → reports.charts, which
imports it back: a cycle too), a cycle of two modules through a TYPE_CHECKING import (run.runner ↔
verdicts.columns), and sub-packages importing each other with no module cycle (problems.scenes → run.store →
problems.reference). The command line importing reports is allowed."""


@pytest.fixture(scope="module")
def planted_graph(tmp_path_factory) -> dict[str, frozenset[str]]:
    root = tmp_path_factory.mktemp("planted")
    for relative, source in PLANTED_SOURCES.items():
        (root / relative).parent.mkdir(parents=True, exist_ok=True)
        (root / relative).write_text(source, encoding="utf-8")
    return read_import_graph(root)


def test_a_planted_upward_import_is_found(planted_graph) -> None:
    assert upward_imports(planted_graph) == [
        "foucault_bench.models.base (layer 0) imports foucault_bench.reports.charts (layer 3)"]


def test_a_planted_module_cycle_is_found(planted_graph) -> None:
    assert sorted(import_cycles(planted_graph)) == [
        "foucault_bench.bench.run.runner ↔ foucault_bench.bench.verdicts.columns",
        "foucault_bench.models.base ↔ foucault_bench.reports.charts"]


def test_a_planted_sub_package_cycle_is_found(planted_graph) -> None:
    assert import_cycles(bench_part_graph(planted_graph)) == [
        "foucault_bench.bench.problems ↔ foucault_bench.bench.run ↔ foucault_bench.bench.verdicts"]
    assert "foucault_bench.bench.problems.scenes" not in " ".join(import_cycles(planted_graph))


INTEGRATING_NAMES = frozenset({"get_integrator", "solve", "Problem", "step_matrix"})
"""Names whose use means integrating: looking an integrator up to run it, running it, posing its problem, or
building its one-step map (``bench.verdicts.stability``)."""


def integrating_uses(path: Path, root: Path = ROOT) -> list[str]:
    """Where the module at ``path`` uses a name of ``INTEGRATING_NAMES`` (as a name, an attribute or an import)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        name = (node.id if isinstance(node, ast.Name) else node.attr if isinstance(node, ast.Attribute)
                else None)
        if isinstance(node, ast.alias):
            name = node.asname or node.name.rpartition(".")[2]
        if name in INTEGRATING_NAMES:
            found.append(f"{path.relative_to(root)}:{getattr(node, 'lineno', '?')} {name}")
    return found


def test_reports_only_draw_and_write() -> None:
    """The computing lives in ``bench`` (``bench.studies``, ``bench.simulation``): no module of ``reports`` runs
    an integrator itself."""
    uses = [use for path in sorted((ROOT / "reports").rglob("*.py")) for use in integrating_uses(path)]
    assert not uses, "reports/ integrates: " + "; ".join(uses)


def test_a_planted_integration_in_reports_is_found(tmp_path) -> None:
    planted = tmp_path / "reports" / "draw.py"
    planted.parent.mkdir()
    planted.write_text("from foucault_bench.integrators import get_integrator\n"
                       "def draw(problem):\n    return get_integrator('rk4').solve(problem, step_s=0.1)\n")
    uses = [use.rpartition(" ")[2] for use in integrating_uses(planted, tmp_path)]
    assert sorted(uses) == ["get_integrator", "get_integrator", "solve"]


def test_perf_stands_apart_from_the_run_path() -> None:
    """``bench.perf`` measures the suite from outside: only the command line imports it, and it uses the run
    path's public names only (no ``_private`` import from ``bench.run``)."""
    perf = "foucault_bench.bench.perf"
    importers = sorted(importer for importer, imports in import_graph().items()
                       if not (importer == perf or importer.startswith(perf + ".")) and layer(importer) < COMMAND_LINE_LAYER
                       and any(imported == perf or imported.startswith(perf + ".") for imported in imports))
    assert not importers, f"outside the command line, {importers} import bench.perf"
    private = [f"{name}: {node.module}.{alias.name}" for name, path in source_modules(ROOT).items()
               if name.startswith(perf + ".") or name == perf
               for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
               if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("foucault_bench.bench.run")
               for alias in node.names if alias.name.startswith("_")]
    assert not private, private
