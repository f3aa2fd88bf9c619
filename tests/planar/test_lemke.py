"""Lemke's pivoting against brute force, its contact formulation against the contract, and the reference's
use of it on a step where the Newton rounds cycle."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest

from stackx.models.planar import reference
from stackx.models.planar.lemke import RayTermination, contact_lcp, lemke, solve_lcp
from stackx.models.planar.problem import ContactProblem, residual, velocities_after
from tests.planar.test_reference import brute_force, random_problem


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
def test_lemke_finds_the_one_answer_of_a_positive_definite_lcp(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 2 + seed % 5
    a = rng.normal(size=(n, n))
    m = a @ a.T + 0.1 * np.eye(n) + 0.5 * (a - a.T)  # positive definite, not symmetric: one answer
    q = rng.normal(size=n)
    (expected,) = enumerate_lcp(m, q)
    z = lemke(m, q)
    assert np.abs(z - expected).max() < 1e-10
    w = m @ z + q
    assert w.min() > -1e-10 and abs(z @ w) < 1e-10


def test_an_lcp_without_answer_ends_on_a_ray() -> None:
    with pytest.raises(RayTermination, match="ray"):
        lemke(np.array([[-1.0]]), np.array([-1.0]))  # w = -z - 1 >= 0 has no z >= 0
    assert lemke(np.eye(2), np.array([1.0, 0.0])).tolist() == [0.0, 0.0]  # q >= 0: nothing to push


@pytest.mark.parametrize("points", [1, 2, 3])
def test_the_contact_lcp_answers_are_the_contract_answers(points: int) -> None:
    # whatever Lemke ends on, read back as impulses, meets the contract's conditions and is one of the
    # answers brute force finds mode by mode
    rng = np.random.default_rng(200 + points)
    for _ in range(8):
        p = random_problem(rng, points)
        matrix, constant = contact_lcp(p)
        assert matrix.shape == (4 * points, 4 * points) and constant.shape == (4 * points,)
        (pn, pt), *_ = solve_lcp(p)
        assert residual(p, pn, pt) < 1e-9
        v = velocities_after(p, pn, pt)
        assert min(np.abs(v - answer).max() for answer in brute_force(p)) < 1e-8


def test_a_landing_step_where_newton_cycles_is_solved_by_pivoting(monkeypatch: pytest.MonkeyPatch) -> None:
    """A step of ``planar-warm-start`` (32 iterations) as a 2 kg box lands tilted on a 3-row pyramid: the
    Newton rounds cycle between two mode combinations; Lemke's walk ends on the answer."""
    (step,) = json.loads((Path(__file__).parent / "data" / "landing_step.json").read_text())
    fields = ("inv_mass", "inv_inertia", "velocity", "body_a", "body_b", "normal", "ra", "rb", "friction", "target")
    p = ContactProblem(*(np.array(step[f]) for f in fields))
    pn, pt = np.array(step["pn"]), np.array(step["pt"])
    sol = reference.solve(p, pn, pt)
    assert residual(p, sol.pn, sol.pt) < 1e-10
    assert sol.attempt == 4  # Lemke's walk, right after the three cheap Newton tries on a small problem
    monkeypatch.setattr(reference, "LEMKE_POINTS", 0)
    alone = reference.solve(p, pn, pt)  # without it, the proximal point method gets there too
    assert residual(p, alone.pn, alone.pt) < 1e-10
    monkeypatch.setattr(reference, "SETTLE_ROUNDS", 0)  # Newton rounds alone do not
    with pytest.raises(reference.ReferenceFailure, match="best residual"):
        reference.solve(p, pn, pt)
