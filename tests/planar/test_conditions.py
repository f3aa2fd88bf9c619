"""The contact conditions a solver's own answer breaks, against hand-worked one-point problems, and 0 on the
reference's answers."""

from __future__ import annotations

import numpy as np
import pytest

from stackx.solvers.planar.conditions import approach, violations
from stackx.solvers.planar.problem import ContactProblem
from stackx.solvers.planar.reference import solve
from stackx.solvers.planar.step_problem import step_problem
from tests.planar.hand_states import pyramid


def _box_on_ground(vx: float, vy: float) -> ContactProblem:
    """A 1 kg box (1/I = 6) with one point 0.5 m straight below its centre on the ground, mu 0.5, target 0:
    k_n = 1 (the arm is along the normal) and k_t = 1 / (1 + 6 * 0.5^2) = 0.4."""
    return ContactProblem(np.array([1.0]), np.array([6.0]), np.array([[vx, vy, 0.0]]), np.array([-1]),
                          np.array([0]), np.array([[0.0, 1.0]]), np.zeros((1, 2)), np.array([[0.0, -0.5]]),
                          np.array([0.5]), np.zeros(1))


def test_each_condition_is_measured_on_its_own() -> None:
    # too little push: the point still sinks at 0.2 - 0.1 = 0.1 m/s
    assert violations(_box_on_ground(0.0, -0.2), np.array([0.1]), np.zeros(1)) == pytest.approx(
        {"penetration": 0.1, "pull": 0.0, "complementarity": 0.0, "box": 0.0, "dissipation": 0.0}, abs=1e-15)
    # a pull of 0.05 N s: as a velocity of the point alone, 0.05 m/s (k_n = 1)
    assert violations(_box_on_ground(0.0, 1.0), np.array([-0.05]), np.zeros(1))["pull"] == pytest.approx(0.05)
    # pushing 0.2 while separating at 0.5 + 0.2 = 0.7 m/s: the smaller, 0.2
    assert violations(_box_on_ground(0.0, 0.5), np.array([0.2]), np.zeros(1))["complementarity"] == pytest.approx(0.2)
    # friction 0.3 against a bound of 0.5 * 0.2 = 0.1: 0.2 over, / k_t = 0.5 m/s; the point is held
    out = violations(_box_on_ground(0.0, -0.2), np.array([0.2]), np.array([0.3]))
    assert out["box"] == pytest.approx(0.5) and out["penetration"] == 0.0
    # friction inside the box while the point slips: vx = 0.3 - 0.05, w = 6 * (-0.5 * 0.05) = -0.15, so the
    # point moves at 0.25 - 0.15 * 0.5 = 0.175 m/s along x, ut = -0.175; counted up to how far friction is from
    # its bound, (0.1 - 0.05) / k_t = 0.125 m/s; with friction at 0.09, (0.1 - 0.09) / 0.4 = 0.025 m/s
    out = violations(_box_on_ground(0.3, -0.2), np.array([0.2]), np.array([0.05]))
    assert out["dissipation"] == pytest.approx(0.125) and out["box"] == 0.0
    assert violations(_box_on_ground(0.3, -0.2), np.array([0.2]), np.array([0.09]))["dissipation"] == pytest.approx(0.025)
    # friction at its bound, pt = +mu pn = 0.1 (along t = (-1, 0)), so the point must slip along +x (ut <= 0):
    # from vx = 0.3, vx = 0.2 and w = 6 * (-0.5 * 0.1) = -0.3, the point moves at 0.2 - 0.15 = 0.05 m/s: right;
    # from vx = -0.3, at -0.4 - 0.15 = -0.55 m/s, ut = +0.55: friction pushes the slip along
    ok = violations(_box_on_ground(0.3, -0.2), np.array([0.2]), np.array([0.1]))
    wrong = violations(_box_on_ground(-0.3, -0.2), np.array([0.2]), np.array([0.1]))
    assert ok["dissipation"] == 0.0
    assert wrong["dissipation"] == pytest.approx(0.55)


def test_velocities_alone_give_the_approach_beyond_the_target() -> None:
    p = _box_on_ground(0.0, -0.2)
    assert approach(p, p.velocity) == pytest.approx(0.2)
    assert approach(p, np.array([[0.0, 0.1, 0.0]])) == 0.0


def test_the_reference_answer_breaks_no_condition() -> None:
    p = step_problem(pyramid(5, jitter=0.05, seed=2), 0, -9.8, 1 / 60, 0.02)
    sol = solve(p)
    out = violations(p, sol.pn, sol.pt)
    assert max(out.values()) < 1e-10
    assert approach(p, sol.velocity) < 1e-10
    assert approach(p, p.velocity) > 0.1  # the free velocities (gravity alone) sink every resting point
