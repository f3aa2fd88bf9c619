"""Value expressions: arithmetic over measures, refused when they name what does not exist."""

from __future__ import annotations

import pytest

from stackx.config.expr import ExprError, Known, evaluate
from stackx.models.column.measures import SCALARS, VECTORS

MEASURES = {"a": {"y": [1.0, 2.0, 3.5], "max_depth": 0.25, "depth": [0.0, 0.1, 0.2]},
            "b": {"y": [0.5, 1.5, 2.0], "max_depth": 0.5, "depth": [0.3, 0.0, 0.0]}}
RUNS = {"a": Known(3, SCALARS, VECTORS), "b": Known(3, SCALARS, VECTORS)}


@pytest.mark.parametrize("text, value", [
    ("a.y[0] + b.y[-1]", 3.0),
    ("(a.max_depth - b.max_depth) * 4 / 2", -0.5),
    ("max(a.depth[1], b.depth[0], 0.2)", 0.3),
    ("abs(-a.y[2])", 3.5),
    ("min(a.y[1], 7)", 2.0),
    ("-1.5e-3", -0.0015),
])
def test_evaluates(text: str, value: float) -> None:
    assert evaluate(text, RUNS, MEASURES) == pytest.approx(value, abs=1e-15)


def test_single_run_needs_no_prefix() -> None:
    assert evaluate("y[1] - max_depth", {"main": RUNS["a"]}, {"main": MEASURES["a"]}) == 1.75


@pytest.mark.parametrize("text, words", [
    ("y[0]", "needs a run name"),
    ("c.y[0]", "unknown run 'c'"),
    ("a.hight", "unknown measure"),
    ("a.y", "is a list"),
    ("a.max_depth[0]", "is a number"),
    ("a.y[3]", "out of range"),
    ("a.y[0.5]", "whole number"),
    ("__import__('os').system('true')", "not allowed"),
    ("a.y[0] ** 2", "not allowed"),
    ("a.y[", "not an expression"),
])
def test_refused(text: str, words: str) -> None:
    with pytest.raises(ExprError, match=words.replace("(", r"\(").replace("[", r"\[")):
        evaluate(text, RUNS)


@pytest.mark.parametrize("text, words", [
    ("1/0", "division by zero"),
    ("a.y[0] / (2 - 2)", "('2 - 2' is 0)"),
    ("abs(1, 2)", "abs() takes exactly 1 value, not 2"),
    ("abs()", "abs() takes exactly 1 value, not 0"),
    ("max()", "max() takes at least 1 value, not 0"),
    ("1e308 * 10", "overflows"),
    ("1e400", "too large"),
    ("1" + "0" * 400, "too large"),
    ("+".join(["1"] * 3000), "at most 1,000 characters"),
    ("+".join(["1"] * 150), "nested more than 100"),
    ("-" * 200 + "1", "nested more than 100"),
    ("min(*a.y)", "not allowed"),
    ("a.y[0]\x00", "not an expression"),
])
def test_refused_at_load_whatever_the_measures(text: str, words: str) -> None:
    with pytest.raises(ExprError) as info:
        evaluate(text, RUNS)
    assert words in str(info.value)


def test_a_measured_zero_divisor_is_named_when_computed() -> None:
    assert evaluate("a.y[0] / b.depth[1]", RUNS) == 0.0  # unknown at load: accepted
    with pytest.raises(ExprError, match=r"division by zero in 'a.y\[0\] / b.depth\[1\]' \('b.depth\[1\]' is 0\)"):
        evaluate("a.y[0] / b.depth[1]", RUNS, MEASURES)


def test_arithmetic_within_bounds_still_evaluates() -> None:
    assert evaluate("+".join(["1"] * 100), RUNS) == 100.0
    assert evaluate("max(a.y[0])", RUNS, MEASURES) == 1.0
