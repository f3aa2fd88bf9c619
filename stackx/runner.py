"""Stepping: turn an experiment's runs into results.

Runs of one experiment with the same solver and the same number of boxes and steps form one batch and are
stepped together (the solver gets one params object per row). The state is recorded before the steps
that outputs asked for and over the final motion window; between those points the solver advances many
steps per call.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from itertools import groupby

import numpy as np

from stackx.config import ExperimentSpec, RunSpec
from stackx.errors import RunError
from stackx.metrics import measure, motion_steps
from stackx.results import ExperimentResult, RunResult
from stackx.state import ColumnState

CHUNK = 500  # most steps per solver call: bounds how often progress is reported and blow-ups are caught

Progress = Callable[[int], None]


def record_steps(spec: ExperimentSpec, run: RunSpec) -> list[int]:
    """Steps before which the state is kept: what outputs need, the motion window, and the end."""
    wanted = set(motion_steps(run.steps))
    for output in spec.outputs:
        wanted |= output.frame_steps(spec)
    return sorted(k for k in wanted if 0 <= k <= run.steps)


def _batch_key(run: RunSpec) -> tuple[object, ...]:
    return (run.solver_cls.plugin_name, run.scene.size(), run.steps)


def run_experiment(spec: ExperimentSpec, progress: Progress | None = None) -> ExperimentResult:
    """Step every run of ``spec`` and measure it."""
    result = ExperimentResult(spec)
    by_name: dict[str, RunResult] = {}
    ordered = sorted(spec.runs, key=_batch_key)
    for _, group in groupby(ordered, key=_batch_key):
        for r in _run_batch(spec, list(group), progress):
            by_name[r.name] = r
    result.runs = [by_name[r.name] for r in spec.runs]
    return result


def _run_batch(spec: ExperimentSpec, runs: list[RunSpec], progress: Progress | None) -> list[RunResult]:
    state = ColumnState.concat([r.scene.build() for r in runs])
    solver = runs[0].solver_cls([r.solver_params for r in runs], np.array([r.gravity for r in runs]),
                                np.array([r.dt for r in runs]))
    steps = runs[0].steps
    frames: dict[int, ColumnState] = {}
    wall = 0.0
    done = 0
    for stop in record_steps(spec, runs[0]):
        while done < stop:
            n = min(CHUNK, stop - done)
            t0 = time.perf_counter()
            try:
                solver.advance(state, n)
            except Exception as exc:
                raise RunError(f"{spec.file}: solver {solver.plugin_name!r} failed between steps {done} and "
                               f"{done + n}: {type(exc).__name__}: {exc}") from exc
            wall += time.perf_counter() - t0
            _check_finite(spec, runs, state, done, n, solver.plugin_name)
            done += n
            if progress:
                progress(n * len(runs))
        frames[stop] = state.copy()
    out = []
    for b, run in enumerate(runs):
        row = {k: s.row(b) for k, s in frames.items()}
        final = row[steps]
        out.append(RunResult(run, final, row, measure(final, row, steps, run.dt), wall / len(runs)))
    return out


def _check_finite(spec: ExperimentSpec, runs: list[RunSpec], state: ColumnState, done: int, n: int,
                  solver: str) -> None:
    bad = ~(np.isfinite(state.y) & np.isfinite(state.v))
    if bad.any():
        b, box = map(int, np.argwhere(bad)[0])
        raise RunError(f"{spec.file}: run {runs[b].name!r} blew up (NaN or infinity) in box {box} between "
                       f"steps {done} and {done + n}, solver {solver!r}")
