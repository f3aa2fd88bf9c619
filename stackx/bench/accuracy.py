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

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from stackx import registry
from stackx.config import RunSpec
from stackx.criteria import Criteria
from stackx.errors import ConfigError
from stackx.runner import OnStep
from stackx.state import ColumnState

Reference = Callable[..., None]
"""``(y, v, inv, half, g, dt, speculative, swept, out)``, batch arrays: ``out`` receives the exact step's velocities
from heights ``y`` and velocities ``v`` before the step (``stackx.solvers.exact.exact_step``)."""

REFERENCE_SOLVER = "exact"


def find_reference() -> Reference | None:
    """The exact step, from the ``exact`` solver's module (its ``exact_step`` kernel); None when no such solver
    is registered."""
    try:
        cls = registry.solvers.get(REFERENCE_SOLVER)
    except ConfigError:
        return None
    return getattr(importlib.import_module(cls.__module__), "exact_step", None)  # type: ignore[no-any-return]


@dataclass
class RowLog:
    """What one run's steps came to (see the module text)."""

    sumsq: float = 0.0
    values: int = 0          # velocities compared (steps x boxes)
    measured: int = 0        # steps compared
    worst: float = 0.0
    worst_step: int | None = None
    crushed_at: int | None = None
    last_overlap: int = -1   # last step after which some contact overlapped beyond the depth limit
    last_unheld: int = -1    # ... overlapped or had a gap beyond it
    last_moving: int = -1    # ... moved at or above the settled limit
    steps: int = 0

    def error(self) -> dict[str, Any]:
        """``rms`` and ``max`` (m/s) over every step measured, the ``worst_step`` (0-based), and how many
        ``steps`` were measured (all, or those before the run was crushed)."""
        if self.values == 0:
            return {"rms": None, "max": None, "worst_step": None, "steps": 0}
        worst_step = self.worst_step if self.worst != 0.0 else None  # no step is worst where none differs
        return {"rms": float(np.sqrt(self.sumsq / self.values)), "max": self.worst, "worst_step": worst_step,
                "steps": self.measured}

    def timeline(self) -> dict[str, int | None]:
        """``steps_to_recover`` and ``steps_to_settle``: None when the last step did not get there."""
        last = self.steps - 1
        recover = None if self.last_overlap == last else self.last_overlap + 1
        settle_at = max(self.last_unheld, self.last_moving)
        return {"steps_to_recover": recover, "steps_to_settle": None if settle_at == last else settle_at + 1,
                "crushed_at": self.crushed_at}


class StepLog:
    """A ``stackx.runner.StepObserver`` keeping a ``RowLog`` per run name."""

    def __init__(self, criteria: Criteria, reference: Reference | None) -> None:
        self.criteria, self.reference = criteria, reference
        self.rows: dict[str, RowLog] = {}

    def batch(self, runs: list[RunSpec]) -> OnStep:
        logs = [self.rows.setdefault(r.name, RowLog()) for r in runs]
        g = np.array([r.gravity for r in runs], dtype=np.float64)
        dt = np.array([r.dt for r in runs], dtype=np.float64)
        speculative = np.array([float(getattr(r.solver_params, "speculative", 0.0)) for r in runs])
        swept = np.array([bool(getattr(r.solver_params, "swept", False)) for r in runs])
        limit, settle, reach = self.criteria.depth_limit, self.criteria.settle, self.criteria.reach
        reference = self.reference

        def on_step(k: int, y: np.ndarray, v: np.ndarray, after: ColumnState) -> None:
            d = after.depths()
            overlap = d.max(axis=1) > limit
            gap = (-d).max(axis=1) > limit
            motion = np.sqrt(np.mean(((after.y - y) / dt[:, None]) ** 2, axis=1))
            moving = ~(motion < settle)
            diff = None
            if reference is not None:
                exact = np.empty_like(v)
                reference(y, v, after.inv_mass, after.half, g, dt, speculative, swept, exact)
                diff = np.abs(after.v - exact)
            for b, log in enumerate(logs):
                log.steps = k + 1
                if overlap[b]:
                    log.last_overlap = k
                if overlap[b] or gap[b]:
                    log.last_unheld = k
                if moving[b]:
                    log.last_moving = k
                if log.crushed_at is None and not after.reach[b] <= reach:
                    log.crushed_at = k + 1
                if diff is not None and log.crushed_at is None:
                    row = diff[b]
                    log.sumsq += float(np.dot(row, row))
                    log.values += row.shape[0]
                    log.measured += 1
                    top = float(row.max())
                    if log.worst_step is None or not top <= log.worst:
                        log.worst, log.worst_step = top, k

        return on_step
