"""A step's contact problem can have several exact answers whose velocities differ: with friction, Coulomb's
law does not fix the answer, so "the" reference answer of such a step is one of several.

The step: step 7 of ``pyramid-20`` under ``planar-xpbd`` at 4 substeps (the pile shaking, 847 points, 210
boxes; ``data/xpbd_pyramid20_answers_step.npz``). Three answers were found by the reference solve raising the
friction to the pile's 0.6 along three paths, each stage begun from the last one's answer (coefficients 0.5,
0.55, 0.575, 0.6; 0.55, 0.6; 0.55, 0.59, 0.6). Each is checked here against the conditions written from their
definitions, with a dense Jacobian of this file's own, and by the contract's residual.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from stackx.solvers.planar.problem import ContactProblem, residual
from tests.planar.test_pivoting import FIELDS
from tests.planar.test_reference import _jacobian

ANSWERS = "abc"


def _step() -> tuple[ContactProblem, dict[str, tuple[np.ndarray, np.ndarray]]]:
    data = np.load(Path(__file__).parent / "data" / "xpbd_pyramid20_answers_step.npz")
    problem = ContactProblem(*(data[f] for f in FIELDS))
    return problem, {k: (data[f"pn_{k}"], data[f"pt_{k}"]) for k in ANSWERS}


def _worst_violation(p: ContactProblem, pn: np.ndarray, pt: np.ndarray) -> tuple[float, np.ndarray]:
    """The worst violation (m/s) of the contact conditions by impulses ``pn``, ``pt``, and the velocities they
    give: no pull, no approach beyond the target, a push only at the target, friction within ``mu pn``,
    a point inside the friction box not slipping, friction never along the slip. Impulses are turned into
    m/s by the point's own inverse effective mass along its normal (dense, from the Jacobian)."""
    jac = _jacobian(p)
    inv = np.repeat(p.inv_mass, 3)
    inv[2::3] = p.inv_inertia
    impulse = np.empty(2 * p.points)
    impulse[0::2], impulse[1::2] = pn, pt
    v = p.velocity.reshape(-1) + inv * (jac.T @ impulse)
    u = jac @ v
    un, ut = u[0::2], u[1::2]
    scale = np.einsum("ij,j,ij->i", jac[0::2], inv, jac[0::2])  # m/s per N s along each normal
    gap = un - p.target
    bound = p.friction * pn
    inside = np.abs(pt) < bound - 1e-9
    worst = max(float((-pn * scale).max()), float((-gap).max()),
                float(np.where(pn > 0.0, np.abs(gap), 0.0).max()),
                float(((np.abs(pt) - bound) * scale).max()),
                float(np.where(inside, np.abs(ut), 0.0).max()),
                float(np.where(ut * pt > 0.0, np.abs(ut), 0.0).max()))
    return worst, v.reshape(-1, 3)


def test_a_shaking_pyramid_step_has_several_exact_answers_with_different_velocities() -> None:
    p, answers = _step()
    assert p.points == 847 and p.bodies == 210
    velocities = {}
    for key, (pn, pt) in answers.items():
        worst, velocities[key] = _worst_violation(p, pn, pt)
        assert worst < 1e-10, key
        assert residual(p, pn, pt) < 1e-10, key
    spread = [np.abs(velocities[a] - velocities[b]).max() for a, b in (("a", "b"), ("a", "c"), ("b", "c"))]
    # 3.6e-2, 2.5e-2 and 1.6e-2 m/s: not rounding apart, and not one answer's load shared differently among
    # redundant points (which leaves the velocities as they are): different answers
    assert min(spread) > 1e-2


def test_the_answers_benchmark_finds_one_answer_where_a_step_has_one() -> None:
    """``benchmarks.planar_answers`` solves each step again from zero impulses: a box sliding down a ramp (one
    face on one plane, friction below what holds it) has one answer a step, so every step compares and none
    differs (the benchmark holds the step log's stop at 1e-10 m/s, so that both solves are exact)."""
    from benchmarks.planar_answers import compare
    from stackx.bench import error_planar

    found = compare(str(Path(__file__).parents[2] / "configs" / "planar" / "ramp-slide.yaml"), 20, "planar-pgs", None)
    assert found["compared"] == 20 and found["missed"] == 0 and found["unsolved"] == 0
    assert found["apart"] == [0, 0] and found["largest"] < 1e-9
    assert error_planar.FRACTION == 100.0  # put back for the bench


def test_lemke_s_walk_covered_by_the_step_s_approach_lands_the_step_on_a_fourth_answer(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The same step: its central paths fold and the proximal point method stalls (9.5e-7 m/s at best). Lemke's
    walk on its regularized LCP covered by 1 does not end within its pivots (it wanders, ``z0`` rising and
    falling, no basis met twice); covered by the step's approach (``pivoting.approach_cover``) it ends within
    1e-6 m/s, and Newton's rounds and the proximal point method land from there, on an answer of the conditions
    whose velocities lie more than 1e-2 m/s from each of the three above."""
    from stackx.solvers.planar import pivoting, reference

    p, answers = _step()
    data = np.load(Path(__file__).parent / "data" / "xpbd_pyramid20_answers_step.npz")
    lcp, walks = pivoting.plans(p)
    (size, most, approach), covered = walks
    assert not approach and covered[2]
    with pytest.raises(pivoting.RayEnd):
        pivoting.walk(lcp.matrix, lcp.constant, size, most)
    monkeypatch.setattr(pivoting, "plans", lambda problem: (lcp, [covered]))  # the walk above is not made again
    monkeypatch.setattr(reference, "LEMKE_EARLY", p.points)  # pivoting first, before the proximal point method
    sol = reference.solve(p, data["pn"], data["pt"], interior=False)
    assert sol.attempt == reference.LEMKE and residual(p, sol.pn, sol.pt) < 1e-10
    worst, velocity = _worst_violation(p, sol.pn, sol.pt)
    assert worst < 1e-9
    for key, (pn, pt) in answers.items():
        assert np.abs(velocity - _worst_violation(p, pn, pt)[1]).max() > 1e-2, key
