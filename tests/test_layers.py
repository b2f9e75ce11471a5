"""The import graph of the project's packages: no import cycle between modules (imports
inside functions and ``if TYPE_CHECKING:`` blocks included), no package importing one to
its right (tactile_synth, shapes, synth, models, benchmark; the console script
``tactile_synth.entry`` sits above them all), and benchmark's layers (task types, then
results, then the engine, then protocols, then interpretation, report and figures, then
the commands) importing only downwards.

The graph is read from the source files (``ast``), not from an interpreter's imports, so
an import a test run never reaches counts too. A module importing its own ancestor
package (``from benchmark import x`` inside ``benchmark.y``) is not an edge: the
ancestor is already being imported."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: The packages in their order: each may import only those to its left.
PACKAGES: tuple[str, ...] = ("tactile_synth", "shapes", "synth", "models", "benchmark")
#: Modules exempt from the order: the console script dispatches to every package.
TOP: frozenset[str] = frozenset({"tactile_synth.entry"})

#: benchmark's layers, bottom first. A module imports no benchmark module of a layer
#: above its own; a module not listed (the commands, ``run``, ``stress``...) sits above
#: them all. A name ending in ``.*`` stands for every module under that package.
BENCHMARK_LAYERS: tuple[tuple[str, ...], ...] = (
    # Task types and what they are made of.
    (
        "benchmark.budget",
        "benchmark.episodes",
        "benchmark.guards",
        "benchmark.paper_reference",
        "benchmark.splits",
        "benchmark.tasks",
    ),
    # Results: the record schema and the labels records carry.
    ("benchmark.labels", "benchmark.results"),
    # The engine, and the executor and fit cache beside it.
    (
        "benchmark.cells",
        "benchmark.checkpoints",
        "benchmark.engine",
        "benchmark.evaluate",
        "benchmark.fit_groups",
        "benchmark.fits",
        "benchmark.methods",
        "benchmark.pooling",
        "benchmark.workers",
    ),
    # Protocols.
    ("benchmark.protocols", "benchmark.protocols.*"),
    # Interpretation, report and figures.
    (
        "benchmark.diagnose",
        "benchmark.diagnose.*",
        "benchmark.figures",
        "benchmark.interpret",
        "benchmark.report",
        "benchmark.report.*",
        "benchmark.report_accuracy",
        "benchmark.report_datasets",
        "benchmark.report_interpret",
        "benchmark.report_timing",
        "benchmark.tables",
    ),
)


def modules(root: Path = ROOT) -> dict[str, Path]:
    """Dotted module name -> source file of every module of :data:`PACKAGES`."""
    found = {}
    for package in PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join(parts)] = path
    return found


def _targets(module: str, is_package: bool, node: ast.AST, known: dict[str, Path]) -> list[str]:
    """The dotted names an import statement in ``module`` names (a submodule when an
    imported name is one, else the module it is taken from)."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    assert isinstance(node, ast.ImportFrom)
    if node.level:
        base = module.split(".")
        if not is_package:
            base = base[:-1]
        base = base[: len(base) - (node.level - 1)]
        target = ".".join(base) + ("." + node.module if node.module else "")
    else:
        target = node.module or ""
    out = []
    for alias in node.names:
        sub = f"{target}.{alias.name}"
        out.append(sub if sub in known else target)
    return out


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """Module -> the project's modules it imports anywhere in its source."""
    known = modules(root)
    graph: dict[str, set[str]] = {}
    for module, path in known.items():
        deps = set()
        tree = ast.parse(path.read_text(), filename=str(path))
        for node in ast.walk(tree):
            if not isinstance(node, ast.Import | ast.ImportFrom):
                continue
            for target in _targets(module, path.name == "__init__.py", node, known):
                while target and target not in known:
                    target = target.rpartition(".")[0]
                if target and target != module and not module.startswith(target + "."):
                    deps.add(target)
        graph[module] = deps
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of ``graph`` with more than one module (each an
    import cycle), found with Tarjan's algorithm (iteratively: no recursion limit)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    counter = 0
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def rightward(graph: dict[str, set[str]]) -> list[str]:
    """``"a -> b"`` for every import of a package to the right of the importer's."""
    order = {p: i for i, p in enumerate(PACKAGES)}
    return sorted(
        f"{m} -> {d}"
        for m, deps in graph.items()
        for d in deps
        if m not in TOP and order[d.split(".")[0]] > order[m.split(".")[0]]
    )


def layer_of(module: str) -> int:
    """The layer of a benchmark module (:data:`BENCHMARK_LAYERS`; unlisted: above all)."""
    for i, layer in enumerate(BENCHMARK_LAYERS):
        for name in layer:
            if module == name or (name.endswith(".*") and module.startswith(name[:-1])):
                return i
    return len(BENCHMARK_LAYERS)


def upward(graph: dict[str, set[str]]) -> list[str]:
    """``"a -> b"`` for every benchmark module importing one of a higher layer."""
    return sorted(
        f"{m} -> {d}"
        for m, deps in graph.items()
        if m.startswith("benchmark.")
        for d in deps
        if d.startswith("benchmark.") and layer_of(d) > layer_of(m)
    )


@pytest.fixture(scope="module")
def graph() -> dict[str, set[str]]:
    return import_graph()


def test_no_module_takes_part_in_an_import_cycle(graph):
    assert cycles(graph) == []


def test_no_package_imports_one_to_its_right(graph):
    assert rightward(graph) == []


def test_benchmark_modules_import_only_their_own_layer_and_those_below(graph):
    assert upward(graph) == []


def test_every_listed_benchmark_layer_module_exists(graph):
    names = [n for layer in BENCHMARK_LAYERS for n in layer if not n.endswith(".*")]
    assert [n for n in names if n not in graph] == []


def test_the_analysis_finds_a_cycle_through_a_function_level_import(tmp_path):
    """The checks themselves: a cycle hidden in a function, a rightward import and an
    upward one in a tree made for the purpose are all found."""
    for package in PACKAGES:
        (tmp_path / package).mkdir()
        (tmp_path / package / "__init__.py").write_text("")
    (tmp_path / "benchmark" / "engine.py").write_text("def f():\n    from .interpret import g\n")
    (tmp_path / "benchmark" / "interpret.py").write_text("from benchmark.engine import f\n")
    (tmp_path / "benchmark" / "tasks.py").write_text("from . import results\n")
    (tmp_path / "benchmark" / "results.py").write_text("import numpy\n")
    (tmp_path / "synth" / "store.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from models import base\n"
    )
    (tmp_path / "models" / "base.py").write_text("from benchmark import engine\n")
    (tmp_path / "models" / "nets.py").write_text("import models\nfrom . import base\n")
    found = import_graph(tmp_path)
    assert cycles(found) == [["benchmark.engine", "benchmark.interpret"]]
    assert rightward(found) == ["models.base -> benchmark.engine", "synth.store -> models.base"]
    assert upward(found) == [
        "benchmark.engine -> benchmark.interpret",
        "benchmark.tasks -> benchmark.results",
    ]
    # A module importing its own package (here models.nets -> models) is no edge.
    assert found["models.nets"] == {"models.base"}
