"""Stages of the solvers, each against what it is meant to do, written out independently."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stackx.solvers.contacts import prepare, velocity_iteration, warm_start
from stackx.solvers.column.jacobi import jacobi_iteration
from stackx.solvers.column.ngs import position_iteration
from stackx.solvers.column.position import correct_positions
from stackx.solvers.column.soft_step import soft
from stackx.solvers.column.split_impulse import pseudo_solve
from stackx.solvers.column.xpbd import project
from tests.solvers.columns import column, run, solver

DT = 1 / 60


def overlapping(n: int = 4) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Heights, inverse masses and half-heights of a column whose every contact overlaps by 5 cm."""
    y = 0.5 + np.arange(n) - 0.05 * (np.arange(n) + 1)
    return y, 1.0 / np.array([1.0, 3.0, 0.5, 2.0])[:n], np.full(n, 0.5)


def depths(y: np.ndarray, half: np.ndarray) -> np.ndarray:
    return np.concatenate([[half[0] - y[0]], (half[:-1] + half[1:]) - np.diff(y)])


# --- position handling that is meant to leave velocities alone does

POSITION_ONLY = ["pgs", "warm-start", "exact", "jacobi", "split-impulse", "ngs"]
INTO_VELOCITY = ["baumgarte", "soft-step"]


@pytest.mark.parametrize("name", POSITION_ONLY)
def test_overlap_is_undone_without_touching_velocities(name: str) -> None:
    """No gravity, boxes at rest overlapping: one step moves them apart and leaves every velocity at 0."""
    y, inv, half = overlapping()
    state = column(list(y), list(1.0 / inv))
    solver(name, [{}], g=0.0).advance(state, 1)
    assert (state.v == 0.0).all()
    assert (depths(state.y[0], half) < depths(y, half)).any()


@pytest.mark.parametrize("name", INTO_VELOCITY)
def test_a_bias_turns_overlap_into_velocity(name: str) -> None:
    """The same column: a bias in the velocity solve leaves the boxes moving apart (the lab's mistake 1)."""
    y, inv, _ = overlapping()
    state = column(list(y), list(1.0 / inv))
    solver(name, [{}], g=0.0).advance(state, 1)
    assert state.v[0, -1] > 0.0


def lab_correction(y: np.ndarray, inv: np.ndarray, half: np.ndarray, slop: float, percent: float,
                   cap: float = math.inf) -> tuple[np.ndarray, float]:
    """The lab's position correction written out: floor, then pairs bottom-up, each depth measured as the
    corrections before it left it; ``cap`` limits each visit's total move. Returns the heights and the
    deepest contact a visit found."""
    y = y.copy()
    deepest = -math.inf
    for k in range(len(y)):
        d = half[0] - y[0] if k == 0 else (half[k - 1] + half[k]) - (y[k] - y[k - 1])
        deepest = max(deepest, d)
        lower = 0.0 if k == 0 else inv[k - 1]
        total = lower + inv[k]
        move = min(max(d - slop, 0.0) * percent, cap) / total
        if k:
            y[k - 1] -= move * lower
        y[k] += move * inv[k]
    return y, deepest


def test_ngs_pass_is_the_lab_correction_with_a_cap() -> None:
    y, inv, half = overlapping()
    for cap in (math.inf, 0.005):
        got = y.copy()
        deepest = position_iteration(got, inv, half, 0.005, 0.2, cap if cap < math.inf else 1e9)
        want, want_deepest = lab_correction(y, inv, half, 0.005, 0.2, cap)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
        assert deepest == pytest.approx(want_deepest, rel=1e-14) and deepest > 0.05  # pushes made it deeper
    same = y.copy()
    correct_positions(same, inv, half, 0.005, 0.2)
    np.testing.assert_allclose(same, lab_correction(y, inv, half, 0.005, 0.2)[0], rtol=0, atol=1e-15)


def test_rigid_projection_is_the_full_lab_correction() -> None:
    """XPBD with compliance 0 puts each contact back to touching: slop 0, percent 1."""
    y, inv, half = overlapping()
    got = y.copy()
    project(got, inv, half, 0.0)
    np.testing.assert_allclose(got, lab_correction(y, inv, half, 0.0, 1.0)[0], rtol=0, atol=1e-15)
    box = np.array([0.45])  # alone on the floor, 5 cm deep, inverse mass 1
    project(box, np.array([1.0]), np.array([0.5]), 3.0)  # compliance/h^2 = 3: a visit undoes 1/(1 + 3)
    assert 0.5 - box[0] == pytest.approx(0.05 * 3 / 4, rel=1e-12)


