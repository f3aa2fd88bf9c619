"""What a bench leaves behind: ``bench.json`` (every record), ``report.html`` and its PNG plots.

The page is self-contained apart from the plots beside it (``plots/CASE.png``, linked relatively), so the
output folder can be opened from disk with no network. Every sentence about an outcome is generated from
the records; the fixed text only defines the measures.
"""

from __future__ import annotations

import html
import json
import math
import os
import platform
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

from stackx import __version__, manifest
from stackx.bench.claims import finding
from stackx.bench.compare import TARGETS, Cell, case_records, equal_cost, failing, label, matrix, pareto
from stackx.bench.plan import Case
from stackx.bench.plots import speed_error_png
from stackx.bench.sweep import Record
from stackx.criteria import NAMES
from stackx.models.column.measures import MOTION_WINDOW, STILL
from stackx.outdir import OutputDir

PER_CALL_MARK = "*"  # after an engine's µs/step: timed one step per call, the only way it can be stepped

DEFINITIONS = {
    "holds": "in the final state every contact (the floor's included) overlaps by at most max_depth <= "
             "criteria.depth_factor x criteria.slop and has at most that much gap (max_gap: a column resting on "
             "air does not hold); the top box ends within |top_rest_error| <= criteria.rest_factor x criteria.slop "
             "x contacts of its rigid rest height; and no box ever passed half-way into its neighbour or below "
             "the floor (reach <= criteria.reach, 1 by default)",
    "settled": f"the RMS of the boxes' actual motion (y_now - y_prev)/dt over the last {MOTION_WINDOW} steps is "
               "below criteria.settle (stored velocities that move nothing do not count)",
    "never_launched": "no box moved upward faster than criteria.launch after it first touched something, measured "
                      "from positions after every step, (y_now - y_prev)/dt, the same way for every solver: a "
                      "position correction that throws a box up counts although it never touches a velocity",
    "crushed": "a box passed half-way into its neighbour at some step (reach above criteria.reach): the column's "
               "order no longer says which box rests on which, so the run's depths, heights and errors are left "
               "out of the tables, plots, Pareto fronts and equal-cost winners, and its cell says where it was "
               "crushed",
    "error": "along the solver's own run, at every step: from the state before the step, the exact solver's "
             "velocity stage gives the step's exact velocities (gravity, then no contact approaching and none "
             "pulling, solved to machine precision); the error is the RMS over all steps and boxes of the "
             "solver's stored velocity after the step minus the exact one (m/s), with the largest difference and "
             "the step it came at (0-based). Comparing on the solver's own path measures how well each step is "
             "solved; running both side by side would compare two piles that part ways within a few steps. It "
             "includes what a solver does on purpose that a rigid contact does not (a bias pushing apart, soft "
             "contacts, substeps, speculative contacts). A crushed run's error stops where it was crushed.",
    "steps_to_recover": "the step from which every contact overlaps by at most criteria.depth_factor x "
                        "criteria.slop to the end of the run; - when the run ends overlapping",
    "steps_to_settle": "the step from which every contact is within that depth and that gap and the RMS motion "
                       "of each step is below criteria.settle, to the end of the run; - when it never gets there",
    "us_per_step": "microseconds per step of one run alone, from the scene's start (up to bench.timing.steps "
                   "steps, before any scene event), stepped in one call, compiled, on one thread, the median of "
                   "bench.timing.repeats runs after an untimed warm-up step; with what follows from them (equal "
                   "cost, Pareto fronts, plots) the only numbers that change between two benches of the same "
                   "configs",
    "us_per_call": "the same, one step per call, as a game loop or an engine bound to Python is stepped: the "
                   "figure to set beside pymunk, Box2D or MuJoCo",
    "one_step_per_call": "an engine (pymunk, Box2D, MuJoCo) steps once per Python call and has no way to take "
                         "many steps in one, so it is timed per call only and its µs/step is its µs/call, marked "
                         f"'{PER_CALL_MARK}'; it includes copying the bodies' heights and velocities back into the "
                         "column and the column's monitors after every step",
    "knob": "each solver's cost knob (its 'knob' attribute, else its iterations or substeps parameter) runs at "
            "the values of bench.knob (or bench.knobs for that solver); the config's own solver also runs at "
            "the config's own value; a solver without a knob runs once",
    "top_rest_error": "final height of the top box minus its height on a rigid column (heights of the boxes "
                      "below plus its half-height); negative: the column sank",
    "top_p2p": f"peak-to-peak height of the top box over the last {MOTION_WINDOW} steps",
    "top_reversals": "(cases with a claim) how many times the top box's step-to-step motion changed direction "
                     f"over the whole run once it rested on something, steps under {STILL:g} m skipped",
    "top_rise": "(cases with a claim) the top box's fastest upward motion from positions, (y_next - y)/dt",
    "claim": "a lab claim is measured on pairs of runs, the case's setting and the lab's, for every solver that "
             "has the setting and every knob value; a pair bears it out when the case's setting still moves at "
             "the end (RMS motion at or above criteria.settle) where the lab's has settled",
    "equal_cost": f"for each error level ({', '.join(f'{t:g}' for t in TARGETS)} m/s), the solver whose cheapest "
                  "run at or below that error takes the fewest microseconds per step; the reference (exact) and "
                  "runs that blew up or were crushed are left out",
    "pareto": "runs that no other run beats on both time per step and error (the reference and broken runs left "
              "out)",
}


