"""The reference solve against brute force on small problems, and its residual on real scenes' steps.

Brute force: every point is separating, sticking, or sliding one way or the other; for each of the 4^m
combinations, the linear system that combination sets (written here from the contract, with its own
Jacobian) is solved by least squares, and the combination is kept when its answer satisfies every
condition. The reference must land on the velocities of a kept combination.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from stackx.kernel import compiled
from stackx.solvers.planar import reference
from stackx.solvers.planar.problem import ContactProblem, effective_masses, residual, velocities_after
from stackx.solvers.planar.reference import ModeSystem, ReferenceFailure, project_sweeps, solve
from stackx.solvers.planar.step_problem import ReferenceStep, step_problem
from tests.planar.hand_states import boxes, pyramid

TOL = 1e-9


def _jacobian(p: ContactProblem) -> np.ndarray:
    """Rows: normal then tangent of each point; columns vx, vy, w of each body (dense, by the contract)."""
    m, n = p.points, p.bodies
    jac = np.zeros((2 * m, 3 * n))
    for k in range(m):
        nx, ny = p.normal[k]
        for row, (dx, dy) in ((2 * k, (nx, ny)), (2 * k + 1, (-ny, nx))):
            for body, r, sign in ((p.body_a[k], p.ra[k], -1.0), (p.body_b[k], p.rb[k], 1.0)):
                if body >= 0:
                    jac[row, 3 * body:3 * body + 3] += sign * np.array([dx, dy, r[0] * dy - r[1] * dx])
    return jac


def brute_force(p: ContactProblem) -> list[np.ndarray]:
    """The velocities (n, 3) of every mode combination whose linear system has an answer meeting every
    condition of the contract."""
    m = p.points
    jac = _jacobian(p)
    inv = np.repeat(p.inv_mass, 3)
    inv[2::3] = p.inv_inertia
    w = jac @ (inv[:, None] * jac.T)
    u0 = jac @ p.velocity.reshape(-1)
    found = []
    for modes in itertools.product(("separate", "stick", "slide+", "slide-"), repeat=m):
        a = np.zeros((2 * m, 2 * m))
        b = np.zeros(2 * m)
        for k, mode in enumerate(modes):
            n_row, t_row = 2 * k, 2 * k + 1
            if mode == "separate":
                a[n_row, n_row] = a[t_row, t_row] = 1.0
                continue
            a[n_row], b[n_row] = w[n_row], p.target[k] - u0[n_row]
            if mode == "stick":
                a[t_row], b[t_row] = w[t_row], -u0[t_row]
            else:
                a[t_row, t_row] = 1.0
                a[t_row, n_row] = -p.friction[k] if mode == "slide+" else p.friction[k]
        imp = np.linalg.lstsq(a, b, rcond=None)[0]
        if np.abs(a @ imp - b).max() > TOL:
            continue  # this combination's equations have no answer
        u = u0 + w @ imp
        ok = True
        for k, mode in enumerate(modes):
            pn, pt, un, ut = imp[2 * k], imp[2 * k + 1], u[2 * k], u[2 * k + 1]
            bound = p.friction[k] * pn
            ok &= {"separate": un - p.target[k] >= -TOL,
                   "stick": pn >= -TOL and abs(pt) <= bound + TOL,
                   "slide+": pn >= -TOL and ut <= TOL,
                   "slide-": pn >= -TOL and ut >= -TOL}[mode]
        if ok:
            found.append(p.velocity + (inv * (jac.T @ imp)).reshape(-1, 3))
    return found


def random_problem(rng: np.random.Generator, points: int) -> ContactProblem:
    """Two movable boxes and a static one over the ground, ``points`` random points between them: normals
    near upright, arms within a box, velocities, frictions and targets of a step's size."""
    inv_mass = np.array([rng.uniform(0.2, 2.0), rng.uniform(0.2, 2.0), 0.0])
    inv_inertia = np.array([inv_mass[0] * rng.uniform(2.0, 12.0), inv_mass[1] * rng.uniform(2.0, 12.0), 0.0])
    velocity = np.zeros((3, 3))
    velocity[:2] = rng.normal(0.0, 0.5, (2, 3))
    pairs = [(-1, 0), (0, 1), (-1, 1), (2, 0), (2, 1)]
    chosen = [pairs[i] for i in rng.integers(0, len(pairs), points)]
    angle = rng.uniform(np.pi / 2 - 0.6, np.pi / 2 + 0.6, points)
    normal = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    target = np.where(rng.uniform(size=points) < 0.25, -rng.uniform(0.0, 0.5, points), 0.0)
    return ContactProblem(inv_mass, inv_inertia, velocity, np.array([a for a, _ in chosen]),
                          np.array([b for _, b in chosen]), normal, rng.uniform(-0.5, 0.5, (points, 2)),
                          rng.uniform(-0.5, 0.5, (points, 2)), rng.uniform(0.0, 1.0, points), target)


