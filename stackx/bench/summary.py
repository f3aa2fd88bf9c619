"""The report's first screen: for each case, the cheapest solver that passes and why each other one fails.

One row per case. Each solver is shown at the run ``compare.chosen`` picks (its smallest passing knob value,
else its largest tried); the cheapest of those that passed, by microseconds per step, is the case's answer,
shown with its time (marked as ``stackx.bench.figures`` marks how it was stepped) and its error.
Every other solver's cell says in a word or three why it failed at the most effort tried (hover for the
values and limits), or from which knob value it passes too.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from stackx.bench.compare import by_solver, failing, label, outcomes, unstable, why
from stackx.bench.figures import error_text, steppings, timed
from stackx.bench.markup import esc, number, swatch, td
from stackx.bench.stepping import COMPILED
from stackx.bench.sweep import Record

if TYPE_CHECKING:
    from stackx.bench.result import CaseResult

WORDS = {
    "overlaps": "a contact ends deeper than the depth limit",
    "gap": "a contact ends with a gap wider than the depth limit",
    "sunk": "the top box ends below its rigid rest height by more than the rest limit",
    "high": "the top box ends above its rigid rest height by more than the rest limit",
    "moving": "not settled: the final RMS motion is at or above the settled limit",
    "launched": "a box that had touched something moved up faster than the launch limit",
    "crushed": "a box passed half-way into another",
    "drifted": "a box placed at rest ended farther sideways from where it started than the drift limit",
    "turned": "a box placed at rest ended turned by more than the turn limit",
    "slides wrong": "the box on the ramp slid with an acceleration farther from the analytic one than the limit",
    "blew up": "the run went non-finite or faster than limits.max_speed",
}


def summary_html(results: list[CaseResult]) -> str:
    """The summary table and the meaning of its words."""
    solvers = list(dict.fromkeys(r.solver for res in results for r in res.records))
    head = "".join(f"<th>{swatch(s)}</th>" for s in solvers)
    rows = []
    for res in results:
        shown = outcomes(res.records)
        best = shown[0] if shown and shown[0].passed else None
        how = steppings(res)
        cells = [f'<td class="l"><a href="#{esc(res.name)}">{esc(res.name)}</a></td>']
        if best is None:
            cells += [td("none passes", "fail l"), td("-"), td("-")]
        else:
            cells += [f'<td class="l pass"><b>{swatch(best.solver)}</b>{esc(_knob(best))}</td>',
                      td(timed(best, how.get(best.solver, COMPILED)), "warn" if unstable(best) else "",
                         best.timing.get("unstable") or None),
                      td(error_text(best))]
        runs = {r.solver: r for r in shown}
        for solver in solvers:
            rec = runs.get(solver)
            if rec is None:
                cells.append(td("-", title=f"{solver} was not run on {res.name}"))
            elif rec.passed:
                text = "pass" + (f" {rec.value}" if rec.knob else "")
                error = "the reference" if rec.reference else f"error {error_text(rec, ' m/s')}"
                tip = (f"passes from {label(rec.solver, rec.knob, rec.value)} at {number(rec.us_per_step)} µs per "
                       f"step, {error}; passed at {_passing(res, solver)}")
                cells.append(td(text, "pass best" if rec is best else "pass", tip))
            else:
                at = f" at {rec.knob} {rec.value}" if rec.knob else ""
                cells.append(td(why(rec), "fail", f"fails{at}: {failing(rec)}"))
        rows.append("<tr>" + "".join(cells) + "</tr>")
    words = "; ".join(f"<b>{esc(w)}</b>: {esc(m)}" for w, m in WORDS.items())
    return (f'<table class="summary"><tr><th>case</th><th>cheapest that passes</th><th>µs per step</th>'
            f'<th>error (m/s)</th>{head}</tr>' + "".join(rows) + "</table>"
            + "<p class=note>Each solver at its smallest knob value that passed ('pass N'), or, when none did, at "
            "the largest it tried, with what failed there (hover a cell for the values and limits). The cheapest "
            "is the fastest, in microseconds per step, of the solvers' smallest passing runs, the reference "
            "included: it answers the case; its error is the RMS against the reference ('reference': zero by "
            "definition), with its uncertainty where measured ('± u'; '<= u' where the error is within it and "
            "cannot be told from zero) and the steps the reference left unsolved, if any. A time marked 'py' "
            "was stepped as plain Python (no compiled kernels), '*' by an engine one step per call. "
            f"Words: {words}.</p>")


def _knob(rec: Record) -> str:
    return f" ({rec.knob} {rec.value})" if rec.knob else ""


def _passing(res: CaseResult, solver: str) -> str:
    recs = by_solver(res.records).get(solver, [])
    return ", ".join(str(r.value) if r.knob else "its one setting" for r in recs if r.passed)
