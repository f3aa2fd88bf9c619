"""Comparisons across solvers: the stability matrix, the speed-against-error front, equal-cost winners, and
the run of each solver that a report shows.

Only the case's own settings count here (a claim's baseline runs are compared in ``claims``). Speed and
error are drawn for every run that neither blew up nor was crushed (a run with steps the reference left
unsolved included: its error is measured against the reference's best answer there, and says so), but fronts
and winners are chosen only among runs that **passed** the case: a run that is fast and accurate step by step
yet leaves the column sunk, moving or launched is no answer to the case, and letting it win would recommend a
setting that fails. The reference never competes: ``exact`` is what the error is measured against, so its
error is zero by definition, not by merit (the report shows its time beside the winners instead).

Times are compared with a tolerance: two figures within ``TIE`` of each other are the same cost, since a
timing on a shared machine moves by that much between benches (``stackx.bench.timing``). A run leaves the
front only for one that is at least as accurate and clearly faster, or more accurate and not clearly slower;
an equal-cost winner names the runs tied with it (within ``TIE`` as measured: the margin printed beside it).
The front keeps a run unless another beats it even with both times moved against it by their noise (their
spread, at least ``NOISE``), and marks it ``borderline`` when the noise could go either way, so two benches
agree on the front unless a figure moved beyond its noise; any front or winner that rests on a figure flagged
unstable says so.

Errors are compared beside their uncertainty (``stackx.bench.uncertainty``): two runs whose error intervals
overlap are tied on error and the cheaper beats the other, as runs of equal error do; a run is more accurate
than another only when its interval lies wholly below; an error level is reached when the run's stated error,
``max(rms, spread)``, is at most it. So an error within its spread never wins on a number the measurement
cannot tell from zero, and with every spread 0 the comparison is that of the RMS errors.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from stackx.bench.plan import CASE
from stackx.bench.sweep import Record
from stackx.bench.criteria import word
from stackx.bench.uncertainty import at_least_as_accurate, more_accurate, reaches, spread, stated, unsolved

TARGETS = (1e-1, 1e-2, 1e-3, 1e-4, 1e-6)  # error levels (m/s) at which solvers are compared at equal cost
TIE = 0.2  # times within this share of each other are the same cost
NOISE = 0.05  # the least share by which a time is taken to be uncertain (more where its spread says so)


def clearly_faster(a: float, b: float) -> bool:
    """Whether time ``a`` is below ``b`` by more than the tolerance ``TIE``."""
    return a * (1.0 + TIE) < b


def unstable(rec: Record) -> bool:
    """Whether a record's timing was flagged (``stackx.bench.timing``): too busy a machine to trust it."""
    return bool(rec.timing.get("unstable"))


def label(solver: str, knob: str | None, value: int | None) -> str:
    """``warm-start (iterations 8)``, or the bare name of a solver without a knob."""
    return f"{solver} ({knob} {value})" if knob else solver


def case_records(records: Iterable[Record]) -> list[Record]:
    return [r for r in records if r.variant == CASE]


def failing(rec: Record) -> str:
    """What broke a record's criteria, e.g. ``holds: max_depth 1.42 > 0.02; settled: rms_motion 1.02 >= 1e-04``;
    for a run that blew up, where (the runner's message without the file and run it names)."""
    if rec.blew_up:
        return "blew up: " + rec.blew_up.split(" blew up ", 1)[-1]
    if rec.crushed:
        return f"crushed at step {rec.crushed_at} (boxes passed through each other; its figures are left out)"
    return "; ".join(f"{name}: {v['failing']}" for name, v in rec.criteria.items() if not v["passed"])


@dataclass
class Cell:
    """One solver on one case: passed at some knob value, or the failure at the most effort tried."""

    passed: bool
    knob: str | None
    passing: list[int | None]
    tried: list[int | None]
    shown: int | None       # the knob value the failure is shown at (the largest tried)
    failing: str
    words: str              # why it failed there, in the words of ``why`` (empty when passed)
    crushed_at: int | None = None  # where the run shown was crushed, if it was

    def text(self) -> str:
        if self.passed:
            if self.knob is None:
                return "pass"
            return f"pass at {self.knob} {_values(self.passing)} ({len(self.passing)}/{len(self.tried)})"
        at = f" at {self.knob} {self.shown}" if self.knob is not None else ""
        return f"FAIL{at}: {self.failing}"

    def short(self) -> str:
        """A terminal-width version: ``pass 8 (4/7)`` (the smallest passing knob value, passing/tried), or
        ``FAIL`` and why, in the words every output uses (``why``: ``overlaps, moving``, ``crushed at step
        40``)."""
        if self.passed:
            return "pass" if self.knob is None else f"pass {self.passing[0]} ({len(self.passing)}/{len(self.tried)})"
        return f"FAIL {self.words}"

    def as_dict(self) -> dict[str, Any]:
        return {"passed": self.passed, "knob": self.knob, "passing": self.passing, "tried": self.tried,
                "shown": self.shown, "failing": self.failing, "crushed_at": self.crushed_at, "text": self.text()}


