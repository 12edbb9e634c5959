"""The package's layout as a graph of imports: no cycles, and the data concerns depend one way.

Every ``import`` in the source counts, also those inside functions (a lazy import
is still a dependency); only ``if TYPE_CHECKING:`` blocks are left out. The
layout itself is described in docs/architecture.md.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCES = [ROOT / "hapticfx", *sorted((ROOT / "plugins").glob("hapticfx-*/hapticfx_*"))]


def _module_name(path: Path, source: Path) -> str:
    parts = [source.name, *path.relative_to(source).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p, src): p for src in SOURCES for p in src.rglob("*.py")}


def _imports(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()

    def visit(node: ast.AST) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                continue
            if isinstance(child, ast.Import):
                found.update(a.name for a in child.names)
            elif isinstance(child, ast.ImportFrom):
                if child.level:
                    base = package.split(".")[: len(package.split(".")) - child.level + 1]
                    target = ".".join(base + ([child.module] if child.module else []))
                else:
                    target = child.module or ""
                for alias in child.names:  # "from pkg import module" depends on the module
                    found.add(f"{target}.{alias.name}" if f"{target}.{alias.name}" in modules else target)
            visit(child)

    visit(ast.parse(path.read_text(), filename=str(path)))
    return {m for m in found if m in modules and m != name}


GRAPH = {name: _imports(name, path, _modules()) for name, path in _modules().items()}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
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


def test_the_graph_sees_the_package():
    assert len(GRAPH) > 100
    assert "hapticfx.droprig.state" in GRAPH["hapticfx.droprig.receiver"]
    assert "hapticfx.board.protocol" in GRAPH["hapticfx.board.record"]  # lazy and relative imports resolved


def test_the_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_module_imports_itself_through_others():
    assert _cycles(GRAPH) == []


# What each concern of recorded data may import of the others. ``commands`` modules
# are the CLI wiring of a command group and may reach any of them.
CONCERNS = ("data", "processing", "droprig", "board")
MAY_IMPORT = {
    "processing": set(),
    "data": {"processing"},
    "droprig": {"data", "processing"},
    "board": {"data"},
}


def _concern(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if parts[0] == "hapticfx" and len(parts) > 2 else None


@pytest.mark.parametrize("concern", CONCERNS)
def test_each_data_concern_imports_only_what_it_builds_on(concern):
    wrong = sorted(
        f"{name} imports {dep}"
        for name, deps in GRAPH.items()
        if name.startswith(f"hapticfx.{concern}.") and not name.endswith(".commands")
        for dep in deps
        if _concern(dep) in CONCERNS and _concern(dep) not in MAY_IMPORT[concern] | {concern}
    )
    assert wrong == []


# Packages that only measure or fuzz. Nothing a user's impact runs through imports them; the wiring of
# the command line (the core's `builtins/` and `cli/`, a plugin's `plugin`, `cli` and `commands`
# modules) registers the bench commands and imports them inside those commands only.
MEASURING = ("hapticfx.bench", "hapticfx.fuzz", "hapticfx.evaluation",
             "hapticfx_soundcard.bench", "hapticfx_solenoid.bench", "hapticfx_neural.bench")


def _within(module: str, packages) -> bool:
    return any(module == p or module.startswith(p + ".") for p in packages)


def _wiring(module: str) -> bool:
    parts = module.split(".")
    return parts[:2] in (["hapticfx", "builtins"], ["hapticfx", "cli"]) or parts[-1] in ("commands", "plugin", "cli")


def _top_level_imports(name: str) -> set[str]:
    """Imports made when the module itself is imported (not those inside its functions)."""
    path = _modules()[name]
    module = ast.parse(path.read_text(), filename=str(path))
    top = ast.Module(body=[n for n in module.body if not isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef,
                                                                         ast.ClassDef))], type_ignores=[])
    return {dep for dep in GRAPH[name] if dep in _imports_in(top, name)}


def _imports_in(tree: ast.Module, name: str) -> set[str]:
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            package = name if _modules()[name].name == "__init__.py" else name.rpartition(".")[0]
            base = package.split(".")[: len(package.split(".")) - node.level + 1] if node.level else []
            target = ".".join(base + ([node.module] if node.module else []))
            found.add(target)
            found.update(f"{target}.{a.name}" for a in node.names)
    return found


def test_the_measuring_packages_are_in_the_graph():
    for package in MEASURING:
        assert package in GRAPH, package


def test_no_product_module_imports_a_measuring_one():
    wrong = sorted(f"{name} imports {dep}" for name, deps in GRAPH.items()
                   if not _within(name, MEASURING) and not _wiring(name)
                   for dep in deps if _within(dep, MEASURING))
    assert wrong == []


def test_the_command_line_wiring_imports_measuring_code_only_inside_a_bench_command():
    wrong = sorted(f"{name} imports {dep} when it is imported"
                   for name in GRAPH if _wiring(name) and not _within(name, MEASURING)
                   for dep in _top_level_imports(name) if _within(dep, MEASURING))
    assert wrong == []
