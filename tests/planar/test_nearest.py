"""The planar step log measures a solver against the exact answer nearest its own, stops the reference where its
residual is a small share of what it measures, restarts it cold before giving up, and measures a step it leaves
unsolved against the closest answer it found."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from stackx.bench import error_planar
from stackx.bench.criteria import Criteria
from stackx.bench.error_planar import BatchLog, RowLog, log_step, measure, stop_rule
from stackx.solvers.planar import step_problem as sp
from stackx.solvers.planar.problem import ContactProblem, residual, velocities_after
from stackx.solvers.planar.reference import ReferenceFailure, solve
from tests.planar.hand_states import pyramid
from tests.planar.test_pivoting import FIELDS

DT = 1 / 60


def _answers_step() -> tuple[ContactProblem, dict[str, tuple[np.ndarray, np.ndarray]]]:
    data = np.load(Path(__file__).parent / "data" / "xpbd_pyramid20_answers_step.npz")
    problem = ContactProblem(*(data[f] for f in FIELDS))
    return problem, {k: (data[f"pn_{k}"], data[f"pt_{k}"]) for k in "abc"}


def _rms_speed(a: np.ndarray, b: np.ndarray, radius: np.ndarray) -> float:
    d = a - b
    return float(np.sqrt(np.mean(d[:, 0] ** 2 + d[:, 1] ** 2 + (radius * d[:, 2]) ** 2)))


def test_a_velocity_between_two_exact_answers_is_measured_within_their_spread() -> None:
    p, answers = _answers_step()
    moving = p.inv_mass > 0.0
    radius = np.ones(p.bodies)  # any fixed radius: the same metric on both sides
    velocity = {k: velocities_after(p, *answers[k]) for k in answers}
    first, second = max([("a", "b"), ("a", "c"), ("b", "c")],
                        key=lambda ab: _rms_speed(velocity[ab[0]], velocity[ab[1]], radius[moving]))
    apart = _rms_speed(velocity[first][moving], velocity[second][moving], radius[moving])
    assert apart > 2e-3  # two answers truly apart
    # a solver's answer midway between them: its impulses and velocities (both linear in the impulses)
    pn = 0.5 * (answers[first][0] + answers[second][0])
    pt = 0.5 * (answers[first][1] + answers[second][1])
    own = velocities_after(p, pn, pt)
    log = BatchLog(1, p.bodies)
    log.reference.problem = p
    diff = measure(log, 0, own, radius, moving, velocity[first], (pn, pt), stop_rule(own, radius, moving))
    error = float(np.sqrt(np.mean(diff * diff)))
    spread = float(np.sqrt(log.spread_sumsq[0] / diff.size))
    assert log.nearest[0] == 1
    # a second exact answer was found apart from the first, and the solver's answer lies within that spread:
    # an error the reference cannot resolve, shown as such rather than as a distance from one answer
    assert spread > 0.25 * apart
    assert error <= spread


def test_the_stop_is_a_hundredth_of_the_error_it_measures_and_never_below_1e_10() -> None:
    own = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    radius, moving = np.array([2.0, 1.0]), np.array([True, False])
    rule = stop_rule(own, radius, moving)
    # box 0 differs by 0.3 along x and 0.2 rad/s at radius 2: sqrt(0.09 + 0.16) = 0.5 m/s; box 1 does not move
    assert rule(np.array([[0.7, 0.0, 0.2], [5.0, 5.0, 5.0]])) == pytest.approx(0.5 / error_planar.FRACTION)
    assert rule(own) == 1e-10
    assert rule(np.full((2, 3), np.nan)) == 1e-10


def test_the_reference_stops_at_the_tolerance_its_candidate_answer_is_given() -> None:
    state = pyramid(4, jitter=0.05, seed=3)
    state.vx[0] = np.random.default_rng(4).normal(0.0, 0.3, state.bodies)
    p = sp.step_problem(state, 0, -9.8, DT, 0.02)
    exact = solve(p)
    seen: list[float] = []

    def loose(velocity: np.ndarray) -> float:
        seen.append(float(np.abs(velocity - exact.velocity).max()))
        return 1e-4

    found = solve(p, tolerance=loose)
    assert seen  # asked about the candidate answers it met
    assert residual(p, found.pn, found.pt) < 1e-4
    assert found.rounds + found.sweeps <= exact.rounds + exact.sweeps


def _run_two_steps(log: BatchLog) -> None:
    state = pyramid(3)
    state.vx[0] += 0.1
    after = state.copy()
    after.vx[0] += 0.05
    g, dt, spec = np.array([-9.8]), np.array([DT]), np.array([0.02])
    for k in range(2):
        log_step(log, k, state, after, g, dt, spec, Criteria())
    log.steps = 2


def test_a_step_that_misses_is_measured_against_its_closest_answer_and_counted(
        monkeypatch: pytest.MonkeyPatch) -> None:
    tried: list[bool] = []

    def failing(problem: ContactProblem, pn=None, pt=None, tolerance=1e-10, quick=False, **_: object):
        tried.append(pn is None)
        kept = np.full(problem.points, 0.01)  # the closest answer: a light push at every point
        raise ReferenceFailure("scripted", 3e-6 if pn is None else 2e-6, kept, 0.0 * kept)

    monkeypatch.setattr(sp, "solve", failing)
    log = BatchLog(1, pyramid(3).bodies)
    _run_two_steps(log)
    got = RowLog(log, 0).error()
    assert got["unsolved"] == 2 and got["steps"] == 2
    assert got["rms"] is not None and got["rms"] > 0.0  # a push too light to hold the boxes: measured, not skipped
    assert got["unsolved_residual"] > 0.0
    # the first step starts from zero impulses already; the second starts from the closest answer the first
    # kept, and restarts cold once that missed
    assert tried == [False, False, True]


def test_a_warm_start_that_misses_is_restarted_cold_before_giving_up(monkeypatch: pytest.MonkeyPatch) -> None:
    plain = sp.solve

    def warm_fails(problem: ContactProblem, pn=None, pt=None, **kwargs: object):
        if pn is not None and (np.any(pn) or np.any(pt)):
            raise ReferenceFailure("scripted", 1e-3)
        return plain(problem, pn, pt, **kwargs)

    state = pyramid(3)
    reference = sp.ReferenceStep(1, state.bodies)
    s = state
    args = (s.x[0], s.y[0], s.angle[0], s.vx[0], s.vy[0], s.w[0], s.inv_mass[0], s.inv_inertia[0], s.hx[0],
            s.hy[0], s.friction[0], -9.8, DT, 0.02)
    _, first = reference.measure(0, 1e-10, *args)
    monkeypatch.setattr(sp, "solve", warm_fails)
    found, second = reference.measure(0, 1e-10, *args)
    assert (first, second) == (sp.LANDED, sp.COLD)
    assert residual(reference.problem, found.pn, found.pt) < 1e-10


def _log_at(problem: ContactProblem, measured: int, spreads: list[float]) -> BatchLog:
    """A batch log of one row that has measured ``measured`` steps and found second answers ``spreads`` apart
    (RMS over one box each), on ``problem``."""
    log = BatchLog(1, problem.bodies)
    log.reference.problem = problem
    log.measured[0] = measured
    log.spread_sumsq[0] = sum(s * s for s in spreads)
    log.spread_values[0] = len(spreads)
    return log


def test_a_second_solve_is_sought_where_the_error_is_within_twice_the_runs_spread_and_not_negligible() -> None:
    p, answers = _answers_step()
    given = answers["a"]
    # one step's answers lay 0.1 m/s apart, three others' 1e-3: the run's spread is their RMS, 0.05 m/s
    log = _log_at(p, 7, [0.1, 1e-3, 1e-3, 1e-3])
    spread = float(np.sqrt((0.01 + 3e-6) / 4))
    assert error_planar.nearest_wanted(log, 0, 1.9 * spread, given)
    # an error far above the spread: the nearest answer could move it by at most the spread, which the error
    # carries as its uncertainty; one outlying step's spread (0.1) does not make every such step a second solve
    assert not error_planar.nearest_wanted(log, 0, 2.1 * spread, given)
    # ... but one measured step in SAMPLE is asked whatever its error, to find the spread
    assert error_planar.nearest_wanted(_log_at(p, error_planar.SAMPLE, [1e-3]), 0, 1.0, given)
    assert not error_planar.nearest_wanted(_log_at(p, 7, [1e-3]), 0, 1.0, given)
    assert not error_planar.nearest_wanted(log, 0, 1.9 * spread, None)  # no impulses to start from
    assert not error_planar.nearest_wanted(log, 0, 1e-10, given)  # at an exact answer already
    # a step whose error is under a tenth of the run's RMS error so far barely moves that RMS, whichever answer
    # it is measured against: no second solve for it
    log.sumsq[0], log.values[0] = 30 * (0.5 * spread) ** 2, 30  # 30 box velocities so far, RMS 0.5 spread
    assert error_planar.nearest_wanted(log, 0, 0.06 * spread, given)
    assert not error_planar.nearest_wanted(log, 0, 0.04 * spread, given)


def test_a_second_solve_gives_up_after_its_rounds(monkeypatch: pytest.MonkeyPatch) -> None:
    p, answers = _answers_step()
    step = sp.ReferenceStep(1, p.bodies)
    step.problem = p
    stop = 1e-5  # the stop of an error of 1e-3 m/s
    # a solver's answer midway between two exact ones walks to one of them within the rounds allowed
    mid = tuple(0.5 * (answers["a"][i] + answers["b"][i]) for i in range(2))
    found = step.nearest(*mid, stop)
    assert found is not None and residual(p, found.pn, found.pt) < stop
    # from zero impulses, far from any answer, the walk is a long one: the second solve gives up (the full
    # walk lands, after more rounds than a second solve is worth)
    zeros = np.zeros(p.points)
    assert step.nearest(zeros, zeros, stop) is None
    walked = solve(p, zeros, zeros, tolerance=stop, interior=False, lemke=False)
    assert residual(p, walked.pn, walked.pt) < stop
    monkeypatch.setattr(sp, "NEAREST_WALK", 0)
    assert step.nearest(*mid, stop) is None


def test_a_large_step_both_starts_miss_ends_with_lemkes_walk_on_the_whole(monkeypatch: pytest.MonkeyPatch) -> None:
    from stackx.solvers.planar import pivoting

    plain = sp.solve
    calls: list[str] = []
    whole_lands = [True]

    def starts_miss(problem: ContactProblem, pn=None, pt=None, **kwargs: object):
        if kwargs.get("interior", True):  # the warm start and the cold restart
            calls.append("start")
            raise ReferenceFailure("scripted", 1e-3)
        calls.append("whole")
        if not whole_lands[0]:
            raise ReferenceFailure("scripted", 2e-3)
        assert kwargs.get("walk") == 0  # Lemke's walk alone: the proximal point method just missed twice
        return plain(problem, pn, pt, **kwargs)

    state = pyramid(3)
    monkeypatch.setattr(pivoting, "EXACT_POINTS", 2)  # this small pile counts as a large problem
    reference = sp.ReferenceStep(1, state.bodies)
    s = state
    args = (s.x[0], s.y[0], s.angle[0], s.vx[0], s.vy[0], s.w[0], s.inv_mass[0], s.inv_inertia[0], s.hx[0],
            s.hy[0], s.friction[0], -9.8, DT, 0.02)
    reference.measure(0, 1e-10, *args)  # a first step, landed: the next starts warm
    monkeypatch.setattr(sp, "solve", starts_miss)
    found, how = reference.measure(0, 1e-10, *args)
    assert how == sp.WHOLE and calls == ["start", "start", "whole"]
    assert residual(reference.problem, found.pn, found.pt) < 1e-10
    # a whole walk that misses is not made again until a step of the row lands
    whole_lands[0] = False
    calls.clear()
    assert reference.measure(0, 1e-10, *args)[1] == sp.UNSOLVED
    assert reference.measure(0, 1e-10, *args)[1] == sp.UNSOLVED
    assert calls == ["start", "start", "whole", "start"]  # (the closest answer kept was none: no cold restart)
    monkeypatch.setattr(sp, "solve", plain)
    assert reference.measure(0, 1e-10, *args)[1] != sp.UNSOLVED
    monkeypatch.setattr(sp, "solve", starts_miss)
    calls.clear()
    reference.measure(0, 1e-10, *args)
    assert calls == ["start", "start", "whole"]
