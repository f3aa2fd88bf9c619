"""What a bench report draws against time: the height of the top box and the largest contact depth.

The series come from the runs the bench does anyway, watched by the step observer that already sees every
step (the model's step log, which compares each with the exact solve): ``SeriesLog`` wraps it and, after
``SAMPLES`` evenly spaced steps, reads every row of the batch at once, a few numpy operations on the state
the observer is handed. Nothing is copied or stepped differently, so no number changes and the bench takes
no noticeably longer. The heights and depths are read from the state's ``y`` (heights, bottom first) and
``penetration()`` (contact depths), which the column's state has; a model whose state has not, or that has no
step log, gets no such plot.

A sample is the state after its step, before any scene event at the next one (the top box about to be
taken away is still drawn). A crushed run is drawn up to the state before it was crushed (its later heights
describe no column); a run that blew up has no series.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from stackx.runner import OnStep, StepObserver
from stackx.spec import RunSpec

SAMPLES = 200  # points per run: enough for a smooth line at a report's width


def sample_steps(steps: int) -> set[int]:
    """The steps whose state is sampled (the state before that step, after the one before it):
    ``SAMPLES`` + 1 evenly spaced from 0 to ``steps``, both ends included (every step of a shorter run)."""
    n = min(SAMPLES, steps)
    return {steps * i // n for i in range(n + 1)}


@dataclass
class Trajectory:
    """One run's series: at each sampled ``step`` (time ``step * dt``), the ``top`` box's height (m) and the
    largest contact ``depth`` (m)."""

    dt: float
    steps: list[int]
    top: list[float]
    depth: list[float]

    def times(self) -> list[float]:
        return [k * self.dt for k in self.steps]

    def as_dict(self) -> dict[str, Any]:
        return {"dt": self.dt, "steps": self.steps, "top": self.top, "max_depth": self.depth}

    def until(self, step: int) -> Trajectory:
        """The samples before ``step`` (a crushed run's, before the step it was crushed at)."""
        n = sum(1 for k in self.steps if k < step)
        return Trajectory(self.dt, self.steps[:n], self.top[:n], self.depth[:n])


@dataclass
class _Batch:
    """The samples of one batch: per sampled step, every row's top height and largest depth."""

    dt: np.ndarray
    steps: list[int]
    top: list[np.ndarray]
    depth: list[np.ndarray]
    readable: bool = True


class SeriesLog:
    """A ``stackx.runner.StepObserver`` that passes every step on to ``inner`` (the model's step log) and
    samples each batch's rows; ``series(name, crushed_at)`` gives a run's ``Trajectory``."""

    def __init__(self, inner: StepObserver) -> None:
        self.inner = inner
        self.rows: dict[str, tuple[_Batch, int]] = {}

    def batch(self, runs: list[RunSpec]) -> OnStep:
        inner = self.inner.batch(runs)
        kept = sample_steps(runs[0].steps)
        found = _Batch(np.array([r.dt for r in runs]), [], [], [])
        self.rows.update((r.name, (found, b)) for b, r in enumerate(runs))

        def sample(k: int, state: Any) -> None:
            if not (hasattr(state, "y") and hasattr(state, "penetration")):
                found.readable = False
                return
            found.steps.append(k)
            found.top.append(state.y[:, -1].copy())
            found.depth.append(state.penetration().max(axis=1))

        def on_step(k: int, before: Any, after: Any) -> None:
            inner(k, before, after)
            if k == 0 and 0 in kept:
                sample(0, before)
            if k + 1 in kept and found.readable:
                sample(k + 1, after)

        return on_step

    def series(self, name: str) -> Trajectory | None:
        """Run ``name``'s samples; None when its state had no heights and depths to read."""
        found, row = self.rows[name]
        if not found.readable:
            return None
        return Trajectory(float(found.dt[row]), list(found.steps), [float(t[row]) for t in found.top],
                          [float(d[row]) for d in found.depth])
