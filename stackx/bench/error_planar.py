"""What the bench measures on every step of a planar run: the error against the reference solve, when boxes
passed through each other, and when the pile recovered and settled. The column's step log
(``stackx.bench.error_column``) does the same for the column, and the module text there says why every step
and why along the solver's own path; this one carries it over to boxes that slide and turn.

**Error against the reference.** At every step ``k`` of a solver's own run, from the state before the step
(poses and velocities as the solver left them), the reference (``stackx.solvers.planar.step_problem``) sets the
step's problem (gravity, the points within the solver's own ``speculative`` margin, 0 for a solver without
one, grown as the solver grows it for a solver with ``speculative_reach``) and solves it to a residual below
``max(1e-10, e / FRACTION)`` m/s, e the error it measures against the candidate answer (``stop_rule``: an answer a
hundredth of the error from exact moves the error by a hundredth of itself; docs/bench.md gives the calibration).
Per movable box, the difference between the velocities the solver stored after step ``k`` and the reference's is
one speed,
``sqrt(dvx^2 + dvy^2 + (r dw)^2)`` with ``r`` the box's half-diagonal (rotation as the speed of its
corners), in m/s. The error is the RMS over all steps and movable boxes, with the largest difference and its
step beside it. The reference starts each step from the impulses it found for the same points the step
before, so a run's steps cost it few Newton rounds.

**The nearest exact answer.** With friction a step may have several exact answers; the error is the distance to
the one nearest the solver's: where ``nearest_wanted`` (more contact rows than velocities, the solver's impulses
given, its error within ``NEAREST_FACTOR`` of the spread its run has found so far and at least ``NEGLIGIBLE`` of
the run's RMS error so far, or one step in ``SAMPLE``), a second
solve from the solver's impulses (``ReferenceStep.nearest``) finds another, the nearer counts, and the distance
between the two is the step's spread: ``spread`` (RMS over the boxes of the steps where a second answer was
found: the one-in-``SAMPLE`` steps give an unbiased sample of it, so averaging in the steps never asked, as if
their answers were unique, would understate it) and ``spread_max`` (one box's largest), the error's
uncertainty; None where no second answer was found (a solver that gives no impulses to start from, or a run
whose steps have no redundant rows).

**Its own answer's conditions.** Beside the error, which needs the reference, each step also gets what the
solver's answer breaks on its own (``stackx.solvers.planar.conditions``), on the same step problem, whether or
not the reference solves it:

- from the velocities it stored, for every solver (engines included), the fastest approach beyond any
  point's target (a point sinking faster than the step allows): its largest value over the run
  (``approach_max``) and the RMS of the per-step values (``approach_rms``), m/s;
- from the impulses its step applied, for a solver that exposes them
  (``stackx.solvers.planar.base.PlanarSolver.step_impulses``, matched to the problem's points by
  ``(A, B, FEATURE)``), each condition's violation (``conditions.violations``: penetration, pull,
  complementarity, Coulomb's box, maximal dissipation): per condition its largest value over the run
  (``violation_max``, a dict by condition), the condition with the largest (``violation_worst``), the RMS
  over the checked steps of each step's worst condition (``violation_rms``), and how many steps were
  checked (``violation_steps``); None for a solver that does not expose them.

All are in the run's error beside ``rms`` and ``max``, 0 for an exact answer, and each costs a pass over
the step's points (``python3 -m benchmarks.planar_reference``'s ``own us``).

A step the reference cannot solve, even restarted from zero impulses (``ReferenceStep.measure``), is measured
against the closest answer it found and counted: ``unsolved`` steps, and ``unsolved_residual``, the largest
residual of those answers (m/s), beside the error, so a weak spot in the measurement is never silent.

**Crushed.** Once a box has passed half-way into another (the ``reach`` monitor above ``criteria.reach``),
contact normals and features no longer describe which box rests on which; the first such step is kept and
the error stops there.

**Steps to recover and to settle.** After every step: is every contact's depth (by the model's collision
test) at most the depth limit (``depth_factor x slop``); is the RMS motion of the step over movable boxes,
``sqrt(dx^2 + dy^2 + (r da)^2)/dt``, below ``criteria.settle``. ``steps_to_recover`` is the step from which
the first stays true to the end, ``steps_to_settle`` the step from which both do; None when the end of the
run does not reach it. (The column's "no gap" check has no planar meaning: boxes may rightly stand apart.)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from stackx.bench.criteria import Criteria
from stackx.bench import steplog
from stackx.solvers.planar.conditions import CONDITIONS, approach, matched, violations
from stackx.models.planar.measures import half_diagonal, max_depth
from stackx.solvers.planar.reference import TOLERANCE
from stackx.models.planar.state import PlanarState
from stackx.solvers.planar.step_problem import UNSOLVED, ReferenceStep
from stackx.run.runner import OnStep
from stackx.solvers.planar.base import StepImpulses
from stackx.solvers.planar.reach import reach_in_step
from stackx.config.spec import RunSpec


FRACTION = 100.0  # the reference stops at residual <= max(1e-10, e / FRACTION), e the step's error (docs/bench.md)
NEAREST_FACTOR = 2.0  # a second, nearest answer is sought where the error is within this factor of the spread so far
NEGLIGIBLE = 0.1  # ... and at least this share of the run's RMS error so far (a smaller one barely moves the RMS)
SAMPLE = 25  # ... and at every SAMPLE-th measured step of a row whatever its error, to find the row's spread
AT_ANSWER = 1e-9  # m/s: an error this small is at an exact answer already; no second answer is sought


class BatchLog:
    """What the steps of one batch came to, one array element per row (as the column's ``BatchLog``)."""

    def __init__(self, rows: int, bodies: int) -> None:
        self.reference = ReferenceStep(rows, bodies)
        self.bodies = bodies
        self.sumsq = np.zeros(rows)
        self.values = np.zeros(rows, dtype=np.int64)     # box velocities compared (steps x movable boxes)
        self.measured = np.zeros(rows, dtype=np.int64)   # steps compared
        self.unsolved = np.zeros(rows, dtype=np.int64)   # steps the reference could not solve
        self.unsolved_residual = np.zeros(rows)  # the largest residual of the answers kept on those (m/s)
        self.spread_sumsq = np.zeros(rows)  # squared distances between the exact answers found, summed over boxes
        self.spread_values = np.zeros(rows, dtype=np.int64)  # box velocities of the steps with a second answer
        self.spread_max = np.zeros(rows)  # the largest such distance of one box (m/s)
        self.nearest = np.zeros(rows, dtype=np.int64)  # steps given a second solve for the nearest answer
        self.worst = np.full(rows, -1.0)
        self.approach_max = np.zeros(rows)  # fastest approach beyond a target, over the steps (m/s)
        self.approach_sumsq = np.zeros(rows)  # sum over steps of each step's fastest approach squared
        self.violation_max = np.zeros((rows, len(CONDITIONS)))  # each condition's largest violation (m/s)
        self.violation_sumsq = np.zeros(rows)  # sum over checked steps of each step's worst violation squared
        self.checked = np.zeros(rows, dtype=np.int64)  # steps whose impulses were checked
        self.worst_step = np.full(rows, -1, dtype=np.int64)
        self.crushed_at = np.full(rows, -1, dtype=np.int64)
        self.last_overlap = np.full(rows, -1, dtype=np.int64)  # last step after which a contact overlapped too much
        self.last_moving = np.full(rows, -1, dtype=np.int64)   # ... moved at or above the settled limit
        self.last_unheld = self.last_overlap  # no gap check: a pile is held when nothing overlaps too much
        self.steps = 0

    def spread(self, b: int) -> float | None:
        """Row ``b``'s spread so far: the RMS over the boxes of the steps where a second answer was found (m/s);
        None before the first."""
        found = self.spread_values[b]
        return float(np.sqrt(self.spread_sumsq[b] / found)) if found else None


class RowLog(steplog.RowLog):
    """What one run's steps came to: the column's figures, and how many steps the reference left unsolved."""

    def error(self) -> dict[str, Any]:
        log, b = self.log, self.b
        steps = log.measured[b]
        checked = int(log.checked[b])
        largest = dict(zip(CONDITIONS, map(float, log.violation_max[b])))
        found = log.spread_values[b]
        spread = log.spread(b)
        return {**super().error(), "unsolved": int(log.unsolved[b]),
                "unsolved_residual": float(log.unsolved_residual[b]),
                "spread": spread, "spread_max": float(log.spread_max[b]) if found else None,
                "approach_max": float(log.approach_max[b]) if steps else None,
                "approach_rms": float(np.sqrt(log.approach_sumsq[b] / steps)) if steps else None,
                "violation_max": largest if checked else None,
                "violation_worst": max(CONDITIONS, key=largest.__getitem__) if checked else None,
                "violation_rms": float(np.sqrt(log.violation_sumsq[b] / checked)) if checked else None,
                "violation_steps": checked}


def box_speeds(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """``sqrt(vx^2 + vy^2 + (radius w)^2)`` per box: a velocity (or a difference of two) as one speed."""
    return np.sqrt(vx * vx + vy * vy + (radius * w) ** 2)


def check_own(log: BatchLog, b: int, after: PlanarState,
              own: StepImpulses | None) -> tuple[np.ndarray, np.ndarray] | None:
    """Row ``b``'s own answer against the conditions of the step problem the reference just set: from its
    stored velocities always, from its impulses ``own`` when it gave them (see the module text). Returns
    those impulses matched to the problem's points (None: not given)."""
    problem = log.reference.problem
    assert problem is not None
    fastest = approach(problem, np.stack([after.vx[b], after.vy[b], after.w[b]], axis=1))
    log.approach_max[b] = max(log.approach_max[b], fastest)
    log.approach_sumsq[b] += fastest * fastest
    if own is None:
        return None
    pn, pt = matched(log.reference.ids[:problem.points], own.keys, own.pn, own.pt)
    found = np.array(list(violations(problem, pn, pt).values()))
    np.maximum(log.violation_max[b], found, out=log.violation_max[b])
    log.violation_sumsq[b] += float(found.max()) ** 2
    log.checked[b] += 1
    return pn, pt


def rms(speeds: np.ndarray) -> float:
    """The RMS of per-box speeds (0 for none; inf for a speed run off to infinity)."""
    with np.errstate(over="ignore", invalid="ignore"):
        return float(np.sqrt(np.mean(speeds * speeds))) if speeds.size else 0.0


def stop_rule(own: np.ndarray, radius: np.ndarray, moving: np.ndarray) -> Callable[[np.ndarray], float]:
    """The reference's tolerance for a candidate answer's velocities (n, 3): ``max(1e-10, e / FRACTION)``, e the
    RMS box speed between them and the solver's own velocities ``own`` (n, 3) over the ``moving`` boxes. The
    reference then stops once its own residual is a hundredth of what it measures (docs/bench.md); a NaN
    error (a run blown up) keeps 1e-10."""

    def tolerance(velocity: np.ndarray) -> float:
        e = rms(distances(own, velocity, radius, moving))
        return max(TOLERANCE, e / FRACTION) if np.isfinite(e) else TOLERANCE

    return tolerance


def distances(own: np.ndarray, velocity: np.ndarray, radius: np.ndarray, moving: np.ndarray) -> np.ndarray:
    """Per moving box, the speed of the difference between velocities ``own`` and ``velocity`` (n, 3)."""
    d = own - velocity
    with np.errstate(over="ignore", invalid="ignore"):  # a candidate run off to infinity is infinitely far
        return box_speeds(d[:, 0], d[:, 1], d[:, 2], radius)[moving]


def nearest_wanted(log: BatchLog, b: int, error: float, impulses: tuple[np.ndarray, np.ndarray] | None) -> bool:
    """Whether a step is worth a second solve for the exact answer nearest the solver's: it has more contact
    rows than velocities (so its answers need not be unique), the solver gave impulses to start from, its error
    is above ``AT_ANSWER``, and either it is within ``NEAREST_FACTOR`` of the row's spread so far (``spread``,
    the RMS of the answers' distances: an error the spread could account for) and at least ``NEGLIGIBLE`` of the
    row's RMS error so far (a step whose error is a tenth of the run's moves the run's mean square by a
    hundredth of its share, whichever answer it is measured against), or the step is one of every ``SAMPLE``
    the row measures (which find that spread). A step measured against the first answer alone
    overstates its error by at most its own spread, so over the run the error is overstated by at most the
    RMS of the spreads of the steps not asked, which ``spread`` estimates and the error carries as its
    uncertainty. A second solve costs about five first ones (it starts from the solver's answer, not the last
    exact one), tens on a solver whose impulses are far from consistent (``planar-avbd``), so made more often
    it would double the bench (docs/bench.md)."""
    problem = log.reference.problem
    if impulses is None or problem is None or problem.points == 0 or not error > AT_ANSWER:
        return False
    velocities = 3 * int(np.count_nonzero(problem.inv_mass > 0.0))
    sampled = log.measured[b] % SAMPLE == 0
    spread = log.spread(b) or 0.0
    so_far = np.sqrt(log.sumsq[b] / log.values[b]) if log.values[b] else 0.0
    return 2 * problem.points > velocities and (sampled or NEGLIGIBLE * so_far <= error <= NEAREST_FACTOR * spread)


def measure(log: BatchLog, b: int, own: np.ndarray, radius: np.ndarray, moving: np.ndarray,
            first: np.ndarray, impulses: tuple[np.ndarray, np.ndarray] | None,
            tolerance: Callable[[np.ndarray], float]) -> np.ndarray:
    """Per moving box, the solver's distance (velocities ``own``) to the exact answer nearest them: the
    reference's ``first`` answer's velocities, or where ``nearest_wanted`` another answer found from the
    solver's ``impulses``, whichever is nearer in RMS; the distance between the two is logged as the step's
    spread (0 where no second answer was sought or found)."""
    diff = distances(own, first, radius, moving)
    if not nearest_wanted(log, b, rms(diff), impulses):
        return diff
    assert impulses is not None
    log.nearest[b] += 1
    other = log.reference.nearest(*impulses, tolerance)
    if other is None:
        return diff
    apart = distances(first, other.velocity, radius, moving)
    log.spread_sumsq[b] += float(np.sum(apart * apart))
    log.spread_values[b] += apart.size
    if apart.size:
        log.spread_max[b] = max(log.spread_max[b], float(apart.max()))
    near = distances(own, other.velocity, radius, moving)
    return near if rms(near) < rms(diff) else diff


def log_step(log: BatchLog, k: int, before: PlanarState, after: PlanarState, g: np.ndarray, dt: np.ndarray,
             speculative: np.ndarray, criteria: Criteria, reaches: np.ndarray | None = None,
             impulses: list[StepImpulses | None] | None = None) -> None:
    """Log step ``k`` of every batch row, from ``before`` to ``after`` (see the module text); ``impulses``:
    per row, what the solver's step applied (None: not exposed)."""
    radius = half_diagonal(after)
    for b in range(after.batch):
        moving = after.inv_mass[b] > 0.0
        motion = box_speeds(after.x[b] - before.x[b], after.y[b] - before.y[b], after.angle[b] - before.angle[b],
                            radius[b])[moving] / dt[b]
        if max_depth(after, b) > criteria.depth_limit:
            log.last_overlap[b] = k
        if not (motion.size == 0 or np.sqrt(np.mean(motion * motion)) < criteria.settle):
            log.last_moving[b] = k
        if log.crushed_at[b] < 0 and not after.reach[b] <= criteria.reach:
            log.crushed_at[b] = k + 1
        if log.crushed_at[b] >= 0:
            continue
        s = before
        margin = speculative[b]
        if reaches is not None and reaches[b]:  # the solver looks as far as the fastest box closes in the step
            margin = max(margin, reach_in_step(s.vx[b], s.vy[b], s.w[b], s.inv_mass[b], s.hx[b], s.hy[b], g[b], dt[b]))
        own = np.stack([after.vx[b], after.vy[b], after.w[b]], axis=1)
        tolerance = stop_rule(own, radius[b], moving)
        found, how = log.reference.measure(b, tolerance, s.x[b], s.y[b], s.angle[b], s.vx[b], s.vy[b], s.w[b],
                                           s.inv_mass[b], s.inv_inertia[b], s.hx[b], s.hy[b], s.friction[b], g[b],
                                           dt[b], margin)
        given = check_own(log, b, after, None if impulses is None else impulses[b])
        if how == UNSOLVED:  # measured against the closest answer the reference found, and counted
            log.unsolved[b] += 1
            log.unsolved_residual[b] = max(log.unsolved_residual[b], found.residual)
            diff = distances(own, found.velocity, radius[b], moving)
        else:
            diff = measure(log, b, own, radius[b], moving, found.velocity, given, tolerance)
        log.sumsq[b] += float(np.sum(diff * diff))
        log.values[b] += diff.size
        log.measured[b] += 1
        top = 0.0
        for d in diff:
            if not d <= top:  # a NaN difference is the worst there is
                top = d
        if not top <= log.worst[b]:
            log.worst[b] = top
            log.worst_step[b] = k


class StepLog(steplog.StepLog):
    """A ``stackx.run.runner.StepObserver`` keeping a ``RowLog`` per run name."""

    row_log = RowLog

    def batch(self, runs: list[RunSpec], solver: object = None) -> OnStep:
        log = BatchLog(len(runs), runs[0].scene.size())
        g, dt, speculative = self.start(log, runs)
        reaches = np.array([bool(getattr(r.solver_cls, "speculative_reach", False)) for r in runs])
        exposed = getattr(solver, "step_impulses", None)  # planar solvers have it; engines do not
        if exposed is not None:
            solver.watch_impulses()  # type: ignore[union-attr]

        def on_step(k: int, before: PlanarState, after: PlanarState) -> None:
            log.steps = k + 1
            if after.bodies != log.bodies:  # a scene event took a box out: the remembered points name old indices
                log.bodies = after.bodies
                log.reference = ReferenceStep(after.batch, after.bodies)
            impulses = None if exposed is None else [exposed(b) for b in range(after.batch)]
            log_step(log, k, before, after, g, dt, speculative, self.criteria, reaches, impulses)

        return on_step
