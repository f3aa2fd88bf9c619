"""An experiment's runs in chunks that step apart (on Dask workers), and their results put back together.

A chunk is consecutive rows of one of the runner's batches (runs with the same model, solver, size, steps and
events), so a worker steps it as the runner would step its batch, and every row comes out with the same
numbers: rows of a batch never depend on one another (``tests/speed`` holds the runner to that). A worker runs
``run_chunk``, which calls ``run_experiment`` on a plan holding only the chunk's runs, and sends back what the
experiment's readers need: each row's measures, its share of the chunk's stepping time and whether it stepped
compiled, and the batch's states before the steps its outputs draw and at the end (the states kept only to
measure, such as the motion window, stay on the worker).

The client merges the chunks' results in the plan's order (``merge``), so outputs, manifest and every
artifact are those of a local run. A chunk that fails sends its error instead; ``failure`` turns the
failures into the error a local run raises: the first batch (in the runner's order) that failed, its first
bad step over all its chunks and, at that step, its first bad row, so the message names the same step, run,
box and solver. For a blow-up, the failed-run report holds every row of that batch in the last good state,
as a local run's does: rows of chunks that did not fail at that step are stepped again to it
(``states_at``), as ordinary tasks.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from stackx.errors import BlowUp, RunError, StackxError, listing
from stackx.run.results import OWN, SHARE, ExperimentResult, RunFrames, RunResult
from stackx.run.runner import batches, plain_note, planned_work, run_experiment
from stackx.config.sizing import run_bytes
from stackx.config.spec import Plan, RunSpec
from stackx.run.watch import add_finished, stopped

TASKS_PER_THREAD = 4  # chunks per worker thread a batch is cut into: a slow chunk at the end delays less
CHUNK_BYTES = 256 * 2**20  # the most a chunk's recorded states take on a worker (the whole motion window)


@dataclass
class Chunk:
    """Rows ``first``.. of batch ``batch`` of an experiment, as a plan of their own; ``frames`` the steps
    whose states the experiment's outputs draw; ``share`` the part of its batch's work the chunk holds, so
    that a worker decides whether to compile on the whole batch, as a local run does (a sweep cut into
    chunks of two rows would otherwise step every chunk plain, at many times the CPU)."""

    plan: Plan
    batch: int
    first: int
    frames: frozenset[int]
    share: float = 1.0

    @property
    def names(self) -> list[str]:
        return [r.name for r in self.plan.runs]

    @property
    def weight(self) -> int:
        """Steps of its runs, as the local progress bar counts them."""
        return sum(r.steps for r in self.plan.runs)


@dataclass
class Stepped:
    """A chunk that ran: each row's measures, the batch's states kept for the outputs, each row's stepping time
    and contact visits (``stackx.run.results.RunResult``), and whether it stepped compiled."""

    measures: list[dict[str, Any]]
    frames: dict[int, Any]
    wall_seconds: list[float]
    work: list[float]
    compiled: bool


@dataclass
class Failed:
    """A chunk that stopped: its error, the failed-run report of a blow-up, and its step (None when the error
    does not say, as when a plugin raises)."""

    message: str
    report: dict[str, Any] | None
    step: int | None


def chunk_rows(groups: list[list[RunSpec]], wanted: set[int], threads: int) -> int:
    """Rows per chunk of the batches ``groups``: about ``TASKS_PER_THREAD`` chunks per worker thread for the
    largest batch, and no more rows than ``CHUNK_BYTES`` of recorded states allow (``wanted``: the steps the
    outputs draw). A batch's rows share steps, size and events, so its first row sizes them all."""
    largest = max((len(g) for g in groups), default=1)
    spread = math.ceil(largest / (TASKS_PER_THREAD * max(1, threads)))
    fits = CHUNK_BYTES // max([1, *(run_bytes(g[0], wanted) for g in groups)])
    return max(1, min(spread, fits))


def split(plan: Plan, rows: int | None = None, threads: int = 1) -> list[Chunk]:
    """The plan's batches cut into chunks of at most ``rows`` runs (None: ``chunk_rows`` for ``threads``
    worker threads), in the runner's order."""
    frames = frozenset(plan.frame_steps())
    groups = batches(plan.runs)
    size = rows or chunk_rows(groups, set(frames), threads)
    parts = []
    for b, group in enumerate(groups):
        whole = planned_work(group)
        for first in range(0, len(group), size):
            rows = group[first:first + size]
            share = planned_work(rows) / whole if whole > 0 else 1.0
            parts.append(Chunk(Plan(plan.file, plan.name, plan.description, rows, plan.limits), b, first, frames,
                               share))
    return parts


def run_chunk(chunk: Chunk) -> Stepped | Failed:
    """Step a chunk (on a worker) and keep what the client needs; a failure is sent back, not raised, so that
    Dask retries only what may go better elsewhere (a worker dying, a machine out of memory)."""
    try:
        result = run_experiment(chunk.plan, record=set(chunk.frames), share=chunk.share)
    except BlowUp as exc:
        return Failed(str(exc), exc.report, exc.report.get("step"))  # type: ignore[arg-type]
    except StackxError as exc:
        return Failed(str(exc), None, None)
    first = result.runs[0]
    steps = first.spec.steps
    kept = {k: s for k, s in first.frames.batch.items() if k in chunk.frames or k == steps}  # type: ignore[attr-defined]
    return Stepped([r.measures for r in result.runs], kept, [r.wall_seconds for r in result.runs],
                   [r.work for r in result.runs], first.compiled)


