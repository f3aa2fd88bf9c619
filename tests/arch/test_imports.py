"""The package's imports flow one way: no module of ``stackx`` reaches, through any chain of imports, back to
itself. Every import counts (at the top, inside a function, under ``TYPE_CHECKING``), and importing
``stackx.a.b`` counts as importing the package ``stackx.a`` too, as Python runs its ``__init__`` first."""

from __future__ import annotations

import ast
from pathlib import Path

import stackx

ROOT = Path(stackx.__file__).parent


def _modules() -> dict[str, Path]:
    out = {}
    for path in ROOT.rglob("*.py"):
        parts = path.relative_to(ROOT.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = path
    return out


def _targets(name: str, path: Path, known: set[str]) -> set[str]:
    """The modules of ``stackx`` that the file imports, each with the packages above it."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*up, base] if base else up)
            found.add(base)
            found.update(f"{base}.{a.name}" for a in node.names)  # ``from stackx import registry``
    out = set()
    for target in found:
        parts = target.split(".")
        out.update(".".join(parts[:i]) for i in range(1, len(parts) + 1))
    return {t for t in out if t in known and t != name}


def graph() -> dict[str, set[str]]:
    modules = _modules()
    known = set(modules)
    return {name: _targets(name, path, known) for name, path in modules.items()}


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected groups of more than one module (Tarjan), each as a sorted list."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                out.append(sorted(group))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def test_the_finder_sees_a_planted_cycle() -> None:
    """The check can fail: three modules importing in a ring are one group, a chain is none."""
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": {"c"}, "c": set()}) == []


def test_the_graph_holds_the_imports_it_should() -> None:
    """Edges the walker must see: a top-level import, one under TYPE_CHECKING, a parent package."""
    edges = graph()
    assert "stackx.config.spec" in edges["stackx.run.runner"]
    assert "stackx.config.spec" in edges["stackx.outputs"]  # under TYPE_CHECKING
    assert {"stackx.models", "stackx.models.column"} <= edges["stackx.models.column.model"]


def test_no_module_of_stackx_imports_itself_through_others() -> None:
    found = cycles(graph())
    assert not found, "import cycles: " + "; ".join(" <-> ".join(group) for group in found)
