"""The bench in the terminal.

By default it fits 80 columns: per case a short table, one row per solver at the run the summary shows
(``compare.chosen``): the knob value (its smallest that passed, else the largest tried), its µs/step with
its spread and how it was stepped (``stackx.bench.figures``), its error against the reference with its
uncertainty where the record has one, and its verdict in the words every output uses (``compare.why``);
then, indented under it, the cheapest that passes, the Pareto front and the equal-cost winners, each run
with its numbers, each saying when it rests on a tie or an unstable timing and that the reference is left
out where it is. ``--wide`` prints instead every run of every case with all its figures, and the stability
matrix. Tables are laid out within the screen's width by the screen itself (``stackx.output.screen``).

An error reads with its uncertainty and the steps the reference left unsolved (``stackx.bench.uncertainty``):
the front's and the winners' headings count the runs on them that carry unsolved steps and those whose error is
within its uncertainty (tied on error), and each such run's line says so."""

from __future__ import annotations

from rich import box
from rich.console import Console, RenderableType
from rich.markup import escape
from rich.padding import Padding
from rich.table import Table
from rich.text import Text

from stackx.bench.compare import (TIE, borderline, case_records, cheapest, matrix, outcomes, tied_with, unstable,
                                  why)
from stackx.bench.figures import error_text, plain_note, steppings, timed
from stackx.bench.result import CaseResult, call_time, per_call_note, shown, unstable_note
from stackx.bench.stepping import COMPILED
from stackx.bench.sweep import Record
from stackx.bench.criteria import NAMES
from stackx.bench.uncertainty import carrying_unsolved, within

_KNOB = {"iterations": "it", "substeps": "sub"}
KEY = ("knob: each solver at its smallest value that passed, else the largest tried (it: iterations, sub: "
       "substeps); error: RMS against the reference, m/s (± its uncertainty; <= u: within its uncertainty u, "
       "tied on error with any run it overlaps)")


def case_table(res: CaseResult, how: dict[str, str] | None = None) -> Table:
    """Every run of one case at the case's own settings, by solver and knob value."""
    how = steppings(res) if how is None else how
    run = res.case.run
    table = Table(title=f"{res.name}: {run.scene.size()} boxes, {run.steps} steps", title_justify="left")
    for col in ("solver", "knob", "µs/step", "µs/call", "error", "violation", "approach", "depth", "gap", "top err",
                "motion", "launch", *NAMES):
        name = col in ("solver", "knob")
        table.add_column(col, justify="left" if name else "right", overflow="fold", no_wrap=not name)
    for r in case_records(res.records):
        f = shown(r)
        row = [escape(r.solver), _knob(r), escape(timed(r, how.get(r.solver, COMPILED))), call_time(r),
               escape(error_text(r)), f["violation"], f["approach"]]
        row += [f[k] for k in ("max_depth", "max_gap", "top_rest_error", "rms_motion", "launch")]
        for name in NAMES:
            v = r.criteria[name]
            row.append("-" if v["passed"] and not v["checks"] else "[green]pass[/]" if v["passed"] else "[red]fail[/]")
        table.add_row(*row)
    notes = [n for n in (per_call_note(res), plain_note(how), unstable_note(res)) if n]
    if notes:
        table.caption, table.caption_justify = "\n".join(notes), "left"
    return table


def _knob(rec: Record) -> str:
    return f"{_KNOB.get(rec.knob, rec.knob)} {rec.value}" if rec.knob else "-"


def _verdict(rec: Record, records: list[Record]) -> str:
    """``pass at 4 of 7`` (the knob values that passed of those tried), ``pass``, or ``fail: overlaps, sunk``."""
    if not rec.passed:
        return f"[red]fail[/]: {escape(why(rec))}"
    if not rec.knob:
        return "[green]pass[/]"
    own = [x for x in case_records(records) if x.solver == rec.solver]
    return f"[green]pass[/] at {sum(1 for x in own if x.passed)} of {len(own)}"


def compact_table(res: CaseResult, how: dict[str, str] | None = None) -> Table:
    """One case in 80 columns: each solver at the run the summary shows (its smallest passing knob value, else
    its largest tried), passing ones cheapest first, with its time (and how it was stepped, ``how``: solver ->
    ``stackx.bench.stepping``), its error against the reference and its verdict."""
    how = steppings(res) if how is None else how
    run = res.case.run
    table = Table(title=f"{res.name}: {run.scene.size()} boxes, {run.steps} steps", title_justify="left",
                  box=box.SIMPLE_HEAD, pad_edge=False)
    table.add_column("solver", overflow="fold")
    table.add_column("knob", no_wrap=True)
    table.add_column("µs/step", justify="right", no_wrap=True)
    table.add_column("error m/s", justify="right", overflow="fold")
    table.add_column("verdict", overflow="fold")
    for r in outcomes(res.records):
        table.add_row(escape(r.solver), _knob(r), escape(timed(r, how.get(r.solver, COMPILED))),
                      escape(error_text(r)), _verdict(r, res.records))
    notes = [n for n in (per_call_note(res), plain_note(how), unstable_note(res)) if n]
    if notes:
        table.caption, table.caption_justify = "\n".join(notes), "left"
    return table


def _name(rec: Record) -> str:
    """``warm-start it 8``; a solver without a knob by its name alone."""
    return f"{rec.solver} {_knob(rec)}" if rec.knob else rec.solver


def _run(rec: Record, how: dict[str, str]) -> str:
    """``warm-start it 8`` with its time: ``warm-start it 8, 1.37 +2% µs/step``."""
    return f"{_name(rec)}, {timed(rec, how.get(rec.solver, COMPILED))} µs/step"