@dataclass
class CaseResult:
    """A benched case: its records and what is derived from them."""

    case: Case
    records: list[Record]
    left_out: dict[str, str]
    claim: dict[str, Any] | None = None
    equal_cost: list[dict[str, Any]] = field(default_factory=list)
    front: list[Record] = field(default_factory=list)

    @classmethod
    def build(cls, case: Case, records: list[Record], left_out: dict[str, str]) -> CaseResult:
        return cls(case, records, left_out, finding(case, records), equal_cost(records), pareto(records))

    @property
    def name(self) -> str:
        return self.case.name


def config_hash(path: str) -> str:
    """SHA-256 of the config file's bytes: which exact config produced a record."""
    return manifest.sha256(Path(path).read_bytes())


def machine() -> dict[str, Any]:
    from stackx import kernel

    return {"platform": platform.platform(), "machine": platform.machine(), "processor": platform.processor(),
            "cpus": os.cpu_count(), "python": sys.version.split()[0], "compiled_kernels": kernel.enabled()}


def versions(results: Sequence[CaseResult] = ()) -> dict[str, str]:
    """stackx, Python and every dependency, as the manifest records them, matplotlib, which draws the plots, and
    the package of every engine benched (its numbers are that version's)."""
    engines = sorted({d for res in results for p in res.case.plans
                      if (d := getattr(p.solver_cls, "distribution", None))})
    return {"stackx": __version__, **manifest.versions(), "matplotlib": metadata.version("matplotlib"),
            **{d: metadata.version(d) for d in engines}}


def _case_doc(res: CaseResult) -> dict[str, Any]:
    case, run = res.case, res.case.run
    return {
        "name": case.name, "file": case.spec.file, "config_sha256": config_hash(case.spec.file),
        "description": case.spec.description, "boxes": run.scene.size(), "dt": run.dt, "steps": run.steps,
        "gravity": run.gravity, "events": [repr(e) for e in run.scene.events()],
        "criteria": case.section.criteria.model_dump(mode="json"),
        "solvers": {p.solver: {"knob": p.knob, "values": p.values, "config_value": p.own, "applied": p.applied,
                               "not_applicable": p.skipped, "claim_baseline": p.claim} for p in case.plans},
        "left_out": res.left_out,
        "records": [r.as_dict() for r in res.records],
        "pareto": [{"solver": r.solver, "value": r.value} for r in res.front],
        "equal_cost": res.equal_cost,
        "claim": res.claim,
    }


def bench_json(results: list[CaseResult], command: str, wall_seconds: float) -> str:
    """Every record of every case, with the machine, versions, definitions and the stability matrix."""
    all_records = [r for res in results for r in res.records]
    doc = {
        "command": command, "wall_seconds": wall_seconds, "machine": machine(), "versions": versions(results),
        "definitions": DEFINITIONS,
        "cases": [_case_doc(res) for res in results],
        "matrix": {s: {c: cell.as_dict() for c, cell in row.items()} for s, row in matrix(all_records).items()},
    }
    return json.dumps(_finite(doc), indent=1, allow_nan=False) + "\n"