def _values(values: list[int | None]) -> str:
    return ", ".join(str(v) for v in values)


def cell(records: list[Record]) -> Cell:
    """The matrix cell of one solver's records on one case."""
    recs = sorted(case_records(records), key=lambda r: r.value or 0)
    passing = [r.value for r in recs if r.passed]
    last = recs[-1]
    return Cell(bool(passing), last.knob, passing, [r.value for r in recs], last.value,
                "" if passing else failing(last), "" if passing else why(last),
                None if passing else last.crushed_at)


def matrix(records: Iterable[Record]) -> dict[str, dict[str, Cell]]:
    """solver -> case -> cell, in the order the records come."""
    grouped: dict[str, dict[str, list[Record]]] = {}
    for r in case_records(records):
        grouped.setdefault(r.solver, {}).setdefault(r.case, []).append(r)
    return {solver: {case: cell(recs) for case, recs in by_case.items()} for solver, by_case in grouped.items()}


def measured(records: Iterable[Record]) -> list[Record]:
    """Records to draw on speed and error: timed, with an error against the exact solver (steps the reference
    left unsolved measured against its best answer, and marked where shown), neither blown up nor crushed, and
    not the reference itself (passed or not)."""
    return [r for r in case_records(records) if r.us_per_step is not None and r.error.get("rms") is not None
            and not r.broke and not r.reference]


def contenders(records: Iterable[Record]) -> list[Record]:
    """Records that compete for fronts and winners: measured (see ``measured``) and passed the case."""
    return [r for r in measured(records) if r.passed]


def noise(rec: Record) -> float:
    """How far a record's time may be off, as a share: its spread, at least ``NOISE``."""
    return max(NOISE, float(rec.timing.get("spread") or 0.0))


def dominates(a: Record, b: Record, lean: int = 0) -> bool:
    """Whether run ``a`` beats ``b`` on speed against error: at least as accurate (tied on error included:
    ``stackx.bench.uncertainty``) and clearly faster, or more accurate beyond both uncertainties and not
    clearly slower (times within ``TIE`` are the same cost). ``lean`` moves both times by their noise: +1 in
    ``a``'s favour (``a`` as fast as it could be, ``b`` as slow), -1 against it."""
    ta = a.us_per_step * (1.0 - lean * noise(a))  # type: ignore[operator]
    tb = b.us_per_step * (1.0 + lean * noise(b))  # type: ignore[operator]
    return ((at_least_as_accurate(a, b) and clearly_faster(ta, tb))
            or (more_accurate(a, b) and not clearly_faster(tb, ta)))


def pareto(records: Iterable[Record]) -> list[Record]:
    """The speed-against-error front of the runs that passed, fastest first: those that no other such run beats
    (``dominates``) with both times moved by their noise in the run's favour. A run beaten only at the times
    as measured, or only when they move the other way, is on the front and ``borderline``: another bench may
    put it either side."""
    runs = contenders(records)
    front = [r for r in runs if not any(dominates(o, r, lean=-1) for o in runs if o is not r)]
    return sorted(front, key=lambda r: (r.us_per_step, stated(r)))  # type: ignore[arg-type, return-value]


def borderline(rec: Record, records: Iterable[Record]) -> bool:
    """Whether a run on the front could be beaten with the timings leaning against it by their noise."""
    return any(dominates(o, rec, lean=1) for o in contenders(records) if o is not rec)


def cheapest(records: Iterable[Record], target: float) -> dict[str, Record]:
    """Per solver, the fastest run that passed and reaches ``target``: its stated error (its RMS, or its
    uncertainty where the RMS is within it) at most ``target``."""
    out: dict[str, Record] = {}
    for r in sorted(contenders(records), key=lambda r: r.us_per_step):  # type: ignore[arg-type, return-value]
        if reaches(r, target):
            out.setdefault(r.solver, r)
    return out


