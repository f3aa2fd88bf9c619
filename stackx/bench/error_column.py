"""What the bench measures on every step of a run: the error against the exact solve, when the column formed,
and whether boxes passed through each other.

**Error against the exact solver.** At every step ``k`` of a solver's own run, take the state before the step
(heights and velocities, as the solver left them) and let the exact solver's velocity stage compute the
velocities that step should end with: gravity, then the step's velocity problem (no contact approaches, no
contact pulls) solved to machine precision. The solver's answer is the velocity it stored after step ``k``.
The error is the RMS over all steps and boxes of the difference (m/s), with the worst step and its largest
difference beside it. Every step, because the steps that matter most are the rare ones: an impact is a few
steps of a run, and an error sampled at evenly spread steps misses it.

Why along the solver's own path and not by running both side by side: two runs part ways within a few
steps on any stack that is not held, after which a per-step comparison measures the distance between two
different piles, not how well each step was solved. From the same state, the difference is the error of
this step's solve alone: iteration error for an iterative solver, plus whatever the solver does on purpose
that a rigid contact does not (a bias that pushes apart, a soft contact, substeps).

Which contacts take part is part of the problem, not of its solution, so the exact step uses the solver's
own ``speculative`` margin (0, the lab's rule, for a solver without one), widened each step as the solver
does when it sweeps (``swept``): a solver is compared with the exact solve of the problem it set itself.

**Crushed.** The column keeps its boxes in order; once a box has passed half-way into its neighbour (the
``reach`` monitor above ``criteria.reach``) the order no longer says which box rests on which, and depths,
heights and errors after that step describe nothing physical. The first such step is kept; the error stops
there.

**Steps to recover and to settle.** After every step: does every contact overlap by at most the depth limit
(``depth_factor x slop``); does every contact also have at most that much gap; is the RMS motion of the step
``(y_after - y_before)/dt`` below ``criteria.settle``. ``steps_to_recover`` is the step from which the first
stays true to the end, ``steps_to_settle`` the step from which all three do; None when the end of the run
does not reach it.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import kernel
from stackx.models.column.state import ColumnState
from stackx.bench import steplog
from stackx.run.runner import OnStep
from stackx.solvers.column.exact import solve_step
from stackx.solvers.column.isotonic import workspace
from stackx.solvers.column.pgs import gravity
from stackx.config.spec import RunSpec


class BatchLog:
    """What the steps of one batch came to, one array element per row: kept as arrays so that a step costs a
    few numpy operations whatever the batch size (the bench observes every step of runs 100,000 steps long)."""

    def __init__(self, rows: int, boxes: int) -> None:
        self.scratch = np.empty((5, boxes))  # the exact step's velocities, contact masses, targets, impulses, start
        self.floats, self.indices = workspace(boxes)
        self.sumsq = np.zeros(rows)
        self.values = np.zeros(rows, dtype=np.int64)     # velocities compared (steps x boxes)
        self.measured = np.zeros(rows, dtype=np.int64)   # steps compared
        self.worst = np.full(rows, -1.0)
        self.worst_step = np.full(rows, -1, dtype=np.int64)
        self.crushed_at = np.full(rows, -1, dtype=np.int64)
        self.last_overlap = np.full(rows, -1, dtype=np.int64)  # last step after which a contact overlapped too much
        self.last_unheld = np.full(rows, -1, dtype=np.int64)   # ... overlapped or had too wide a gap
        self.last_moving = np.full(rows, -1, dtype=np.int64)   # ... moved at or above the settled limit
        self.steps = 0


@kernel
def log_step(k: int, y: np.ndarray, v: np.ndarray, after_y: np.ndarray, after_v: np.ndarray, inv: np.ndarray,
             half: np.ndarray, reach: np.ndarray, g: np.ndarray, dt: np.ndarray, speculative: np.ndarray,
             swept: np.ndarray, limit: float, settle: float, reach_limit: float,
             sumsq: np.ndarray, values: np.ndarray, measured: np.ndarray, worst: np.ndarray, worst_step: np.ndarray,
             crushed_at: np.ndarray, last_overlap: np.ndarray, last_unheld: np.ndarray, last_moving: np.ndarray,
             scratch: np.ndarray, floats: np.ndarray, indices: np.ndarray) -> None:
    """Log step ``k`` of every batch row, from heights ``y`` and velocities ``v`` before it to ``after_y``,
    ``after_v`` (see the module text): one call per step for the whole batch, compiled with the solvers.
    ``scratch`` (5 rows of ``n``), ``floats`` and ``indices`` are reused by every row and step."""
    n = y.shape[1]
    for b in range(y.shape[0]):
        overlap, gap, motion = False, False, 0.0
        for c in range(n):
            if c == 0:
                d = half[b, 0] - after_y[b, 0]
            else:
                d = (half[b, c - 1] + half[b, c]) - (after_y[b, c] - after_y[b, c - 1])
            overlap = overlap or d > limit
            gap = gap or -d > limit
            speed = (after_y[b, c] - y[b, c]) / dt[b]
            motion += speed * speed
        if overlap:
            last_overlap[b] = k
        if overlap or gap:
            last_unheld[b] = k
        if not np.sqrt(motion / n) < settle:
            last_moving[b] = k
        if crushed_at[b] < 0 and not reach[b] <= reach_limit:
            crushed_at[b] = k + 1
        if crushed_at[b] >= 0:
            continue
        exact = scratch[0]
        for i in range(n):
            exact[i] = v[b, i]
        gravity(exact, g[b], dt[b])
        solve_step(y[b], exact, inv[b], half[b], dt[b], speculative[b], swept[b], scratch[1], scratch[2],
                   scratch[3], floats, indices, scratch[4])
        top = 0.0
        for i in range(n):
            diff = abs(after_v[b, i] - exact[i])
            sumsq[b] += diff * diff
            if not diff <= top:  # a NaN difference is the worst there is
                top = diff
        values[b] += n
        measured[b] += 1
        if not top <= worst[b]:
            worst[b] = top
            worst_step[b] = k


class StepLog(steplog.StepLog):
    """A ``stackx.run.runner.StepObserver`` keeping a ``RowLog`` per run name."""

    def batch(self, runs: list[RunSpec], solver: object = None) -> OnStep:
        log = BatchLog(len(runs), runs[0].scene.size())
        g, dt, speculative = self.start(log, runs)
        swept = np.array([bool(getattr(r.solver_params, "swept", False)) for r in runs])
        c = self.criteria

        def on_step(k: int, before: ColumnState, after: ColumnState) -> None:
            log.steps = k + 1
            y, v = before.y, before.v
            n = y.shape[1]  # boxes left after scene events; the scratch is sized for the most
            log_step(k, y, v, after.y, after.v, after.inv_mass, after.half, after.reach, g, dt, speculative, swept,
                     c.depth_limit, c.settle, c.reach, log.sumsq, log.values, log.measured, log.worst,
                     log.worst_step, log.crushed_at, log.last_overlap, log.last_unheld, log.last_moving,
                     log.scratch[:, :n], log.floats, log.indices)

        return on_step
