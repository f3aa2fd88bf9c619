"""The interior point stage of the planar reference (``stackx.solvers.planar.interior``): against brute force
where the answer is unique, and on recorded steps that only the later tries of the reference could land."""

from __future__ import annotations

import numpy as np
import pytest

from stackx.kernel import compiled
from stackx.solvers.planar import interior, reference
from stackx.solvers.planar.problem import effective_masses, residual, velocities_after
from stackx.solvers.planar.step_problem import ReferenceStep
from tests.planar.hand_states import pyramid
from tests.planar.test_own_answer import plain_conditions
from tests.planar.test_pivoting import _recorded_npz
from tests.planar.test_reference import _jacobian, _recorded, brute_force, random_problem


def path_end(p, start=None):  # type: ignore[no-untyped-def]
    """The central path's end for problem ``p`` (begun at scaled impulses ``start``, if given): its velocities,
    iterations and whether it got there."""
    kn, kt = effective_masses(p)
    s = reference.ModeSystem(p, kn, kt)
    q, iterations, ended = interior.central_path(s.values, s.columns, s.k, s.cone, s.v0, s.inv, s.fixed_u, s.target,
                                                 start)
    m = p.points
    return velocities_after(p, np.maximum(q[:m], 0.0) * kn, q[m:] * kt), iterations, ended


def path_arrays(p):  # type: ignore[no-untyped-def]
    """``central_path``'s arrays for problem ``p`` (rows, columns, scales, cone, free velocities, inverse
    masses, fixed velocities, targets), as the reference passes them."""
    s = reference.ModeSystem(p, *effective_masses(p))
    return [s.values, s.columns, s.k, s.cone, s.v0, s.inv, s.fixed_u, s.target]


def paths_ended(p, pn, pt):  # type: ignore[no-untyped-def]
    """Whether the central path of problem ``p`` ends (1) or jams (0): from its own start, from the warm start
    ``pn``, ``pt``, and without friction from its own start."""
    kn, kt = effective_masses(p)
    arrays = path_arrays(p)
    warm = np.concatenate([pn / kn, pt / kt])
    with np.errstate(all="ignore"):
        return (interior.central_path(*arrays)[2], interior.central_path(*arrays, warm)[2],
                interior.central_path(*arrays[:3], 0.0 * arrays[3], *arrays[4:])[2])


@pytest.mark.parametrize("on", [False, True])
def test_without_friction_the_path_ends_on_the_one_answer(on: bool) -> None:
    # frictionless, a step is a convex problem whose velocities are unique: the path must reach them from its
    # own start, whatever the problem (points between two boxes, a static one and the ground, some closing gaps)
    rng = np.random.default_rng(11)
    with compiled(on):
        for points in (1, 2, 3, 4, 5):
            for _ in range(4):
                p = random_problem(rng, points)
                p.friction[:] = 0.0
                (answer,) = {tuple(np.round(v, 6).ravel()): v for v in brute_force(p)}.values()
                v, iterations, ended = path_end(p)
                assert ended == 1 and iterations < interior.ITERATIONS
                assert np.abs(v - answer).max() < 1e-9


@pytest.mark.parametrize("seed, friction, begun", [(12, None, False), (13, 0.1, True)])
def test_with_friction_the_path_ends_near_an_answer(seed: int, friction: float | None, begun: bool) -> None:
    # begun at zero impulses with low friction: the box is narrower than the margin the start keeps off each
    # bound, and the start must still lie strictly inside it (11 of 24 ended near an answer when it did not)
    rng = np.random.default_rng(seed)
    ended_near = 0
    for points in (1, 2, 3, 4):
        for _ in range(6):
            p = random_problem(rng, points)
            if friction is not None:
                p.friction[:] = friction
            with np.errstate(all="ignore"):
                v, _, ended = path_end(p, np.zeros(2 * points) if begun else None)
                if ended:
                    ended_near += min(np.abs(v - a).max() for a in brute_force(p)) < 1e-5
    assert ended_near >= 20  # of 24: where friction folds the path it may jam, and the later tries take over


@pytest.mark.parametrize("name", ["landing_step", "xpbd_pyramid_step", "domino_step", "trembling_stack_step"])
def test_recorded_steps_the_newton_tries_missed_land_from_the_path(name: str) -> None:
    # a box landing on a pile (Lemke's walk before), a pile seen through a speculative margin and a leaning row
    # of dominoes (the proximal point walk before), a trembling stack (the full rounds from zero before)
    for p, pn, pt in _recorded(name):
        sol = reference.solve(p, pn, pt)
        assert sol.attempt == 0
        assert residual(p, sol.pn, sol.pt) < 1e-10
        assert np.array_equal(sol.velocity, velocities_after(p, sol.pn, sol.pt))


