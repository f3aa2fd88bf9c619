"""The planar reference solve: one step's contact problem (``problem.ContactProblem``) solved to a residual
below 1e-10 m/s, or a ``ReferenceFailure`` saying how close it got.

**First: a warm start at the answer, then the central path.** A warm start already near the answer (a pile at
rest) lands in ``WARM_ROUNDS`` Newton rounds of its own modes (below). Otherwise the solve follows the central
path of the step's complementarity problem (``stackx.models.planar.interior``: a primal-dual interior point
method, which chooses no mode until the end and so is not thrown by a pile's redundant contacts) and makes the
two cheap Newton tries from its end; where that path folds (with friction the problem is not monotone), it
follows the path again from the warm start, which more often lies on the answer's side of the fold. Where that
folds too, it raises the friction in stages (``FRICTION_RAMP``): without friction the step is a convex problem,
whose path ends from its own start; each stage's path begins where the last one's ended, so the path meets the
friction a share at a time instead of all at once (on a shaking 20-row pyramid, ``planar-xpbd`` at 16 substeps,
most steps whose two paths folded end there). A landing on any of these paths is ``Solution.attempt`` 0. Only
where every path jams or its end does not land come the tries below, from the warm start; ``interior=False``
makes them alone. Side by side on the same 30-step bench
(``python3 -m benchmarks.planar_reference --bench configs/planar/pyramid-10.yaml --steps 30``, 21 runs), the
step log took 26.1 s with the path (and the compiled row sums of ``mode_rows``) against 95.2 s without either.

**The tries: projected Gauss-Seidel for the active set, then Newton on it (a primal-dual active-set method).**
The solution is fixed by which mode each point is in: *separating* (no impulse), *sticking* (the point's
relative velocity is zero), or *sliding* either way (friction at ``+mu pn`` or ``-mu pn``) with its normal
held. Once the modes are known, the impulses solve one linear system: held normals and sticking tangents
give rows of the Delassus matrix ``W = J M^-1 J^T`` (the point's relative velocity equals its target), a
sliding tangent gives ``pt = +-mu pn``, a separating point gives ``pn = pt = 0``. So:

1. sweeps of projected Gauss-Seidel (sequential impulses with accumulated clamping, in body velocities:
   O(points) a sweep, compiled) from the caller's warm start, until the residual is below ``NEAR``;
2. each Newton round reads the modes off the current answer with the same min / clip maps the residual uses
   (held when ``pn / k_n > un - target``; sliding when ``pt - k_t ut`` leaves ``[-mu pn, mu pn]``), solves
   that mode combination's linear system with a band LU (``ModeSystem``: in the bodies' velocities, 3
   unknowns per box however many points touch), and takes the step if it lowers the residual, else half of
   it, a quarter...; when no step does, more sweeps mend the modes. When the modes are right the answer is
   the solution up to rounding (semismooth Newton on the min-map, which converges locally in a few rounds);
3. tries, each checked by the residual, cheap ones first: damped Newton from the warm start; full Newton
   rounds from the warm start and from zero impulses, mending inconsistent mode systems (below); the
   proximal point method from the warm start (below); damped Newton from zero (a warm start can sit on a
   corner of a pile's many equivalent load paths, where the modes cycle) and full steps from zero allowed
   to raise the residual a few rounds in a row (they cross regions where damped steps crawl); full and
   damped rounds with heavier proximal weights (``DAMPED``), each going only part of the way to its modes'
   answer, which keeps a round from leaping far when the modes read are wrong (which weight lands a step is
   hard to foretell: a step of ``stack-40`` that every try at 1e-5 missed lands at 1e-3, 1e-4 and 1e-6
   alike, so the heavier tries start at 1e-3);
4. Lemke's pivoting (``stackx.models.planar.pivoting``, sparse): on a box landing on a pile, where many points
   change mode at once and the Newton rounds cycle between two mode combinations; its answer is taken to the
   exact one by full Newton rounds. On small problems (up to ``LEMKE_EARLY`` points) it comes right after the
   cheap tries (before the proximal point method), where it costs tens of milliseconds; on larger ones it is
   the last try. On a problem over ``pivoting.EXACT_POINTS`` points it walks a regularized problem (seconds on
   a 20-row pyramid), whose answer lies within about 1e-6 m/s of the step's, and full Newton rounds, then the
   proximal point method (from weight ``PIVOT_SETTLE``), land from there. On recorded steps of a 20-row
   pyramid that every other try missed it lands 28 of 29 under ``planar-soft-step`` at 64 substeps (1.3 to 59
   s a step, most under 3 s) and 8 of 14 under ``planar-xpbd`` at 16; a run of the latter's first 40 steps
   leaves 9 unsolved where 21 were without it (``python3 -m benchmarks.planar_reference --steps 40 --run
   configs/planar/pyramid-20.yaml planar-xpbd 16``).

**Faces that cannot stick at both points.** The two points of a face whose targets differ (one touching,
one closing a speculative gap) close at different normal speeds, so the face turns; as the points sit at
slightly different depths, their tangential slips then differ too (by the turn times their depth
difference over their spacing, ~1e-9 m/s on a tilting stack). Both sticking is then a mode combination
without an exact solution: its linear system is inconsistent, the proximal steps settle on a least-squares
answer, and the modes read there are the same ones, so plain Newton stalls at ~1e-9 m/s. The full rounds
notice the stall (same modes, residual not halving) and make one sticking point of the face that slips
most slide against its slip, friction at its bound, for as long as it keeps slipping that way: the exact
answer has one point of such a face at its bound and the other sticking. Which one is not guessed: the two
slip nearly alike (1.6e-8 and 1.6e-8 m/s on a bouncing ``stack-40``, where the wrong one sent Newton off), so
a round is tried with each and the one that lands lower is kept.

**Piles whose Newton rounds leap: the proximal point method.** On a pile whose boxes sit a hair tilted
(``pyramid-10`` under ``planar-xpbd`` at 16 substeps: a third of its faces have a touching point and one closing
a gap) or that sags and slides, the modes read off swept impulses make mode systems whose answers lie at
1e3 m/s: the rounds leap, and no fraction of such a step lowers the residual. The proximal point method never
solves the true problem's mode systems until the end. Each of its outer rounds solves the *regularized*
problem, whose velocities carry ``d (q - center)`` with the last round's answer as the center, by Newton
rounds with a line search on that problem's own residual; the answers walk to an exact solution of the true
problem. The regularized problem is well conditioned (strongly monotone without friction), so its Newton
rounds do not leap, and its answer lies within about ``residual / d`` of the center. ``d`` starts at 1e-2,
shrinks threefold after an outer round that took at most ``SETTLE_EASY`` Newton rounds (the walk speeds up
as it nears the answer), and grows tenfold after one whose problem was not solved (that round is undone).
Once the true residual is below ``POLISH``, full Newton rounds (mending faces, as above) try to land on the
exact answer of the modes read there, and again whenever those modes change or the residual has fallen
tenfold. With friction the regularized problem is not monotone, so the walk is not sure to end; it lands
most steps every Newton try failed on; the steps it still misses are counted per run (docs/planar.md).

**Loops of held faces: probing the stall.** On a pile seen through a speculative margin (``planar-xpbd``'s
5 cm), a box sitting a hair tilted may rest on one point that closes a gap of a few micrometres (a target of a
few 1e-5 m/s). Where such faces and sticking ones close a loop (box 35 on 40 and 41, each on 45 by such a
point, on recorded ``pyramid-10`` steps), the loop's held normals and sticking tangents fix its bodies'
motion twice over, and their targets disagree by a hair: every try stalls just above the tolerance
(2.3e-10 m/s), the error shared out around the loop, and face mending, which looks at one face, does not get
out. The exact answer has one point of the loop sliding, friction at its bound, which frees the loop; which
one is not told by the residuals (the one that lands slipped second most there). So ``probe`` tries them:
once a try has come below ``PROBE_NEAR`` without landing, each sticking point on a body of a point whose
residual is above the tolerance, those slipping most first (at most ``PROBES``), is made to slide against
its slip for good (``ModeSystem.forced``), and full Newton rounds from the closest answer try to land; the
first that does is the answer, checked by the residual like any other. A pile may hold several such loops (a
20-row pyramid does): a forced slide whose rounds leave fewer points off the contract is kept, and the probing
goes on from there, within ``PROBES`` forced slides in all.

**A restart from the closest answer, following drifts.** Every try is local: it reads modes off where it
starts and where its rounds take it. Where all of them missed but one came within ``RESTART`` (1e-8 m/s), the
tries are made once more, in the default order, from the closest answer reached (``restart``; the restarted
solve does not restart again), and there a Newton round whose mode system has no answer follows its drift
(``DRIFT``, ``mode_rows.proximal_steps``): where held points close a loop whose targets disagree, the round's
proximal steps settle into a steady drift moving load around the loop, and the round strides along it until
the first held point is emptied, which the next round reads as apart. Step 279 of ``pyramid-10`` under
``planar-xpbd`` at 4 substeps missed every try (closest 1.8e-9 m/s, 37 points off by up to that); made again
from there with drifts followed, the full Newton rounds (the second try) land it in under 0.1 s; without them
every try misses again (5.4e-10 m/s). Only the restart follows drifts: made by every solve, a stride lands
some steps sooner and sends others past the answer the path's end was next to (on recorded steps, a
trembling ``stack-40`` and a loop on a pile went from the path's Newton tries, under 0.1 s, to Lemke's walk,
1.6 to 2.8 s).

**Where it may still fail.** A large problem (a 20-row pyramid has 800 points) on which every Newton try
cycles, the proximal point method wanders, the forced slides probed do not land, and the proximal point method
from the regularized problem's answer does not either; the solve
then raises (``ReferenceFailure`` with the best residual reached) and the bench counts the step as
``unsolved``, shown beside the error, never silently skipped. The known cases are on a 20-row pyramid that
topples (``planar-xpbd`` at 4 substeps, ``planar-soft-step`` and ``planar-ngs`` at 1): many points slide at once,
and on recorded steps of the first the held points form loops of redundant contacts whose speculative targets
disagree, the central path folds even at a hundredth of the friction, and Lemke's walk does not end (docs/planar.md
says why, and what else was tried).

**Why exact.** The answer is returned only once the contract's own measure, ``problem.residual`` of the
final impulses (complementarity of every normal, the friction box of every tangent, velocities recomputed
from the impulses), is below the tolerance; else the solve raises. PGS alone only approaches the solution
(its error falls by a constant factor per sweep, slowly on tall stacks); the linear solve of the right
modes lands on it.

**Redundant contacts.** A box resting flat has two points on a face, four rows for its three velocities,
so ``W`` is singular and the impulses that hold a pile are not unique (the velocities are). Every system is
solved with a proximal term: ``(W + d K^-1) p = rhs + d K^-1 p_prev`` with ``d = PROXIMAL`` (scaled by each
point's effective mass ``K``), which picks, of all the impulses that hold, the one nearest the current
answer, and whose repeated rounds converge to an exact solution of the singular system.

**The proximal weight trades speed on tall piles against runaway on wrong modes.** Each proximal step
shrinks the error along an eigenvector of the scaled Delassus matrix ``K^1/2 W K^1/2`` with eigenvalue
``lam`` by ``d / (lam + d)``. A tall stack's boxes tilting together give tiny ones (a step of ``stack-40``:
4.6e-7, 1.8e-5, 1.4e-4), so at ``d = 1e-3`` those parts crawled (0.9995 a step), every Newton try stalled
near 1e-7 m/s, and mostly only Lemke's pivoting, the last try, solved a step: 2.7 s a solve against 29 ms at
``d = 1e-5``, where the first or second try lands (median over the first 40 steps under ``planar-warm-start``:
``python3 -m benchmarks.planar_reference --proximal D``). A smaller ``d`` lets a round on wrong modes, or on a
face that cannot stick at both points, run off faster: at 1e-7, 3 of the first 150 steps of ``stack-10``
under ``planar-xpbd`` at 16 substeps went unsolved, none at 1e-5.

**Speed.** Every system is a band: ``banded`` orders the movable degrees of freedom once per problem (reverse
Cuthill-McKee) and factors each mode system and each central path iteration there, compiled, with row pivoting.
On a ``pyramid-10`` step (165 velocities, half width 20) building and factoring a mode system takes 0.15 ms, where
scipy's SuperLU with its assembly took 0.58 ms side by side; a 20-row pyramid's (630 velocities, half width 35
to 44) 1.6 ms against 2.8 to 3.1 ms, and its central path 67 ms against 167 to 190 ms. Scipy remains for
Lemke's walk (``pivoting``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np

from stackx.kernel import compiled, enabled, kernel
from stackx.models.planar import banded, mode_rows
from stackx.models.planar.interior import central_path
from stackx.models.planar.problem import (GROUND, ContactProblem, effective_masses, inverse_masses, jacobian_rows,
                                          point_residuals, residual, velocities_after)

TOLERANCE = 1e-10  # m/s: the contract's residual the reference reaches
PROXIMAL = 1e-5  # the proximal weight d (dimensionless: a share of each point's own effective mass)
DAMPED = (1e-3, 1e-1, 1e-2)  # heavier proximal weights of the last Newton tries: each round goes part of the way
LEMKE_EARLY = 64  # up to this many points, Lemke comes right after the cheap tries (it then takes < 0.1 s)
SWEEPS = 200  # most projected Gauss-Seidel sweeps before the first Newton round, and after a lost one
CHUNK = 10  # sweeps between looks at the residual
NEAR = 1e-3  # m/s: the sweeps stop once the residual is below this (Newton takes it from there)
ROUNDS = 20  # Newton rounds of each try before the next one (three tries before the solve gives up)
WARM_ROUNDS = 2  # Newton rounds from a near warm start before the interior point stage
REFINE = 30  # most proximal steps per Newton round (each a solve with the round's factorization)
DRIFT = 0.01  # a round's last two proximal steps as long within this share: a drift (mode_rows.proximal_steps)
QUICK = 2  # tries of a quick solve: the first two of its order (from the warm start: damped, then full rounds)
WANDER = 3  # full Newton steps in a row that may leave the residual above the best (last try)
MIN_STEP = 1.0 / 64  # the shortest Newton step tried before going back to sweeps
SETTLE_START = 1e-2  # the proximal point method's first weight d
PIVOT_SETTLE = 1e-5  # its first weight from the answer of Lemke's walk on a large problem (already near)
SETTLE_SHRINK = 0.3  # d shrinks by this after a round whose regularized problem took at most SETTLE_EASY rounds
SETTLE_EASY = 4
SETTLE_FLOOR = 1e-9  # the smallest d
SETTLE_ROUNDS = 300  # most outer rounds (each a regularized problem)
SETTLE_QUICK = 60  # most outer rounds in a quick solve (the walks that land mostly take fewer than 50)
SETTLE_NEWTON = 20  # most Newton rounds per regularized problem
SETTLE_SHARE = 0.1  # a regularized problem is solved once its residual is this share of the contract's
SETTLE_STEP = 1e-4  # the shortest step of its line search
POLISH = 1e-6  # m/s: below this contract residual, the proximal point method's full Newton rounds try to land
PROBE_NEAR = 1e-8  # m/s: a try that got below this without landing has its stall probed by forced slides
FRICTION_RAMP = (0.0, 0.25, 0.5, 0.75, 1.0)  # shares of the friction of the central paths in stages
RESTART = 1e-8  # m/s: a solve whose tries all missed, one of them by less than this, makes them again from there
PROBES = 32  # most forced slides a solve probes (each: full Newton rounds), those slipping most first


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
    took (Newton ``rounds`` of the try that landed, Gauss-Seidel ``sweeps`` in all, and which ``attempt`` of
    the solve's tries landed, from 1)."""

    pn: np.ndarray
    pt: np.ndarray
    velocity: np.ndarray
    residual: float
    rounds: int
    sweeps: int
    attempt: int = 1


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


