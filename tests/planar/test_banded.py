"""The band LU of the reference's systems (``stackx.solvers.planar.banded``) against dense numpy, plain and
compiled: the order's band holds every entry, the assembly is the dense sum, and the factors solve it."""

from __future__ import annotations

import numpy as np
import pytest

from stackx.kernel import compiled
from stackx.solvers.planar import banded
from tests.planar.test_mode_rows import rows


def dense_sum(diagonal: np.ndarray, weight: np.ndarray, left: np.ndarray, right: np.ndarray,
              columns: np.ndarray) -> np.ndarray:
    """``diag + sum_r weight_r left_r right_r^T``, entry by entry (column ``len(diagonal)``: none)."""
    dof = diagonal.shape[0]
    dense = np.diag(diagonal)
    for r in range(columns.shape[0]):
        for i in range(6):
            for jj in range(6):
                if columns[r, i] < dof and columns[r, jj] < dof:
                    dense[columns[r, i], columns[r, jj]] += weight[r] * left[r, i] * right[r, jj]
    return dense


def chain(bodies: int) -> np.ndarray:
    """The columns of rows joining body ``i`` to ``i + 1`` in a shuffled numbering, plus one on the ground
    (column ``3 * bodies``) for the first: a pile one box wide, numbered anyhow."""
    rng = np.random.default_rng(2)
    label = rng.permutation(bodies)
    dof = 3 * bodies
    columns = [np.concatenate([np.full(3, dof), 3 * label[0] + np.arange(3)])]
    for i in range(bodies - 1):
        columns.append(np.concatenate([3 * label[i] + np.arange(3), 3 * label[i + 1] + np.arange(3)]))
    return np.array(columns, np.int64)


def unsymmetric(seed: int, count: int, dof: int) -> tuple[np.ndarray, ...]:
    """``count`` random rows on ``dof`` unknowns, unsymmetric (pivoting needed): ``(columns, left, right,
    weight, diagonal)`` of ``diag + sum_r weight_r left_r right_r^T``."""
    rng = np.random.default_rng(seed)
    columns = rows(rng, count, dof)[1]
    left, right = rng.standard_normal((count, 6)), rng.standard_normal((count, 6))
    return columns, left, right, rng.uniform(0.5, 2.0, count), rng.uniform(0.01, 0.02, dof)


def assembled(columns: np.ndarray, left: np.ndarray, right: np.ndarray, weight: np.ndarray,
              diagonal: np.ndarray) -> tuple[np.ndarray, int, np.ndarray]:
    """The order, half width and band of the system (``banded``'s, plain or compiled as the caller runs)."""
    where, half = banded.ordering(columns, diagonal.shape[0])
    ab = banded.band(diagonal, where, half)
    banded.add(ab, half, where, weight, left, right, columns)
    return where, half, ab


@pytest.mark.parametrize("on", [False, True])
def test_the_order_puts_a_chain_in_a_narrow_band(on: bool) -> None:
    columns = chain(30)
    with compiled(on):
        where, half = banded.ordering(columns, 90)
    assert sorted(where[:90]) == list(range(90)) and where[90] == 90
    assert half == 5  # a box's three and its neighbour's three: every entry within five of the diagonal
    natural = max(abs(a - b) for row in columns for a in row for b in row if a < 90 and b < 90)
    assert natural > 5 * half  # the shuffled numbering's own band is far wider


@pytest.mark.parametrize("on", [False, True])
def test_the_band_solves_what_numpy_solves(on: bool) -> None:
    dof = 30
    columns, left, right, weight, diagonal = unsymmetric(4, 50, dof)
    dense = dense_sum(diagonal, weight, left, right, columns)
    rhs = np.random.default_rng(5).standard_normal(dof)
    with compiled(on):
        where, half, ab = assembled(columns, left, right, weight, diagonal)
        # the band in order: every entry of the dense sum, where the order puts it
        within = np.zeros((dof, dof))
        for i in range(dof):
            for j in range(dof):
                if abs(where[i] - where[j]) <= half:
                    within[i, j] = ab[where[j], 2 * half + where[i] - where[j]]
        np.testing.assert_allclose(within, dense, rtol=1e-14, atol=1e-14)
        pivots = np.zeros(dof, np.int64)
        assert banded.factor(ab, half, pivots)
        x = banded.solve(ab, half, pivots, where, rhs)
    assert x.shape == (dof + 1,) and x[dof] == 0.0
    np.testing.assert_allclose(x[:dof], np.linalg.solve(dense, rhs), rtol=1e-9, atol=1e-9)
    assert np.abs(dense @ x[:dof] - rhs).max() < 1e-10


@pytest.mark.parametrize("on", [False, True])
def test_a_singular_system_is_reported(on: bool) -> None:
    columns = chain(4)
    weight = np.ones(4)
    left = np.zeros((4, 6))
    left[:, 3:] = 1.0
    with compiled(on):
        where, half = banded.ordering(columns, 12)
        ab = banded.band(np.zeros(12), where, half)  # no mass, and rows that reach one direction of each body
        banded.add(ab, half, where, weight, left, left, columns)
        assert not banded.factor(ab, half, np.zeros(12, np.int64))


def textbook_lu(dense: np.ndarray, half: int) -> tuple[np.ndarray, list[int]]:
    """LU with row pivoting of a matrix whose entries lie within ``half`` of the diagonal, entry by entry on
    the dense matrix: at step ``k`` the largest of column ``k``'s ``half`` entries below the diagonal (the first
    of equals) is swapped up in columns ``k`` on (earlier multipliers stay where they are, as LAPACK's band LU
    keeps them), the column below is divided by the pivot, and every entry ``(i, j)`` right of and below it
    loses ``l_ik u_kj`` (none where ``u_kj`` is 0). Returns the factors in place of the matrix, and the swaps."""
    a = dense.copy()
    n = a.shape[0]
    swaps = []
    for k in range(n):
        last = min(n - 1, k + half)
        p = k
        for i in range(k + 1, last + 1):
            if abs(a[i, k]) > abs(a[p, k]):
                p = i
        swaps.append(p)
        a[[k, p], k:] = a[[p, k], k:]
        for i in range(k + 1, last + 1):
            a[i, k] = a[i, k] / a[k, k]
        for j in range(k + 1, n):
            if a[k, j] != 0.0:
                for i in range(k + 1, last + 1):
                    a[i, j] = a[i, j] - a[i, k] * a[k, j]
    return a, swaps


@pytest.mark.parametrize("on", [False, True])
def test_the_band_factors_are_the_textbook_ones_to_the_bit(on: bool) -> None:
    # an unsymmetric band whose columns need swaps: the factors, the fill above the band included, are the ones
    # of the elimination written entry by entry, bit for bit (the compiled loop's layout changes no operation)
    dof = 36
    with compiled(on):
        _, half, ab = assembled(*unsymmetric(7, 60, dof))
        ordered = np.zeros((dof, dof))
        for j in range(dof):
            for i in range(max(0, j - half), min(dof, j + half + 1)):
                ordered[i, j] = ab[j, 2 * half + i - j]
        pivots = np.zeros(dof, np.int64)
        assert banded.factor(ab, half, pivots)
    expected, swaps = textbook_lu(ordered, half)
    assert list(pivots) == swaps and sum(p != k for k, p in enumerate(swaps)) >= 5
    for j in range(dof):
        for i in range(max(0, j - 2 * half), min(dof, j + half + 1)):
            assert ab[j, 2 * half + i - j] == expected[i, j]
    assert np.array_equal(np.triu(expected, 2 * half + 1), np.zeros((dof, dof)))  # no fill beyond 2 half
