"""Lemke's sparse pivoting against brute force, its contact formulation against the contract, and the
reference's use of it on steps where the Newton rounds cycle."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest
from scipy import sparse

from stackx.solvers.planar import pivoting, reference
from stackx.solvers.planar.pivoting import RayEnd, contact_lcp, walk
from stackx.solvers.planar.problem import (ContactProblem, effective_masses, relative_velocities, residual,
                                          velocities_after)
from tests.planar.test_reference import brute_force, random_problem

FIELDS = ("inv_mass", "inv_inertia", "velocity", "body_a", "body_b", "normal", "ra", "rb", "friction", "target")


def enumerate_lcp(m: np.ndarray, q: np.ndarray) -> list[np.ndarray]:
    """Every ``z`` of the LCP ``(m, q)``: for each subset of basic ``z``, solve ``w_S = 0`` and keep it when
    ``z >= 0`` and ``w >= 0``."""
    n = q.shape[0]
    found = []
    for chosen in itertools.product((False, True), repeat=n):
        basic = np.flatnonzero(chosen)
        z = np.zeros(n)
        if basic.size:
            z[basic] = np.linalg.solve(m[np.ix_(basic, basic)], -q[basic])
        w = m @ z + q
        if (z >= -1e-12).all() and (w >= -1e-12).all():
            found.append(z)
    return found


@pytest.mark.parametrize("seed", range(6))
def test_the_walk_finds_the_one_answer_of_a_positive_definite_lcp(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 2 + seed % 5
    a = rng.normal(size=(n, n))
    m = a @ a.T + 0.1 * np.eye(n) + 0.5 * (a - a.T)  # positive definite, not symmetric: one answer
    q = rng.normal(size=n)
    (expected,) = enumerate_lcp(m, q)
    z = walk(sparse.csc_matrix(m), q).z
    assert np.abs(z - expected).max() < 1e-10
    w = m @ z + q
    assert w.min() > -1e-10 and abs(z @ w) < 1e-10


def test_a_walk_through_many_refactorizations_keeps_its_answer(monkeypatch: pytest.MonkeyPatch) -> None:
    # the etas and fresh LUs represent the same basis: refactoring after every pivot or never changes the answer
    rng = np.random.default_rng(9)
    n = 40
    a = sparse.random(n, n, density=0.1, random_state=3).toarray()
    m = a @ a.T + np.eye(n)
    q = rng.normal(size=n)
    answers = []
    for every in (1, 1000):
        monkeypatch.setattr(pivoting, "REFACTOR", every)
        found = walk(sparse.csc_matrix(m), q)
        answers.append(found.z)
        assert (found.factorizations > found.pivots) == (every == 1)
    assert np.abs(answers[0] - answers[1]).max() < 1e-12
    w = m @ answers[0] + q
    assert w.min() > -1e-12 and answers[0].min() >= 0.0 and abs(answers[0] @ w) < 1e-10


def test_a_basis_solve_through_its_lu_and_etas_solves_the_basis() -> None:
    # 60 pivots into a walk on a recorded step (232 unknowns), the basis is held as the LU of the cold basis and
    # 60 etas: B^-1 rhs from them solves B, the current basis built column by column from the tableau, dense;
    # the compiled solve and the plain one (``STACKX_JIT=0``) give the same bits
    from stackx.kernel import compiled, settings
    from tests.planar.test_reference import _recorded

    ((p, _, _),) = _recorded("domino_step")
    lcp = contact_lcp(p)
    matrix = sparse.csc_matrix(lcp.matrix)
    n = lcp.constant.shape[0]
    cover = pivoting.approach_cover(lcp.constant)
    state = pivoting._Basis(matrix, cover)
    state.factor()
    x = lcp.constant + 1e-12 * np.abs(lcp.constant).max() * (1.0 + np.random.default_rng(0).random(n))
    with compiled(True):
        status, pivots, *_, state.count = pivoting.pivot_run(
            *state.columns, cover, *state.triangles, state.eta_rows, state.etas, state.count, x, state.variables,
            int(np.argmin(x / cover)), 2 * n, -cover, False, 0, 60, pivoting.PIVOT_TOLERANCE)
    assert (status, pivots, state.count) == (pivoting.SPENT, 60, 60)
    assert (state.variables >= n).sum() > 30  # most of the basis is no longer slack
    rhs = np.random.default_rng(1).normal(size=n)
    with compiled(True):
        solved = state.solve(rhs)
    basis = state.build().toarray()
    assert np.abs(basis @ solved - rhs).max() < 1e-9 * np.abs(solved).max()
    with settings({"STACKX_JIT": "0"}):
        assert np.array_equal(state.solve(rhs), solved)


def test_a_walk_plain_and_compiled_is_the_same_walk() -> None:
    from stackx.kernel import settings
    from tests.planar.test_reference import _recorded

    ((p, _, _),) = _recorded("landing_step")
    lcp = contact_lcp(p)
    walks = []
    for jit in ("0", "1"):  # STACKX_JIT: plain, compiled
        with settings({"STACKX_JIT": jit}):
            walks.append(walk(lcp.matrix, lcp.constant, 1e-12, cover=pivoting.approach_cover(lcp.constant)))
    assert walks[0].pivots == walks[1].pivots > 20
    assert np.array_equal(walks[0].z, walks[1].z)
    assert residual(p, *lcp.impulses(walks[1].z)) < 1e-12


def test_a_walk_gives_up_after_its_pivots_per_unknown() -> None:
    # w = z - 1 per row: each z_i enters once, after z0 (n + 1 pivots in all); with one pivot per unknown the walk
    # stops one short, with two it ends on z = 1
    n = 5
    with pytest.raises(RayEnd, match=f"did not end in {n} pivots"):
        walk(sparse.identity(n, format="csc"), -np.ones(n), pivots_each=1)
    found = walk(sparse.identity(n, format="csc"), -np.ones(n), pivots_each=2)
    assert found.pivots == n + 1 and np.abs(found.z - 1.0).max() < 1e-12


def test_an_lcp_without_answer_ends_on_a_ray() -> None:
    with pytest.raises(RayEnd, match="ray"):
        walk(sparse.csc_matrix([[-1.0]]), np.array([-1.0]))  # w = -z - 1 >= 0 has no z >= 0
    nothing = walk(sparse.identity(2, format="csc"), np.array([1.0, 0.0]))  # q >= 0: nothing to push
    assert nothing.z.tolist() == [0.0, 0.0] and nothing.pivots == 0


@pytest.mark.parametrize("points", [1, 2, 3])
def test_the_contact_lcp_answers_are_the_contract_answers(points: int) -> None:
    # whatever the walk ends on, read back as impulses, meets the contract's conditions and is one of the
    # answers brute force finds mode by mode
    rng = np.random.default_rng(200 + points)
    for _ in range(8):
        p = random_problem(rng, points)
        lcp = contact_lcp(p)
        assert lcp.matrix.shape == (4 * points, 4 * points) and lcp.constant.shape == (4 * points,)
        pn, pt = next(pivoting.starts(p))
        assert residual(p, pn, pt) < 1e-9
        v = velocities_after(p, pn, pt)
        assert min(np.abs(v - answer).max() for answer in brute_force(p)) < 1e-8


@pytest.mark.parametrize("points", [2, 5])
def test_a_regularized_lcp_answer_meets_the_contract_of_the_regularized_problem(points: int) -> None:
    # with weight d, every relative velocity carries d p / k (k: the point's effective mass): written out point
    # by point here, the normal's complementarity and the friction box hold exactly for those velocities
    d = 1e-3
    rng = np.random.default_rng(300 + points)
    for _ in range(6):
        p = random_problem(rng, points)
        lcp = contact_lcp(p, d)
        pn, pt = lcp.impulses(walk(lcp.matrix, lcp.constant).z)
        kn, kt = effective_masses(p)
        un, ut = relative_velocities(p, velocities_after(p, pn, pt))
        un, ut = un + d * pn / kn, ut + d * pt / kt
        normal = np.abs(np.minimum(pn / kn, un - p.target))
        bound = p.friction * pn
        tangent = np.abs(pt - np.clip(pt - kt * ut, -bound, bound)) / kt
        assert max(normal.max(), tangent.max()) < 1e-12


def _recorded_npz(name: str) -> tuple[ContactProblem, np.ndarray, np.ndarray]:
    """A step recorded in ``data/NAME.npz`` (the problem's fields, and the impulses the bench started from)."""
    data = np.load(Path(__file__).parent / "data" / f"{name}.npz")
    return ContactProblem(*(data[f] for f in FIELDS)), data["pn"], data["pt"]


def test_a_landing_step_where_newton_cycles_is_solved_by_pivoting(monkeypatch: pytest.MonkeyPatch) -> None:
    """A step of ``planar-warm-start`` (32 iterations) as a 2 kg box lands tilted on a 3-row pyramid: the
    Newton rounds cycle between two mode combinations; Lemke's walk ends on the answer."""
    (step,) = json.loads((Path(__file__).parent / "data" / "landing_step.json").read_text())
    p = ContactProblem(*(np.array(step[f]) for f in FIELDS))
    pn, pt = np.array(step["pn"]), np.array(step["pt"])
    sol = reference.solve(p, pn, pt, interior=False)
    assert residual(p, sol.pn, sol.pt) < 1e-10
    assert sol.attempt == reference.LEMKE  # on a problem this small the fallback pivots first
    monkeypatch.setattr(pivoting, "starts", lambda problem: iter(()))
    alone = reference.solve(p, pn, pt, interior=False)  # without it, the proximal point method gets there too
    assert residual(p, alone.pn, alone.pt) < 1e-10 and alone.attempt == reference.WALK
    monkeypatch.setattr(reference, "SETTLE_ROUNDS", 0)  # Newton rounds alone do not
    with pytest.raises(reference.ReferenceFailure, match="best residual"):
        reference.solve(p, pn, pt, interior=False)


def test_a_settling_20_row_pyramid_is_solved_by_pivoting_on_its_regularized_problem(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Step 5 of ``pyramid-20`` under ``planar-soft-step`` at 64 substeps (800 points, 210 boxes): the path lands
    it (``tests/planar/test_interior.py``); before the path, every Newton try and the proximal point method
    stalled above the tolerance. Lemke's walk on the regularized problem (the pile is too large for its own)
    ends within 1e-5 m/s, and Newton's rounds land from there; made first here (as on a small problem), since
    the walk that comes before it on a pile this large takes seconds to miss."""
    p, pn, pt = _recorded_npz("soft_pyramid20_step")
    assert p.points == 800 > pivoting.EXACT_POINTS
    near = next(pivoting.starts(p))
    assert 1e-10 < residual(p, *near) < 1e-5
    monkeypatch.setattr(reference, "LEMKE_EARLY", p.points)
    sol = reference.solve(p, pn, pt, interior=False)
    assert sol.attempt == reference.LEMKE
    assert residual(p, sol.pn, sol.pt) < 1e-10



@pytest.mark.parametrize("name", ["domino_pgs_step", "stack40_ngs_step"])
def test_steps_every_newton_try_misses_are_landed_by_the_walk_on_their_own_lcp(
        name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Step 283 of the 20 dominoes under ``planar-pgs`` at 16 iterations (44 points) and step 312 of ``stack-40``
    under ``planar-ngs`` at 4 (155 points): without the path, the proximal point method stalls above the
    tolerance (within 1e-8 m/s). The walk at the smallest perturbation ends on the answer itself, which is taken as it is
    (a Newton round there, reading modes on their boundaries, left it)."""
    from tests.planar.test_reference import _recorded

    ((p, pn, pt),) = _recorded(name)
    assert p.points <= pivoting.EXACT_POINTS
    assert residual(p, *next(pivoting.starts(p))) < 1e-12
    sol = reference.solve(p, pn, pt, interior=False)
    assert residual(p, sol.pn, sol.pt) < 1e-10 and sol.attempt == reference.LEMKE
    assert np.array_equal(sol.velocity, velocities_after(p, sol.pn, sol.pt))
    monkeypatch.setattr(pivoting, "starts", lambda problem: iter(()))
    with pytest.raises(reference.ReferenceFailure) as failure:
        reference.solve(p, pn, pt, interior=False)
    assert 1e-10 < failure.value.best < 1e-8


def test_the_pivoting_benchmark_reports_the_walk_that_ended_and_the_stage_that_landed() -> None:
    from benchmarks.planar_pivoting import measure
    from tests.planar.test_reference import _recorded

    ((p, pn, pt),) = _recorded("landing_step")
    name, points, pivots, _, cover, walked, _, stage, solved, _ = measure("landing", p, pn, pt).split()
    lcp, walks = pivoting.plans(p)
    size, most, approach = walks[0]  # covered by 1, at the smallest perturbation: it ends on this step
    assert not approach and (name, int(points), cover) == ("landing", p.points, "1")
    assert int(pivots) == walk(lcp.matrix, lcp.constant, size, most).pivots
    assert float(walked) < 1e-12
    assert int(stage) in (reference.PATH, reference.WARM, reference.WALK, reference.LEMKE) and float(solved) < 1e-10