def _finite(value: Any) -> Any:
    """JSON has no NaN or infinity: such numbers (a run gone wild) are written as null."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def write(results: list[CaseResult], out: OutputDir, command: str, wall_seconds: float) -> None:
    """Stage ``bench.json``, ``report.html`` and the plots (``OutputDir.commit`` writes them)."""
    plots = {}
    for res in results:
        png = speed_error_png(res.name, res.records)
        if png is not None:
            plots[res.name] = f"plots/{res.name}.png"
            out.write_bytes(plots[res.name], png)
    out.write_text("bench.json", bench_json(results, command, wall_seconds))
    out.write_text("report.html", report_html(results, plots, command, wall_seconds))


# ---------------------------------------------------------------------------- the page

CSS = """
body { font: 14px/1.45 system-ui, sans-serif; margin: 1.5em auto; max-width: 1250px; color: #222; padding: 0 1em; }
table { border-collapse: collapse; margin: .6em 0 1.2em; font-size: 12.5px; }
th, td { border: 1px solid #ccc; padding: 3px 6px; text-align: right; vertical-align: top; }
th { background: #f2f2f2; } td.l, th.l { text-align: left; }
td.pass { background: #e3f4e3; } td.fail { background: #fbe3e0; }
.matrix td, .matrix th { text-align: left; max-width: 170px; overflow-wrap: anywhere; }
code { background: #f4f4f4; padding: 0 3px; } p.note { color: #555; } img { max-width: 100%; }
"""


def _e(text: object) -> str:
    return html.escape(str(text))


def number(value: float | None, fmt: str = ".3g") -> str:
    """A measure for a table; ``-`` where there is none."""
    return "-" if value is None else format(value, fmt)


def step_time(rec: Record) -> str:
    """A record's µs/step for a table; an engine's, which is its µs/call, marked (see DEFINITIONS)."""
    text = number(rec.us_per_step, ".2f")
    return text + PER_CALL_MARK if rec.us_per_step is not None and rec.timing.get("one_step_per_call") else text


def _table(head: list[str], rows: list[list[str]], cls: str = "") -> str:
    th = "".join(f"<th>{_e(h)}</th>" for h in head)
    body = "".join("<tr>" + "".join(cells) + "</tr>" for cells in rows)
    return f'<table class="{cls}"><tr>{th}</tr>{body}</table>'


def _td(text: object, cls: str = "") -> str:
    return f'<td class="{cls}">{_e(text)}</td>'


def _matrix_html(results: list[CaseResult]) -> str:
    """Cases down, solvers across."""
    cells = matrix(r for res in results for r in res.records)
    rows = []
    for res in results:
        line = [_td(res.name, "l")]
        for row in cells.values():
            c: Cell | None = row.get(res.name)
            line.append(_td("not run") if c is None else _td(c.text(), "pass" if c.passed else "fail"))
        rows.append(line)
    return _table(["case", *cells], rows, "matrix")


def _timeline_html(results: list[CaseResult]) -> str:
    """Cases down, with their boxes, solvers across: steps to recover / steps to settle at each solver's largest
    knob value, so cases that differ only in size (recovery-10, -100, -1000) read as a curve against n."""
    solvers = list(dict.fromkeys(r.solver for res in results for r in case_records(res.records)))
    rows = []
    for res in results:
        line = [_td(res.name, "l"), _td(res.case.run.scene.size())]
        for solver in solvers:
            recs = sorted((r for r in case_records(res.records) if r.solver == solver), key=lambda r: r.value or 0)
            if not recs:
                line.append(_td("not run"))
                continue
            last = recs[-1]
            if last.broke:
                line.append(_td("blew up" if last.blew_up else f"crushed at {last.crushed_at}", "fail"))
                continue
            f = shown(last)
            at = f" ({last.knob} {last.value})" if last.knob else ""
            ok = f["steps_to_settle"] != "-"
            line.append(_td(f"{f['steps_to_recover']} / {f['steps_to_settle']}{at}", "pass" if ok else "fail"))
        rows.append(line)
    return _table(["case", "boxes", *solvers], rows, "matrix")


MEASURES = ("max_depth", "max_gap", "peak_depth", "top_rest_error", "rms_motion", "top_p2p", "launch",
            "steps_to_recover", "steps_to_settle")


def shown(rec: Record) -> dict[str, str]:
    """A record's figures as a table shows them: '-' where there is none, and none of a run that broke (a
    crushed run keeps only its reach, which says by how much)."""
    if rec.broke:
        figures = {k: "-" for k in ("error", "error_max", "worst_step", *MEASURES)}
        figures["reach"] = "-" if rec.blew_up else number(rec.measures.get("reach"))
        return figures
    m, e = rec.measures, rec.error
    figures = {"error": number(e.get("rms")), "error_max": number(e.get("max")),
               "worst_step": number(e.get("worst_step"), "d"), "reach": number(m.get("reach"))}
    for k in MEASURES:
        figures[k] = number(m.get(k), "g" if k.startswith("steps_") else ".3g")
    return figures


def _records_html(res: CaseResult) -> str:
    head = ["solver", "knob", "µs/step", "µs/call", "error rms", "error max", "worst step", "final depth",
            "final gap", "peak depth", "reach", "top rest err", "rms motion", "top p2p", "launch", "recovered at",
            "settled at", *NAMES]
    rows = []
    for r in case_records(res.records):
        f = shown(r)
        line = [_td(r.solver, "l"), _td(f"{r.knob} {r.value}" if r.knob else "-", "l"),
                _td(step_time(r)), _td(number(r.us_per_call, ".2f")),
                _td(f["error"] if not r.reference else "reference"), _td(f["error_max"]),
                _td(f["worst_step"])]
        line += [_td(f[k]) for k in ("max_depth", "max_gap", "peak_depth", "reach", "top_rest_error", "rms_motion",
                                     "top_p2p", "launch", "steps_to_recover", "steps_to_settle")]
        for name in NAMES:
            v = r.criteria[name]
            line.append(_td("pass" if v["passed"] else f"fail: {v['failing']}", "pass" if v["passed"] else "fail"))
        rows.append(line)
    note = ""
    if any(r.timing.get("one_step_per_call") for r in res.records):
        note = (f"<p class=note>{_e(PER_CALL_MARK)} an engine, stepped once per Python call: its µs/step is its "
                "µs/call (see one_step_per_call).</p>")
    return _table(head, rows) + note


def _equal_cost_html(res: CaseResult) -> str:
    rows = []
    for row in res.equal_cost:
        ranked = row["solvers"]
        if not ranked:
            rows.append([_td(f"{row['target']:g}"), _td("no solver reaches it", "l"), _td("-"), _td("-", "l")])
            continue
        win = ranked[0]
        others = "; ".join(f"{label(s['solver'], s['knob'], s['value'])} {s['us_per_step']:.2f} µs"
                           for s in ranked[1:])
        rows.append([_td(f"{row['target']:g}"), _td(label(win["solver"], win["knob"], win["value"]), "l"),
                     _td(f"{win['us_per_step']:.2f}"), _td(others or "-", "l")])
    return _table(["error ≤ (m/s)", "fastest to reach it", "µs/step", "others, slower"], rows)


def _case_html(res: CaseResult, plot: str | None) -> str:
    case, run = res.case, res.case.run
    crit = case.section.criteria
    contacts = run.scene.size() - len(run.scene.events())
    parts = [f'<h2 id="{_e(res.name)}">{_e(res.name)}</h2>',
             f"<p>{_e(case.spec.description)}</p>",
             f"<p class=note><code>{_e(case.spec.file)}</code>: {run.scene.size()} boxes, dt = {run.dt:.6g} s, "
             f"{run.steps} steps{''.join(f', {_e(repr(e))}' for e in run.scene.events())}. Holds: final depth "
             f"and final gap ≤ {crit.depth_limit:g} m, top box within {crit.rest_limit(contacts):.3g} m of its rigid "
             f"rest height ({crit.rest_factor:g} x {crit.slop:g} m x {contacts} contacts), reach ≤ {crit.reach:g}; "
             f"settled: RMS motion &lt; {crit.settle:g} m/s; never launched: ≤ {crit.launch:g} m/s upward, from "
             "positions.</p>"]
    if run.solver_cls.plugin_name in {p.solver for p in case.plans}:
        own = run.solver_params.model_dump(mode="json")
        parts.append(f"<p class=note>{_e(run.solver_cls.plugin_name)} runs with the config's own settings "
                     f"<code>{_e(json.dumps(own, sort_keys=True))}</code>; the others at their defaults.</p>")
    knobs = "; ".join(f"{p.solver}: {p.knob} {', '.join(map(str, p.values))}" if p.knob else f"{p.solver}: no knob"
                      for p in case.plans)
    parts.append(f"<p class=note>Knob values: {_e(knobs)}.</p>")
    if case.section.set:
        applied = ", ".join(p.solver for p in case.plans if p.applied) or "none"
        skipped = ", ".join(p.solver for p in case.plans if p.skipped) or "none"
        parts.append(f"<p class=note>Settings {_e(case.section.set)} given to: {_e(applied)}; not applicable to "
                     f"(run at their defaults): {_e(skipped)}.</p>")
    if res.left_out:
        parts.append(f"<p class=note>Left out: {_e('; '.join(f'{k}: {v}' for k, v in res.left_out.items()))}.</p>")
    if res.claim:
        parts.append(f"<p><b>Lab claim.</b> {_e(res.claim['text'])}</p>")
    if plot:
        parts.append(f'<p><img src="{_e(plot)}" alt="speed against error, {_e(res.name)}"></p>')
    else:
        parts.append("<p class=note>No plot: no run has both a time and an error against the exact solver.</p>")
    parts.append("<h3>Equal cost</h3>" + _equal_cost_html(res))
    if res.front:
        front = ", ".join(label(r.solver, r.knob, r.value) for r in res.front)
        parts.append(f"<p class=note>Pareto front, fastest first: {_e(front)}.</p>")
    parts.append("<h3>Every run</h3>" + _records_html(res))
    return "\n".join(parts)


def report_html(results: list[CaseResult], plots: dict[str, str], command: str, wall_seconds: float) -> str:
    mach, vers = machine(), versions(results)
    claims = [f"<li><b>{_e(res.name)}</b>: {_e(res.claim['text'])}</li>" for res in results if res.claim]
    defs = "".join(f"<li><b>{_e(k)}</b>: {_e(v)}</li>" for k, v in DEFINITIONS.items())
    blown = [r for res in results for r in res.records if r.blew_up]
    head = [
        "<!doctype html><html><head><meta charset='utf-8'><title>stackx bench</title>",
        f"<style>{CSS}</style></head><body>",
        "<h1>stackx bench</h1>",
        f"<p><code>{_e(command)}</code> took {wall_seconds:.1f} s on {_e(mach['platform'])}, {mach['cpus']} CPUs, "
        f"compiled kernels {'on' if mach['compiled_kernels'] else 'off'}; "
        f"{_e(', '.join(f'{k} {v}' for k, v in vers.items()))}.</p>",
        f"<p>Cases: {' '.join(f'<a href=#{_e(r.name)}>{_e(r.name)}</a>' for r in results)}.</p>",
        "<h2>Stability matrix</h2>",
        "<p class=note>Each cell: the knob values at which the solver passed all three criteria, or, when it "
        "passed at none, what failed at the largest knob value tried.</p>",
        _matrix_html(results),
    ]
    if blown:
        head.append("<p class=note>Runs that blew up: " + "; ".join(
            f"{_e(label(r.solver, r.knob, r.value))} on {_e(r.case)} {_e(failing(r))}" for r in blown) + ".</p>")
    head += ["<h2>Steps to recover / steps to settle</h2>",
             "<p class=note>At each solver's largest knob value: the step from which no contact overlaps beyond the "
             "depth limit, and the step from which the column also has no gap beyond it and moves below the "
             "settled limit, to the end of the run ('-': not by the end). Cases that differ only in their number "
             "of boxes show how recovery grows with the height of the column.</p>",
             _timeline_html(results)]
    if claims:
        head += ["<h2>The lab's claims, measured</h2>", "<ul>" + "".join(claims) + "</ul>"]
    head += ["<h2>Definitions</h2>", f"<ul>{defs}</ul>"]
    body = [_case_html(res, plots.get(res.name)) for res in results]
    return "\n".join(head + body + ["</body></html>"]) + "\n"

