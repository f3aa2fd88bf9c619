"""Stepping: turn an experiment's runs into results.

Runs of one experiment with the same model, solver, number of boxes and steps form one batch and are stepped
together (the solver gets one params object per row). The state is recorded before the steps that the
plan's readers ask for (``Plan.frame_steps``: the outputs' frames) and over the model's final measuring
window; between those points the solver advances many steps per call. The model turns the recorded states
into measures. A caller that must see every step (the bench measures each step against a reference solve)
passes a ``StepObserver``: the batch then advances one step per call, and the observer sees the state before
each step and after it.

Before a batch steps, a copy of its solver steps a copy of the batch once, untimed (``stackx.run.monitored``):
kernels compile there, so the time charged to the runs is stepping alone, and a solver that does not update
the model's monitors after every step (its ``observe``) is refused with one line naming its file.

Time. Rows of a batch step in one call, so no row's own time can be read off the clock. After every stretch of
steps the runner asks the solver what each row did (``Solver.step_work``: contact visits, passes times
contacts) and shares the stretch's time out in proportion: a row making 256 passes a step is charged 64 times
the time of one making 4, and the shares add up to the batch's time. A run stepped alone (a batch of one row)
is charged its own time. The same counted work decides whether the batch steps compiled
(``stackx.kernel.worth_compiling``).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from itertools import groupby
from typing import Any, Protocol

import numpy as np

from stackx import kernel
from stackx.errors import BlowUp, RunError, first_line, listing
from stackx.run.results import OWN, SHARE, ExperimentResult, RunFrames, RunResult
from stackx.config.spec import Plan, RunSpec, record_steps
from stackx.run import monitored
from stackx.run.watch import Watch, add_finished, snapshot

CHUNK = 500  # most steps per solver call: bounds how often progress is reported and blow-ups are caught
CLOCK = time.perf_counter  # the stepping clock, read through this name (a test makes each stretch a fixed time)

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


def weighed(visits: float, runs: list[RunSpec]) -> float:
    """Contact visits of rows of one batch as the work ``STACKX_JIT_WORK`` counts: box-steps at the solver's
    default passes (``Solver.default_passes``), times the model's ``step_cost``. A row making 40 times the
    passes of the solver's defaults is 40 times the work; a planar body-step costs a hundred column ones."""
    if not runs:
        return 0.0
    return visits * runs[0].model.step_cost / (runs[0].solver_cls.default_passes() + 1)


def planned_work(runs: list[RunSpec]) -> float:
    """The work of ``runs`` (rows of one batch, ``weighed``) as their specs give it, before a solver exists:
    steps x bodies x (``passes`` + 1) contact visits per run, as ``Solver.step_work`` counts by default. A
    chunk's part of its batch is measured with it."""
    visits = sum(r.steps * r.scene.size() * (r.solver_cls.passes(r.solver_params) + 1) for r in runs)
    return weighed(float(visits), runs)


def run_experiment(spec: Plan, progress: Progress | None = None, observer: StepObserver | None = None,
                   record: set[int] | None = None, share: float = 1.0) -> ExperimentResult:
    """Step every run of ``spec`` and measure it; ``observer`` sees every step of every batch, and the states
    before the steps in ``record`` are kept beside those the plan's readers ask for (``spec.frame_steps()``).
    ``share``: the part of its batch's work that ``spec`` holds (a Dask chunk's rows), so that whether to
    compile is decided on the whole batch, as a local run decides it."""
    result = ExperimentResult(spec)
    wanted = spec.frame_steps() | (record or set())
    by_name: dict[str, RunResult] = {}
    try:
        for batch in batches(spec.runs):
            stepped = _run_batch(spec, batch, progress, observer, wanted, share)
            by_name.update((r.name, r) for r in stepped)
            note = plain_note(spec.file, stepped)
            if note:
                result.notes.append(note)
    except BlowUp as exc:
        add_finished(exc.report, by_name, [r.name for r in spec.runs])
        raise
    result.runs = [by_name[r.name] for r in spec.runs]
    return result


def plain_note(file: str, runs: list[RunResult]) -> str | None:
    """One line for a batch that ``auto`` left plain and that stepped long enough for compiling to have been
    far faster (``stackx.kernel.regrets_plain``), naming the switch; None for any other batch."""
    seconds = sum(r.wall_seconds for r in runs)
    if not runs or any(r.compiled for r in runs) or not kernel.regrets_plain(seconds):
        return None
    names = [r.name for r in runs]
    which = repr(names[0]) if len(names) == 1 else f"{len(names)} runs ({names[0]!r}..{names[-1]!r})"
    solver = runs[0].spec.solver_cls.plugin_name
    work = weighed(sum(r.work for r in runs), [r.spec for r in runs])
    return (f"note: {file}: {which} stepped {seconds:.0f} s as plain Python, where compiled stepping is some "
            f"100 times faster: set STACKX_JIT=1 (auto judged the batch small: solver {solver!r} counted "
            f"{work:,.0f} box-steps of work, under STACKX_JIT_WORK={kernel.min_work():,})")


def tell(notes: list[str]) -> None:
    """An experiment's notes on how it stepped (``ExperimentResult.notes``), a line each on standard error, as
    the executor hands its result over: a progress bar drawn there keeps below them."""
    for note in notes:
        sys.stderr.write(note + "\n")
    sys.stderr.flush()


