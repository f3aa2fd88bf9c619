"""The reference's compiled row arithmetic (``mode_rows``) against the same sums written with numpy and dense
matrices, plain and compiled."""

import numpy as np
import pytest

from stackx.kernel import compiled
from stackx.solvers.planar import banded, mode_rows


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


def factored(mass: np.ndarray, g: np.ndarray, j_rows: np.ndarray, j_columns: np.ndarray,
             proximal: float) -> tuple[np.ndarray, int, np.ndarray, np.ndarray]:
    """The band LU of the mode system ``diag(mass) + sum_r g_r j_r^T / proximal`` (``banded``): its factors,
    half width, pivots and order."""
    where, half = banded.ordering(j_columns, mass.shape[0])
    ab = banded.band(mass, where, half)
    banded.add(ab, half, where, np.full(j_rows.shape[0], 1.0 / proximal), g, j_rows, j_columns)
    pivots = np.zeros(mass.shape[0], np.int64)
    assert banded.factor(ab, half, pivots)
    return ab, half, pivots, where


@pytest.mark.parametrize("on", [False, True])
def test_proximal_steps_reach_the_answer_of_the_mode_system(on: bool) -> None:
    # the fixed point of the proximal steps solves J_F v = base with M (v - v0) = G q, written densely; three rows
    # repeat others (two points of a face carrying one load), so the system is singular and its answers many
    rng = np.random.default_rng(7)
    dof, free = 12, 9
    j_rows, j_columns = rows(rng, 6, dof)
    j_rows, j_columns = np.concatenate([j_rows, j_rows[:3]]), np.concatenate([j_columns, j_columns[:3]])
    g = j_rows * rng.uniform(0.5, 2.0, (free, 1))
    mass = rng.uniform(1.0, 2.0, dof)
    v0 = rng.standard_normal(dof)
    base = 0.1 * rng.standard_normal(free)
    base[6:] = base[:3]
    dense_j = np.zeros((free, dof + 1))
    dense_g = np.zeros((free, dof + 1))
    for r in range(free):
        np.add.at(dense_j[r], j_columns[r], j_rows[r])
        np.add.at(dense_g[r], j_columns[r], g[r])
    dense_j, dense_g = dense_j[:, :dof], dense_g[:, :dof]
    proximal = 1e-2
    ab, half, pivots, where = factored(mass, g, j_rows, j_columns, proximal)
    with compiled(on):
        q = mode_rows.proximal_steps(ab, half, pivots, where, g, j_rows, j_columns, base, mass * v0, proximal,
                                     np.zeros(free), 2000, 1e-14, np.ones(free, np.bool_), 0.01)
    v = v0 + (dense_g.T @ q) / mass
    np.testing.assert_allclose(dense_j @ v, base, atol=1e-10)
    # one step from a center is the regularized answer: J_F v + d (q - center) = base
    center = rng.standard_normal(free)
    with compiled(on):
        one = mode_rows.proximal_steps(ab, half, pivots, where, g, j_rows, j_columns, base, mass * v0, proximal,
                                       center, 1, 0.0, np.ones(free, np.bool_), 0.01)
    v = v0 + (dense_g.T @ one) / mass
    np.testing.assert_allclose(dense_j @ v + proximal * (one - center), base, atol=1e-10)


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


@pytest.mark.parametrize("on", [False, True])
def test_a_system_without_an_answer_drifts_until_a_held_point_is_emptied(on: bool) -> None:
    # two points on one face pushing along the same row, whose targets disagree: no impulses meet both, and the
    # proximal steps move load from one to the other by the same amount each step. Followed, the drift empties
    # the point losing load, and the other carries the rest; not followed, both still carry load
    rng = np.random.default_rng(9)
    dof = 6
    j_rows, j_columns = rows(rng, 1, dof)
    j_rows, j_columns = np.concatenate([j_rows, j_rows]), np.concatenate([j_columns, j_columns])
    g = j_rows.copy()
    mass = rng.uniform(1.0, 2.0, dof)
    v0 = rng.standard_normal(dof)
    base = np.array([0.1, 0.1 + 1e-5])
    proximal = 1e-2
    ab, half, pivots, where = factored(mass, g, j_rows, j_columns, proximal)
    start = np.array([1.0, 1.0])
    normal = np.ones(2, np.bool_)
    with compiled(on):
        kept = mode_rows.proximal_steps(ab, half, pivots, where, g, j_rows, j_columns, base, mass * v0, proximal,
                                        start, 30, 1e-14, normal, 0.0)
        followed = mode_rows.proximal_steps(ab, half, pivots, where, g, j_rows, j_columns, base, mass * v0,
                                            proximal, start, 30, 1e-14, normal, 0.01)
    assert (kept > 0.0).all()
    drift = kept - mode_rows.proximal_steps(ab, half, pivots, where, g, j_rows, j_columns, base, mass * v0,
                                            proximal, start, 29, 1e-14, normal, 0.0)
    emptied = int(np.argmin(drift))  # the point whose load the drift takes
    assert drift[emptied] < 0.0 < drift[1 - emptied]
    assert abs(followed[emptied]) < 1e-12 and followed[1 - emptied] > kept[1 - emptied]
    # the stride is along the drift: the two loads move in the drift's proportion
    np.testing.assert_allclose((followed - kept) / np.abs(followed - kept).max(), drift / np.abs(drift).max(),
                               rtol=1e-6, atol=1e-9)
