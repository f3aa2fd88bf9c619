"""What the bench measures on every step of a planar run: the error against the reference solve, when boxes
passed through each other, and when the pile recovered and settled. The column's step log
(``stackx.bench.error_column``) does the same for the column, and the module text there says why every step
and why along the solver's own path; this one carries it over to boxes that slide and turn.

**Error against the reference.** At every step ``k`` of a solver's own run, from the state before the step
(poses and velocities as the solver left them), the reference (``stackx.solvers.planar.step_problem``) sets the
step's problem (gravity, the points within the solver's own ``speculative`` margin, 0 for a solver without
one, grown as the solver grows it for a solver with ``speculative_reach``) and solves it to a residual below 1e-10 m/s. Per movable box, the difference between the velocities the
solver stored after step ``k`` and the reference's is one speed,
``sqrt(dvx^2 + dvy^2 + (r dw)^2)`` with ``r`` the box's half-diagonal (rotation as the speed of its
corners), in m/s. The error is the RMS over all steps and movable boxes, with the largest difference and its
step beside it. The reference starts each step from the impulses it found for the same points the step
before, so a run's steps cost it few Newton rounds.

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

A step the reference cannot solve (it says so rather than return a wrong answer) is not measured; how many
there were is reported as ``unsolved`` beside the error, so a gap in the measurement is never silent.

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

from typing import Any

import numpy as np

from stackx.bench.criteria import Criteria
from stackx.bench import steplog
from stackx.solvers.planar.conditions import CONDITIONS, approach, matched, violations
from stackx.models.planar.measures import half_diagonal, max_depth
from stackx.solvers.planar.reference import ReferenceFailure
from stackx.models.planar.state import PlanarState
from stackx.solvers.planar.step_problem import ReferenceStep
from stackx.run.runner import OnStep
from stackx.solvers.planar.base import StepImpulses
from stackx.solvers.planar.reach import reach_in_step
from stackx.config.spec import RunSpec


class BatchLog:
    """What the steps of one batch came to, one array element per row (as the column's ``BatchLog``)."""

    def __init__(self, rows: int, bodies: int) -> None:
        self.reference = ReferenceStep(rows, bodies)
        self.bodies = bodies
        self.sumsq = np.zeros(rows)
        self.values = np.zeros(rows, dtype=np.int64)     # box velocities compared (steps x movable boxes)
        self.measured = np.zeros(rows, dtype=np.int64)   # steps compared
        self.unsolved = np.zeros(rows, dtype=np.int64)   # steps the reference could not solve
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


class RowLog(steplog.RowLog):
    """What one run's steps came to: the column's figures, and how many steps the reference left unsolved."""

    def error(self) -> dict[str, Any]:
        log, b = self.log, self.b
        steps = log.measured[b] + log.unsolved[b]
        checked = int(log.checked[b])
        largest = dict(zip(CONDITIONS, map(float, log.violation_max[b])))
        return {**super().error(), "unsolved": int(log.unsolved[b]),
                "approach_max": float(log.approach_max[b]) if steps else None,
                "approach_rms": float(np.sqrt(log.approach_sumsq[b] / steps)) if steps else None,
                "violation_max": largest if checked else None,
                "violation_worst": max(CONDITIONS, key=largest.__getitem__) if checked else None,
                "violation_rms": float(np.sqrt(log.violation_sumsq[b] / checked)) if checked else None,
                "violation_steps": checked}


def box_speeds(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """``sqrt(vx^2 + vy^2 + (radius w)^2)`` per box: a velocity (or a difference of two) as one speed."""
    return np.sqrt(vx * vx + vy * vy + (radius * w) ** 2)


def check_own(log: BatchLog, b: int, after: PlanarState, own: StepImpulses | None) -> None:
    """Row ``b``'s own answer against the conditions of the step problem the reference just set: from its
    stored velocities always, from its impulses ``own`` when it gave them (see the module text)."""
    problem = log.reference.problem
    assert problem is not None
    fastest = approach(problem, np.stack([after.vx[b], after.vy[b], after.w[b]], axis=1))
    log.approach_max[b] = max(log.approach_max[b], fastest)
    log.approach_sumsq[b] += fastest * fastest
    if own is None:
        return
    pn, pt = matched(log.reference.ids[:problem.points], own.keys, own.pn, own.pt)
    found = np.array(list(violations(problem, pn, pt).values()))
    np.maximum(log.violation_max[b], found, out=log.violation_max[b])
    log.violation_sumsq[b] += float(found.max()) ** 2
    log.checked[b] += 1


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
        try:
            found = log.reference.solve(b, s.x[b], s.y[b], s.angle[b], s.vx[b], s.vy[b], s.w[b], s.inv_mass[b],
                                        s.inv_inertia[b], s.hx[b], s.hy[b], s.friction[b], g[b], dt[b],
                                        margin)
        except ReferenceFailure:
            log.unsolved[b] += 1
            continue
        finally:
            if log.reference.problem is not None:
                check_own(log, b, after, None if impulses is None else impulses[b])
        v = found.velocity
        diff = box_speeds(after.vx[b] - v[:, 0], after.vy[b] - v[:, 1], after.w[b] - v[:, 2], radius[b])[moving]
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


class StepLog:
    """A ``stackx.run.runner.StepObserver`` keeping a ``RowLog`` per run name."""

    def __init__(self, criteria: Criteria) -> None:
        self.criteria = criteria
        self.rows: dict[str, RowLog] = {}

    def batch(self, runs: list[RunSpec], solver: object = None) -> OnStep:
        log = BatchLog(len(runs), runs[0].scene.size())
        self.rows.update((r.name, RowLog(log, b)) for b, r in enumerate(runs))
        g = np.array([r.gravity for r in runs], dtype=np.float64)
        dt = np.array([r.dt for r in runs], dtype=np.float64)
        speculative = np.array([float(getattr(r.solver_params, "speculative", 0.0)) for r in runs])
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
