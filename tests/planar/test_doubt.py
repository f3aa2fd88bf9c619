"""Lemke's walk on the points whose mode is in doubt (``stackx.solvers.planar.doubt``), on a recorded step of a
toppling 20-row pyramid (``planar-xpbd`` at 4 substeps, 866 points, 210 boxes;
``data/xpbd_pyramid20_doubt_step.npz``, with the impulses the bench started the reference from) that the
reference's paths and its proximal point method miss, and Lemke's walks on the whole problem too (measured:
they run out of pivots after about 20 s, so that is not repeated here)."""

from __future__ import annotations

import numpy as np
import pytest

from stackx.solvers.planar import doubt, pivoting, reference
from stackx.solvers.planar.problem import ContactProblem, effective_masses, residual
from tests.planar.test_answers import _worst_violation
from tests.planar.test_pivoting import _recorded_npz
from tests.planar.test_reference import _jacobian


@pytest.fixture(scope="module")
def step() -> tuple[ContactProblem, np.ndarray, np.ndarray]:
    return _recorded_npz("xpbd_pyramid20_doubt_step")


@pytest.fixture(scope="module")
def near(step: tuple[ContactProblem, np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray, float]:
    """The closest answer the paths and the proximal point method reach (they miss the step), and its residual."""
    p, pn, pt = step
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(reference, "doubtful_start", lambda *args: None)
        patch.setattr(pivoting, "starts", lambda problem: iter(()))
        with pytest.raises(reference.ReferenceFailure) as failure:
            reference.solve(p, pn, pt)
    return failure.value.pn, failure.value.pt, failure.value.best


def test_a_toppling_pyramid_step_is_landed_from_the_walk_on_its_points_in_doubt(step, near) -> None:
    p, pn, pt = step
    assert p.points == 866 > pivoting.EXACT_POINTS
    assert near[2] > 1e-7  # without it, the closest answer is far from the tolerance
    sol = reference.solve(p, pn, pt)
    assert sol.attempt == reference.DOUBT
    assert residual(p, sol.pn, sol.pt) < 1e-10
    worst, velocity = _worst_violation(p, sol.pn, sol.pt)  # the conditions from their definitions
    assert worst < 1e-9
    assert np.allclose(velocity, sol.velocity, rtol=0.0, atol=1e-12)


def test_the_start_holds_the_clear_points_and_solves_the_points_in_doubt(step, near) -> None:
    """Every point of the start is one of three: apart and left alone (no impulse), held (its normal and
    tangent move at their targets but for the proximal term, ``-d (q - q_near)`` with ``q = p / k``), or in
    doubt, where the walk solved its conditions: no pull, no approach beyond the target, a push only at it,
    friction within ``mu pn`` and against any slip. Velocities and conditions are written here from the
    definitions, with a dense Jacobian."""
    p, _, _ = step
    m = p.points
    kn, kt = effective_masses(p)
    near_pn, near_pt, _ = near
    system = reference.ModeSystem(p, kn, kt, reference.PROXIMAL)
    start = doubt.doubtful_start(p, system, np.concatenate([near_pn / kn, near_pt / kt]))
    assert start is not None
    pn, pt = start
    jac = _jacobian(p)
    inv = np.repeat(p.inv_mass, 3)
    inv[2::3] = p.inv_inertia
    impulse = np.empty(2 * m)
    impulse[0::2], impulse[1::2] = pn, pt
    u = jac @ (p.velocity.reshape(-1) + inv * (jac.T @ impulse))
    gap, ut = u[0::2] - p.target, u[1::2]
    apart = (pn == 0.0) & (pt == 0.0)
    d = reference.PROXIMAL
    held = ~apart & (np.abs(gap + d * (pn - near_pn) / kn) < 1e-9) & (np.abs(ut + d * (pt - near_pt) / kt) < 1e-9)
    qn, qt = pn / kn, pt / kt  # impulses as the speeds they give the point alone (m/s)
    cone = p.friction * kn / kt * qn  # the friction bound, likewise
    tol = 1e-9
    solved = ((qn > -tol) & (gap > -tol) & ((qn < tol) | (np.abs(gap) < tol)) & (np.abs(qt) < cone + tol)
              & ((np.abs(qt) > cone - tol) | (np.abs(ut) < tol)) & ((qt * ut <= 0.0) | (np.abs(ut) < tol)))
    in_doubt = ~apart & ~held
    assert (solved | ~in_doubt).all()
    assert apart.sum() > 0 and held.sum() > 100 and in_doubt.sum() > 20
    # the start is not the near answer: the walk moved the points in doubt
    assert np.abs(pn - near_pn).max() > 1e-3 * np.abs(near_pn).max()


def test_a_quick_solve_walks_the_points_in_doubt_but_not_the_whole_problem(step, monkeypatch) -> None:
    p, pn, pt = step

    def refused(problem: ContactProblem) -> None:
        raise AssertionError("a quick solve walked the whole problem")

    monkeypatch.setattr(pivoting, "starts", refused)
    sol = reference.solve(p, pn, pt, quick=True)
    assert sol.attempt == reference.DOUBT and residual(p, sol.pn, sol.pt) < 1e-10


def test_the_walk_on_the_points_in_doubt_is_made_again_while_it_brings_the_closest_answer_tenfold_nearer(
        monkeypatch) -> None:
    """Step 13 of pyramid-20 under ``planar-warm-start`` at 4 iterations (800 points): the first walk on the
    points in doubt brings the closest answer from about 7e-6 to 2.4e-7 m/s without landing; the second, from
    there, lands. Made once only, the quick solve misses the step."""
    p, pn, pt = _recorded_npz("warm_pyramid20_doubt_step")
    walks = []
    real = reference.doubtful_start

    def counted(*args):
        walks.append(args[2])
        return real(*args)

    monkeypatch.setattr(reference, "doubtful_start", counted)
    sol = reference.solve(p, pn, pt, quick=True)
    assert sol.attempt == reference.DOUBT and residual(p, sol.pn, sol.pt) < 1e-10
    assert len(walks) == 2
    monkeypatch.setattr(reference, "DOUBT_GAIN", 0.0)
    walks.clear()
    with pytest.raises(reference.ReferenceFailure, match="points in doubt"):
        reference.solve(p, pn, pt, quick=True)
    assert len(walks) == 1