def test_where_the_path_folds_from_its_own_start_it_is_followed_again_from_the_warm_start() -> None:
    # a loop of held faces on a pile seen through xpbd's margin: from every pair at 1 the path jams far from
    # any answer; begun at the last step's impulses it ends, and Newton lands from there (the forced slides
    # and Lemke's walk before)
    (p, pn, pt), = _recorded("xpbd_pyramid_loop_step")
    assert paths_ended(p, pn, pt)[:2] == (0, 1)
    sol = reference.solve(p, pn, pt)
    assert sol.attempt == 0 and residual(p, sol.pn, sol.pt) < 1e-10


def test_a_settling_20_row_pyramid_lands_from_the_path() -> None:
    # 800 points, 210 boxes: every Newton try and the proximal point walk missed it; Lemke's walk on the
    # regularized problem took seconds
    p, pn, pt = _recorded_npz("soft_pyramid20_step")
    sol = reference.solve(p, pn, pt)
    assert sol.attempt == 0
    assert residual(p, sol.pn, sol.pt) < 1e-10
    # full Newton rounds land from the path's end: no Gauss-Seidel sweeps, which damped rounds spend mending
    # modes (3,600 here when they came first)
    assert sol.sweeps == 0


def test_a_warm_start_at_the_answer_needs_no_path(monkeypatch: pytest.MonkeyPatch) -> None:
    (p, pn, pt), = _recorded("xpbd_pyramid_step")
    sol = reference.solve(p, pn, pt)

    def refused(*args: object) -> None:
        raise AssertionError("the path was followed")

    monkeypatch.setattr(reference, "central_path", refused)
    again = reference.solve(p, sol.pn, sol.pt)
    assert again.attempt == reference.WARM and again.rounds <= reference.WARM_ROUNDS
    assert residual(p, again.pn, again.pt) < 1e-10


def _contact_conditions(p, pn, pt):  # type: ignore[no-untyped-def]
    """The worst breach (m/s) of the contract's conditions by impulses ``pn``, ``pt``: the bodies' velocities
    from the dense Jacobian (``v0 + M^-1 J^T p``), each condition from its definition (``plain_conditions``)."""
    jac = _jacobian(p)
    inv = np.repeat(p.inv_mass, 3)
    inv[2::3] = p.inv_inertia
    impulses = np.empty(2 * p.points)
    impulses[0::2], impulses[1::2] = pn, pt
    velocity = (p.velocity.reshape(-1) + inv * (jac.T @ impulses)).reshape(-1, 3)
    return max(plain_conditions(p, list(pn), list(pt), velocity).values())


def test_a_shaking_pile_whose_paths_fold_ends_its_path_where_friction_is_raised_in_stages() -> None:
    # a 20-row pyramid shaking under planar-xpbd at 16 substeps (924 points): the central path folds both from
    # its own start and from the warm start; without friction the path ends, and raised from there in stages it
    # ends on this step too. What then lands it depends on the last bits of the path's end: its Newton rounds,
    # or (where they stall at 1.3e-10 m/s) the fallback's proximal point method begun where they came closest
    p, pn, pt = _recorded_npz("xpbd_pyramid20_fold_step")
    assert paths_ended(p, pn, pt) == (0, 0, 1)
    kn, kt = effective_masses(p)
    values, columns, k, cone, *rest = path_arrays(p)
    staged = None
    with np.errstate(all="ignore"):
        for share in reference.FRICTION_RAMP:
            staged, _, ended = interior.central_path(values, columns, k, share * cone, *rest, staged)
            assert ended == 1
    m = p.points
    assert residual(p, np.maximum(staged[:m], 0.0) * kn, staged[m:] * kt) < 1e-4
    sol = reference.solve(p, pn, pt)
    assert sol.attempt in (reference.PATH, reference.WALK)
    assert residual(p, sol.pn, sol.pt) < 1e-10
    assert _contact_conditions(p, sol.pn, sol.pt) < 1e-9
    assert _contact_conditions(p, pn, pt) > 1e-3  # the warm start is far from it



def test_a_measured_solve_walks_right_after_the_first_path_that_folds(monkeypatch: pytest.MonkeyPatch) -> None:
    # the same shaking pile: for the bench's measurement the proximal point method comes right after the path
    # from its own start folds, not after two more paths and five stages of friction; the exact solver keeps
    # its order (all seven paths followed)
    p, pn, pt = _recorded_npz("xpbd_pyramid20_fold_step")
    plain = interior.central_path
    followed: list[int] = []

    def counted(*args: object, **kwargs: object):  # type: ignore[no-untyped-def]
        followed.append(1)
        return plain(*args, **kwargs)

    monkeypatch.setattr(reference, "central_path", counted)
    sol = reference.solve(p, pn, pt, tolerance=1e-6, early_walk=True)  # a measurement's stop (error / 100)
    assert len(followed) == 1 and sol.attempt == reference.WALK
    assert residual(p, sol.pn, sol.pt) < 1e-6
    assert _contact_conditions(p, sol.pn, sol.pt) < 1e-6
    followed.clear()
    reference.solve(p, pn, pt, tolerance=1e-6)
    assert len(followed) == 2 + len(reference.FRICTION_RAMP)
