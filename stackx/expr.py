"""Arithmetic over a run's measures, as written in a config: ``y[0]``, ``sink.depth[0] - fixed.depth[0]``.

Only numbers, measure names (prefixed with a run name when an experiment has several runs), constant
indices, ``+ - * /``, unary minus and ``min``, ``max``, ``abs`` are allowed; everything is checked against
the experiment before any stepping, so a typo fails at load time, not after a long run.
"""

from __future__ import annotations

import ast
from collections.abc import Mapping
from typing import Any, NamedTuple

FUNCTIONS = {"min": min, "max": max, "abs": abs}
OPS = {ast.Add: lambda a, b: a + b, ast.Sub: lambda a, b: a - b, ast.Mult: lambda a, b: a * b,
       ast.Div: lambda a, b: a / b}


class ExprError(ValueError):
    pass


class Known(NamedTuple):
    """What an expression may name of one run: its bodies at the end and its model's measures."""

    size: int
    scalars: Mapping[str, str]
    vectors: Mapping[str, str]


def _measure(node: ast.AST, runs: Mapping[str, Known], single: str | None) -> tuple[str, str]:
    """(run name, measure name) named by ``node`` (a Name or run.Attribute)."""
    if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
        run, name = node.value.id, node.attr
        if run not in runs:
            raise ExprError(f"unknown run {run!r}; runs: {', '.join(runs)}")
    elif isinstance(node, ast.Name):
        if single is None:
            raise ExprError(f"{node.id!r} needs a run name in front (RUN.{node.id}); runs: {', '.join(runs)}")
        run, name = single, node.id
    else:
        raise ExprError("expected a measure such as max_depth or y[0]")
    known = runs[run]
    if name not in known.scalars and name not in known.vectors:
        raise ExprError(f"unknown measure {name!r}; measures: {', '.join([*known.scalars, *known.vectors])}")
    return run, name


def evaluate(text: str, runs: Mapping[str, Known], measures: Mapping[str, Mapping[str, Any]] | None = None) -> float:
    """Check ``text`` against ``runs`` (name -> what it has); with ``measures`` also compute it."""
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError:
        raise ExprError(f"not an expression: {text!r}") from None
    single = next(iter(runs)) if len(runs) == 1 else None

    def ev(node: ast.AST) -> float:
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            return float(node.value)
        if isinstance(node, ast.BinOp) and type(node.op) in OPS:
            a, b = ev(node.left), ev(node.right)
            if isinstance(node.op, ast.Div) and b == 0.0 and measures is not None:
                raise ExprError(f"division by zero in {text!r}")
            return OPS[type(node.op)](a, b)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            return -ev(node.operand) if isinstance(node.op, ast.USub) else ev(node.operand)
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in FUNCTIONS \
                and node.args and not node.keywords:
            args = [ev(a) for a in node.args]
            return float(FUNCTIONS[node.func.id](*args)) if len(args) > 1 or node.func.id == "abs" else args[0]
        if isinstance(node, ast.Subscript):
            run, name = _measure(node.value, runs, single)
            if name not in runs[run].vectors:
                raise ExprError(f"{name!r} is a number, not a list: drop the [index]")
            index = node.slice
            sign = 1
            if isinstance(index, ast.UnaryOp) and isinstance(index.op, ast.USub):
                sign, index = -1, index.operand
            if not (isinstance(index, ast.Constant) and type(index.value) is int):
                raise ExprError("an index is a whole number, e.g. y[0] or y[-1]")
            i, n = sign * index.value, runs[run].size
            if not -n <= i < n:
                raise ExprError(f"index {i} out of range: {name} has {n} entries (0..{n - 1})")
            return float(measures[run][name][i]) if measures is not None else 0.0
        if isinstance(node, (ast.Name, ast.Attribute)):
            run, name = _measure(node, runs, single)
            if name in runs[run].vectors:
                raise ExprError(f"{name!r} is a list: pick one entry, e.g. {name}[0]")
            return float(measures[run][name]) if measures is not None else 0.0
        raise ExprError(f"not allowed in a value expression: {ast.unparse(node)!r} "
                        "(use numbers, measures, + - * /, min, max, abs)")

    return ev(tree.body)
