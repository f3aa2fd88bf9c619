"""A model is the world the solvers step and the bench measures: ``stackx.models`` imports neither
``stackx.solvers`` nor ``stackx.bench``. Every import counts (at the top, inside a function, under
``TYPE_CHECKING``, relative, or a module named to ``importlib.import_module``)."""

from __future__ import annotations

import ast
from pathlib import Path

import stackx

ROOT = Path(stackx.__file__).parent
WORLD = "stackx.models"
ABOVE = ("stackx.solvers", "stackx.bench")  # what steps a model and what measures it


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported(source: str, name: str, is_package: bool) -> set[str]:
    """Every module the source names in an import, relative ones resolved against ``name``."""
    package = name if is_package else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                up = parts[: len(parts) - node.level + 1]
                base = ".".join([*up, base] if base else up)
            found.add(base)
            found.update(f"{base}.{a.name}" for a in node.names)
        elif (isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant)
              and isinstance(node.args[0].value, str)
              and ((isinstance(node.func, ast.Attribute) and node.func.attr == "import_module")
                   or (isinstance(node.func, ast.Name) and node.func.id in ("import_module", "__import__")))):
            found.add(node.args[0].value)
    return found


def reaches_above(modules: set[str]) -> list[str]:
    return sorted(m for m in modules if any(m == top or m.startswith(top + ".") for top in ABOVE))


def offences() -> dict[str, list[str]]:
    """Per module of ``stackx.models``, the solver and bench modules it imports (none is the rule)."""
    out = {}
    for path in sorted((ROOT / "models").rglob("*.py")):
        name = module_name(path)
        bad = reaches_above(imported(path.read_text(encoding="utf-8"), name, path.name == "__init__.py"))
        if bad:  # ``from a.b import c`` names ``a.b`` and ``a.b.c``: the shorter says it
            out[name] = [m for m in bad if not any(m.startswith(o + ".") for o in bad)]
    return out


def test_the_walker_sees_every_kind_of_import() -> None:
    """The check can fail: imports at the top, inside a function, relative, and by name all count."""
    source = '''
import stackx.bench.criteria
from ...solvers.planar import base
def later():
    from stackx.solvers.planar.contacts import A
    import importlib
    return importlib.import_module("stackx.bench.sweep")
'''
    found = imported(source, "stackx.models.planar.error", False)
    assert reaches_above(found) == ["stackx.bench.criteria", "stackx.bench.sweep", "stackx.solvers.planar",
                                    "stackx.solvers.planar.base", "stackx.solvers.planar.contacts",
                                    "stackx.solvers.planar.contacts.A"]
    assert reaches_above(imported("from stackx.models.planar import state", "stackx.models.x", False)) == []


def test_the_models_import_neither_solvers_nor_bench() -> None:
    found = offences()
    assert not found, "stackx.models reaches above itself: " + "; ".join(
        f"{name} imports {', '.join(bad)}" for name, bad in found.items())
