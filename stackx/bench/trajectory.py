"""What a bench report draws against time: the height of the top box and the largest contact depth, and on
planar scenes the drift of the boxes placed at rest (sideways and turned).

The series come from the runs the bench does anyway, watched by the step observer that already sees every
step (the model's step log, which compares each with the exact solve): ``SeriesLog`` wraps it and, after
``SAMPLES`` evenly spaced steps, reads every row of the batch at once, a few numpy operations on the state
the observer is handed. Nothing is copied or stepped differently, so no number changes and the bench takes
no noticeably longer. A column's heights and depths are read from the state's ``y`` (heights, bottom first)
and ``penetration()`` (contact depths), as from any model's state that has them; a planar world's through
``stackx.models.planar.figures``: the height of the pile's top box where the scene names one (``rest_top``),
else of the highest box; the deepest contact by the model's collision test; and the drift of the boxes the
scene places at rest (``rests``) from where the scene built them, as the criteria measure it at the end. A
model whose state gives none of these gets no such plot; one without a step log is still watched, for these
series alone.

A sample is the state after its step, before any scene event at the next one (the top box about to be
taken away is still drawn). A crushed run is drawn up to the state before it was crushed (its later heights
describe no column); a run that blew up has no series.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from stackx.run.runner import OnStep, StepObserver
from stackx.config.spec import RunSpec

SAMPLES = 200  # points per run: enough for a smooth line at a report's width


def sample_steps(steps: int) -> set[int]:
    """The steps whose state is sampled (the state before that step, after the one before it):
    ``SAMPLES`` + 1 evenly spaced from 0 to ``steps``, both ends included (every step of a shorter run)."""
    n = min(SAMPLES, steps)
    return {steps * i // n for i in range(n + 1)}


@dataclass
class Trajectory:
    """One run's series: at each sampled ``step`` (time ``step * dt``), the ``top`` box's height (m) and the
    largest contact ``depth`` (m); on planar scenes with boxes placed at rest, their largest sideways
    ``drift_x`` (m) and turn ``drift_angle`` (rad) since the start."""

    dt: float
    steps: list[int]
    top: list[float]
    depth: list[float]
    drift_x: list[float] | None = None
    drift_angle: list[float] | None = None

    def times(self) -> list[float]:
        return [k * self.dt for k in self.steps]

    def as_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"dt": self.dt, "steps": self.steps, "top": self.top, "max_depth": self.depth}
        if self.drift_x is not None:
            out.update(drift_x=self.drift_x, drift_angle=self.drift_angle)
        return out

    def until(self, step: int) -> Trajectory:
        """The samples before ``step`` (a crushed run's, before the step it was crushed at)."""
        n = sum(1 for k in self.steps if k < step)
        cut = (lambda v: None if v is None else v[:n])  # noqa: E731
        return Trajectory(self.dt, self.steps[:n], self.top[:n], self.depth[:n], cut(self.drift_x),
                          cut(self.drift_angle))


Figures = dict[str, np.ndarray]  # "top", "depth" and optionally "drift_x", "drift_angle": one value per row
Reader = Callable[[Any], Figures | None]  # a batch's state -> its figures, None when it has none


def column_reader(state: Any) -> Figures | None:
    """The top box's height and the deepest contact of a state with ``y`` (bottom first) and ``penetration()``."""
    if not (hasattr(state, "y") and hasattr(state, "penetration")):
        return None
    return {"top": state.y[:, -1].copy(), "depth": state.penetration().max(axis=1)}


def planar_reader(runs: list[RunSpec]) -> Reader:
    """The figures of a planar batch whose rows are ``runs``: each row's scene says which box is the pile's
    top (``rest_top``), which boxes should rest (``rests``) and where they started (``build``); a scene that
    does not say gets the highest box and no drift."""
    from stackx.models.planar import figures

    scenes = [r.scene for r in runs]
    built = {id(s): s.build() for s in scenes}
    start = runs[0].model.concat([built[id(s)] for s in scenes])
    top = np.array([(getattr(s, "rest_top", lambda: None)() or (-1,))[0] for s in scenes])
    rests = np.zeros(start.x.shape, dtype=bool)
    for b, scene in enumerate(scenes):  # a scene plugin of another author may not say which boxes rest
        rests[b, getattr(scene, "rests", list)()] = True
    placed = bool(rests.any())

    def read(state: Any) -> Figures:
        found = {"top": figures.top_height(state, top), "depth": figures.deepest(state)}
        if placed:
            found["drift_x"], found["drift_angle"] = figures.drift(state, start, rests)
        return found

    return read


def reader(runs: list[RunSpec]) -> Reader:
    """How the states of a batch of ``runs`` are read: by the model they are worlds of."""
    if runs[0].scene.model == "planar":
        return planar_reader(runs)
    return column_reader


@dataclass
class _Batch:
    """The samples of one batch: per sampled step, every row's figures."""

    dt: np.ndarray
    steps: list[int] = field(default_factory=list)
    found: list[Figures] = field(default_factory=list)
    readable: bool = True


class SeriesLog:
    """A ``stackx.run.runner.StepObserver`` that passes every step on to ``inner`` (the model's step log, if it
    has one) and samples each batch's rows; ``series(name)`` gives a run's ``Trajectory``."""

    def __init__(self, inner: StepObserver | None) -> None:
        self.inner = inner
        self.rows: dict[str, tuple[_Batch, int]] = {}

    def batch(self, runs: list[RunSpec], solver: Any = None) -> OnStep:
        inner = self.inner.batch(runs, solver) if self.inner is not None else None
        kept = sample_steps(runs[0].steps)
        found = _Batch(np.array([r.dt for r in runs]))
        self.rows.update((r.name, (found, b)) for b, r in enumerate(runs))
        read = reader(runs)

        def sample(k: int, state: Any) -> None:
            figures = read(state)
            if figures is None:
                found.readable = False
                return
            found.steps.append(k)
            found.found.append(figures)

        def on_step(k: int, before: Any, after: Any) -> None:
            if inner is not None:
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

        def values(key: str) -> list[float] | None:
            if not found.found or key not in found.found[0]:
                return None
            return [float(f[key][row]) for f in found.found]

        return Trajectory(float(found.dt[row]), list(found.steps), values("top") or [], values("depth") or [],
                          values("drift_x"), values("drift_angle"))