def merge(plan: Plan, chunks: Sequence[Chunk], outcomes: Sequence[Stepped]) -> ExperimentResult:
    """The experiment's result from its chunks' (all stepped), its runs in the plan's order, with a note for
    each batch that stepped plain far longer than compiling would have taken (over all its chunks)."""
    by_name: dict[str, RunResult] = {}
    by_batch: dict[int, list[RunResult]] = {}
    for chunk, got in zip(chunks, outcomes):
        rows = _results(chunk, got)
        by_name.update(rows)
        by_batch.setdefault(chunk.batch, []).extend(rows.values())
    notes = [note for b in sorted(by_batch) if (note := plain_note(plan.file, by_batch[b]))]
    return ExperimentResult(plan, [by_name[r.name] for r in plan.runs], notes)


def _results(chunk: Chunk, got: Stepped) -> dict[str, RunResult]:
    """Each row of a stepped chunk as a run's result: its own share of the chunk's time (its own time when it
    is the chunk's only row)."""
    runs = chunk.plan.runs
    final = got.frames[runs[0].steps]
    timed = OWN if len(runs) == 1 else SHARE
    return {run.name: RunResult(run, final.row(b), RunFrames(got.frames, b), got.measures[b], got.wall_seconds[b],
                                got.compiled, timed, got.work[b])
            for b, run in enumerate(runs)}


Rerun = Callable[[list[tuple[Chunk, int]]], list[list[dict[str, Any]]]]
"""Steps chunks again to a step: ``[(chunk, step)]`` -> per chunk, per row, what ``states_at`` gives."""


def _first_failing_batch(chunks: Sequence[Chunk], outcomes: dict[int, Stepped | Failed]) -> int | None:
    """The batch (by index) a local run would fail in: the first with a failed chunk among those known."""
    failed = [chunks[i].batch for i, got in outcomes.items() if isinstance(got, Failed)]
    return min(failed) if failed else None


def failure(plan: Plan, chunks: Sequence[Chunk], outcomes: dict[int, Stepped | Failed], rerun: Rerun) -> RunError:
    """The error a local run of ``plan`` raises, from its chunks' outcomes: those of every chunk of the first
    failing batch and of the batches before it must be in ``outcomes``."""
    bad = _first_failing_batch(chunks, outcomes)
    assert bad is not None
    mine = [i for i, c in enumerate(chunks) if c.batch == bad]
    failed = {i: got for i in mine if isinstance(got := outcomes[i], Failed)}
    # the first bad step of the batch (an error that names none, such as a plugin raising, comes first); then the
    # first row, which is in the first chunk failing at that step (the model names a batch's first bad row)
    first = min(failed, key=lambda i: (-1 if failed[i].step is None else failed[i].step, i))
    got = failed[first]
    batch_names = [name for i in mine for name in chunks[i].names]
    if got.report is None or got.step is None:
        message = got.message.replace(listing(chunks[first].names), listing(batch_names), 1)
        if got.report is None:
            return RunError(message)
        return BlowUp(message, got.report)  # a solver that did not repeat its blow-up: its chunk's report
    report = _whole_report(plan, chunks, outcomes, mine, failed, got, rerun)
    return BlowUp(got.message, report)


def _whole_report(plan: Plan, chunks: Sequence[Chunk], outcomes: dict[int, Stepped | Failed], mine: list[int],
                  failed: dict[int, Failed], got: Failed, rerun: Rerun) -> dict[str, Any]:
    """The failed-run report of the whole batch: every row at the last good step, as a local run writes it."""
    assert got.report is not None and got.step is not None
    step, culprit = got.step, got.report["run"]
    good = got.report["runs"][culprit]["steps_done"]
    again = [i for i in mine if not (i in failed and failed[i].step == step)]
    redone = dict(zip(again, rerun([(chunks[i], step) for i in again]))) if again else {}
    rows: dict[str, Any] = {}
    for i in mine:
        names = chunks[i].names
        seen = redone[i] if i in redone else [failed[i].report["runs"][n] for n in names]  # type: ignore[index]
        for name, row in zip(names, seen):
            status = "blew up" if name == culprit else "stopped with its batch"
            rows[name] = {"status": status, "steps_done": good, "measures": row["measures"],
                          "after_failing_step": row["after_failing_step"]}
    report = {**got.report, "runs": rows}
    finished: dict[str, RunResult] = {}
    for i, outcome in outcomes.items():
        if chunks[i].batch < chunks[mine[0]].batch and isinstance(outcome, Stepped):
            finished.update(_results(chunks[i], outcome))
    add_finished(report, finished, [r.name for r in plan.runs])
    return report


def states_at(chunk: Chunk, step: int) -> list[dict[str, Any]]:
    """Step a chunk again (on a worker) up to step ``step`` and say of each row what a failed-run report says:
    its measures after ``step - 1`` steps and its motion after ``step`` (before any scene event there, as the
    runner checks a state)."""
    runs = chunk.plan.runs
    model = runs[0].model
    if step == 0:  # the batch was refused before its first step: every row as it starts
        good = bad = model.concat([r.scene.build() for r in runs])
    else:
        watch = _Catch(step - 1)
        short = dataclasses.replace(chunk.plan, runs=[dataclasses.replace(r, steps=step) for r in runs])
        run_experiment(short, observer=watch)
        good, bad = watch.before, watch.after
    return [stopped(model, "stopped with its batch", max(0, step - 1), good, bad, b) for b in range(len(runs))]


class _Catch:
    """A step observer that keeps the states before and after step ``k`` (0-based) of the batch it watches."""

    def __init__(self, k: int) -> None:
        self.k = k
        self.before: Any = None
        self.after: Any = None

    def batch(self, runs: list[RunSpec], solver: Any = None) -> Callable[[int, Any, Any], None]:
        def seen(k: int, before: Any, after: Any) -> None:
            if k == self.k:
                self.before, self.after = before, after.copy()
        return seen