def solve(problem: ContactProblem, pn: np.ndarray | None = None, pt: np.ndarray | None = None,
          tolerance: float = TOLERANCE, sweeps: int = SWEEPS, rounds: int = ROUNDS, quick: bool = False,
          begin: int = 1, interior: bool = True, restart: bool = True, drift: float = 0.0) -> Solution:
    """Solve ``problem`` to ``residual < tolerance`` (m/s), starting from impulses ``pn``, ``pt`` (a warm
    start, e.g. the last step's by feature; zeros when None). ``begin``: the try (numbered as
    ``Solution.attempt``) to make first, the ones before it coming last: the try that landed the last step of
    the same run, which most likely lands this one too (the order changes only the cost; a number names the
    same try as long as the problem stays on the same side of ``LEMKE_EARLY`` points). ``quick``: the first
    ``QUICK`` tries of that order only, the proximal point method's walk cut to ``SETTLE_QUICK`` rounds (see
    ``step_problem.ReferenceStep``: after steps in a row that every try failed). ``restart``: where every try
    missed but one came within ``RESTART``, the tries are made once more from that closest answer, their Newton
    rounds following a drift (``drift``: see ``ModeSystem``). Raises ``ReferenceFailure`` when no try gets there
    (see the module text for the method)."""
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
    newton = ModeSystem(problem, kn, kt, PROXIMAL, drift)
    # every mode system of the problem is factored in the band of the same order: found once
    mode_system = partial(ModeSystem, problem, kn, kt, drift=drift, order=(newton.where, newton.half))
    args = (problem.body_a, problem.body_b, problem.normal, problem.ra, problem.rb, problem.friction,
            problem.target, problem.inv_mass, problem.inv_inertia, kn, kt)
    swept = 0

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

    closest: list = [np.inf, None]  # the least residual any try reached, and where

    def near(q: np.ndarray, now: float) -> None:
        """Keep ``q`` as the closest answer yet if its residual ``now`` is the least seen."""
        if now < closest[0]:
            closest[:] = [now, q]

    def landed(q: np.ndarray, rounds: int) -> Solution | None:
        """The solution at scaled impulses ``q`` if the contract's residual, recomputed from them, is below
        the tolerance (after ``rounds`` Newton rounds), else None."""
        pn, pt = q[:m] * kn, q[m:] * kt
        score = residual(problem, pn, pt)
        return Solution(pn, pt, velocities_after(problem, pn, pt), score, rounds, swept) if score < tolerance else None

    def attempt(q: np.ndarray, rounds: int, wander: int) -> tuple[Solution | None, float]:
        """Newton rounds from ``q`` (swept first unless already near): the solution, or None and the best
        residual reached. ``wander``: how many full steps in a row may leave the residual above the best
        (0: every step is damped until the residual falls)."""
        now = newton.merit(q)
        if now >= NEAR:
            q = sweep(q, NEAR)
            now = newton.merit(q)
        best_q, best, wandering = q, now, 0
        for done in range(rounds + 1):
            found = landed(q, done) if now < tolerance else None
            if found is not None:
                return found, found.residual
            if done == rounds:
                break
            target = newton.step(q)
            after = newton.merit(target)
            if after < best or (wandering < wander and np.isfinite(after)):
                # the full step: it switches every point whose mode it shows wrong at once
                wandering = 0 if after < best else wandering + 1
                q, now = target, after
            else:
                if wander:
                    q, now, wandering = best_q, best, 0  # back to the best answer
                    target = newton.step(q)
                lower = backtrack(newton.merit, q, target, now, 0.5, MIN_STEP)
                if lower is not None:
                    q, now = lower
                else:  # Newton makes no progress here: mend the modes by sweeps
                    q = sweep(q, 0.5 * now)
                    now = newton.merit(q)
                    newton.modes = None
            if now < best:
                best_q, best = q, now
                near(q, now)
        return None, best

    face = np.unique(np.stack([problem.body_a, problem.body_b], axis=1), axis=0, return_inverse=True)[1].reshape(-1)

    ended: list[np.ndarray] = []  # where the last full rounds came closest

    def full(q: np.ndarray, rounds: int) -> tuple[Solution | None, float]:
        """Full Newton rounds from ``q``, mending inconsistent mode systems: the solution, or None and the best
        residual reached (where: ``ended``). When the modes stay and the residual stops falling, the round's
        system has no exact solution: two points of one face with different targets (one touching, one
        speculative) cannot both stick, as their slips differ by what the face's turning gives. Then a sticking
        point of the face that slips most, whichever's round lands lower, is made to slide against its slip
        (friction at its bound), and stays so while it slips that way."""
        slide: dict[int, float] = {}
        best, last = np.inf, np.inf
        for done in range(rounds):
            q = newton.step(q, slide)
            now = newton.merit(q)
            found = landed(q, done + 1) if now < tolerance else None
            if found is not None:
                return found, found.residual
            if not np.isfinite(now):
                break
            if now < best:
                best, ended[:] = now, [q]
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
        for _ in range(SETTLE_QUICK if quick else SETTLE_ROUNDS):
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
            if reached < TOLERANCE:
                found = landed(q, spent)
                if found is not None:
                    return found, found.residual
            modes = system.read(q) if reached < POLISH else None
            if modes is not None and (reached < 0.1 * polished or not np.array_equal(modes, tried)):
                polished, tried = reached, modes
                newton.modes = None
                found, _ = full(q, rounds)
                if found is not None:
                    found.rounds += spent
                    return found, found.residual
        return None, best

    def off(q: np.ndarray) -> np.ndarray:
        """Which points of scaled impulses ``q`` are off the contract (residual at or above the tolerance)."""
        normal, tangent = point_residuals(problem, q[:m] * kn, q[m:] * kt)
        return np.maximum(normal, tangent) >= tolerance

    def probe(q: np.ndarray) -> Solution | None:
        """Forced slides from a stall ``q``, at most ``PROBES`` in all: each sticking point on a body of a point
        that is off the contract, those slipping most first, is made to slide against its slip for good, and
        full Newton rounds from ``q`` try to land; the first that does is the answer. Where held faces close a
        loop whose targets disagree by a hair, the exact answer has a point of the loop sliding, and which one
        is not told by the residuals (on a recorded pile the one that lands slipped second most). A pile may
        hold several such loops: a slide whose rounds leave fewer points off, still within ``PROBE_NEAR``, is
        kept, and the probing goes on from where those rounds came closest."""
        nonlocal newton
        forced: dict[int, float] = {}
        bad, budget = off(q), PROBES
        while budget > 0:
            bodies = np.setdiff1d(np.concatenate([problem.body_a[bad], problem.body_b[bad]]), [GROUND])
            around = np.isin(problem.body_a, bodies) | np.isin(problem.body_b, bodies)
            newton = mode_system(PROXIMAL)
            gap, qn, qt = newton.gap(q), q[:m], q[m:]
            stick = (qn > gap[:m]) & (np.abs(qt - gap[m:]) <= newton.cone * qn)
            slip = gap[m:]
            points = np.flatnonzero(around & stick & (slip != 0.0))
            points = [int(i) for i in points[np.argsort(-np.abs(slip[points]), kind="stable")] if i not in forced]
            kept = None
            for i in points[:budget]:
                budget -= 1
                newton = mode_system(PROXIMAL)
                newton.forced = {**forced, i: -float(np.sign(slip[i]))}
                found, reached = full(q, 2 * rounds)
                if found is not None:
                    return found
                if reached < PROBE_NEAR and off(ended[0]).sum() < bad.sum():
                    kept = newton.forced, ended[0]
                    break
            if kept is None:
                return None
            forced, q = kept
            bad = off(q)
        return None

    def pivot() -> tuple[Solution | None, float]:
        """Lemke's pivoting (``stackx.models.planar.pivoting``), each answer it ends on taken to the exact one by
        full Newton rounds; on a large problem, whose walk is on a regularized problem, then by the proximal
        point method from there."""
        from stackx.models.planar import pivoting

        best = np.inf
        for pn_start, pt_start in pivoting.starts(problem):
            q = np.concatenate([pn_start / kn, pt_start / kt])
            newton.modes = None
            # a walk on the problem's own LCP may end on its answer, taken as it is: a Newton round there reads
            # modes on their boundaries and can leave it
            found = landed(q, 0)
            if found is None:
                found, reached = full(q, 2 * rounds)
            if found is None and m > pivoting.EXACT_POINTS:
                found, reached = settle(q, 2 * rounds, PIVOT_SETTLE)
            if found is not None:
                return found, found.residual
            best = min(best, reached)
        return None, best

    warm, zero = np.concatenate([pn / kn, pt / kt]), np.zeros(2 * m)
    starts = [warm, zero] if pn.any() or pt.any() else [warm]
    if interior:
        # a warm start near the answer (a pile at rest: the last step's answer is this one's) lands in a round or
        # two of its own modes, the first try's opening: cheaper than any path
        if newton.merit(warm) < NEAR:
            found, _ = attempt(warm, WARM_ROUNDS, 0)
            if found is not None:
                return found
        # the interior point stage (``interior``): the central path from the problem alone, then the two cheap
        # Newton tries from where it ends; a landing there is ``attempt`` 0
        def follow(begun: np.ndarray | None, ramp: tuple[float, ...] = (1.0,)) -> Solution | None:
            """The central path from ``begun`` (None: its own start), once per share of the friction in
            ``ramp``, each from where the last ended, then the two cheap Newton tries from its end."""
            path, ended_on_path = begun, 0
            for share in ramp:
                with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # far end's products underflow
                    path, _, ended_on_path = central_path(newton.values, newton.columns, newton.k,
                                                          share * newton.cone, newton.v0, newton.inv,
                                                          newton.fixed_u, newton.target, path,
                                                          (newton.where, newton.half))
            for run in (partial(attempt, path, rounds, 0), partial(full, path, 2 * rounds)) if ended_on_path else ():
                newton.modes = None
                found, _ = run()
                if found is not None:
                    found.attempt = 0
                    return found
            return None

        # from the path's own start, then (where that folded) from the warm start, which lies on the answer's side
        # of a fold more often than not, then with the friction raised in stages from none (``FRICTION_RAMP``)
        paths = [partial(follow, None)] + ([partial(follow, warm)] if pn.any() or pt.any() else [])
        for run in paths + [partial(follow, None, FRICTION_RAMP)]:
            newton.modes = None
            found = run()
            if found is not None:
                return found
    # every try is checked by the residual, so the order changes nothing but the cost: the cheap tries first,
    # then (on small problems, where it costs a few tens of ms) Lemke's pivoting, then the proximal point
    # method (seconds on a 20-row pyramid), then heavier Newton tries, and Lemke last on larger problems,
    # where it takes seconds. A try: its proximal weight and what it runs.
    cheap = [(PROXIMAL, partial(attempt, warm, rounds, 0))]
    cheap += [(PROXIMAL, partial(full, start, 2 * rounds)) for start in starts]
    heavy = [(PROXIMAL, partial(attempt, zero, rounds, 0))] * (len(starts) - 1)
    heavy += [(PROXIMAL, partial(attempt, zero, rounds, WANDER))]
    for d in DAMPED:
        heavy += [(d, partial(full, warm, 2 * rounds)), (d, partial(attempt, warm, rounds, 0))]
    walk = [(PROXIMAL, partial(settle, warm, 2 * rounds))]
    lemke = [(PROXIMAL, pivot)]
    tries = cheap + lemke + walk + heavy if m <= LEMKE_EARLY else cheap + walk + heavy + lemke
    numbered = list(enumerate(tries, 1))
    if 1 < begin <= len(tries):
        numbered = numbered[begin - 1:] + numbered[:begin - 1]
    if quick:
        numbered = numbered[:QUICK]
    best, probed = np.inf, False
    for number, (proximal, run) in numbered:
        if proximal != newton.proximal or newton.forced:
            newton = mode_system(proximal)
        newton.modes = None
        found, reached = run()
        if found is None and not probed and closest[0] < PROBE_NEAR:
            probed = True  # the stall of a try that came this near is probed once, counted as that try's
            found = probe(closest[1])
        if found is not None:
            found.attempt = number
            return found
        best = min(best, reached)
    if begin > 1 and not quick:
        # the tries are the same in any order, but not what they leave each other (the stall probed once, the
        # modes read): a row that begins with the try that landed its last step (the fifth, on a leaning row of
        # dominoes) can miss a step the default order lands, so the default order has the last word
        return solve(problem, pn, pt, tolerance, sweeps, rounds, interior=False, restart=restart)
    kept = warm if closest[1] is None else closest[1]
    kept_pn, kept_pt = np.maximum(kept[:m], 0.0) * kn, kept[m:] * kt
    kept_pt = np.clip(kept_pt, -problem.friction * kept_pn, problem.friction * kept_pn)
    if restart and not quick and closest[0] < RESTART:
        # every try is local: begun from the closest answer any of them reached, they read its modes, not the
        # warm start's (see the module text)
        try:
            return solve(problem, kept_pn, kept_pt, tolerance, sweeps, rounds, interior=False, restart=False,
                         drift=DRIFT)
        except ReferenceFailure as again:
            if again.best < closest[0]:
                raise
    raise ReferenceFailure(f"the contact problem ({m} points, {n} bodies) was not solved to {tolerance:g} m/s "
                           f"in {len(numbered)} tries ({rounds} damped or {2 * rounds} full Newton rounds each, "
                           f"Lemke pivoting) and {swept} sweeps: best residual {best:.3g} m/s",
                           best, kept_pn, kept_pt)


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
        self.forced: dict[int, float] = {}  # point: +-1, held and sliding that way whatever the impulses say
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
        for i, sign in self.forced.items():
            modes[i], modes[m + i], modes[2 * m + i] = True, sign > 0.0, sign < 0.0
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
        self.factors = banded.band(1.0 / self.inv, self.where, self.half)
        banded.add(self.factors, self.half, self.where, np.full(free.shape[0], 1.0 / self.proximal), g, self.j_rows,
                   self.j_columns)
        self.pivots = np.zeros(self.dof, np.int64)
        if not banded.factor(self.factors, self.half, self.pivots):  # a singular mode system: back to sweeps
            self.factors = None
        self.sign = sign

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