def test_pseudo_velocity_leaves_positions_and_velocities_alone() -> None:
    """The split-impulse pseudo solve fills only the pseudo-velocity: a separating speed of beta/dt of the
    overlap beyond slop on every contact (checked on the floor contact, solved last by nothing above)."""
    y, inv, half = overlapping(1)
    pseudo, impulse, mass, target = np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1)
    before = y.copy()
    pseudo_solve(y, inv, half, DT, 0.2, 0.01, 5, pseudo, impulse, mass, target)
    np.testing.assert_array_equal(y, before)
    assert pseudo[0] == pytest.approx(0.2 / DT * (0.05 - 0.01))


# --- accumulated impulses


def test_without_memory_it_is_the_lab_solver() -> None:
    """No warm start and no speculative contacts: the lab's per-visit clamp never takes an impulse back on a
    column, so the accumulated form gives the lab's numbers (up to rounding), here on the lab's stack."""
    lab = run("pgs", column([2.5 + 1.6 * i for i in range(5)]), 900, iterations=15)
    same = run("warm-start", column([2.5 + 1.6 * i for i in range(5)]), 900, iterations=15, warm_start=False,
               speculative=0.0)
    np.testing.assert_allclose(same.y, lab.y, rtol=0, atol=1e-9)
    np.testing.assert_allclose(same.v, lab.v, rtol=0, atol=1e-9)


def test_the_accumulated_impulse_may_shrink_but_never_pull() -> None:
    """Two boxes, the lower one 1 cm into the floor, the upper one exactly touching it and flying off: the
    carried impulses over-push, a pass takes part back, and the pair's total stops at 0 instead of pulling."""
    y = np.array([0.49, 1.49])
    inv, half = np.array([1.0, 1.0]), np.array([0.5, 0.5])
    v = np.array([-1.0, 10.0])
    impulse, mass, target = np.array([5.0, 3.0]), np.zeros(2), np.zeros(2)
    prepare(y, inv, half, DT, 0.02, 0.0, 0.0, math.inf, impulse, mass, target)
    assert list(mass) == [1.0, 0.5] and list(target) == [0.0, 0.0]
    warm_start(v, inv, impulse, True)
    assert list(v) == [1.0, 13.0]  # floor +5 on box 0; pair -3 on box 0, +3 on box 1
    velocity_iteration(v, inv, impulse, mass, target)
    # floor: separating at 1, its total drops 5 -> 4 and box 0 stops; pair: separating at 13 asks -6.5, but
    # only its 3 can be taken back, which moves box 0 up by 3 and box 1 down by 3
    assert list(impulse) == [4.0, 0.0] and list(v) == [3.0, 10.0]
    velocity_iteration(v, inv, impulse, mass, target)
    assert list(impulse) == [1.0, 0.0] and list(v) == [0.0, 10.0]


def test_jacobi_applies_every_contact_from_the_same_velocities() -> None:
    y = np.array([0.49, 1.48])
    inv, half = np.array([1.0, 1.0]), np.array([0.5, 0.5])
    v = np.array([-1.0, -3.0])
    impulse, mass, target, change = np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2)
    prepare(y, inv, half, DT, 0.0, 0.0, 0.0, math.inf, impulse, mass, target)
    jacobi_iteration(v, inv, impulse, mass, target, 0.5, change)
    # both from v = (-1, -3): floor wants +1 on box 0, the pair 2 split evenly; half of each is applied
    assert list(impulse) == [0.5, 0.5]
    assert list(v) == [-1.0 + 0.5 - 0.5, -3.0 + 0.5]


def test_forgetting_clears_the_impulses() -> None:
    v, impulse = np.array([1.0, 2.0]), np.array([3.0, 4.0])
    warm_start(v, np.ones(2), impulse, False)
    assert list(impulse) == [0.0, 0.0] and list(v) == [1.0, 2.0]


def test_soft_coefficients_follow_the_published_formulas() -> None:
    h, hertz, zeta = 1 / 240, 30.0, 10.0
    omega = 2 * math.pi * hertz
    spring = h * omega * (2 * zeta + h * omega)
    bias_rate, mass_scale, impulse_scale = soft(hertz, zeta, h)
    assert bias_rate == pytest.approx(omega / (2 * zeta + h * omega), rel=1e-14)
    assert mass_scale == pytest.approx(spring / (1 + spring), rel=1e-14)
    assert impulse_scale == pytest.approx(1 / (1 + spring), rel=1e-14)
    assert mass_scale + impulse_scale == pytest.approx(1.0, rel=1e-14)  # a visit trades old for new impulse


def test_removing_a_box_keeps_the_contact_memory_aligned() -> None:
    """The load-removal event: the impulse under the removed box goes, the one above it moves down."""
    state = column([0.5 + i for i in range(5)], [1.0, 1.0, 1.0, 1.0, 100.0])
    stepper = solver("warm-start", [{}])
    stepper.advance(state, 50)
    before = stepper.impulse.copy()
    stepper.remove_box(state, 2)
    np.testing.assert_array_equal(stepper.impulse, np.delete(before, 2, axis=1))