@pytest.mark.parametrize("points", [1, 2, 3, 4])
def test_the_reference_lands_on_a_brute_force_answer(points: int) -> None:
    rng = np.random.default_rng(100 + points)
    for _ in range(12):
        p = random_problem(rng, points)
        answers = brute_force(p)
        assert answers, "brute force found no answer"
        sol = solve(p)
        assert sol.residual < 1e-10
        assert residual(p, sol.pn, sol.pt) < 1e-10  # recomputed from the impulses alone
        assert min(np.abs(sol.velocity - v).max() for v in answers) < 1e-9


def test_a_box_flat_on_the_ground_under_a_sideways_push_against_brute_force() -> None:
    """Two points under one box: four conditions for three velocities, the impulses not unique; sliding
    (vx = 2 m/s) and sticking (vx = 0.05 m/s, mu g dt = 0.08 m/s) both found."""
    for vx in (2.0, 0.05):
        p = ContactProblem(np.array([1.0]), np.array([6.0]), np.array([[vx, -9.8 / 60, 0.0]]), np.array([-1, -1]),
                           np.array([0, 0]), np.array([[0.0, 1.0], [0.0, 1.0]]), np.zeros((2, 2)),
                           np.array([[-0.5, -0.5], [0.5, -0.5]]), np.array([0.5, 0.5]), np.zeros(2))
        answers = brute_force(p)
        sol = solve(p)
        assert sol.residual < 1e-10
        assert min(np.abs(sol.velocity - v).max() for v in answers) < 1e-9
        expected = max(vx - 0.5 * 9.8 / 60, 0.0)  # Coulomb: slows by mu g dt, or stops
        assert sol.velocity[0].tolist() == pytest.approx([expected, 0.0, 0.0], abs=1e-9)


def test_a_resting_pyramid_is_held_exactly_and_a_jittered_one_is_solved_to_1e_10() -> None:
    state = pyramid(10)
    p = step_problem(state, 0, -9.8, 1 / 60, 0.02)
    sol = solve(p)
    assert residual(p, sol.pn, sol.pt) < 1e-10
    assert np.abs(sol.velocity).max() < 1e-9  # every box rests: nothing may move
    assert sol.pn[p.body_a == -1].sum() == pytest.approx(55 * 9.8 / 60, rel=1e-9)  # the ground bears all 55
    shaken = pyramid(10, jitter=0.05, seed=3)
    shaken.vx[0] = np.random.default_rng(4).normal(0.0, 0.3, shaken.bodies)
    reference = ReferenceStep(1, shaken.bodies)
    s = shaken
    for _ in range(3):  # a few steps, each from the last one's impulses, as the bench solves them
        sol = reference.solve(0, s.x[0], s.y[0], s.angle[0], s.vx[0], s.vy[0], s.w[0], s.inv_mass[0],
                              s.inv_inertia[0], s.hx[0], s.hy[0], s.friction[0], -9.8, 1 / 60, 0.02)
        assert residual(reference.problem, sol.pn, sol.pt) < 1e-10
        s.vx[0], s.vy[0], s.w[0] = sol.velocity.T
        for name, rate in (("x", "vx"), ("y", "vy"), ("angle", "w")):
            getattr(s, name)[0] += getattr(s, rate)[0] / 60
    assert sol.sweeps == 0 or sol.rounds < 40  # the later steps start from the last impulses


