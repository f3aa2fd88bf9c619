"""The bench in the terminal.

By default it fits 80 columns: per case a short table, one row per solver at the run the summary shows
(``compare.chosen``): the smallest knob value that passed, its µs/step with its spread, and its verdict in
the words every output uses (``compare.why``); then the cheapest that passes, the Pareto front and the
equal-cost winners, each saying when it rests on a tie or an unstable timing. ``--wide`` prints instead every
run of every case with all its figures, and the stability matrix: as wide as they need."""

from __future__ import annotations

from rich import box
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from stackx.bench.compare import TIE, borderline, case_records, label, matrix, outcomes, tied_with, unstable, why
from stackx.bench.markup import number
from stackx.bench.result import (UNSTABLE_MARK, CaseResult, call_time, per_call_note, shown, step_time,
                                 unstable_note)
from stackx.bench.sweep import Record
from stackx.bench.criteria import NAMES

_KNOB = {"iterations": "it", "substeps": "sub"}


def case_table(res: CaseResult) -> Table:
    """Every run of one case at the case's own settings, by solver and knob value."""
    run = res.case.run
    table = Table(title=f"{res.name}: {run.scene.size()} boxes, {run.steps} steps", title_justify="left")
    for col in ("solver", "knob", "µs/step", "µs/call", "error", "violation", "approach", "depth", "gap", "top err",
                "motion", "launch", *NAMES):
        table.add_column(col, justify="left" if col in ("solver", "knob") else "right", overflow="fold")
    for r in case_records(res.records):
        f = shown(r)
        knob = f"{_KNOB.get(r.knob, r.knob)} {r.value}" if r.knob else "-"
        row = [r.solver, knob, step_time(r), call_time(r), f["error"], f["violation"], f["approach"]]
        row += [f[k] for k in ("max_depth", "max_gap", "top_rest_error", "rms_motion", "launch")]
        for name in NAMES:
            v = r.criteria[name]
            row.append("-" if v["passed"] and not v["checks"] else "[green]pass[/]" if v["passed"] else "[red]fail[/]")
        table.add_row(*row)
    notes = [n for n in (per_call_note(res), unstable_note(res)) if n]
    if notes:
        table.caption, table.caption_justify = "\n".join(notes), "left"
    return table


def _knob(rec: Record) -> str:
    return f"{_KNOB.get(rec.knob, rec.knob)} {rec.value}" if rec.knob else "-"


def compact_table(res: CaseResult) -> Table:
    """One case in 80 columns: each solver at the run the summary shows, passing ones cheapest first."""
    run = res.case.run
    table = Table(title=f"{res.name}: {run.scene.size()} boxes, {run.steps} steps", title_justify="left",
                  box=box.SIMPLE_HEAD, pad_edge=False)
    table.add_column("solver", no_wrap=True)
    table.add_column("passes from", no_wrap=True)
    table.add_column("µs/step", justify="right", no_wrap=True)
    table.add_column("verdict", overflow="fold")
    for r in outcomes(res.records):
        tried = sum(1 for x in case_records(res.records) if x.solver == r.solver)
        passing = sum(1 for x in case_records(res.records) if x.solver == r.solver and x.passed)
        if r.passed:
            verdict = "[green]pass[/]" + (f" at {passing} of {tried}" if r.knob else "")
        else:
            at = f" at {_knob(r)}" if r.knob else ""
            verdict = f"[red]fail[/]{escape(at)}: {escape(why(r))}"
        passes = (_knob(r) if r.knob else "no knob") if r.passed else "-"
        table.add_row(escape(r.solver), passes, escape(step_time(r)), verdict)
    notes = [n for n in (per_call_note(res), unstable_note(res)) if n]
    if notes:
        table.caption, table.caption_justify = "\n".join(notes), "left"
    return table


def _timed(rec: Record) -> str:
    flag = f" (timing unstable {UNSTABLE_MARK})" if unstable(rec) else ""
    return f"{label(rec.solver, rec.knob, rec.value)} {number(rec.us_per_step)} µs/step{flag}"


def answers(res: CaseResult) -> list[str]:
    """What the case comes to, in lines: the cheapest that passes (and the runs tied with it), the Pareto front,
    the equal-cost winners; each says when it rests on a tie or an unstable timing."""
    shown_runs = outcomes(res.records)
    if not (shown_runs and shown_runs[0].passed):
        return ["  [red]no solver passes[/]"]
    best = shown_runs[0]
    line = f"  cheapest that passes: {escape(_timed(best))}"
    ties = tied_with(best, shown_runs)
    if ties:
        line += f"; tied with it (within {100 * TIE:.0f}%): {escape(', '.join(_timed(r) for r in ties))}"
    lines = [line]
    if res.front:
        flagged = [r for r in res.front if unstable(r)]
        front = ", ".join(label(r.solver, r.knob, r.value) + ("?" if borderline(r, res.records) else "")
                          for r in res.front)
        lines.append(f"  front (speed against error, passed runs; ?: borderline): {escape(front)}"
                     + (f" [yellow]rests on {len(flagged)} unstable timing(s)[/]" if flagged else ""))
    winners = []
    for row in res.equal_cost:
        if row["winner"]:
            tie = f" = {' = '.join(row['tied'])}" if row["tied"] else ""
            shaky = f" {UNSTABLE_MARK}" if row["unstable"] else ""
            winners.append(f"<= {row['target']:g}: {row['winner']}{tie}{shaky}")
    if winners:
        lines.append(f"  fastest to reach an error (m/s) {escape('; '.join(winners))}")
    return lines


def matrix_table(results: list[CaseResult]) -> Table:
    """Cases down, solvers across (the HTML report has the failing values in full)."""
    cells = matrix(r for res in results for r in res.records)
    table = Table(title="stability matrix: 'pass 8 (4/7)' passed at 4 of 7 knob values, the smallest 8; FAIL and "
                        "the measures that failed at the largest knob value", title_justify="left")
    table.add_column("case")
    for solver in cells:
        table.add_column(solver, overflow="fold")
    for res in results:
        row = [cells[s].get(res.name) for s in cells]
        table.add_row(res.name, *["-" if c is None else f"[{'green' if c.passed else 'red'}]{escape(c.short())}[/]"
                                  for c in row])
    return table


def print_all(results: list[CaseResult], console: Console, wide: bool = False) -> None:
    """Each case's table and what it comes to, then (``wide``) the stability matrix, then each lab claim."""
    for res in results:
        console.print(case_table(res) if wide else compact_table(res))
        for line in answers(res):
            console.print(line)
    if wide:
        console.print(matrix_table(results))
    for res in results:
        if res.claim:
            console.print(f"[bold]{escape(res.name)}[/]: {escape(res.claim['text'])}")
