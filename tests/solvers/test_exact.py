"""The exact solver's velocity solve against a brute-force solution of the same LCP, and against the lab
solver's iterations, whose limit it is."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from stackx.solvers.contacts import prepare
from stackx.solvers.column.exact import exact_velocities, solve_column, workspace
from stackx.solvers.column.pgs import velocity_pass

DT = 1 / 60
TOLERANCE = 1e-9


def contact_matrix(n: int) -> np.ndarray:
    """Rows of J: contact 0 is the floor under box 0, contact k the pair (k-1 below, k above)."""
    jac = np.eye(n)
    jac[np.arange(1, n), np.arange(n - 1)] = -1.0
    return jac


def brute_force(y: np.ndarray, u: np.ndarray, inv: np.ndarray, half: np.ndarray, speculative: float
                ) -> tuple[np.ndarray, np.ndarray] | None:
    """Try every set of pushing contacts; return (velocities, impulses) of the first that solves the LCP.

    Contacts with depth > -speculative whose two sides are not both immovable take part; each must end with
    a relative velocity of at least 0 (touching) or depth/dt (a gap it may close), pushing only when it ends
    exactly there. None when no set works (boxes squeezed between immovable things).
    """
    n = len(y)
    depth = np.empty(n)
    depth[0] = half[0] - y[0]
    depth[1:] = (half[:-1] + half[1:]) - (y[1:] - y[:-1])
    jac = contact_matrix(n)
    a = jac @ np.diag(inv) @ jac.T
    b = jac @ u - np.where(depth > 0, 0.0, depth / DT)
    part = [k for k in range(n) if depth[k] > -speculative and a[k, k] > 0]
    scale = 1.0 + np.abs(b).max()
    for size in range(len(part) + 1):
        for pushing in itertools.combinations(part, size):
            lam = np.zeros(n)
            if pushing:
                idx = list(pushing)
                lam[idx] = np.linalg.lstsq(a[np.ix_(idx, idx)], -b[idx], rcond=None)[0]
            w = a @ lam + b
            if (lam >= 0).all() and all(abs(w[k]) <= 1e-10 * scale for k in pushing) \
                    and all(w[k] >= -1e-10 * scale for k in part):
                return u + inv * (jac.T @ lam), lam
    return None


def random_column(rng: np.random.Generator, n: int, immovable: bool) -> tuple[np.ndarray, ...]:
    half = rng.uniform(0.2, 0.8, n)
    gaps = rng.uniform(-0.05, 0.03, n)  # negative: overlap
    y = np.cumsum(np.concatenate([[half[0]], half[:-1] + half[1:]]) - gaps)
    mass = np.exp(rng.uniform(np.log(0.01), np.log(1000.0), n))  # mass ratios up to 1e5
    inv = 1.0 / mass
    if immovable:
        inv[rng.integers(n)] = 0.0
    v = rng.normal(0.0, 2.0, n)
    return y, v, inv, half


@pytest.mark.parametrize("n", range(1, 9))
def test_exact_matches_brute_force(n: int) -> None:
    rng = np.random.default_rng(n)
    solved = 0
    for trial in range(60):
        speculative = 0.0 if trial % 2 else 0.02
        y, v, inv, half = random_column(rng, n, immovable=trial % 3 == 0)
        want = brute_force(y, v, inv, half, speculative)
        if want is None:
            continue
        solved += 1
        got_v, got_lam = exact_velocities(y, v, inv, half, DT, speculative)
        scale = 1.0 + np.abs(want[0]).max()
        np.testing.assert_allclose(got_v, want[0], rtol=0, atol=TOLERANCE * scale)
        if (inv > 0).all():  # with an immovable box the impulses need not be unique, the velocities are
            np.testing.assert_allclose(got_lam, want[1], rtol=0, atol=TOLERANCE * (1.0 + np.abs(want[1]).max()))
        else:  # but they must still solve the problem
            jac = contact_matrix(n)
            np.testing.assert_allclose(got_v, v + inv * (jac.T @ got_lam), rtol=0, atol=TOLERANCE * scale)
            assert (got_lam >= 0).all()
    assert solved >= 40


@pytest.mark.parametrize("n", [1, 5, 12])
def test_a_reused_workspace_carries_nothing_over(n: int) -> None:
    """The solve's scratch is made once and reused at every step without zeroing: started full of garbage
    (NaN, wrong block indices) and then holding what the last column's solve left, it gives bit for bit the
    numbers of a fresh solve."""
    rng = np.random.default_rng(100 + n)
    floats, indices = workspace(n)
    floats.fill(np.nan)
    indices.fill(n + 1)  # a valid index, but the wrong one for every box
    for trial in range(30):
        speculative = 0.0 if trial % 2 else 0.02
        y, v, inv, half = random_column(rng, n, immovable=trial % 3 == 0)
        want_v, want_lam = exact_velocities(y, v, inv, half, DT, speculative)
        mass, target, impulse = np.zeros(n), np.zeros(n), np.zeros(n)
        prepare(y, inv, half, DT, speculative, 0.0, 0.0, np.inf, impulse, mass, target)
        got = v.copy()
        solve_column(got, inv, mass, target, impulse, floats, indices)
        np.testing.assert_array_equal(got, want_v)
        np.testing.assert_array_equal(impulse, want_lam)


def test_inputs_are_left_alone() -> None:
    y, v, inv, half = random_column(np.random.default_rng(0), 6, immovable=False)
    copies = [a.copy() for a in (y, v, inv, half)]
    exact_velocities(y, v, inv, half, DT, 0.0)
    for a, b in zip((y, v, inv, half), copies):
        np.testing.assert_array_equal(a, b)


def test_lab_iterations_converge_to_it() -> None:
    """The lab's Gauss-Seidel passes tend to the exact solve as their number grows (mass ratio 20 here)."""
    y = np.array([0.49, 1.48, 2.475, 3.47, 4.46])
    half = np.full(5, 0.5)
    inv = 1.0 / np.array([1.0, 1.0, 2.0, 1.0, 20.0])
    v = np.array([-0.2, -0.4, -0.1, -0.3, -0.5])
    want, _ = exact_velocities(y, v, inv, half, DT, 0.0)
    errors = []
    lab = v.copy()
    for passes in (1, 10, 100, 3000):
        while passes > 0:
            velocity_pass(y, lab, inv, half)
            passes -= 1
        errors.append(np.abs(lab - want).max())
    assert errors[0] > errors[1] > errors[2] > 0.0
    assert errors[-1] < TOLERANCE


def test_a_resting_column_on_the_floor_stops_dead() -> None:
    """Every contact touching: the whole column takes the floor's velocity, whatever the masses."""
    n = 7
    half = np.full(n, 0.5)
    y = 0.5 + np.arange(n) - 0.001 * (np.arange(n) + 1)  # every contact 1 mm deep
    inv = 1.0 / np.array([1.0, 1000.0, 0.5, 3.0, 100.0, 1.0, 1000.0])
    v, lam = exact_velocities(y, np.full(n, -9.8 * DT), inv, half, DT, 0.0)
    np.testing.assert_allclose(v, 0.0, atol=1e-15)
    # each contact carries the momentum of everything above it
    weight_above = np.cumsum((1.0 / inv)[::-1])[::-1] * 9.8 * DT
    np.testing.assert_allclose(lam, weight_above, rtol=1e-12)