def _tall_stack(count: int) -> ContactProblem:
    """The first step of ``count`` unit boxes stacked from rest on the ground, each shifted sideways by up to 5 cm
    (seeded) and sunk 0.1 mm into the one below, so every face touches at two points."""
    rng = np.random.default_rng(1)
    x = list(rng.uniform(-0.05, 0.05, count))
    y = [0.5 - 1e-4 + i * (1.0 - 1e-4) for i in range(count)]
    s = boxes(x, y, [0.0] * count, [(0.5, 0.5)] * count, [1.0] * count, [0.6] * count)
    return step_problem(s, 0, -9.8, 1 / 60, 0.0)


def test_a_tall_stack_is_held_still_by_the_path_and_by_the_fallback_alone() -> None:
    # every point touches (target 0) and the stack starts at rest, so the exact answer holds every box still
    p = _tall_stack(40)
    assert p.points == 80
    for interior, landing in ((True, reference.PATH), (False, reference.WALK)):
        sol = solve(p, interior=interior)
        assert residual(p, sol.pn, sol.pt) < 1e-10
        # each of the 40 faces may slip and turn by what the 1e-10 m/s residual lets it; a box's turn carries
        # every box above it sideways by its lever, so the top moves up to ~40 * 40 / 2 * 2e-10 m/s
        assert np.abs(sol.velocity).max() < 1e-6
        assert sol.attempt == landing


def test_a_solve_that_does_not_get_there_says_so(monkeypatch: pytest.MonkeyPatch) -> None:
    from stackx.solvers.planar import pivoting

    p = step_problem(pyramid(6, jitter=0.05, seed=1), 0, -9.8, 1 / 60, 0.02)
    monkeypatch.setattr(pivoting, "starts", lambda problem: iter(()))  # pivoting would solve it
    monkeypatch.setattr(reference, "SETTLE_ROUNDS", 0)  # and so would the proximal point method
    with pytest.raises(ReferenceFailure, match=r"not solved to 1e-10 m/s by the proximal point method or Lemke's "
                                               r"pivoting \(\d+ sweeps\): best residual"):
        solve(p, sweeps=0, rounds=1, interior=False)
    stuck = ContactProblem(np.zeros(1), np.zeros(1), np.zeros((1, 3)), np.array([-1]), np.array([0]),
                           np.array([[0.0, 1.0]]), np.zeros((1, 2)), np.zeros((1, 2)), np.ones(1), np.ones(1))
    with pytest.raises(ReferenceFailure, match="two immovable bodies"):
        solve(stuck)


def test_the_sweeps_run_plain_and_compiled_to_the_same_bits() -> None:
    p = step_problem(pyramid(5, jitter=0.05, seed=2), 0, -9.8, 1 / 60, 0.02)
    kn, kt = effective_masses(p)
    out = []
    for on in (False, True):
        pn, pt = np.zeros(p.points), np.zeros(p.points)
        v = velocities_after(p, pn, pt)
        with compiled(on):
            project_sweeps(p.body_a, p.body_b, p.normal, p.ra, p.rb, p.friction, p.target, p.inv_mass,
                           p.inv_inertia, kn, kt, v, pn, pt, 5)
        out.append((pn, pt, v))
    for a, b in zip(*out):
        assert np.array_equal(a, b)
    assert out[0][0].sum() > 0.0


