"""The planar reference solve: one step's contact problem (``problem.ContactProblem``) solved to a residual below
1e-10 m/s, or a ``ReferenceFailure`` saying how close it got.

**The problem.** In 2D, Coulomb friction has one tangent, so a step's contact problem is a linear complementarity
problem: each point's normal pushes only while the point is at its target speed, and its friction stays within
``[-mu pn, mu pn]``, at the bound against the slip. Each point's mode (separating, sticking, sliding either way)
fixes the answer by one linear system in the bodies' velocities (``ModeSystem``), so Newton rounds that read the
modes off an answer near the exact one land on it (semismooth Newton on the min map the residual uses). Getting
near is the hard part: a pile has more contact rows than its boxes have velocities, so redundant points may share
a load in any way, and with friction the problem is not monotone.

**The method: the central path, then Newton rounds.** A warm start already at the answer (a pile at rest: the
last step's answer is this one's) lands in ``WARM_ROUNDS`` rounds of its own modes. Otherwise the solve follows
the central path of the step's complementarity problem (``stackx.solvers.planar.interior``: a primal-dual
interior point method, which holds every complementary pair at one shrinking product and so chooses no mode
until the end, where redundant points share their load evenly), and full Newton rounds land from its end
(``Solution.attempt`` ``PATH``; where they miss, damped rounds, whose sweeps mend the modes but cost: on a
recorded 20-row pyramid step, 265 ms against the path's 23). Where that path folds (friction), it is followed
again from the warm start, which more often lies on the answer's side of the fold, and then with the friction
raised in stages (``FRICTION_RAMP``): without friction the step is a convex problem, whose path ends from its
own start, and each stage's path begins where the last one's ended.

**The fallback, where no path lands.** The proximal point method (``settle``, ``WALK``), begun from the closest
answer the paths' Newton rounds reached: each outer round solves the *regularized* problem, whose velocities
carry ``d (q - center)`` with the last round's answer as the center, by Newton rounds with a line search on its
own residual, and the answers walk to an exact solution; the regularized problem is well conditioned, so its
rounds do not leap where the true problem's modes read off a far answer give systems with answers at 1e3 m/s.
Where the walk misses on a problem over ``pivoting.EXACT_POINTS`` points, Lemke's walk on the points whose mode
is in doubt at the closest answer, the clearly sticking points held rigid (``stackx.solvers.planar.doubt``,
``DOUBT``): a problem of a tenth to a third of the points, walked in a second or two, whose answer Newton rounds
and proximal points take to the exact one; made again from the closest answer then while the last brought it
tenfold nearer (``DOUBT_GAIN``). Where that misses too (but for a quick solve, which stops here), Lemke's
complementary pivoting on the Stewart-Trinkle formulation (``stackx.solvers.planar.pivoting``, ``LEMKE``), which
cannot cycle and ends on an answer for this class of problem, covered first by 1 and then by the step's approach
(``pivoting.approach_cover``), which ends where the first wanders; Newton rounds take its answer to the exact one
(on a problem over ``pivoting.EXACT_POINTS`` points its walk is on a regularized problem, and the walk of proximal
points lands from there). On a problem of at most ``LEMKE_EARLY`` points Lemke's walk costs milliseconds and
comes first. Where the fallback's full Newton rounds miss, they are made again following drifts (``DRIFT``,
``mode_rows.proximal_steps``): where held points close a loop whose targets disagree, a round's mode system has
no answer and its proximal steps settle into a steady drift that moves load around the loop; the round strides
along it until the first held point is emptied, which the next round reads as apart. Plain rounds come first:
with drifts followed from the start, the fallback missed a step of a shaking 20-row pyramid (``planar-xpbd`` at
16 substeps, 902 points, 1.5e-9 m/s) that it now lands. A solve for the bench's measurement
(``early_walk``) walks right after the first path misses, before the other two: where the first path folds on a
toppling pile the others mostly fold too, and the walk lands for less than they cost
(``step_problem.ReferenceStep.measure``); ``planar-exact`` keeps the order above.

**Faces that cannot stick at both points.** The two points of a face whose targets differ (one touching, one
closing a speculative gap) slip at rates that differ by the face's turn times their depth difference, so both
sticking is a mode combination without an exact answer, and plain Newton stalls near 1e-9 m/s. Full rounds
notice the stall (same modes, residual not halving) and make a sticking point of the face that slips most slide
against its slip; the two slip nearly alike, so each is tried and the one whose round lands lower is kept.

**Redundant contacts and the proximal weight.** ``W = J M^-1 J^T`` is singular on a pile (a box resting flat has
four rows for three velocities), so every mode system is solved with a proximal term, ``(W + d K^-1) p = rhs + d
K^-1 p_prev`` with ``d = PROXIMAL`` scaled by each point's effective mass ``K``: of all the impulses that hold,
the one nearest the current answer, and repeated steps converge to an exact solution of the singular system.
Each step shrinks the error along an eigenvector of ``K^1/2 W K^1/2`` with eigenvalue ``lam`` by ``d / (lam +
d)``: on a step of ``stack-40`` the smallest are 4.6e-7 to 1.4e-4, along which a weight of 1e-3 crawled (2.7 s a
solve against 29 ms at 1e-5); at 1e-7 a round on wrong modes ran off faster (3 of the first 150 steps of
``stack-10`` under ``planar-xpbd`` at 16 substeps unsolved, none at 1e-5). Both were measured with the earlier
solve, which made more Newton tries before its fallback.

**Measured** (``python3 -m benchmarks.planar_reference --bench CONFIG``): every shipped planar case but
``pyramid-20`` runs its whole bench with every step solved; docs/planar.md gives what lands the steps and what a
bench costs. Where it fails: a 20-row pyramid that topples, whose held points form loops of redundant contacts
with disagreeing speculative targets; the failure raises ``ReferenceFailure`` with the best residual reached,
and the bench counts the step as unsolved, shown beside the error, never skipped.

**Why exact.** An answer is returned only once the contract's own measure, ``problem.residual`` of the final
impulses (complementarity of every normal, the friction box of every tangent, velocities recomputed from the
impulses), is below the tolerance; else the solve raises.

**Speed.** Every system is a band: ``banded`` orders the movable degrees of freedom once per problem (reverse
Cuthill-McKee) and factors each mode system and each central path iteration there, compiled, with row pivoting.
``benchmarks.planar_banded`` measures it on recorded steps beside LAPACK's band LU and SuperLU: on a 20-row
pyramid's step (630 velocities, half width 35 to 44) a factorization takes 0.6 to 0.8 times LAPACK's time and
0.17 to 0.28 times SuperLU's, and the central path 27 to 48 ms (where its iterations in numpy around SuperLU took
167 to 190 ms). Scipy remains for Lemke's walk (``pivoting``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np

from stackx.kernel import compiled, enabled, kernel
from stackx.solvers.planar import banded, mode_rows, pivoting
from stackx.solvers.planar.doubt import doubtful_start
from stackx.solvers.planar.interior import central_path
from stackx.solvers.planar.problem import (GROUND, ContactProblem, effective_masses, inverse_masses, jacobian_rows,
                                          residual, velocities_after)

TOLERANCE = 1e-10  # m/s: the contract's residual the reference reaches
PROXIMAL = 1e-5  # the proximal weight d (dimensionless: a share of each point's own effective mass)
LEMKE_EARLY = 64  # up to this many points, the fallback pivots first (Lemke then takes < 0.1 s)
SWEEPS = 200  # most projected Gauss-Seidel sweeps before the first Newton round, and after a lost one
CHUNK = 10  # sweeps between looks at the residual
NEAR = 1e-3  # m/s: the sweeps stop once the residual is below this (Newton takes it from there)
ROUNDS = 20  # damped Newton rounds from a path's end (twice as many full ones)
WARM_ROUNDS = 2  # Newton rounds from a near warm start before the central path
REFINE = 30  # most proximal steps per Newton round (each a solve with the round's factorization)
DRIFT = 0.01  # the fallback's second rounds: last two proximal steps as long within this share, a drift
MIN_STEP = 1.0 / 64  # the shortest Newton step tried before going back to sweeps
SETTLE_START = 1e-2  # the proximal point method's first weight d
PIVOT_SETTLE = 1e-5  # its first weight from the answer of Lemke's walk on a large problem (already near)
DOUBT_GAIN = 0.1  # the walk on the points in doubt again while its last brought the closest answer this near
SETTLE_SHRINK = 0.3  # d shrinks by this after a round whose regularized problem took at most SETTLE_EASY rounds
SETTLE_EASY = 4
SETTLE_FLOOR = 1e-9  # the smallest d
SETTLE_ROUNDS = 300  # most outer rounds (each a regularized problem)
SETTLE_NEWTON = 20  # most Newton rounds per regularized problem
SETTLE_SHARE = 0.1  # a regularized problem is solved once its residual is this share of the contract's
SETTLE_STEP = 1e-4  # the shortest step of its line search
POLISH = 1e-6  # m/s: below this contract residual, the proximal point method's full Newton rounds try to land
FRICTION_RAMP = (0.0, 0.25, 0.5, 0.75, 1.0)  # shares of the friction of the central paths in stages
PATH, WARM, WALK, LEMKE, DOUBT = 0, 1, 2, 3, 4  # what landed a step (``Solution.attempt``)


class ReferenceFailure(RuntimeError):
    """The reference solve did not reach its tolerance; ``best``: the least residual it reached (m/s), and
    ``pn``, ``pt`` the impulses of the closest answer it found (None when it found none), for a caller that
    must go on (``planar-exact`` keeps them and flags the step)."""

    def __init__(self, message: str, best: float = float("inf"), pn: np.ndarray | None = None,
                 pt: np.ndarray | None = None) -> None:
        super().__init__(message)
        self.best = best
        self.pn, self.pt = pn, pt


@dataclass
class Solution:
    """A solved problem: impulses per point, the bodies' velocities after, the residual (m/s), and what it
    took (Newton ``rounds`` of the stage that landed, Gauss-Seidel ``sweeps`` in all, and which stage landed,
    ``attempt``: ``PATH`` the central path, ``WARM`` the warm start's Newton rounds, ``WALK`` the proximal point
    method, ``LEMKE`` Lemke's pivoting, ``DOUBT`` Lemke's walk on the points in doubt)."""

    pn: np.ndarray
    pt: np.ndarray
    velocity: np.ndarray
    residual: float
    rounds: int
    sweeps: int
    attempt: int = WARM


@kernel
def project_sweeps(body_a: np.ndarray, body_b: np.ndarray, normal: np.ndarray, ra: np.ndarray, rb: np.ndarray,
                   friction: np.ndarray, target: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
                   kn: np.ndarray, kt: np.ndarray, v: np.ndarray, pn: np.ndarray, pt: np.ndarray,
                   sweeps: int) -> None:
    """``sweeps`` passes of projected Gauss-Seidel over the points in order, in place: ``v`` (n, 3) holds the
    velocities of the impulses ``pn``, ``pt`` on entry and on exit. Per point, the normal impulse is
    clamped to ``>= 0`` in total (accumulated), then the tangent to ``[-mu pn, mu pn]`` of that new ``pn``."""
    m = body_a.shape[0]
    for _ in range(sweeps):
        for k in range(m):
            a, b = body_a[k], body_b[k]
            nx, ny = normal[k, 0], normal[k, 1]
            for axis in range(2):
                dx, dy = (nx, ny) if axis == 0 else (-ny, nx)
                u = 0.0
                if b != GROUND:
                    u += (v[b, 0] - v[b, 2] * rb[k, 1]) * dx + (v[b, 1] + v[b, 2] * rb[k, 0]) * dy
                if a != GROUND:
                    u -= (v[a, 0] - v[a, 2] * ra[k, 1]) * dx + (v[a, 1] + v[a, 2] * ra[k, 0]) * dy
                if axis == 0:
                    new = max(pn[k] - kn[k] * (u - target[k]), 0.0)
                    delta = new - pn[k]
                    pn[k] = new
                else:
                    bound = friction[k] * pn[k]
                    new = min(max(pt[k] - kt[k] * u, -bound), bound)
                    delta = new - pt[k]
                    pt[k] = new
                if b != GROUND:
                    v[b, 0] += inv_mass[b] * delta * dx
                    v[b, 1] += inv_mass[b] * delta * dy
                    v[b, 2] += inv_inertia[b] * delta * (rb[k, 0] * dy - rb[k, 1] * dx)
                if a != GROUND:
                    v[a, 0] -= inv_mass[a] * delta * dx
                    v[a, 1] -= inv_mass[a] * delta * dy
                    v[a, 2] -= inv_inertia[a] * delta * (ra[k, 0] * dy - ra[k, 1] * dx)


def backtrack(merit: Callable[[np.ndarray], float], q: np.ndarray, target: np.ndarray, now: float, step: float,
              shortest: float) -> tuple[np.ndarray, float] | None:
    """The point ``q + s (target - q)`` for the largest ``s`` of ``step``, ``step / 2``, ... down to
    ``shortest`` whose ``merit`` falls below ``(1 - 1e-4 s) now`` (Armijo's rule), with that merit; None when
    none does."""
    while step >= shortest:
        trial = q + step * (target - q)
        after = merit(trial)
        if after < (1.0 - 1e-4 * step) * now:
            return trial, after
        step *= 0.5
    return None


Tolerance = float | Callable[[np.ndarray], float]  # m/s, or the tolerance for a candidate's velocities (n, 3)


def solve(problem: ContactProblem, pn: np.ndarray | None = None, pt: np.ndarray | None = None,
          tolerance: Tolerance = TOLERANCE, sweeps: int = SWEEPS, rounds: int = ROUNDS, quick: bool = False,
          interior: bool = True, walk: int | None = None, lemke: bool = True, early_walk: bool = False) -> Solution:
    """Solve ``problem`` to ``residual < tolerance`` (m/s), starting from impulses ``pn``, ``pt`` (a warm
    start, e.g. the last step's by feature; zeros when None): the warm start's own Newton rounds, the central
    path, and where no path lands, the fallback (see the module text). ``tolerance`` may be a callable giving
    the tolerance for a candidate answer's velocities (the bench's stop tied to what it measures:
    ``stackx.bench.error_planar``); a candidate is taken once its residual is below what it gives there.
    ``quick``: the fallback without Lemke's walks on the whole problem, which cost the most (see
    ``step_problem.ReferenceStep``: after steps in a row that nothing landed). ``interior=False`` leaves the
    paths out (the fallback alone). ``walk``: the most outer rounds of the proximal point method (None:
    ``SETTLE_ROUNDS``); ``lemke=False`` leaves every Lemke's walk out (on the points in doubt and on the whole),
    for a second solve that should end near where it starts and may give up
    (``step_problem.ReferenceStep.nearest``). ``early_walk``: the proximal point method right after the first
    central path misses, before the other two (the bench's measured solves: on recorded pyramid steps the walk
    lands where the other paths do, for less, and where they miss too it is not paid after seven paths; the
    exact solver keeps the order above). Raises ``ReferenceFailure`` when nothing gets there."""
    m, n = problem.points, problem.bodies
    pn = np.zeros(m) if pn is None else np.array(pn, dtype=np.float64)
    pt = np.zeros(m) if pt is None else np.array(pt, dtype=np.float64)
    if m == 0:
        return Solution(pn, pt, problem.velocity.copy(), 0.0, 0, 0)
    kn, kt = effective_masses(problem)
    if not (np.isfinite(kn).all() and np.isfinite(kt).all()):
        bad = int(np.flatnonzero(~(np.isfinite(kn) & np.isfinite(kt)))[0])
        raise ReferenceFailure(f"contact point {bad} joins two immovable bodies "
                               f"({problem.body_a[bad]}, {problem.body_b[bad]}): no impulse can act on it")
    newton = ModeSystem(problem, kn, kt, PROXIMAL)
    # every mode system of the problem is factored in the band of the same order: found once
    mode_system = partial(ModeSystem, problem, kn, kt, order=(newton.where, newton.half))
    args = (problem.body_a, problem.body_b, problem.normal, problem.ra, problem.rb, problem.friction,
            problem.target, problem.inv_mass, problem.inv_inertia, kn, kt)
    swept = 0

    def allowed(pn: np.ndarray, pt: np.ndarray, velocity: np.ndarray | None = None) -> float:
        """The tolerance for the answer of impulses ``pn``, ``pt`` (velocities ``velocity`` when known)."""
        if not callable(tolerance):
            return tolerance
        return tolerance(velocities_after(problem, pn, pt) if velocity is None else velocity)

    seen: list = [None, None]  # the last scaled impulses whose velocities were made, and those velocities

    def velocity_at(q: np.ndarray) -> np.ndarray:
        """The velocities of scaled impulses ``q``: asked by ``within`` and then by ``landed`` of the same
        candidate, so the last one is kept."""
        if seen[0] is None or not np.array_equal(seen[0], q):
            seen[:] = [q.copy(), velocities_after(problem, q[:m] * kn, q[m:] * kt)]
        return seen[1]

    def within(q: np.ndarray, now: float) -> bool:
        """Whether a merit of ``now`` at scaled impulses ``q`` is below the tolerance there (worth a look)."""
        if not callable(tolerance):
            return now < tolerance
        return now < TOLERANCE or (now < np.inf and now < tolerance(velocity_at(q)))

    def sweep(q: np.ndarray, limit: float) -> np.ndarray:
        """Projected Gauss-Seidel from ``q`` (projected first) until its residual is below ``limit`` or
        ``sweeps`` more sweeps are done."""
        nonlocal swept
        pn = np.maximum(q[:m], 0.0) * kn
        pt = np.clip(q[m:] * kt, -problem.friction * pn, problem.friction * pn)
        v = velocities_after(problem, pn, pt)
        for _ in range(0, sweeps, CHUNK):
            with compiled(enabled()):  # compiled unless STACKX_JIT=0, however small the run around it
                project_sweeps(*args, v, pn, pt, CHUNK)
            swept += CHUNK
            q = np.concatenate([pn / kn, pt / kt])
            if newton.merit(q) < limit:
                break
        return q

    closest: list = [np.inf, None]  # the least residual reached, and where: what a failure hands back

    def near(q: np.ndarray, now: float) -> None:
        """Keep ``q`` as the closest answer yet if its residual ``now`` is the least seen."""
        if now < closest[0]:
            closest[:] = [now, q]

    def landed(q: np.ndarray, rounds: int) -> Solution | None:
        """The solution at scaled impulses ``q`` if the contract's residual, recomputed from them, is below
        the tolerance (after ``rounds`` Newton rounds), else None."""
        pn, pt = q[:m] * kn, q[m:] * kt
        score = residual(problem, pn, pt)
        if not callable(tolerance):
            return (Solution(pn, pt, velocities_after(problem, pn, pt), score, rounds, swept) if score < tolerance
                    else None)
        velocity = velocity_at(q).copy()
        return Solution(pn, pt, velocity, score, rounds, swept) if score < allowed(pn, pt, velocity) else None

    def attempt(q: np.ndarray, rounds: int) -> tuple[Solution | None, float]:
        """Damped Newton rounds from ``q`` (swept first unless already near): each round's step is taken if it
        lowers the residual below the best yet, else half of it, a quarter... if that lowers it; where none
        does, sweeps mend the modes. The solution, or None and the best residual reached."""
        now = newton.merit(q)
        if now >= NEAR:
            q = sweep(q, NEAR)
            now = newton.merit(q)
        best = now
        for done in range(rounds + 1):
            found = landed(q, done) if within(q, now) else None
            if found is not None:
                return found, found.residual
            if done == rounds:
                break
            target = newton.step(q)
            after = newton.merit(target)
            if after < best:  # the full step: it switches every point whose mode it shows wrong at once
                q, now = target, after
            else:
                lower = backtrack(newton.merit, q, target, now, 0.5, MIN_STEP)
                if lower is not None:
                    q, now = lower
                else:  # Newton makes no progress here: mend the modes by sweeps
                    q = sweep(q, 0.5 * now)
                    now = newton.merit(q)
                    newton.modes = None
            best = min(best, now)
            near(q, now)
        return None, best

    face = np.unique(np.stack([problem.body_a, problem.body_b], axis=1), axis=0, return_inverse=True)[1].reshape(-1)

    def full(q: np.ndarray, rounds: int) -> tuple[Solution | None, float]:
        """Full Newton rounds from ``q``, mending inconsistent mode systems: the solution, or None and the best
        residual reached. When the modes stay and the residual stops falling, the round's system has no exact
        solution: two points of one face with different targets (one touching, one speculative) cannot both
        stick, as their slips differ by what the face's turning gives. Then a sticking point of the face that
        slips most, whichever's round lands lower, is made to slide against its slip (friction at its bound),
        and stays so while it slips that way."""
        slide: dict[int, float] = {}
        best, last = np.inf, np.inf
        for done in range(rounds):
            q = newton.step(q, slide)
            now = newton.merit(q)
            found = landed(q, done + 1) if within(q, now) else None
            if found is not None:
                return found, found.residual
            if not np.isfinite(now):
                break
            best = min(best, now)
            near(q, now)
            gap = newton.gap(q)
            for i in list(slide):  # a forced slide running the wrong way, or a point let go, is freed
                if gap[m + i] * slide[i] > 0.0 or not q[i] > gap[i]:
                    del slide[i]
            if newton.kept and now > 0.5 * last:
                qn, qt = q[:m], q[m:]
                stick = (qn > gap[:m]) & (np.abs(qt - gap[m:]) <= newton.cone * qn)
                slip = np.where(stick, np.abs(gap[m:]), 0.0)
                worst = int(np.argmax(slip))
                if slip[worst] > 0.0:
                    # a face's two points slip alike, so which one slides is tried: the one whose round lands lower
                    tried = [{**slide, i: -float(np.sign(gap[m + i]))}
                             for i in np.flatnonzero((face == face[worst]) & stick & (slip > 0.0))]
                    slide = min(tried, key=lambda forced: newton.merit(newton.step(q, forced)))
                last = np.inf
            else:
                last = now
        return None, best

    polishers = [newton]  # the mode systems ``polish`` lands with: the fallback adds one that follows drifts

    def polish(q: np.ndarray, rounds: int) -> tuple[Solution | None, float]:
        """``full`` rounds from ``q`` with each of ``polishers`` in turn: the first solution, or None and the best
        residual reached."""
        nonlocal newton
        best = np.inf
        for newton in polishers:
            newton.modes = None
            found, reached = full(q, rounds)
            if found is not None:
                break
            best = min(best, reached)
        newton = polishers[0]
        return (found, found.residual) if found is not None else (None, best)

    def settle(q: np.ndarray, rounds: int, start: float = SETTLE_START) -> tuple[Solution | None, float]:
        """The proximal point method from ``q``: each outer round solves the regularized problem whose
        velocities carry ``d (q - center)`` (the center: the last round's answer) by Newton rounds with a line
        search on its residual, and the answers walk to an exact solution. The weight ``d`` adapts: it
        shrinks (``SETTLE_SHRINK``) after a round whose problem took few Newton rounds, so the walk speeds
        up, and grows tenfold after one whose problem was not solved, which is then left. Once the
        contract's residual is below ``POLISH``, ``rounds`` full Newton rounds try to land on the answer of
        the modes read there, again each time the residual has fallen tenfold or the modes changed since."""
        system = mode_system(start)
        best = polished = reached = system.merit(q)  # reached: the contract's residual at q
        tried = None  # the modes the last full rounds started from
        spent = 0  # Newton rounds of the regularized problems
        for _ in range(SETTLE_ROUNDS if walk is None else walk):
            center = q
            aim = max(TOLERANCE * 1e-3, SETTLE_SHARE * reached)
            now = system.merit(q, center)
            for done in range(SETTLE_NEWTON + 1):
                if now < aim or done == SETTLE_NEWTON:
                    break
                target = system.step(q, center=center)
                spent += 1
                lower = backtrack(partial(system.merit, center=center), q, target, now, 1.0, SETTLE_STEP)
                if lower is None:
                    break
                q, now = lower
            if now >= aim:  # too little regularized to solve: back to the center, heavier
                q, system.proximal = center, min(10.0 * system.proximal, 1.0)
                continue
            if done <= SETTLE_EASY:
                system.proximal = max(SETTLE_SHRINK * system.proximal, SETTLE_FLOOR)
            reached = system.merit(q)
            best = min(best, reached)
            near(q, reached)
            if within(q, reached):
                found = landed(q, spent)
                if found is not None:
                    return found, found.residual
            modes = system.read(q) if reached < POLISH else None
            if modes is not None and (reached < 0.1 * polished or not np.array_equal(modes, tried)):
                polished, tried = reached, modes
                found, _ = polish(q, rounds)
                if found is not None:
                    found.rounds += spent
                    return found, found.residual
        return None, best

    def start_from(pn_start: np.ndarray, pt_start: np.ndarray) -> tuple[Solution | None, float]:
        """Impulses from a walk taken to the exact answer: as they are if they solve the step (a Newton round
        there reads modes on their boundaries and can leave it), else by full Newton rounds, and on a large
        problem (whose walks do not solve it exactly) then by the proximal point method from there."""
        q = np.concatenate([pn_start / kn, pt_start / kt])
        newton.modes = None
        found = landed(q, 0)
        reached = np.inf
        if found is None:
            found, reached = polish(q, 2 * rounds)
        if found is None and m > pivoting.EXACT_POINTS:
            found, reached = settle(q, 2 * rounds, PIVOT_SETTLE)
        return (found, found.residual) if found is not None else (None, reached)

    def pivot() -> tuple[Solution | None, float]:
        """Lemke's pivoting (``stackx.solvers.planar.pivoting``), each answer it ends on taken to the exact one
        (``start_from``)."""
        best = np.inf
        for pn_start, pt_start in pivoting.starts(problem):
            found, reached = start_from(pn_start, pt_start)
            if found is not None:
                return found, reached
            best = min(best, reached)
        return None, best

    def in_doubt() -> tuple[Solution | None, float]:
        """Lemke's walk on the points whose mode is in doubt at the closest answer yet, the others held
        (``stackx.solvers.planar.doubt``), taken to the exact answer (``start_from``); again from the closest
        answer then, while the last walk brought it ``DOUBT_GAIN`` nearer or more."""
        best = np.inf
        while closest[1] is not None:
            before = closest[0]
            start = doubtful_start(problem, mode_system(PROXIMAL), closest[1])
            if start is None:
                break
            found, reached = start_from(*start)
            if found is not None:
                return found, reached
            best = min(best, reached)
            if not closest[0] < DOUBT_GAIN * before:
                break
        return None, best

    warm = np.concatenate([pn / kn, pt / kt])
    # a warm start near the answer (a pile at rest: the last step's answer is this one's) lands in a round or two
    # of its own modes: cheaper than any path
    if newton.merit(warm) < NEAR:
        found, _ = attempt(warm, WARM_ROUNDS)
        if found is not None:
            return found

    def follow(begun: np.ndarray | None, ramp: tuple[float, ...] = (1.0,)) -> Solution | None:
        """The central path from ``begun`` (None: its own start), once per share of the friction in ``ramp``,
        each from where the last ended, then full Newton rounds from its end, and where they miss damped ones."""
        path, ended_on_path = begun, 0
        for share in ramp:
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # far end's products underflow
                path, _, ended_on_path = central_path(newton.values, newton.columns, newton.k, share * newton.cone,
                                                      newton.v0, newton.inv, newton.fixed_u, newton.target, path,
                                                      (newton.where, newton.half))
        for run in (partial(full, path, 2 * rounds), partial(attempt, path, rounds)) if ended_on_path else ():
            newton.modes = None
            found, _ = run()
            if found is not None:
                found.attempt = PATH
                return found
        return None

    if interior:
        # from the path's own start, then (where that folded) from the warm start, which lies on the answer's side
        # of a fold more often than not, then with the friction raised in stages from none (``FRICTION_RAMP``)
        paths = [partial(follow, None)] + ([partial(follow, warm)] if pn.any() or pt.any() else [])
        for number, run in enumerate(paths + [partial(follow, None, FRICTION_RAMP)]):
            newton.modes = None
            found = run()
            if found is not None:
                return found
            if number == 0 and early_walk:
                polishers.append(mode_system(PROXIMAL, drift=DRIFT))
                found, _ = settle(warm if closest[1] is None else closest[1], 2 * rounds)
                if found is not None:
                    found.attempt = WALK
                    return found
    # the fallback: the proximal point method from the closest answer (unless it walked already), then Lemke's
    # pivoting (on small problems, where it costs tens of milliseconds, the other way round); full rounds that
    # miss are made again following drifts (``DRIFT``)
    walked = len(polishers) > 1
    if not walked:
        polishers.append(mode_system(PROXIMAL, drift=DRIFT))
    begun = warm if closest[1] is None else closest[1]  # the closest answer the paths' Newton rounds reached
    doubt = lemke and m > pivoting.EXACT_POINTS  # a large problem: the walk on its points in doubt, before the whole's
    fallback = ([(WALK, partial(settle, begun, 2 * rounds))] * (not walked) + [(DOUBT, in_doubt)] * doubt
                + [(LEMKE, pivot)])
    quick = quick or not lemke
    if quick:
        fallback = fallback[:-1]
    elif m <= LEMKE_EARLY:
        fallback.reverse()
    best = np.inf
    for number, run in fallback:
        found, reached = run()
        if found is not None:
            found.attempt = number
            return found
        best = min(best, reached)
    kept = warm if closest[1] is None else closest[1]
    kept_pn, kept_pt = np.maximum(kept[:m], 0.0) * kn, kept[m:] * kt
    kept_pt = np.clip(kept_pt, -problem.friction * kept_pn, problem.friction * kept_pn)
    stages = (["the central path"] * interior + ["the proximal point method"]
              + ["Lemke's walk on the points in doubt"] * doubt + ["Lemke's pivoting"] * (not quick))
    tried = " or ".join(filter(None, [", ".join(stages[:-1]), stages[-1]]))
    best = min(best, closest[0])
    stop = f"{tolerance:g}" if not callable(tolerance) else f"{allowed(kept_pn, kept_pt):g}"
    raise ReferenceFailure(f"the contact problem ({m} points, {n} bodies) was not solved to {stop} m/s by "
                           f"{tried} ({swept} sweeps): best residual {best:.3g} m/s", best, kept_pn, kept_pt)


class ModeSystem:
    """The linear system of one mode combination, solved in the bodies' velocities.

    Impulses are kept scaled, ``q = p / k`` (m/s). The unknown impulses are the held normals and the sticking
    tangents (the *free* rows F); a sliding tangent follows its normal (``q_t = +-cone q_n``), a separating
    point carries nothing. With the proximal term, row ``r`` of F reads ``J_r v + d q_r = target_r + d c_r``
    and the velocities ``M v = M v0 + G q`` (``G``: each free row's impulse direction, a sliding point's
    normal column carrying its friction too). Eliminating ``q = (h - J_F v) / d`` leaves
    ``(M + G J_F / d) v = M v0 + G h / d``: one unknown per movable degree of freedom (3 per box), however
    many points touch, symmetric unless a point slides, a band in the order ``banded.ordering`` finds.

    ``J`` is held row by row (``problem.jacobian_rows``: six entries per row), so ``J x`` is a gather,
    ``J^T y`` a sum over rows, and a mode system's band is assembled from each free row's 6 x 6 outer
    product in one pass; a round's proximal steps run compiled (``mode_rows.proximal_steps``).
    """

    def __init__(self, problem: ContactProblem, kn: np.ndarray, kt: np.ndarray, proximal: float = PROXIMAL,
                 drift: float = 0.0, order: tuple[np.ndarray, int] | None = None) -> None:
        self.m = m = problem.points
        inv = inverse_masses(problem)
        free_dof = inv > 0.0
        self.dof = dof = int(free_dof.sum())  # movable degrees of freedom; index ``dof`` stands for none
        where = np.full(inv.shape[0] + 1, dof, np.int64)
        where[:-1][free_dof] = np.arange(dof)
        values, columns = jacobian_rows(problem)
        self.values, self.columns = values, where[columns]
        # the band every mode system of the problem is factored in (``order``: one found already for it)
        self.where, self.half = banded.ordering(self.columns, dof) if order is None else order
        self.inv = inv[free_dof]
        v0 = problem.velocity.reshape(-1)
        self.v0 = v0[free_dof].copy()
        fixed = np.append(np.where(free_dof, 0.0, v0), 0.0)  # the velocities J sees but no impulse changes
        self.fixed_u = (values * fixed[columns]).sum(axis=1)
        self.k = np.concatenate([kn, kt])
        self.target = np.concatenate([problem.target, np.zeros(m)])
        self.cone = problem.friction * kn / kt  # the friction bound in q units: |q_t| <= cone q_n
        self.mu = problem.friction
        self.modes: np.ndarray | None = None
        self.kept = False
        self.proximal = proximal  # the weight d; may be changed between rounds (the factorization follows)
        self.drift = drift  # 0: a round's proximal steps stop after REFINE; else a steady drift is followed
        self.factored = proximal

    def merit(self, q: np.ndarray, center: np.ndarray | None = None) -> float:
        """The contract's residual (m/s) of scaled impulses ``q``, from ``W`` (the min map of every normal,
        the friction box of every tangent): cheap, for the line search; the answer is checked by
        ``problem.residual``. With a ``center``, the residual of the regularized problem whose velocities
        carry the proximal term ``d (q - center)`` (see ``step``)."""
        m = self.m
        with np.errstate(over="ignore", invalid="ignore"):  # a step run off to infinity: merit inf
            return float(mode_rows.merit(q[:m], q[m:], self.gap(q, center), self.cone))

    def gap(self, q: np.ndarray, center: np.ndarray | None = None) -> np.ndarray:
        """``J v - target`` (m/s) for the velocities of scaled impulses ``q``, plus ``d (q - center)`` with a
        ``center``."""
        gap = mode_rows.gaps(self.values, self.columns, self.k * q, self.v0, self.inv, self.fixed_u, self.target)
        return gap if center is None else gap + self.proximal * (q - center)

    def read(self, q: np.ndarray, center: np.ndarray | None = None) -> np.ndarray:
        """The modes at ``q``, as ``(held, plus, minus)`` flags over the points, concatenated: held when
        ``qn > un - target``; sliding (plus or minus) when ``qt - ut`` leaves the friction box."""
        m = self.m
        gap = self.gap(q, center)
        qn, qt = q[:m], q[m:]
        held = qn > gap[:m]
        z = qt - gap[m:]
        modes = np.concatenate([held, held & (z > self.cone * qn), held & (z < -self.cone * qn)])
        return modes

    def factor(self, held: np.ndarray, plus: np.ndarray, minus: np.ndarray) -> None:
        """Factor the mode combination's matrix ``M + G J_F / d`` (see the class text), as a band
        (``banded``) in the order found for the problem's rows: a subset's band is no wider."""
        m = self.m
        stick = held & ~plus & ~minus
        self.free = free = np.flatnonzero(np.concatenate([held, stick]))
        sign = np.where(plus, 1.0, np.where(minus, -1.0, 0.0))
        self.j_rows, self.j_columns = self.values[free], self.columns[free]
        # G: column r of F is k_r J_r^T, plus +-mu k_n J_t^T for a sliding normal (its tangent row has the
        # same two bodies, so the same six columns)
        g = self.j_rows * self.k[free][:, None]
        normal = free < m
        point = free[normal]
        g[normal] += (sign * self.mu * self.k[:m])[point][:, None] * self.values[m + point]
        self.g = g
        self.factors = self.matrix()
        self.pivots = np.zeros(self.dof, np.int64)
        if not banded.factor(self.factors, self.half, self.pivots):  # a singular mode system: back to sweeps
            self.factors = None
        self.sign = sign

    def matrix(self) -> np.ndarray:
        """The band of ``M + G J_F / d`` for the rows ``factor`` last chose, not yet factored."""
        ab = banded.band(1.0 / self.inv, self.where, self.half)
        banded.add(ab, self.half, self.where, np.full(self.free.shape[0], 1.0 / self.proximal), self.g, self.j_rows,
                   self.j_columns)
        return ab

    def step(self, q: np.ndarray, slide: dict[int, float] | None = None,
             center: np.ndarray | None = None) -> np.ndarray:
        """One Newton round: the modes read at ``q``, and the scaled impulses that solve that mode
        combination, by proximal steps from ``q`` (with a singular system, the answer nearest ``q``).
        ``slide`` (point: +-1) puts those held points in that sliding mode whatever ``q`` says.
        With a ``center``, the round is one of the regularized problem instead (the proximal term
        ``d (q - center)`` added to every velocity): modes read with that term, and one solve, which is
        that mode combination's exact answer (the regularized system is never singular).
        ``kept`` says the modes (and weight) were the last round's, whose factorization is reused."""
        m = self.m
        modes = self.read(q, center)
        held, plus, minus = modes[:m], modes[m:2 * m], modes[2 * m:]
        for i, sign in (slide or {}).items():
            if held[i]:
                plus[i], minus[i] = sign > 0, sign < 0
        self.kept = (self.modes is not None and np.array_equal(modes, self.modes)
                     and self.factored == self.proximal)
        if not self.kept:
            self.modes, self.factored = modes, self.proximal
            self.factor(held, plus, minus)
        if self.factors is None:
            return np.full(2 * m, np.nan)
        free = self.free
        base = self.target[free] - self.fixed_u[free]
        momentum = self.v0 / self.inv
        out = (q if center is None else center)[free]
        # a wrong mode combination's system may have no answer, and its proximal steps then run off to
        # infinity: that is expected, and the caller's merit (inf or NaN) rejects the step
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            # proximal steps on one factorization converge to the modes' answer; with a center, one step is it
            out = mode_rows.proximal_steps(self.factors, self.half, self.pivots, self.where, self.g, self.j_rows,
                                           self.j_columns, base, momentum, self.proximal, out,
                                           REFINE if center is None else 1, 1e-3 * TOLERANCE, free < m, self.drift)
            q = np.zeros(2 * m)
            q[free] = out
            q[m:] += self.sign * self.cone * q[:m]
        return q
