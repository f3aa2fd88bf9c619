"""The bench in the terminal: a rich table per case with the cheapest solver that passes it, the stability
matrix, claims and equal-cost winners."""

from __future__ import annotations

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from stackx.bench.compare import case_records, label, matrix, outcomes
from stackx.bench.markup import number
from stackx.bench.result import CaseResult, per_call_note, shown, step_time
from stackx.criteria import NAMES

_KNOB = {"iterations": "it", "substeps": "sub"}


def case_table(res: CaseResult) -> Table:
    """Every run of one case at the case's own settings, by solver and knob value."""
    run = res.case.run
    table = Table(title=f"{res.name}: {run.scene.size()} boxes, {run.steps} steps", title_justify="left")
    for col in ("solver", "knob", "µs/step", "µs/call", "error", "depth", "gap", "top err", "motion", "launch",
                *NAMES):
        table.add_column(col, justify="left" if col in ("solver", "knob") else "right", overflow="fold")
    for r in case_records(res.records):
        f = shown(r)
        knob = f"{_KNOB.get(r.knob, r.knob)} {r.value}" if r.knob else "-"
        row = [r.solver, knob, step_time(r), number(r.us_per_call, ".2f"), f["error"]]
        row += [f[k] for k in ("max_depth", "max_gap", "top_rest_error", "rms_motion", "launch")]
        for name in NAMES:
            v = r.criteria[name]
            row.append("-" if v["passed"] and not v["checks"] else "[green]pass[/]" if v["passed"] else "[red]fail[/]")
        table.add_row(*row)
    if per_call_note(res):
        table.caption, table.caption_justify = per_call_note(res), "left"
    return table


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


def print_all(results: list[CaseResult], console: Console) -> None:
    """The case tables with their equal-cost winners, the matrix, then what each lab claim came to."""
    for res in results:
        console.print(case_table(res))
        shown = outcomes(res.records)
        if shown and shown[0].passed:
            best = shown[0]
            console.print(f"  cheapest that passes: {escape(label(best.solver, best.knob, best.value))}, "
                          f"{number(best.us_per_step)} µs/step")
        else:
            console.print("  [red]no solver passes[/]")
        winners = [f"<= {row['target']:g}: {row['winner']}" for row in res.equal_cost if row["winner"]]
        if winners:
            console.print(f"  fastest to reach an error (m/s) {'; '.join(winners)}")
    console.print(matrix_table(results))
    for res in results:
        if res.claim:
            console.print(f"[bold]{escape(res.name)}[/]: {escape(res.claim['text'])}")