def _recorded(name: str) -> list[tuple[ContactProblem, np.ndarray, np.ndarray]]:
    """The steps recorded in ``data/NAME.json`` (one or a list), as the bench set them to the reference, with the
    impulses it started from."""
    import json
    from pathlib import Path

    steps = json.loads((Path(__file__).parent / "data" / f"{name}.json").read_text())
    fields = ("inv_mass", "inv_inertia", "velocity", "body_a", "body_b", "normal", "ra", "rb", "friction", "target")
    return [(ContactProblem(*(np.array(s[f]) for f in fields)), np.array(s["pn"]), np.array(s["pt"]))
            for s in (steps if isinstance(steps, list) else [steps])]


def _recorded_steps() -> list[tuple[ContactProblem, np.ndarray, np.ndarray]]:
    """Four steps of ``planar-xpbd`` (16 substeps) on ``stack-10``: each has a face whose two points have different
    targets."""
    return _recorded("stack_steps")


def test_faces_whose_points_have_different_targets_are_solved() -> None:
    # two points of a face with different targets (e.g. one touching, one closing a gap) slip at different rates
    # when the face turns; where the difference is above the tolerance both cannot stick, and the answer has one
    # point sliding at its friction bound (two of these four steps)
    sliding = 0
    for p, pn, pt in _recorded_steps():
        faces: dict[tuple[int, int], list[float]] = {}
        for k in range(p.points):
            faces.setdefault((p.body_a[k], p.body_b[k]), []).append(p.target[k])
        assert any(len(t) == 2 and t[0] != t[1] for t in faces.values())
        sol = solve(p, pn, pt)
        assert residual(p, sol.pn, sol.pt) < 1e-10
        assert np.array_equal(sol.velocity, velocities_after(p, sol.pn, sol.pt))
        slides = np.isclose(np.abs(sol.pt), p.friction * sol.pn, rtol=0, atol=1e-12) & (sol.pn > 1e-9)
        sliding += bool(slides.any())
        alone = solve(p, pn, pt, interior=False)  # the fallback alone (Lemke's pivoting, on a problem this small)
        assert residual(p, alone.pn, alone.pt) < 1e-10 and alone.attempt == reference.LEMKE
    assert sliding >= 2


def test_which_point_of_a_face_slides_is_tried_not_guessed(monkeypatch: pytest.MonkeyPatch) -> None:
    # step 2 of stack-40 under planar-warm-start at 16 iterations, relaxation 1.9: the pile bounces, so 32 faces
    # have a touching point and one closing a gap. Where both of a face's points are read sticking, they slip by
    # nearly the same 1e-8 m/s; making the one that slips a hair more slide sent Newton off, and only Lemke's
    # pivoting solved the step. Trying both and keeping the one whose round lands lower solves it by Newton.
    (p, pn, pt), = _recorded("trembling_stack_step")
    from stackx.solvers.planar import pivoting

    monkeypatch.setattr(pivoting, "starts", lambda problem: iter(()))
    sol = solve(p, pn, pt)
    assert residual(p, sol.pn, sol.pt) < 1e-10
    slides = np.isclose(np.abs(sol.pt), p.friction * sol.pn, rtol=0, atol=1e-12) & (sol.pn > 1e-9)
    faces: dict[tuple[int, int], list[int]] = {}
    for k in range(p.points):
        faces.setdefault((int(p.body_a[k]), int(p.body_b[k])), []).append(k)
    split = [f for f in faces.values() if len(f) == 2 and slides[f].sum() == 1]  # one point slides, one sticks
    assert len(split) >= 8