def equal_cost(records: list[Record], targets: Iterable[float] = TARGETS) -> list[dict[str, Any]]:
    """For each error level: which solver reaches it with the fewest microseconds per step in a run that passed,
    the solvers tied with it (within ``TIE``), whether any of those rest on an unstable timing, which carry
    steps the reference left unsolved, and the others' (each with its error, ``error_spread`` its
    uncertainty and ``unsolved`` its unsolved steps)."""
    rows = []
    for target in targets:
        by_solver = cheapest(records, target)
        ranked = sorted(by_solver.values(), key=lambda r: r.us_per_step)  # type: ignore[arg-type, return-value]
        tied = [r for r in ranked[1:] if tie(ranked[0], r)]
        rows.append({"target": target,
                     "winner": ranked[0].solver if ranked else None,
                     "tied": [r.solver for r in tied],
                     "unstable": [r.solver for r in ranked[:1 + len(tied)] if unstable(r)],
                     "unsolved": [r.solver for r in ranked[:1 + len(tied)] if unsolved(r.error)],
                     "solvers": [{"solver": r.solver, "knob": r.knob, "value": r.value, "us_per_step": r.us_per_step,
                                  "spread": r.timing.get("spread"), "error": r.error["rms"],
                                  "error_spread": spread(r.error), "unsolved": unsolved(r.error)}
                                 for r in ranked]})
    return rows


def tie(best: Record, other: Record) -> bool:
    """Whether ``other``'s time is within ``TIE`` of the faster ``best``'s, as measured: the margin every output
    states ("tied (within 20%)") is the one tested. A pair further apart is not called tied however noisy its
    figures: a figure too noisy to trust is flagged unstable (``unstable``) and says so where it is used, which
    is how the noise is told, rather than by widening the margin past what is printed."""
    return not clearly_faster(best.us_per_step, other.us_per_step)  # type: ignore[arg-type]


def tied_with(best: Record, shown: list[Record]) -> list[Record]:
    """The passing runs of ``shown`` (each solver's, ``outcomes``) tied with ``best`` (``tie``)."""
    return [r for r in shown if r is not best and r.passed and best.us_per_step is not None
            and r.us_per_step is not None and tie(best, r)]


def by_solver(records: Iterable[Record]) -> dict[str, list[Record]]:
    """The case's own records of each solver, in the order the solvers come, each by knob value."""
    out: dict[str, list[Record]] = {}
    for r in case_records(records):
        out.setdefault(r.solver, []).append(r)
    return {solver: sorted(recs, key=lambda r: r.value or 0) for solver, recs in out.items()}


def chosen(records: list[Record]) -> Record:
    """The run of one solver on one case that a report shows against time and in its summary: the smallest
    knob value that passed (the cheapest setting that answers the case), else the largest tried (the most
    effort; the stability matrix shows its failure too). It depends on the criteria only, never on timings,
    so two benches of the same configs show the same runs."""
    recs = sorted(case_records(records), key=lambda r: r.value or 0)
    return next((r for r in recs if r.passed), recs[-1])


def why(rec: Record) -> str:
    """Why a run failed, in a few words: ``overlaps, sunk, moving``; ``blew up at step 40``; ``crushed at step
    12``. ``failing`` has the values and limits."""
    if rec.blew_up:
        step = re.search(r"blew up at step (\d+)", rec.blew_up)
        return "blew up" + (f" at step {step.group(1)}" if step else "")
    if rec.crushed:
        return f"crushed at step {rec.crushed_at}"
    words = []
    for verdict in rec.criteria.values():
        for check in verdict["checks"]:
            if check["passed"]:
                continue
            words.append(word(check["measure"], rec.measures))
    return ", ".join(dict.fromkeys(words))


def _cost(rec: Record) -> float:
    return rec.us_per_step if rec.us_per_step is not None else float("inf")


def outcomes(records: Iterable[Record]) -> list[Record]:
    """Each solver's shown run (``chosen``): those that passed first, cheapest (microseconds per step) first,
    then those that failed, in the order the solvers come. The first is the case's answer when it passed."""
    shown = [chosen(recs) for recs in by_solver(records).values()]
    return sorted((r for r in shown if r.passed), key=_cost) + [r for r in shown if not r.passed]
