"""The planar contact problem's residual, effective masses and velocities against values worked by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stackx.solvers.planar.problem import ContactProblem, effective_masses, residual, velocities_after

G_DT = 9.8 / 60.0  # speed gravity adds in a step of 1/60 s


def _box_on_ground(arm: tuple[float, float], vx: float = 0.0, mu: float = 0.5, mass: float = 2.0,
                   inertia: float = 0.4) -> ContactProblem:
    """One box falling onto the ground at one point ``arm`` from its centre."""
    return ContactProblem(np.array([1.0 / mass]), np.array([1.0 / inertia]), np.array([[vx, -G_DT, 0.0]]),
                          np.array([-1]), np.array([0]), np.array([[0.0, 1.0]]), np.zeros((1, 2)),
                          np.array([arm]), np.array([mu]), np.array([0.0]))


def test_effective_masses_of_an_off_centre_point_follow_from_mass_and_inertia() -> None:
    kn, kt = effective_masses(_box_on_ground((0.5, -0.5)))
    # n = (0, 1), t = (-1, 0): r x n = 0.5, r x t = -0.5
    assert kn[0] == pytest.approx(1.0 / (0.5 + 0.25 / 0.4), rel=1e-15)
    assert kt[0] == pytest.approx(1.0 / (0.5 + 0.25 / 0.4), rel=1e-15)
    kn, kt = effective_masses(_box_on_ground((0.0, -0.5)))
    assert kn[0] == pytest.approx(2.0, rel=1e-15)  # under the centre the normal does not turn the box
    assert kt[0] == pytest.approx(1.0 / (0.5 + 0.25 / 0.4), rel=1e-15)


def test_an_impulse_turns_the_box_by_its_moment() -> None:
    p = _box_on_ground((0.5, -0.5))
    v = velocities_after(p, np.array([1.0]), np.array([0.0]))
    assert v[0].tolist() == pytest.approx([0.0, -G_DT + 0.5, 0.5 / 0.4], abs=1e-15)  # dw = (r x P) / I
    v = velocities_after(p, np.array([0.0]), np.array([1.0]))  # along t = (-1, 0): r x t = -0.5
    assert v[0].tolist() == pytest.approx([-0.5, -G_DT, -0.5 / 0.4], abs=1e-15)


def test_the_impulse_that_stops_a_falling_box_has_no_residual_and_others_do() -> None:
    p = _box_on_ground((0.0, -0.5))
    held = 2.0 * G_DT  # m g dt
    assert residual(p, np.array([held]), np.array([0.0])) == pytest.approx(0.0, abs=1e-15)
    assert residual(p, np.array([0.0]), np.array([0.0])) == pytest.approx(G_DT, rel=1e-14)  # still approaching
    # twice the impulse: the box leaves at g dt while still pushed (pn / k_n = 2 g dt)
    assert residual(p, np.array([2 * held]), np.array([0.0])) == pytest.approx(G_DT, rel=1e-14)
    assert residual(p, np.array([-held]), np.array([0.0])) == pytest.approx(2 * G_DT, rel=1e-14)  # pulls


def test_a_sliding_box_is_solved_only_by_friction_at_the_bound_against_the_slip() -> None:
    p = _box_on_ground((0.0, -0.5), vx=1.0)  # slides to +x: ut = -vx < 0, so pt must be +mu pn
    held = 2.0 * G_DT
    kt = 1.0 / (0.5 + 0.25 / 0.4)
    assert residual(p, np.array([held]), np.array([0.5 * held])) == pytest.approx(0.0, abs=1e-15)
    wrong = residual(p, np.array([held]), np.array([-0.5 * held]))
    assert wrong == pytest.approx(2 * 0.5 * held / kt, rel=1e-14)  # |pt - mu pn| / k_t
    # too little friction: pt - k_t ut still above mu pn, clipped to it
    assert residual(p, np.array([held]), np.array([0.2 * held])) == pytest.approx(0.3 * held / kt, rel=1e-14)


def test_a_slow_slide_is_stopped_by_sticking_friction() -> None:
    p = _box_on_ground((0.0, -0.5), vx=0.01)  # mu g dt = 0.08 m/s > 0.01 m/s: the point stops in the step
    held = 2.0 * G_DT
    kt = 1.0 / (0.5 + 0.25 / 0.4)  # along t = (-1, 0) at r = (0, -0.5): r x t = -0.5
    pt = kt * 0.01  # brings the point's ut = -0.01 m/s to 0, well inside mu pn
    v = velocities_after(p, np.array([held]), np.array([pt]))
    assert v[0, 0] - v[0, 2] * -0.5 == pytest.approx(0.0, abs=1e-16)  # the point's x velocity
    assert residual(p, np.array([held]), np.array([pt])) == pytest.approx(0.0, abs=1e-15)
    assert residual(p, np.array([held]), np.array([0.0])) == pytest.approx(0.01, rel=1e-13)  # still slips


def test_a_speculative_point_lets_the_gap_close_and_no_more() -> None:
    p = _box_on_ground((0.0, -0.5))
    p.target[:] = -0.05 * 60  # 5 cm apart: may approach at 3 m/s
    assert residual(p, np.array([0.0]), np.array([0.0])) == pytest.approx(0.0, abs=1e-15)
    p.velocity[0, 1] = -4.0
    assert residual(p, np.array([2.0]), np.array([0.0])) == pytest.approx(0.0, abs=1e-14)  # -4 + 2/2 = -3


def test_no_points_is_solved_and_nan_is_not() -> None:
    p = _box_on_ground((0.0, -0.5))
    empty = ContactProblem(p.inv_mass, p.inv_inertia, p.velocity, np.zeros(0), np.zeros(0), np.zeros((0, 2)),
                           np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), np.zeros(0))
    assert residual(empty, np.zeros(0), np.zeros(0)) == 0.0
    assert math.isnan(residual(p, np.array([np.nan]), np.array([0.0])))