def _cheapest(res: CaseResult, how: dict[str, str]) -> str:
    """The cheapest run that passes (there is one), and those tied with it within the margin ``TIE``, as
    measured."""
    shown_runs = outcomes(res.records)
    best = shown_runs[0]
    line = escape(_run(best, how)) + (", the reference (error 0 by definition)" if best.reference else
                                      f", error {escape(error_text(best, ' m/s'))}")
    ties = tied_with(best, shown_runs)
    if ties:
        line += f"; tied with it (within {100 * TIE:.0f}%): " + escape("; ".join(_run(r, how) for r in ties))
    return line


def _front(res: CaseResult, how: dict[str, str]) -> Table:
    """The Pareto front, one run a line: the run, its time and its error; ``?`` after a borderline one."""
    grid = Table.grid(padding=(0, 2))
    grid.add_column(overflow="fold")
    grid.add_column(no_wrap=True)
    grid.add_column(overflow="fold")  # an error with its unsolved steps runs long
    grid.add_column(no_wrap=True)
    for r in res.front:
        grid.add_row(escape(_name(r)),
                     escape(timed(r, how.get(r.solver, COMPILED))) + " µs/step",
                     escape(error_text(r, " m/s")), "?" if borderline(r, res.records) else "")
    return grid


def _winners(res: CaseResult, how: dict[str, str]) -> Table:
    """For each error level some passing run reaches: the fastest such run, its time and error, and the runs
    tied with it (within ``TIE``, as measured)."""
    grid = Table.grid(padding=(0, 2))
    grid.add_column(no_wrap=True)
    grid.add_column(overflow="fold")
    grid.add_column(no_wrap=True)
    grid.add_column(overflow="fold")
    grid.add_column(overflow="fold")
    for row in res.equal_cost:
        if not row["winner"]:
            continue
        win = cheapest(res.records, row["target"])[row["winner"]]
        tied = f"tied (within {100 * TIE:.0f}%): {', '.join(row['tied'])}" if row["tied"] else ""
        grid.add_row(f"<= {row['target']:g}", escape(_name(win)),
                     escape(timed(win, how.get(win.solver, COMPILED))) + " µs/step", escape(error_text(win, " m/s")),
                     escape(tied))
    return grid


def answers(res: CaseResult, how: dict[str, str] | None = None) -> list[RenderableType]:
    """What the case comes to: the cheapest that passes (the reference included, and said so) with the runs
    tied with it, the Pareto front with each run's time and error, and the fastest passing run to reach each
    error level (the reference left out, and said so); each says when it rests on an unstable timing. Every
    line is indented under the case's table, and so is every line it wraps to."""
    how = steppings(res) if how is None else how
    shown_runs = outcomes(res.records)
    if not (shown_runs and shown_runs[0].passed):
        return [_indented(Text.from_markup("[red]no solver passes[/]"))]
    out: list[RenderableType] = [_indented(Text.from_markup(f"cheapest that passes: {_cheapest(res, how)}"))]
    ref = next((r for r in case_records(res.records) if r.reference), None)
    apart = "; the reference left out" if ref is not None else ""
    if res.front:
        flagged = sum(1 for r in res.front if unstable(r))
        shaky = f"; [yellow]rests on {flagged} unstable timing{'s' if flagged > 1 else ''}[/]" if flagged else ""
        marks = _marks(res.front)
        out.append(_indented(Text.from_markup(f"front (passed runs, fastest first{apart}; ?: borderline){shaky}"
                                              f"{marks}:")))
        out.append(_indented(_front(res, how), 4))
    if any(row["winner"] for row in res.equal_cost):
        shaky = "; [yellow]! rests on an unstable timing[/]" if any(row["unstable"] for row in res.equal_cost) else ""
        winners = [cheapest(res.records, row["target"])[row["winner"]] for row in res.equal_cost if row["winner"]]
        marks = _marks(list({id(r): r for r in winners}.values()))
        out.append(_indented(Text.from_markup(f"fastest to reach each error (passed runs{apart}){shaky}{marks}:")))
        out.append(_indented(_winners(res, how), 4))
    return out


def _marks(runs: list[Record]) -> str:
    """What a front's or the winners' heading says of its runs' errors: how many carry steps the reference left
    unsolved (measured against its best answer there) and how many are within their uncertainty ('<=', tied
    on error); empty when none."""
    parts = []
    unsolved = carrying_unsolved(runs)
    if unsolved:
        parts.append(f"[yellow]{len(unsolved)} with steps unsolved by the reference: "
                     f"{escape(', '.join(_name(r) for r in unsolved))}[/]")
    inside = sum(1 for r in runs if within(r.error))
    if inside:
        parts.append(f"<=: {inside} within {'their' if inside > 1 else 'its'} uncertainty, tied on error")
    return "".join(f"; {p}" for p in parts)


def _indented(renderable: RenderableType, left: int = 2) -> Padding:
    """``renderable`` moved ``left`` columns in, the lines it wraps to as well: they read as part of the case."""
    return Padding(renderable, (0, 0, 0, left))


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
        how = steppings(res)
        console.print(case_table(res, how) if wide else compact_table(res, how))
        for part in answers(res, how):
            console.print(part)
    if results and not wide:
        console.print(KEY)
    if wide:
        console.print(matrix_table(results))
    for res in results:
        if res.claim:
            console.print(f"[bold]{escape(res.name)}[/]: {escape(res.claim['text'])}")
