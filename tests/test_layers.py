"""Layer rules of issue 16, checked on the AST import graph of spacarpy/.

Every ``import`` statement counts, deferred ones inside functions included: a deferred import
hides a dependency from the reader, it does not remove it. Rules: no import cycles among
spacarpy modules; element kernels (spacarpy.elements.*) import no model, deck, solver or
results module; the structure (model, settings, job) imports no deck, solver or results
module; the deck layer imports no solver or results module; the solvers import no deck or
results module; the results layer imports no solver or deck module. docs/architecture.md
states the same layers. A failing rule prints the offending edges (importer -> imported,
with the line).
"""
from __future__ import annotations

import ast
import functools
import os
import subprocess
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "spacarpy"


def module_names() -> dict[str, Path]:
    """Dotted name -> file of every module of the package."""
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


@functools.lru_cache(maxsize=1)
def import_edges() -> list[tuple[str, str, int]]:
    """(importer, imported, line) for every import of a spacarpy module by a spacarpy module.

    ``from a.b import c`` is an edge to ``a.b.c`` when that is a module, else to ``a.b``;
    relative imports are resolved against the importing module's package.
    """
    modules = module_names()
    edges = []
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            targets = []
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    anchor = package.split(".")[:len(package.split(".")) - node.level + 1]
                    base = ".".join(anchor + ([base] if base else []))
                targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules
                           else base for alias in node.names]
            for target in targets:
                while target and target not in modules:     # import a.b.c of a package a.b
                    target = target.rpartition(".")[0]
                if target and target != name:
                    edges.append((name, target, node.lineno))
    return sorted(set(edges))


def cycles(edges) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    graph: dict[str, set[str]] = {}
    for a, b, _ in edges:
        graph.setdefault(a, set()).add(b)
        graph.setdefault(b, set())
    index, low, stack, on_stack, out = {}, {}, [], set(), []

    def visit(v):
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
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def _in(module: str, *layers: str) -> bool:
    return any(module == f"spacarpy.{layer}" or module.startswith(f"spacarpy.{layer}.")
               for layer in layers)


def violations(importer_layers, forbidden_layers) -> list[str]:
    return [f"{a} -> {b} (line {line})" for a, b, line in import_edges()
            if _in(a, *importer_layers) and _in(b, *forbidden_layers)]


def test_the_graph_sees_deferred_and_relative_imports():
    edges = import_edges()
    assert len(edges) > 50
    assert any(a.startswith("spacarpy.cli") and b.startswith("spacarpy.deck") for a, b, _ in edges)


def test_no_import_cycles():
    edges = import_edges()
    found = cycles(edges)
    detail = [f"{' <-> '.join(comp)}: "
              + ", ".join(f"{a} -> {b} (line {line})" for a, b, line in edges
                          if a in comp and b in comp) for comp in found]
    assert not found, "import cycles:\n" + "\n".join(detail)


def test_kernels_import_no_model_deck_solver_or_results():
    bad = violations(["elements"], ["model", "deck", "solvers", "results"])
    assert not bad, "element kernels import higher layers:\n" + "\n".join(bad)


def test_deck_imports_no_solver():
    bad = violations(["deck"], ["solvers", "results"])
    assert not bad, "the deck layer imports solvers or results:\n" + "\n".join(bad)


def test_results_import_no_solver():
    bad = violations(["results"], ["solvers", "deck"])
    assert not bad, "the results layer imports solvers or the deck:\n" + "\n".join(bad)


def test_structure_imports_no_deck_solver_or_results():
    bad = violations(["model", "settings", "job"], ["deck", "solvers", "results", "run", "cli"])
    assert not bad, "the structure imports higher layers:\n" + "\n".join(bad)


def test_solvers_import_no_deck_or_results():
    bad = violations(["solvers"], ["deck", "results", "run", "cli", "batch"])
    assert not bad, "the solvers import the deck or results layer:\n" + "\n".join(bad)


def test_importing_spacarpy_leaves_the_environment_alone():
    """A library import sets no process environment (the CLI sets its BLAS threads itself),
    and importing the CLI module loads no numpy, so cli.main can still set them."""
    code = ("import os, sys; before = dict(os.environ); import spacarpy, spacarpy.cli; "
            "assert dict(os.environ) == before, 'import spacarpy changed os.environ'; "
            "assert 'numpy' not in sys.modules, 'spacarpy.cli imports numpy'")
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    env["PYTHONPATH"] = str(PACKAGE.parent) + os.pathsep + env.get("PYTHONPATH", "")
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
