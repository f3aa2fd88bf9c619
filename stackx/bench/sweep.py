"""Run a bench case: every plan's knob values as one batched run per solver, then timings and errors.

The measures come from the batched run (the runner puts the same solver and shape in one batch), watched at
every step by the model's step log (``stackx.bench.step_logs``; the column's: ``stackx.bench.error_column``).
Time per step cannot be split between the rows of a batch, so it is measured apart: short runs of one row from
the scene's start, repeated, the median kept. A batch that blows up is run again row by row, so that one
unstable knob value is a failing record and not a lost solver.

A run whose boxes passed through each other is **crushed**: its criteria are judged (it fails "holds" by
reach), but its depths, heights and errors describe no column, so tables, plots, fronts and winners leave
them out.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from stackx.bench.plan import CASE, Case, SolverPlan
from stackx.bench.step_logs import step_log
from stackx.bench.timing import one_thread, time_run
from stackx.bench.trajectory import SeriesLog, Trajectory
from stackx.bench.criteria import NAMES, judge, passed
from stackx.errors import RunError
from stackx.run.results import RunResult
from stackx.run.runner import run_experiment
from stackx.config.spec import Plan, RunSpec

RUN_MEASURES = ("max_depth", "peak_depth", "reach", "launch", "rms_motion")  # taken from the runner's measures

Progress = Callable[[int], None]


@dataclass
class Record:
    """One run of the bench: a solver at one knob value on one case, measured and judged."""

    case: str
    solver: str
    knob: str | None
    value: int | None
    variant: str
    params: dict[str, Any]
    measures: dict[str, float] = field(default_factory=dict)
    error: dict[str, Any] = field(default_factory=dict)
    criteria: dict[str, Any] = field(default_factory=dict)
    passed: bool = False
    blew_up: str | None = None
    crushed_at: int | None = None
    us_per_step: float | None = None
    us_per_call: float | None = None
    timing: dict[str, Any] = field(default_factory=dict)
    reference: bool = False  # the model's reference solver: its error is zero by definition
    series: Trajectory | None = field(default=None, repr=False)  # against time, for the report (not in as_dict)
    final: Any = field(default=None, repr=False)  # the final state (a batch of one), for the report's pictures

    @property
    def crushed(self) -> bool:
        """Boxes passed through each other: the run's figures describe no column."""
        return self.crushed_at is not None

    @property
    def broke(self) -> bool:
        """Blew up or was crushed: no figure of it is worth comparing."""
        return self.blew_up is not None or self.crushed

    def as_dict(self) -> dict[str, Any]:
        """The record as ``bench.json`` keeps it: every field but the series (the report's file keeps the
        series of the runs it shows) and the final state."""
        doc = dataclasses.asdict(dataclasses.replace(self, series=None, final=None))
        del doc["series"], doc["final"]
        return {**doc, "crushed": self.crushed}


def _run_name(plan: SolverPlan, variant: str, value: int) -> str:
    return f"{plan.solver}/{variant}/{value}"


def _measure(case: Case, plan: SolverPlan, variant: str, value: int, result: RunResult, log: Any,
             series: Trajectory | None) -> Record:
    """A finished run's record: its measures, the model's for the bench, the step log's (``log`` is the
    row's log, None when the model has no reference to measure against) and its ``series`` against time."""
    rec = _record(case, plan, variant, value)
    m = result.measures
    rec.measures = {k: float(m[k]) for k in RUN_MEASURES}  # type: ignore[arg-type]
    rec.measures.update(result.spec.model.bench_measures(result, case.section.claim is not None))
    if log is not None:
        rec.measures.update(log.timeline())
        rec.crushed_at = log.crushed_at
        rec.error = log.error()
    rec.series = series if rec.crushed_at is None or series is None else series.until(rec.crushed_at)
    rec.final = result.final
    verdicts = judge(rec.measures, case.section.criteria, case.run.model.unjudged(case.run))
    rec.criteria = {name: v.as_dict() for name, v in verdicts.items()}
    rec.passed = passed(verdicts)
    return rec


def _record(case: Case, plan: SolverPlan, variant: str, value: int) -> Record:
    params = plan.params[variant][value].model_dump(mode="json")
    return Record(case.name, plan.solver, plan.knob, value if plan.knob else None, variant, params,
                  reference=plan.solver == case.run.model.reference)


def _blown(case: Case, plan: SolverPlan, variant: str, value: int, message: str) -> Record:
    rec = _record(case, plan, variant, value)
    rec.blew_up = message
    rec.criteria = {name: {"passed": False, "failing": "blew up", "checks": []} for name in NAMES}
    return rec


def _runs(case: Case, plan: SolverPlan) -> list[tuple[str, int, RunSpec]]:
    base = case.run
    return [(variant, value, dataclasses.replace(base, name=_run_name(plan, variant, value),
                                                 solver_cls=plan.solver_cls, solver_params=params, overrides={}))
            for variant, by_value in plan.params.items() for value, params in by_value.items()]


def run_plan(case: Case, plan: SolverPlan, progress: Progress | None = None) -> list[Record]:
    """Every run of one solver on a case, measured; a blow-up is retried alone to find which rows blew up."""
    # a claim about bouncing is judged on every step's state (see top_motion)
    record = set(range(case.run.steps + 1)) if case.section.claim is not None else None
    runs = _runs(case, plan)

    whole = case.spec

    def run(specs: list[RunSpec], log: Any, report: Progress | None) -> dict[str, RunResult]:
        experiment = Plan(whole.file, whole.name, whole.description, specs, whole.limits)
        return {r.name: r for r in run_experiment(experiment, report, log, record).runs}

    log = step_log(case.run.model, case.section.criteria)
    watched = SeriesLog(log)  # the step log, if the model has one, and the series against time
    try:
        results = run([r for _, _, r in runs], watched, progress)
    except RunError:
        results = {}
    out = []
    for variant, value, spec in runs:
        result = results.get(spec.name)
        if result is None:
            try:
                result = run([spec], watched, None)[spec.name]
            except RunError as exc:
                out.append(_blown(case, plan, variant, value, str(exc)))
                continue
        row_log = log.rows[spec.name] if log is not None else None
        out.append(_measure(case, plan, variant, value, result, row_log, watched.series(spec.name)))
    return out


def time_plan(case: Case, plan: SolverPlan, records: list[Record]) -> None:
    """Fill ``us_per_step`` and ``us_per_call`` of a plan's records (a baseline row costs what its case row
    costs)."""
    by_value = {value: run for variant, value, run in _runs(case, plan) if variant == CASE}
    for value, run in by_value.items():
        timing = time_run(run, case.section.timing)
        for rec in records:
            if (rec.value if rec.knob else 0) == value:
                rec.us_per_step = timing["us_per_step"]
                rec.us_per_call = timing["us_per_call"]
                rec.timing = timing


def bench_plan(case: Case, plan: SolverPlan, progress: Progress | None = None) -> list[Record]:
    """One solver on a case: measured, judged and timed, on one thread (see ``one_thread``). The bench's unit of
    work: an executor may run each on another machine (``stackx.run.executor``)."""
    with one_thread():
        found = run_plan(case, plan, progress)
        time_plan(case, plan, found)
    return found


def plan_work(case: Case, plan: SolverPlan) -> int:
    """Steps the measured runs of one solver on a case take (box-steps are not counted: for a progress bar)."""
    return sum(case.run.steps * len(by_value) for by_value in plan.params.values())


def work(case: Case) -> int:
    """Steps the measured runs of a case take."""
    return sum(plan_work(case, plan) for plan in case.plans)
