"""A solver's own answer checked without the reference: the impulses each planar solver says its step applied
are the ones that give its stored velocities, and the step log's figures for them are the contact conditions
worked point by point in plain Python from their definitions (``stackx.solvers.planar.problem``): 0 for an
exact answer, the expected violation for a wrong one."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from stackx.bench.criteria import Criteria
from stackx.config.experiment import load
from stackx.solvers.planar.conditions import matched
from stackx.bench.error_planar import BatchLog, RowLog, StepLog, log_step
from stackx.solvers.planar.problem import ContactProblem
from stackx.registry import solvers
from stackx.run.runner import run_experiment
from stackx.solvers.planar.base import StepImpulses
from tests.planar.hand_states import boxes

DT = 1 / 60
G = -9.8
NAMES = ("penetration", "pull", "complementarity", "box", "dissipation")

STACK = """
scene:
  name: planar
  stack: {count: 4, offset: 0.05, seed: 1, friction: 0.6}
solver: {name: planar-pgs, iterations: 1}
dt: 1/60
steps: 15
"""


def point_terms(problem: ContactProblem, k: int, velocity: np.ndarray) -> tuple[float, float, float, float]:
    """Point ``k``'s relative normal and tangent velocities under body velocities ``velocity``, and its
    inverse effective masses along the normal and the tangent (``1/k_n``, ``1/k_t``)."""
    nx, ny = problem.normal[k]
    tx, ty = -ny, nx
    ux = uy = inv_n = inv_t = 0.0
    for body, r, sign in ((problem.body_a[k], problem.ra[k], -1.0), (problem.body_b[k], problem.rb[k], 1.0)):
        if body < 0:
            continue
        vx, vy, w = velocity[body]
        ux += sign * (vx - w * r[1])
        uy += sign * (vy + w * r[0])
        im, ii = problem.inv_mass[body], problem.inv_inertia[body]
        inv_n += im + ii * (r[0] * ny - r[1] * nx) ** 2
        inv_t += im + ii * (r[0] * ty - r[1] * tx) ** 2
    return ux * nx + uy * ny, ux * tx + uy * ty, inv_n, inv_t


def plain_conditions(problem: ContactProblem, pn: list[float], pt: list[float],
                     velocity: np.ndarray) -> dict[str, float]:
    """Each condition's largest violation over the points, m/s, from the definitions: no point approaches
    faster than its target; ``pn >= 0`` (as the speed ``pn / k_n`` it gives the point alone); no push while
    separating (``min(pn / k_n, un - target)``); ``|pt| <= mu pn`` (the excess over ``k_t``); a point pressed
    (``pn > 0``) slips only with friction at its bound, ``pt = mu pn`` with ``ut <= 0``, ``pt = -mu pn`` with
    ``ut >= 0``; inside the bound, the slip counts up to the friction's distance from it (``/ k_t``). ``velocity``: the bodies' velocities after the step."""
    out = dict.fromkeys(NAMES, 0.0)
    for k in range(problem.points):
        un, ut, inv_n, inv_t = point_terms(problem, k, velocity)
        gap = un - problem.target[k]
        bound = problem.friction[k] * pn[k]
        slip = 0.0
        if pn[k] > 0.0:
            if abs(pt[k]) < bound:
                slip = min(abs(ut), (bound - abs(pt[k])) * inv_t)
            elif pt[k] >= bound:
                slip = max(ut, 0.0)
            else:
                slip = max(-ut, 0.0)
        found = {"penetration": max(-gap, 0.0), "pull": max(-pn[k] * inv_n, 0.0),
                 "complementarity": max(min(pn[k] * inv_n, gap), 0.0),
                 "box": max(abs(pt[k]) - max(bound, 0.0), 0.0) * inv_t, "dissipation": slip}
        for name, value in found.items():
            out[name] = max(out[name], value)
    return out


class Recorder:
    """The planar step log, and beside it, per step of the batch's first row: the step problem the log
    checked, its points' ``(A, B, FEATURE)``, the impulses the solver said it applied and its stored
    velocities."""

    def __init__(self) -> None:
        self.log = StepLog(Criteria())
        self.steps: list[tuple[ContactProblem, np.ndarray, StepImpulses | None, np.ndarray]] = []

    def batch(self, runs: list[Any], solver: Any) -> Any:
        inner = self.log.batch(runs, solver)
        batch_log = self.log.rows[runs[0].name].log

        def on_step(k: int, before: Any, after: Any) -> None:
            inner(k, before, after)
            ref = batch_log.reference
            problem = ref.problem
            exposed = getattr(solver, "step_impulses", None)  # an engine has none
            self.steps.append((problem, ref.ids[:problem.points].copy(), exposed and exposed(0),
                               np.stack([after.vx[0], after.vy[0], after.w[0]], axis=1)))
        return on_step


def record(folder: Path, solver: str, **params: Any) -> tuple[dict[str, Any], Recorder]:
    """A 4-box stack's first 15 steps under ``solver`` with ``params``: the step log's error and the record."""
    path = folder / "stack.yaml"
    path.write_text(STACK)
    spec = load(str(path))
    cls = solvers.get(solver)
    spec.runs = [replace(spec.runs[0], name=solver, solver_cls=cls, solver_params=cls.Params(**params))]
    seen = Recorder()
    run_experiment(spec, None, seen)
    return seen.log.rows[solver].error(), seen


def own_at(keys: np.ndarray, own: StepImpulses) -> tuple[list[float], list[float]]:
    """The solver's impulses at the problem's points, by ``(A, B, FEATURE)``; 0 where it had no such point."""
    by_key = {tuple(k): (n, t) for k, n, t in zip(own.keys.tolist(), own.pn.tolist(), own.pt.tolist())}
    pairs = [by_key.get(tuple(k), (0.0, 0.0)) for k in keys.tolist()]
    return [n for n, _ in pairs], [t for _, t in pairs]


SOLVERS = [("planar-pgs", {"iterations": 1}), ("planar-pgs", {"iterations": 20}),
           ("planar-warm-start", {"iterations": 4}), ("planar-ngs", {"iterations": 4}),
           ("planar-soft-step", {"substeps": 4}), ("planar-soft-step", {"substeps": 3, "relax": False}),
           ("planar-exact", {})]


@pytest.mark.parametrize(("solver", "params"), SOLVERS)
def test_the_impulses_a_solver_exposes_give_the_velocities_it_stored(tmp_path: Path, solver: str,
                                                                     params: dict[str, Any]) -> None:
    # free velocity + M^-1 J^T p, body by body, at the step problem's points: the solver's own velocities
    _, seen = record(tmp_path, solver, **params)
    assert len(seen.steps) == 15
    pushing = []
    for problem, keys, own, stored in seen.steps:
        assert own is not None
        pn, pt = own_at(keys, own)
        v = problem.velocity.copy()
        for k in range(problem.points):
            nx, ny = problem.normal[k]
            px, py = pn[k] * nx - pt[k] * ny, pn[k] * ny + pt[k] * nx
            for body, r, sign in ((problem.body_a[k], problem.ra[k], -1.0), (problem.body_b[k], problem.rb[k], 1.0)):
                if body >= 0:
                    v[body, 0] += sign * problem.inv_mass[body] * px
                    v[body, 1] += sign * problem.inv_mass[body] * py
                    v[body, 2] += sign * problem.inv_inertia[body] * (r[0] * py - r[1] * px)
        assert np.abs(v - stored).max() < 1e-12
        pushing.append(sum(1 for n in pn if n > 0.0))
    assert max(pushing) >= 4  # the stack is held by its points, not by nothing


def test_the_step_log_checks_each_condition_as_its_definition_says(tmp_path: Path) -> None:
    # the lab's solver at one pass on a stack: loads do not reach the top in one pass, so points still sink
    got, seen = record(tmp_path, "planar-pgs", iterations=1)
    largest = dict.fromkeys(NAMES, 0.0)
    worst = []
    for problem, keys, own, stored in seen.steps:
        assert own is not None
        pn, pt = own_at(keys, own)
        step = plain_conditions(problem, pn, pt, stored)
        largest = {name: max(largest[name], step[name]) for name in NAMES}
        worst.append(max(step.values()))
    assert got["violation_steps"] == 15
    assert got["violation_max"] == pytest.approx(largest, rel=1e-9, abs=1e-15)
    assert got["violation_rms"] == pytest.approx(math.sqrt(sum(w * w for w in worst) / len(worst)), rel=1e-9)
    assert got["violation_worst"] == max(NAMES, key=largest.__getitem__)
    assert largest["penetration"] > 0.1  # m/s: a wrong answer reads as wrong
    assert got["approach_max"] == pytest.approx(largest["penetration"], rel=1e-9)


def test_an_exact_answer_breaks_no_condition(tmp_path: Path) -> None:
    exact, _ = record(tmp_path, "planar-exact")
    assert exact["violation_steps"] == 15
    assert max(exact["violation_max"].values()) < 1e-9 and exact["violation_rms"] < 1e-9


@pytest.mark.parametrize(("solver", "params"), [("planar-xpbd", {"substeps": 4}), ("pymunk", {"iterations": 1})])
def test_xpbd_and_engines_are_checked_from_their_velocities_alone(tmp_path: Path, solver: str,
                                                                  params: dict[str, Any]) -> None:
    got, seen = record(tmp_path, solver, **params)
    assert all(own is None for _, _, own, _ in seen.steps)
    assert (got["violation_max"], got["violation_rms"], got["violation_steps"]) == (None, None, 0)
    fastest = []  # the fastest approach beyond a target, from the stored velocities, step by step
    for problem, _, _, stored in seen.steps:
        un = [point_terms(problem, k, stored)[0] for k in range(problem.points)]
        fastest.append(max([0.0] + [t - u for t, u in zip(problem.target, un)]))
    assert got["approach_max"] == pytest.approx(max(fastest), rel=1e-9, abs=1e-15)
    assert got["approach_rms"] == pytest.approx(math.sqrt(sum(f * f for f in fastest) / 15), rel=1e-9, abs=1e-15)


def test_half_the_impulse_that_holds_a_box_shows_as_half_a_step_of_sinking() -> None:
    # a 1 kg unit box resting flat on the ground: the exact step gives each corner m g dt / 2 and the box
    # stays; an answer of half that, on the same points, leaves the box sinking at g dt / 2 (by symmetry it
    # does not turn), so both corners approach at 9.8 / 120 m/s. The stored velocities are the exact ones, so
    # only the impulses can show it.
    before = boxes([0.0], [0.5], [0.0], [(0.5, 0.5)], [1.0], [0.5])
    exact = solvers.get("planar-exact")([exact_params()], np.array([G]), np.array([DT]))
    after = before.copy()
    exact.advance(after, 1)
    held = exact.step_impulses(0)
    assert held is not None and held.pn.tolist() == pytest.approx([9.8 * DT / 2] * 2, rel=1e-9)
    g, dt, margin = np.array([G]), np.array([DT]), np.array([0.02])
    logs = []
    for share in (1.0, 0.5):
        log = BatchLog(1, 1)
        own = StepImpulses(held.keys, share * held.pn, share * held.pt)
        log_step(log, 0, before, after, g, dt, margin, Criteria(), impulses=[own])
        log.steps = 1
        logs.append(RowLog(log, 0).error())
    right, half = logs
    assert max(right["violation_max"].values()) < 1e-12
    assert half["violation_max"]["penetration"] == pytest.approx(9.8 * DT / 2, rel=1e-9)
    assert half["violation_worst"] == "penetration" and half["violation_rms"] == pytest.approx(9.8 * DT / 2)
    assert half["approach_max"] < 1e-12  # the velocities stored are right


def exact_params() -> Any:
    return solvers.get("planar-exact").Params(speculative=0.02)


def test_a_point_the_solver_did_not_have_takes_no_impulse_and_one_the_problem_lacks_is_left_out() -> None:
    keys = np.array([[-1, 0, 1], [-1, 0, 2], [0, 1, 5], [1, 2, 3]])
    own = np.array([[-1, 0, 2], [0, 1, 4], [0, 1, 5], [1, 2, 3]])  # no (-1, 0, 1); (0, 1, 4) not in the problem
    pn, pt = matched(keys, own, np.array([1.0, 2.0, 3.0, 4.0]), np.array([0.5, 0.25, 0.125, 0.0625]))
    assert pn.tolist() == [0.0, 1.0, 3.0, 4.0] and pt.tolist() == [0.0, 0.5, 0.125, 0.0625]
    same, _ = matched(keys, keys.copy(), np.arange(4.0), np.zeros(4))
    assert same.tolist() == [0.0, 1.0, 2.0, 3.0]
