"""The package's import graph: no cycles, and the framework never imports the walker library.

Read from the source (``ast``), not by importing: every ``import`` and ``from ... import``
statement counts, also those inside functions (a lazy import is still a dependency), except those
under ``if TYPE_CHECKING:``, which never run. An edge goes to the module named; ``from pkg import
name`` goes to ``pkg.name`` when that is a module of its own, else to ``pkg``. Importing a module
also runs its parent packages' ``__init__``, but those edges are left out: a package's
``__init__`` gathers its submodules by design.
"""
from __future__ import annotations

import ast
import functools
from pathlib import Path

import networkx as nx

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = "porthamiltonian"


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _imports(tree: ast.AST):
    """Every Import/ImportFrom node, skipping the bodies of ``if TYPE_CHECKING:``."""
    stack = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, ast.If) and _is_type_checking(node):
            stack += node.orelse
            continue
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        stack += ast.iter_child_nodes(node)


@functools.cache
def import_graph(package: str = PACKAGE) -> tuple[nx.DiGraph, dict[str, set[str]]]:
    """(graph of the package's modules, every absolute name each module imports). Made once per
    package (four tests read the framework's; none changes it)."""
    files = sorted((ROOT / package).rglob("*.py"))
    modules = {_module_name(f): f for f in files}
    graph, named = nx.DiGraph(), {}
    for name, path in modules.items():
        graph.add_node(name)
        is_package = path.name == "__init__.py"
        here = name if is_package else name.rpartition(".")[0]
        named[name] = set()
        for node in _imports(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            else:
                base = here
                for _ in range(node.level - 1 if node.level else 0):
                    base = base.rpartition(".")[0]
                source = (f"{base}.{node.module}" if node.module else base) if node.level else (
                    node.module or "")
                targets = [f"{source}.{a.name}" if f"{source}.{a.name}" in modules else source
                           for a in node.names]
            for target in targets:
                named[name].add(target)
                while target and target not in modules and "." in target:
                    target = target.rpartition(".")[0]      # ``import pkg.mod.attr`` forms
                if target in modules and target != name:
                    graph.add_edge(name, target)
    return graph, named


def test_the_framework_has_no_import_cycle():
    graph, _ = import_graph()
    assert len(graph) > 40                                  # the walk found the package
    cycles = list(nx.simple_cycles(graph))
    assert cycles == [], "import cycles: " + "; ".join(" -> ".join([*c, c[0]]) for c in cycles)


def test_no_framework_module_imports_the_walker_library():
    _, named = import_graph()
    offenders = {m: sorted(t for t in targets if t.split(".")[0] == "walker_library")
                 for m, targets in named.items()}
    assert {m: t for m, t in offenders.items() if t} == {}


def _compiler_internals(tree: ast.AST, framework: set[str]) -> list[str]:
    """What ``tree`` imports from inside ``porthamiltonian.compiler``: a submodule (``cache``,
    ``structure``, ...) or a private name. Absolute imports only (relative ones stay inside
    their own package)."""
    found = []
    for node in _imports(tree):
        if isinstance(node, ast.Import):
            found += [a.name for a in node.names if a.name.startswith("porthamiltonian.compiler.")]
        elif node.level == 0 and node.module:
            if node.module.startswith("porthamiltonian.compiler."):
                found.append(node.module)
            elif node.module == "porthamiltonian.compiler":
                found += [f"{node.module}.{a.name}" for a in node.names
                          if a.name.startswith("_") or f"{node.module}.{a.name}" in framework]
    return found


def test_the_walker_library_uses_the_compiler_only_through_its_package():
    """walker_library imports ``porthamiltonian.compiler``'s public names (compile_model,
    layout, Layout) and nothing inside it: not the cache, the structure, the code generator or
    the printers, and no private name. (The walker once wrote into the compiler's cache.)"""
    framework = set(import_graph()[0])
    offenders = {}
    for path in sorted((ROOT / "walker_library").rglob("*.py")):
        found = _compiler_internals(ast.parse(path.read_text(), str(path)), framework)
        if found:
            offenders[_module_name(path)] = found
    assert offenders == {}
    planted = ast.parse("from porthamiltonian.compiler import cache, layout\n"
                        "import porthamiltonian.compiler.structure\n"
                        "def f():\n    from porthamiltonian.compiler import _solved\n")
    assert sorted(_compiler_internals(planted, framework)) == [
        "porthamiltonian.compiler._solved", "porthamiltonian.compiler.cache",
        "porthamiltonian.compiler.structure"]


def test_the_walk_sees_lazy_imports_and_skips_type_checking_ones(tmp_path):
    """The detector itself: a function-level import is an edge, a TYPE_CHECKING one is not."""
    tree = ast.parse("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import a\n"
                     "def f():\n    import b\n")
    assert sorted(n.names[0].name for n in _imports(tree)) == ["TYPE_CHECKING", "b"]


#: the stages of each package in import order: a module may import its own stage and earlier ones.
#: (The compiler comes after the simulation stage in import order although it runs before it: it
#: builds the CompiledModel, so it imports that class; the simulation never imports the compiler.)
STAGES = {
    "porthamiltonian": [("errors", "version", "userfiles", "escaping", "lazy",
                         "collector"), ("modeling",),
                        ("library", "mechanics"), ("integrators",), ("backends", "fmu"),
                        ("simulation",), ("compiler",),
                        ("batch",), ("interfaces",), ("__init__", "__main__")],
    "walker_library": [("core",), ("analyses",), ("report",), ("cli", "__init__", "__main__")],
}
#: imports that reach a later stage (none: a result's notebook views are registered by the
#: report, walker_library.analyses.results.register_view)
KNOWN_UPWARD: set[tuple[str, str]] = set()


def _stage(package: str, module: str) -> int:
    part = module.split(".")[1] if "." in module else "__init__"
    for i, names in enumerate(STAGES[package]):
        if part in names:
            return i
    raise AssertionError(f"{module}: its stage is not declared in STAGES (tests/unit)")


def test_each_stage_imports_only_its_own_and_earlier_stages():
    upward = []
    for package in STAGES:
        graph, _ = import_graph(package)
        for a, b in graph.edges:
            if _stage(package, a) < _stage(package, b) and (a, b) not in KNOWN_UPWARD:
                upward.append(f"{a} -> {b}")
    assert upward == []