def test_a_regularized_round_is_its_modes_exact_answer() -> None:
    # with a center, a round solves the regularized problem (velocities carry d (q - center)) for the modes read
    # at q: every held normal and sticking tangent is then exactly at its target, whatever the modes' quality
    p = step_problem(pyramid(5, jitter=0.05, seed=3), 0, -9.8, 1 / 60, 0.02)
    kn, kt = effective_masses(p)
    system = ModeSystem(p, kn, kt, 1e-2)
    rng = np.random.default_rng(4)
    m = p.points
    for _ in range(3):
        q = np.concatenate([rng.uniform(0.0, 0.2, m), rng.uniform(-0.05, 0.05, m)])
        center = q + rng.normal(0.0, 0.01, 2 * m)
        out = system.step(q, center=center)
        held, plus, minus = np.split(system.modes, 3)
        rows = np.concatenate([np.flatnonzero(held), m + np.flatnonzero(held & ~plus & ~minus)])
        assert rows.size > m // 2
        assert np.abs(system.gap(out, center)[rows]).max() < 1e-12
        sliding = np.flatnonzero(plus | minus)
        bound = np.where(plus, 1.0, -1.0)[sliding] * system.cone[sliding] * out[sliding]
        assert sliding.size and np.allclose(out[m + sliding], bound, rtol=1e-12, atol=0.0)
        assert not out[:m][~held].any()


def test_a_pile_of_hair_gaps_is_solved_by_the_path_and_by_the_proximal_point_method() -> None:
    # step 5 of pyramid-10 under planar-xpbd at 16 substeps: its boxes sit a hair tilted, so a third of the faces
    # have a touching point and one closing a gap a few micrometres wide. Newton rounds from swept impulses
    # leapt to 1e3 m/s there (the modes read make systems with no sensible answer); the central path lands it,
    # and so does the fallback's proximal point method, which comes first on a problem this large
    (p, pn, pt), = _recorded("xpbd_pyramid_step")
    assert p.points == 214 > reference.LEMKE_EARLY
    assert solve(p, pn, pt).attempt == reference.PATH
    sol = solve(p, pn, pt, interior=False)
    assert residual(p, sol.pn, sol.pt) < 1e-10
    assert sol.attempt == reference.WALK


def test_a_quick_solve_makes_no_walk_on_the_whole_problem(monkeypatch: pytest.MonkeyPatch) -> None:
    from stackx.solvers.planar import pivoting

    (p, pn, pt), = _recorded("xpbd_pyramid_step")
    assert solve(p, pn, pt, quick=True, interior=False).attempt == reference.WALK

    def refused(problem: ContactProblem) -> None:
        raise AssertionError("a quick solve pivoted")

    monkeypatch.setattr(pivoting, "starts", refused)
    monkeypatch.setattr(reference, "SETTLE_ROUNDS", 5)
    with pytest.raises(ReferenceFailure, match=r"by the proximal point method \("):
        solve(p, pn, pt, quick=True, interior=False)


def test_a_loop_of_held_faces_whose_targets_disagree_by_a_hair_is_solved(monkeypatch: pytest.MonkeyPatch) -> None:
    # step 103 of pyramid-10 under planar-xpbd at 16 substeps: box 35 sits on 40 and 41, each resting on 45 on one
    # point that closes a hair gap (targets -7.5e-5 and -6.4e-5 m/s). Sticking, those faces make a closed loop
    # whose targets disagree by a few 1e-10 m/s; the exact answer has a point of the loop sliding. The path lands
    # it; without the path, the proximal point method stalls just above the tolerance, the error shared out
    # around the loop, and Lemke's pivoting lands it
    from stackx.solvers.planar import pivoting

    (p, pn, pt), = _recorded("xpbd_pyramid_loop_step")
    assert solve(p, pn, pt).attempt == reference.PATH
    pivoted = solve(p, pn, pt, interior=False)
    assert residual(p, pivoted.pn, pivoted.pt) < 1e-10 and pivoted.attempt == reference.LEMKE
    monkeypatch.setattr(pivoting, "starts", lambda problem: iter(()))
    with pytest.raises(ReferenceFailure) as stalled:
        solve(p, pn, pt, interior=False)
    assert 1e-10 < stalled.value.best < 3e-10


