"""Stepping: turn an experiment's runs into results.

Runs of one experiment with the same model, solver, number of boxes and steps form one batch and are stepped
together (the solver gets one params object per row). The state is recorded before the steps that the
plan's readers ask for (``Plan.frame_steps``: the outputs' frames) and over the model's final measuring
window; between those points the solver advances many steps per call. The model turns the recorded states
into measures. A caller that must see every step (the bench measures each step against a reference solve)
passes a ``StepObserver``: the batch then advances one step per call, and the observer sees the state before
each step and after it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from itertools import groupby
from typing import Any, Protocol

import numpy as np

from stackx import kernel
from stackx.errors import BlowUp, RunError, first_line, listing
from stackx.run.results import ExperimentResult, RunFrames, RunResult
from stackx.config.spec import Plan, RunSpec, record_steps
from stackx.run.watch import Watch, add_finished, snapshot

CHUNK = 500  # most steps per solver call: bounds how often progress is reported and blow-ups are caught

Progress = Callable[[int], None]
OnStep = Callable[[int, Any, Any], None]
"""``(k, before, after)``: step ``k`` of a batch went from the state ``before`` (a copy) to the state ``after``
(before any scene event at ``k + 1``). Called after every step."""


class StepObserver(Protocol):
    """Watches every step of every batch: ``batch(runs, solver)`` gives the callback for the batch of ``runs``
    stepped by ``solver`` (whose state after each step an observer may read, e.g. the impulses it applied)."""

    def batch(self, runs: list[RunSpec], solver: Any) -> OnStep: ...


def _batch_key(run: RunSpec) -> tuple[object, ...]:
    return (run.model.plugin_name, run.solver_cls.plugin_name, run.scene.size(), run.steps, tuple(map(repr, run.scene.events())))


def batches(runs: list[RunSpec]) -> list[list[RunSpec]]:
    """The runs as the runner steps them: one batch per model, solver, size, steps and events, in the order it
    steps them (a batch's rows keep the plan's order)."""
    return [list(group) for _, group in groupby(sorted(runs, key=_batch_key), key=_batch_key)]


def _work(runs: list[RunSpec]) -> int:
    """Box-steps of a batch weighed by its model's ``step_cost``: what decides whether compiling it pays
    (``stackx.kernel.worth_compiling``)."""
    return int(len(runs) * runs[0].scene.size() * runs[0].steps * runs[0].model.step_cost)


def run_experiment(spec: Plan, progress: Progress | None = None,
                   observer: StepObserver | None = None, record: set[int] | None = None) -> ExperimentResult:
    """Step every run of ``spec`` and measure it; ``observer`` sees every step of every batch, and the states
    before the steps in ``record`` are kept beside those the plan's readers ask for (``spec.frame_steps()``)."""
    result = ExperimentResult(spec)
    wanted = spec.frame_steps() | (record or set())
    by_name: dict[str, RunResult] = {}
    try:
        for batch in batches(spec.runs):
            on = kernel.worth_compiling(_work(batch))
            with kernel.compiled(on):
                for r in _run_batch(spec, batch, progress, observer, wanted, on):
                    by_name[r.name] = r
    except BlowUp as exc:
        add_finished(exc.report, by_name, [r.name for r in spec.runs])
        raise
    result.runs = [by_name[r.name] for r in spec.runs]
    return result


def _run_batch(spec: Plan, runs: list[RunSpec], progress: Progress | None,
               observer: StepObserver | None, wanted: set[int], compiled: bool) -> list[RunResult]:
    model = runs[0].model
    state, solver = _setup(spec, runs)
    if compiled:
        _warm_up(state, solver)
    on_step = observer.batch(runs, solver) if observer is not None else None
    watch = Watch(spec.file, [r.name for r in runs], solver, model, runs[0].steps, spec.limits.max_speed)
    watch.start(state)
    steps = runs[0].steps
    events = {e.step: e for e in runs[0].scene.events()}  # same for the whole batch (see _batch_key)
    frames: dict[int, Any] = {}
    wall = 0.0
    done = 0
    for stop in record_steps(runs[0], wanted):
        while done < stop:
            n = min(CHUNK, stop - done)
            watch.save(state)
            if on_step is None:
                t0 = time.perf_counter()
                watch.advance(state, done, n)
                wall += time.perf_counter() - t0
            else:
                for k in range(done, done + n):
                    before = state.copy()
                    t0 = time.perf_counter()
                    watch.advance(state, k, 1)
                    wall += time.perf_counter() - t0
                    on_step(k, before, state)
            watch.check(state, done, n)
            done += n
            if progress:
                progress(n * len(runs))
        if stop in events:
            events[stop].apply(state, solver)
        frames[stop] = state.copy()
    measures = model.measure(frames, steps, np.array([r.dt for r in runs]))
    return [RunResult(run, frames[steps].row(b), RunFrames(frames, b), measures[b], wall / len(runs), compiled)
            for b, run in enumerate(runs)]


def _warm_up(state: Any, solver: Any) -> None:
    """One step of a copy of the batch by a copy of the solver, untimed: compiling the kernels (or loading them
    from the cache) happens here, so the time charged to the runs is stepping alone. A failure is left for
    the real run to report."""
    twin = snapshot(solver)
    if twin is not None:
        try:
            twin.advance(state.copy(), 1)
        except Exception:
            pass


def _setup(spec: Plan, runs: list[RunSpec]) -> tuple[Any, Any]:
    """The batch's initial state and its solver; a scene or solver plugin failing here is named with its file."""
    plugin = runs[0].scene
    try:
        scenes = {id(r.scene): r.scene for r in runs}  # runs with the same scene section share one scene
        starts = {key: scene.build() for key, scene in scenes.items()}
        state = runs[0].model.concat([starts[id(r.scene)] for r in runs])
        plugin = runs[0].solver_cls
        solver = runs[0].solver_cls([r.solver_params for r in runs], np.array([r.gravity for r in runs]),
                                    np.array([r.dt for r in runs]))
    except Exception as exc:
        kind = "scene" if plugin is runs[0].scene else "solver"
        raise RunError(f"{spec.file}: {kind} {plugin.plugin_name!r} ({getattr(plugin, 'plugin_origin', '?')}) "
                       f"failed to set up run(s) {listing([r.name for r in runs])}: {first_line(exc)}") from exc
    return state, solver