def row_work(spec: Plan, solver: Any, state: Any, bodies: int) -> np.ndarray:
    """Each row's contact visits per step, as the solver counts them (``Solver.step_work``), checked: a solver
    plugin whose count fails or is not one number >= 0 per row is named with its file."""
    where = f"{spec.file}: solver {solver.plugin_name!r} ({getattr(solver, 'plugin_origin', '?')})"
    try:
        work = np.asarray(solver.step_work(state, bodies), dtype=np.float64)
    except Exception as exc:
        raise RunError(f"{where}: step_work failed: {first_line(exc)}") from exc
    if work.shape != (state.batch,) or not np.all(np.isfinite(work)) or np.any(work < 0):
        raise RunError(f"{where}: step_work must give one finite number >= 0 per batch row, shape "
                       f"({state.batch},); it gave shape {work.shape}")
    return work


def _compiles(spec: Plan, runs: list[RunSpec], state: Any, solver: Any, share: float) -> bool:
    """Whether a batch steps compiled: ``kernel.worth_compiling`` on the work of its whole batch (``weighed``
    contact visits; ``share``: the part of the batch these rows are). When that says plain under ``auto``, a copy of the solver
    steps a copy of the batch once, plain and untimed, and is asked again: a solver may set its passes only
    when it steps (the README's ``pgs-tall`` raises its iterations in ``advance``). The copy's step costs a
    step of a batch judged small, and a plain run this way never imports numba."""
    bodies, steps = runs[0].scene.size(), runs[0].steps

    def whole(stepper: Any) -> float:
        return weighed(float(row_work(spec, stepper, state, bodies).sum()) * steps, runs) / max(share, 1e-12)

    if kernel.worth_compiling(whole(solver)):
        return True
    if kernel.mode() != kernel.AUTO or steps < 2:
        return False
    twin = snapshot(solver)
    if twin is None:
        return False
    try:
        with kernel.compiled(False):
            twin.advance(state.copy(), 1)
        return kernel.worth_compiling(whole(twin))
    except Exception:  # a solver that fails is reported by the real run
        return False


def _shares(seconds: float, work: np.ndarray) -> np.ndarray:
    """``seconds`` of a stretch of a batch shared out by the work each row did in it (evenly when none)."""
    total = float(work.sum())
    if total > 0:
        return seconds * work / total
    return np.full(len(work), seconds / len(work))


def _run_batch(spec: Plan, runs: list[RunSpec], progress: Progress | None,
               observer: StepObserver | None, wanted: set[int], share: float) -> list[RunResult]:
    with kernel.compiled(kernel.worth_compiling(planned_work(runs) / max(share, 1e-12))):
        state, solver = _setup(spec, runs)  # kernels a solver calls to set up take the path its specs point to
    compiled = _compiles(spec, runs, state, solver, share)
    with kernel.compiled(compiled):
        return _step_batch(spec, runs, state, solver, progress, observer, wanted, compiled)


def _step_batch(spec: Plan, runs: list[RunSpec], state: Any, solver: Any, progress: Progress | None,
                observer: StepObserver | None, wanted: set[int], compiled: bool) -> list[RunResult]:
    """Step a set-up batch to its end, recording the states ``wanted`` and charging each row its time."""
    model = runs[0].model
    names = [r.name for r in runs]
    steps, bodies = runs[0].steps, runs[0].scene.size()
    unchecked = state.copy() if steps > 0 and not monitored.first_step(spec.file, names, state, solver) else None
    on_step = observer.batch(runs, solver) if observer is not None else None
    watch = Watch(spec.file, names, solver, model, steps, spec.limits.max_speed)
    watch.start(state)
    events = {e.step: e for e in runs[0].scene.events()}  # same for the whole batch (see _batch_key)
    frames: dict[int, Any] = {}
    charged = np.zeros(len(runs))
    visits = np.zeros(len(runs))
    done = 0
    for stop in record_steps(runs[0], wanted):
        while done < stop:
            n = min(CHUNK, stop - done)
            watch.save(state)
            seconds = 0.0
            if on_step is None:
                t0 = CLOCK()
                watch.advance(state, done, n)
                seconds = CLOCK() - t0
            else:
                for k in range(done, done + n):
                    before = state.copy()
                    t0 = CLOCK()
                    watch.advance(state, k, 1)
                    seconds += CLOCK() - t0
                    on_step(k, before, state)
            watch.check(state, done, n)
            if unchecked is not None:  # a solver that could not be copied: its first real call is checked
                monitored.observed(spec.file, names, solver, unchecked, state)
                unchecked = None
            work = row_work(spec, solver, state, bodies) * n
            charged += _shares(seconds, work)
            visits += work
            done += n
            if progress:
                progress(n * len(runs))
        if stop in events:
            events[stop].apply(state, solver)
        frames[stop] = state.copy()
    measures = model.measure(frames, steps, np.array([r.dt for r in runs]))
    timed = OWN if len(runs) == 1 else SHARE
    return [RunResult(run, frames[steps].row(b), RunFrames(frames, b), measures[b], float(charged[b]), compiled,
                      timed, float(visits[b]))
            for b, run in enumerate(runs)]


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
