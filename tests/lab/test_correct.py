"""The lab's position correction: who moves, by how much, and when nothing moves."""

from __future__ import annotations

import math

from hypothesis import given
from hypothesis import strategies as st

from stackx.solvers.correct import correct

SLOP = 0.01
PERCENT = 0.2


def assert_float_pair(result: object) -> None:
    """The lab asks for two real numbers: Python floats, not ints or array scalars."""
    assert isinstance(result, tuple) and len(result) == 2
    assert all(type(v) is float for v in result), [type(v) for v in result]


def test_depth_below_slop_moves_nothing() -> None:
    result = correct(0.005, SLOP, PERCENT, 1.0, 1.0)
    assert_float_pair(result)
    assert result == (0.0, 0.0)


def test_depth_equal_to_slop_moves_nothing() -> None:
    result = correct(SLOP, SLOP, PERCENT, 1.0, 1.0)
    assert_float_pair(result)
    assert result == (0.0, 0.0)


def test_zero_inverse_mass_sum_gives_float_zeros() -> None:
    for inv in (0.0, 0):
        result = correct(0.5, SLOP, PERCENT, inv, inv)
        assert_float_pair(result)
        assert result == (0.0, 0.0)


def test_a_nan_depth_gives_nan_moves() -> None:
    """As the lab's ``max(depth - slop, 0)`` does in Python: a blown-up height is not turned into no move."""
    assert all(math.isnan(move) for move in correct(math.nan, SLOP, PERCENT, 1.0, 1.0))


def test_static_object_one_leaves_everything_to_object_two() -> None:
    down, up = correct(0.3, SLOP, PERCENT, 0.0, 1.0)
    assert down == 0.0
    assert math.isclose(up, (0.3 - SLOP) * PERCENT, rel_tol=1e-12)


def test_equal_masses_split_evenly() -> None:
    down, up = correct(0.3, SLOP, PERCENT, 1.0, 1.0)
    assert down == up
    assert math.isclose(down + up, (0.3 - SLOP) * PERCENT, rel_tol=1e-12)


def test_lighter_side_moves_more() -> None:
    down, up = correct(0.3, SLOP, PERCENT, 1.0, 3.0)
    assert math.isclose(up, 3.0 * down, rel_tol=1e-12)
    assert math.isclose(down, (0.3 - SLOP) / 4.0 * PERCENT, rel_tol=1e-12)


sane = st.floats(min_value=0.0, max_value=2.0, allow_nan=False, allow_infinity=False)
inverse_mass = st.one_of(st.just(0.0), st.floats(min_value=1e-3, max_value=100.0))


@given(
    depth=sane,
    slop=st.floats(min_value=0.0, max_value=0.1),
    percent=st.floats(min_value=0.0, max_value=1.0),
    inv1=inverse_mass,
    inv2=inverse_mass,
)
def test_matches_the_lab_formula(depth: float, slop: float, percent: float, inv1: float, inv2: float) -> None:
    result = correct(depth, slop, percent, inv1, inv2)
    assert_float_pair(result)
    total = inv1 + inv2
    c = 0.0 if total == 0 else max(depth - slop, 0.0) / total * percent
    want = (c * inv1, c * inv2)
    # abs_tol only absorbs underflow to subnormals, where relative error means nothing.
    for got, expected in zip(result, want):
        assert got >= 0.0
        assert math.isclose(got, expected, rel_tol=1e-12, abs_tol=1e-300)
    assert math.isclose(sum(result), c * total, rel_tol=1e-12, abs_tol=1e-300)
