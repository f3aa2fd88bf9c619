"""The reference's compiled row arithmetic (``mode_rows``) against the same sums written with numpy and dense
matrices, plain and compiled."""

import numpy as np
import pytest

from stackx.kernel import compiled
from stackx.models.planar import mode_rows


def rows(rng: np.random.Generator, count: int, dof: int) -> tuple[np.ndarray, np.ndarray]:
    """``count`` rows of six entries over two bodies each, some bodies immovable (column ``dof``)."""
    bodies = dof // 3
    values = rng.standard_normal((count, 6))
    columns = np.empty((count, 6), np.int64)
    for r in range(count):
        a, b = rng.choice(bodies + 1, 2, replace=False)  # body ``bodies`` stands for the ground
        for side, body in enumerate((a, b)):
            columns[r, 3 * side:3 * side + 3] = dof if body == bodies else 3 * body + np.arange(3)
    return values, columns


@pytest.mark.parametrize("on", [False, True])
def test_matrix_is_the_dense_sum_in_sorted_columns(on: bool) -> None:
    rng = np.random.default_rng(3)
    dof = 24
    j_rows, j_columns = rows(rng, 40, dof)
    g = rng.standard_normal((40, 6))
    diagonal = rng.uniform(1.0, 2.0, dof)
    dense = np.diag(diagonal)
    for r in range(40):
        for i in range(6):
            for jj in range(6):
                if j_columns[r, i] < dof and j_columns[r, jj] < dof:
                    dense[j_columns[r, i], j_columns[r, jj]] += g[r, i] * j_rows[r, jj] / 1e-3
    with compiled(on):
        data, indices, indptr = mode_rows.matrix(diagonal, g, j_rows, j_columns, 1e-3)
    built = np.zeros((dof, dof))
    for c in range(dof):
        column = indices[indptr[c]:indptr[c + 1]]
        assert np.all(np.diff(column) > 0)  # sorted, each row once
        built[column, c] = data[indptr[c]:indptr[c + 1]]
    np.testing.assert_allclose(built, dense, rtol=1e-13, atol=1e-9)
    assert indptr[-1] == np.count_nonzero(np.abs(dense) > 0)


@pytest.mark.parametrize("on", [False, True])
def test_gaps_and_merit_are_the_numpy_sums(on: bool) -> None:
    rng = np.random.default_rng(5)
    dof, m = 18, 15
    values, columns = rows(rng, 2 * m, dof)
    weights, v0, inv = rng.standard_normal(2 * m), rng.standard_normal(dof), rng.uniform(0.5, 1.5, dof)
    fixed_u, target = rng.standard_normal(2 * m), rng.standard_normal(2 * m)
    v = np.append(v0 + inv * np.bincount(columns.ravel(), (values * weights[:, None]).ravel(), dof + 1)[:dof], 0.0)
    expected = (values * v[columns]).sum(axis=1) + fixed_u - target
    cone = rng.uniform(0.1, 1.0, m)
    q = rng.standard_normal(2 * m)
    bound = cone * q[:m]
    worst = max(np.abs(np.minimum(q[:m], expected[:m])).max(),
                np.abs(q[m:] - np.minimum(np.maximum(q[m:] - expected[m:], -bound), bound)).max())
    with compiled(on):
        gap = mode_rows.gaps(values, columns, weights, v0, inv, fixed_u, target)
        assert np.array_equal(gap, expected)
        assert mode_rows.merit(q[:m], q[m:], gap, cone) == worst
        q[3] = np.nan
        assert mode_rows.merit(q[:m], q[m:], gap, cone) == np.inf
