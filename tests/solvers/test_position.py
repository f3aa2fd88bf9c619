"""The global position stage, its push-out cap, and swept contacts, against independent computations."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

from stackx import kernel
from stackx.solvers.column.position import GLOBAL, SEQUENTIAL, correct_column, position_workspace, project_positions
from tests.bench.reference import ordered_projection
from tests.solvers.columns import solver

SLOP, PERCENT, DT = 0.01, 0.2, 1 / 60


def _depths(y: list[float], half: list[float]) -> list[float]:
    return [half[0] - y[0]] + [half[i] + half[i + 1] - (y[i + 1] - y[i]) for i in range(len(y) - 1)]


@pytest.mark.parametrize("seed", range(12))
def test_the_global_stage_is_the_ordered_projection_found_by_brute_force(seed: int) -> None:
    """Each contact asks for percent x (depth - slop) of separation when deeper than slop, else may close to
    slop; the smallest mass-weighted move meeting every bound, found by trying every set of tight contacts."""
    rng = random.Random(seed)
    n = rng.randint(1, 6)
    half = [rng.uniform(0.2, 0.6) for _ in range(n)]
    inv = [rng.choice([0.1, 1.0, 2.0]) for _ in range(n)]  # movable: squeezed immovable boxes have no answer
    y, top = [], 0.0
    for i in range(n):
        y.append(top + half[i] + rng.uniform(-0.3, 0.05))
        top = y[-1] + half[i]
    bounds = {k: PERCENT * (d - SLOP) if d > SLOP else d - SLOP for k, d in enumerate(_depths(y, half))}
    want = ordered_projection([0.0] * n, inv, bounds)
    got = np.array(y)
    floats, indices = position_workspace(n)
    with kernel.compiled(False):
        project_positions(got, np.array(inv), np.array(half), SLOP, PERCENT, floats, indices)
    assert got - np.array(y) == pytest.approx(want, abs=1e-12)


def test_the_cap_scales_the_whole_move_down_to_max_push() -> None:
    half = np.full(30, 0.5)
    y = 0.4 + 0.9 * np.arange(30)  # every contact 0.1 deep
    inv = np.ones(30)
    free, capped = y.copy(), y.copy()
    floats, indices = position_workspace(30)
    with kernel.compiled(False):
        correct_column(free, inv, half, SLOP, PERCENT, GLOBAL, np.inf, floats, indices)
        correct_column(capped, inv, half, SLOP, PERCENT, GLOBAL, 0.5 * DT, floats, indices)
    move, limited = free - y, capped - y
    assert move.max() == pytest.approx(30 * PERCENT * (0.1 - SLOP))  # the top rises by every contact's share
    assert np.abs(limited).max() == pytest.approx(0.5 * DT, rel=1e-12)
    assert limited == pytest.approx(move * (0.5 * DT / move.max()), rel=1e-12)


def _recovery(n: int, stage: str, steps: int) -> int | None:
    """Steps until every contact of a column spawned 0.1 m deep at each contact stays within 2 x slop."""
    y = 0.4 + 0.9 * np.arange(n)
    from stackx.models.column.state import ColumnState

    state = ColumnState(y[None, :].copy(), np.zeros((1, n)), np.ones((1, n)), np.full((1, n), 0.5))
    stepper = solver("exact", [{"correction": {"slop": SLOP, "percent": PERCENT, "stage": stage, "max_push": 0.5}}])
    last_deep = -1
    for k in range(steps):
        stepper.advance(state, 1)
        if state.depths().max() > 2 * SLOP:
            last_deep = k
    return None if last_deep == steps - 1 else last_deep + 1


@pytest.mark.parametrize("n", [10, 40])
def test_capped_global_recovery_takes_the_steps_the_top_box_needs_at_max_push(n: int) -> None:
    """The top box must rise n x (0.1 - 0.02) m before every contact is within 0.02; at 0.5 m/s that takes
    n x 0.08 / (0.5 x dt) steps: linear in the height of the column."""
    assert _recovery(n, "global", 12 * n) == math.ceil(n * 0.08 / (0.5 * DT) - 1e-9)


def test_the_sequential_stage_with_the_same_cap_is_slower_on_a_tall_column() -> None:
    fast = _recovery(40, "global", 1200)
    assert fast is not None and _recovery(40, "sequential", 3 * fast) is None


def test_swept_contacts_land_a_fast_box_without_penetration() -> None:
    """A box at -50 m/s moves 0.83 m in a step: the fixed 0.02 m margin lets it in (0.17 m here), the swept step never."""
    from stackx.models.column.state import ColumnState

    def peak(swept: bool) -> float:
        state = ColumnState(np.array([[0.5, 1.5, 4.0]]), np.array([[0.0, 0.0, -50.0]]), np.ones((1, 3)),
                            np.full((1, 3), 0.5))
        solver("exact", [{"swept": swept, "correction": "off"}]).advance(state, 120)
        return float(state.peak_depth[0])

    assert peak(False) > 0.1
    assert peak(True) <= 1e-12


def test_the_sequential_stage_is_the_labs() -> None:
    """SEQUENTIAL with no cap is correct() contact by contact, bit for bit (the lab's numbers depend on it)."""
    from stackx.solvers.correct import correct

    y = [0.45, 1.38, 2.2, 3.25]
    half, inv = [0.5] * 4, [1.0, 1.0, 0.5, 1.0]
    want = list(y)
    _, up = correct(half[0] - want[0], SLOP, PERCENT, 0.0, inv[0])
    want[0] += up
    for i in range(3):
        down, up = correct(half[i] + half[i + 1] - (want[i + 1] - want[i]), SLOP, PERCENT, inv[i], inv[i + 1])
        want[i] -= down
        want[i + 1] += up
    got = np.array(y)
    floats, indices = position_workspace(4)
    with kernel.compiled(False):
        correct_column(got, np.array(inv), np.array(half), SLOP, PERCENT, SEQUENTIAL, np.inf, floats, indices)
    assert got.tolist() == want
