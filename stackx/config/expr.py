"""Arithmetic over a run's measures, as written in a config: ``y[0]``, ``sink.depth[0] - fixed.depth[0]``.

Only numbers, measure names (prefixed with a run name when an experiment has several runs), constant
indices, ``+ - * /``, unary minus and ``min``, ``max``, ``abs`` are allowed; everything is checked against
the experiment before any stepping, so a typo fails at load time, not after a long run.

Checking at load also catches what can only fail one way whatever the run measures: a division by a constant
zero, a function given the wrong number of values, a constant too large for a float, and arithmetic on
constants that overflows. An expression is at most ``MAX_LENGTH`` characters and ``MAX_DEPTH`` operations
deep, so reading it never exhausts Python's stack. What depends on the measures (dividing by a measure that
came out zero, a result too large) is refused when the value is computed, naming the expression.
"""

from __future__ import annotations

import ast
import math
from collections.abc import Mapping
from typing import Any, NamedTuple

FUNCTIONS = {"min": min, "max": max, "abs": abs}
ARITY = {"min": (1, None), "max": (1, None), "abs": (1, 1)}  # fewest and most values each function takes
MAX_LENGTH = 1000
"""Most characters in one expression: a difference of a few dozen measures fits many times over."""
MAX_DEPTH = 100
"""Most operations nested inside each other (``1+1+...+1`` of n terms nests n - 1 deep), well below Python's
own limits on parsing and on recursion."""
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
    """Check ``text`` against ``runs`` (name -> what it has); with ``measures`` also compute it.

    Without ``measures`` every measure stands for an unknown number: only what fails whatever it is (see the
    module's docstring) is refused, and the result means nothing."""
    if not isinstance(text, str) or len(text) > MAX_LENGTH:
        raise ExprError(f"an expression is text of at most {MAX_LENGTH:,} characters"
                        + (f" (this one has {len(text):,})" if isinstance(text, str) else ""))
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError, MemoryError, RecursionError):
        raise ExprError(f"not an expression: {text!r}") from None
    _check_depth(tree.body)
    single = next(iter(runs)) if len(runs) == 1 else None

    def ev(node: ast.AST) -> tuple[float, bool]:
        """The value of ``node`` and whether it is known (constants, or everything once measured)."""
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            try:
                value = float(node.value)
            except OverflowError:
                value = math.inf
            if not math.isfinite(value):
                raise ExprError(f"the number {ast.unparse(node)[:20]}... is too large for a float")
            return value, True
        if isinstance(node, ast.BinOp) and type(node.op) in OPS:
            (a, a_known), (b, b_known) = ev(node.left), ev(node.right)
            if isinstance(node.op, ast.Div) and b_known and b == 0.0:
                zero = "" if isinstance(node.right, ast.Constant) else f" ({ast.unparse(node.right)!r} is 0)"
                raise ExprError(f"division by zero in {text!r}{zero}")
            if not (a_known and b_known):
                return 0.0, False  # stands for a measure not yet known
            value = OPS[type(node.op)](a, b)
            if not math.isfinite(value) and math.isfinite(a) and math.isfinite(b):
                raise ExprError(f"{ast.unparse(node)!r} overflows a float in {text!r}")
            return value, True
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            value, exact = ev(node.operand)
            return (-value if isinstance(node.op, ast.USub) else value), exact
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in FUNCTIONS \
                and not node.keywords:
            low, high = ARITY[node.func.id]
            if not low <= len(node.args) <= (high or len(node.args)):
                takes = f"exactly {low}" if low == high else f"at least {low}"
                raise ExprError(f"{node.func.id}() takes {takes} value{'s' if low != 1 else ''}, "
                                f"not {len(node.args)}, in {text!r}")
            if any(isinstance(a, ast.Starred) for a in node.args):
                raise ExprError(f"not allowed in a value expression: {ast.unparse(node)!r}")
            args = [ev(a) for a in node.args]
            if not all(exact for _, exact in args):
                return 0.0, False
            values = [v for v, _ in args]
            return float(FUNCTIONS[node.func.id](*values)) if len(values) > 1 or node.func.id == "abs" \
                else values[0], True
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
            return (float(measures[run][name][i]), True) if measures is not None else (0.0, False)
        if isinstance(node, (ast.Name, ast.Attribute)):
            run, name = _measure(node, runs, single)
            if name in runs[run].vectors:
                raise ExprError(f"{name!r} is a list: pick one entry, e.g. {name}[0]")
            return (float(measures[run][name]), True) if measures is not None else (0.0, False)
        raise ExprError(f"not allowed in a value expression: {ast.unparse(node)!r} "
                        "(use numbers, measures, + - * /, min, max, abs)")

    return ev(tree.body)[0]


def _check_depth(root: ast.AST) -> None:
    """Refuse an expression nested more than ``MAX_DEPTH`` deep, walking it without recursion."""
    stack = [(root, 1)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise ExprError(f"nested more than {MAX_DEPTH} operations deep; split it into simpler values")
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node))