def _solve_steps(reference: ReferenceStep, row: int, steps: int) -> None:
    """``steps`` solves of a 3-row pyramid's first step as row ``row`` of ``reference``, failed ones passed over."""
    s = pyramid(3)
    for _ in range(steps):
        try:
            reference.solve(row, s.x[0], s.y[0], s.angle[0], s.vx[0], s.vy[0], s.w[0], s.inv_mass[0],
                            s.inv_inertia[0], s.hx[0], s.hy[0], s.friction[0], -9.8, 1 / 60, 0.02)
        except ReferenceFailure:
            pass


def test_after_three_failed_steps_in_a_row_a_row_s_solves_are_quick(monkeypatch: pytest.MonkeyPatch) -> None:
    from stackx.solvers.planar import step_problem as sp

    asked: list[bool] = []
    # the best residual each solve reaches: above the tolerance it fails; a near miss (5e-10) is not counted
    outcomes = iter([1e-3, 5e-10, 1e-3, 1e-3, 1e-3, 0.0, 1e-3])

    def scripted(problem: ContactProblem, pn: np.ndarray, pt: np.ndarray, quick: bool = False):
        asked.append(quick)
        best = next(outcomes)
        if best > 1e-10:
            raise ReferenceFailure("scripted", best)
        return solve(problem, pn, pt)

    monkeypatch.setattr(sp, "solve", scripted)
    reference = ReferenceStep(1, pyramid(3).bodies)
    _solve_steps(reference, 0, 7)
    # four full solves fail, one of them a near miss; the fifth and sixth are quick; the sixth lands, so the
    # seventh is full again
    assert asked == [False, False, False, False, True, True, False]


def test_the_fallback_pivots_first_on_a_small_problem() -> None:
    # step 345 of a row of 20 leaning dominoes under planar-exact (58 points), with the impulses it started from:
    # on a problem this small Lemke's walk costs milliseconds, so the fallback makes it before the walk
    (p, pn, pt), = _recorded("domino_step")
    assert p.points <= reference.LEMKE_EARLY
    sol = solve(p, pn, pt, interior=False)
    assert residual(p, sol.pn, sol.pt) < 1e-10 and sol.attempt == reference.LEMKE


def test_the_fallback_s_newton_rounds_follow_a_drift(monkeypatch: pytest.MonkeyPatch) -> None:
    # step 279 of pyramid-10 under planar-xpbd at 4 substeps, as the bench set it (222 points): no path lands it,
    # and the proximal point method's Newton rounds meet mode systems without an answer (held points closing a
    # loop whose targets disagree), whose proximal steps settle into a steady drift; followed until a held point
    # is emptied, the rounds land. Without the drift followed, Lemke's walk covered by the step's approach lands
    # it (on the problem's own LCP, on the answer itself); without both, nothing does (1.8e-9 m/s)
    from stackx.solvers.planar import pivoting
    from tests.planar.test_pivoting import _recorded_npz

    p, pn, pt = _recorded_npz("xpbd_pyramid10_drift_step")
    sol = reference.solve(p, pn, pt)
    assert residual(p, sol.pn, sol.pt) < 1e-10 and sol.attempt == reference.WALK
    assert np.array_equal(sol.velocity, velocities_after(p, sol.pn, sol.pt))
    assert reference.DRIFT > 0.0
    monkeypatch.setattr(reference, "DRIFT", 0.0)
    pivoted = reference.solve(p, pn, pt)
    assert residual(p, pivoted.pn, pivoted.pt) < 1e-10 and pivoted.attempt == reference.LEMKE
    planned = pivoting.plans

    def covered_by_one(problem: object) -> tuple:  # the walks covered by 1 alone, as before the approach
        lcp, walks = planned(problem)
        return lcp, [w for w in walks if not w[2]]

    monkeypatch.setattr(pivoting, "plans", covered_by_one)
    with pytest.raises(ReferenceFailure) as missed:
        reference.solve(p, pn, pt)
    assert 1e-10 < missed.value.best < 1e-8
