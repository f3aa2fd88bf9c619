"""``report.html``: one page that stands alone (its pictures are ``data:`` URIs; no network, no file beside it).

It opens on speed against error, open: each case's plot of every run's time per step against its error, the
answer the bench exists to give, captioned with the case's verdict. Then the summary (``stackx.bench.summary``):
for each case the cheapest solver that passes, its time and error, and why each other one fails. Each case
follows as a collapsible section (closed; a link to ``#CASE`` opens it): its settings, its runs against time,
for a planar case its start and final states drawn (``stackx.bench.snapshots``), the equal-cost winners and
the Pareto front beside a link to its plot, and a table of every run. Then what spans the cases (the stability
matrix, steps to recover and to settle, the lab's claims) and the definitions. An error reads with its
uncertainty and the steps the reference left unsolved (``stackx.bench.uncertainty``), and the front says which
of its runs carry either. Every sentence about an outcome is generated from the records; the fixed text only
defines the measures. Column headers carry their units.
"""

from __future__ import annotations

import json

from stackx.bench.compare import TIE, Cell, borderline, case_records, failing, label, matrix, outcomes, tied_with, unstable
from stackx.bench.markup import esc, number, swatch, table, td
from stackx.bench.result import DEFINITIONS, CaseResult, call_time, per_call_note, shown, unstable_note
from stackx.bench.snapshots import Snapshot
from stackx.bench.summary import summary_html
from stackx.bench.sweep import Record
from stackx.bench.criteria import NAMES
from stackx.bench.figures import error_text, plain_note, steppings, timed
from stackx.bench.stepping import COMPILED
from stackx.bench.uncertainty import carrying_unsolved, spread as uncertainty_spread, unsolved, within

CSS = """
body { font: 14px/1.45 system-ui, sans-serif; margin: 1.5em auto; max-width: 1250px; color: #222; padding: 0 1em; }
table { border-collapse: collapse; margin: .6em 0 1.2em; font-size: 12.5px; }
th, td { border: 1px solid #ccc; padding: 3px 6px; text-align: right; vertical-align: top; }
th { background: #f2f2f2; } td.l, th.l { text-align: left; }
td.pass { background: #e3f4e3; } td.fail { background: #fbe3e0; } td.best { font-weight: bold; }
td.warn { background: #fff3cd; }
.matrix td, .matrix th { text-align: left; max-width: 170px; overflow-wrap: anywhere; }
.summary td, .summary th { text-align: left; white-space: nowrap; } .summary td[title] { cursor: help; }
.sw { display: inline-block; width: .8em; height: .8em; margin-right: .3em; border-radius: 2px; }
code { background: #f4f4f4; padding: 0 3px; } p.note { color: #555; } img { max-width: 100%; }
details { margin: .4em 0; } details > summary { cursor: pointer; }
details > summary > h2, details > summary > h3 { display: inline; font-size: 1.15em; }
details.case { border-top: 1px solid #ddd; padding-top: .3em; } details.case[open] { padding-bottom: .8em; }
span.verdict { color: #555; margin-left: .6em; }
div.speeds { display: flex; flex-wrap: wrap; gap: .6em 1.2em; } figure.speed { margin: 0; max-width: 760px; }
figure.speed figcaption { font-size: 12.5px; color: #333; }
div.states { display: flex; flex-wrap: wrap; gap: .6em; } figure.state { margin: 0; text-align: center; }
figure.state img { max-height: 360px; max-width: 360px; image-rendering: pixelated; } figure.state figcaption { font-size: 12px; }
figcaption.pass { color: #1d6b1d; } figcaption.fail { color: #9b2a1a; }
"""

# opens the collapsed section a link points at (#CASE), on load and when the link is followed
SCRIPT = """
function openTarget() {
  const id = decodeURIComponent(location.hash.slice(1));
  const target = id ? document.getElementById(id) : null;
  if (target && target.tagName === "DETAILS") { target.open = true; target.scrollIntoView(); }
}
window.addEventListener("hashchange", openTarget);
openTarget();
function openAll(open) { document.querySelectorAll("details.case").forEach((d) => { d.open = open; }); }
"""


def _matrix_html(results: list[CaseResult]) -> str:
    """Cases down, solvers across."""
    cells = matrix(r for res in results for r in res.records)
    rows = []
    for res in results:
        line = [td(res.name, "l")]
        for row in cells.values():
            c: Cell | None = row.get(res.name)
            line.append(td("not run") if c is None else td(c.text(), "pass" if c.passed else "fail"))
        rows.append(line)
    return table(["case", *map(swatch, cells)], rows, "matrix", markup=True)


def _timeline_html(results: list[CaseResult]) -> str:
    """Cases down, with their boxes, solvers across: steps to recover / steps to settle at each solver's largest
    knob value, so cases that differ only in size (recovery-10, -100, -1000) read as a curve against n."""
    solvers = list(dict.fromkeys(r.solver for res in results for r in case_records(res.records)))
    rows = []
    for res in results:
        line = [td(res.name, "l"), td(res.case.run.scene.size())]
        for solver in solvers:
            recs = sorted((r for r in case_records(res.records) if r.solver == solver), key=lambda r: r.value or 0)
            if not recs:
                line.append(td("not run"))
                continue
            last = recs[-1]
            if last.broke:
                line.append(td("blew up" if last.blew_up else f"crushed at {last.crushed_at}", "fail"))
                continue
            f = shown(last)
            at = f" ({last.knob} {last.value})" if last.knob else ""
            ok = f["steps_to_settle"] != "-"
            line.append(td(f"{f['steps_to_recover']} / {f['steps_to_settle']}{at}", "pass" if ok else "fail"))
        rows.append(line)
    return table(["case", "boxes", *map(swatch, solvers)], rows, "matrix", markup=True)


HEAD = ["solver", "knob", "µs per step (+spread)", "µs per call (+spread)", "error RMS (m/s)", "error max (m/s)", "worst step",
        "own answer: largest violation (m/s)", "own answer: fastest approach (m/s)",
        "final depth (m)", "final gap (m)", "peak depth (m)", "reach (× half-height)", "top rest error (m)",
        "RMS motion (m/s)", "top p2p (m)", "launch (m/s)", "recovered at (step)", "settled at (step)", *NAMES]


def _records_html(res: CaseResult) -> str:
    rows = []
    how = steppings(res)
    for r in case_records(res.records):
        f = shown(r)
        line = [f'<td class="l">{swatch(r.solver)}</td>', td(f"{r.knob} {r.value}" if r.knob else "-", "l"),
                td(timed(r, how.get(r.solver, COMPILED)), "warn" if unstable(r) else "",
                   r.timing.get("unstable") or None),
                td(call_time(r), "warn" if unstable(r) else "", r.timing.get("unstable") or None),
                td(f["error"] if not r.reference else "reference"), td(f["error_max"]), td(f["worst_step"]),
                td(f["violation"]), td(f["approach"])]
        line += [td(f[k]) for k in ("max_depth", "max_gap", "peak_depth", "reach", "top_rest_error", "rms_motion",
                                    "top_p2p", "launch", "steps_to_recover", "steps_to_settle")]
        for name in NAMES:
            v = r.criteria[name]
            if v["passed"] and not v["checks"]:
                line.append(td("not judged"))  # nothing on this scene could fail it (see criteria)
            else:
                line.append(td("pass" if v["passed"] else f"fail: {v['failing']}", "pass" if v["passed"] else "fail"))
        rows.append(line)
    note = per_call_note(res)
    text = table(HEAD, rows) + (f"<p class=note>{esc(note)} (see one_step_per_call).</p>" if note else "")
    plain = plain_note(how)
    text += f"<p class=note>{esc(plain)}.</p>" if plain else ""
    shaky = unstable_note(res)
    return text + (f"<p class=note>{esc(shaky)} (see unstable; hover a figure for why).</p>" if shaky else "")


def _equal_cost_html(res: CaseResult) -> str:
    rows = []
    for row in res.equal_cost:
        ranked = row["solvers"]
        if not ranked:
            rows.append([td(f"{row['target']:g}"), td("no passing run reaches it", "l"), td("-"), td("-", "l")])
            continue
        win = ranked[0]
        others = "; ".join(f"{label(s['solver'], s['knob'], s['value'])} {_us(s)}{_unsolved(s)}"
                           + (" (tied)" if s["solver"] in row["tied"] else "") for s in ranked[1:])
        shaky = f" unstable timing: {', '.join(row['unstable'])}" if row["unstable"] else ""
        rows.append([td(f"{row['target']:g}"), f'<td class="l">{swatch(win["solver"])}{esc(_knob(win))}'
                     f'{esc(_unsolved(win))}{esc(shaky)}</td>',
                     td(_us(win)), td(others or "-", "l")])
    text = table(["error ≤ (m/s)", "fastest to reach it, among runs that passed", "µs per step",
                  "others that reach it, slower (µs per step; tied: within the tolerance)"], rows)
    ref = next((r for r in case_records(res.records) if r.reference), None)
    if ref is not None and ref.us_per_step is not None:
        text += (f"<p class=note>The reference, {swatch(ref.solver)}, solves every step exactly (error 0 by "
                 f"definition) in {ref.us_per_step:.2f} µs per step and {'passed' if ref.passed else 'failed'} "
                 "the case.</p>")
    return text


def _us(row: dict[str, object]) -> str:
    spread = row.get("spread")
    return f"{row['us_per_step']:.3g}" + (f" +{100 * spread:.0f}%" if isinstance(spread, float) else "")


def _unsolved(row: dict[str, object]) -> str:
    """`` (3 steps unsolved)`` after a winner's or another's name where its error holds steps the reference left
    unsolved; empty otherwise."""
    n = row.get("unsolved")
    return f" ({n} step{'s' if n != 1 else ''} unsolved)" if isinstance(n, int) and n else ""


def _front_run(rec: Record, records: list[Record]) -> str:
    """A run on the front as the page names it: its label, its error where within its uncertainty
    (``<= 0.0024``) or where it holds unsolved steps, and ``borderline`` where another bench may leave it
    off."""
    text = label(rec.solver, rec.knob, rec.value)
    if within(rec.error) or unsolved(rec.error):
        text += f" at error {error_text(rec, ' m/s')}"
    return text + (" (borderline)" if borderline(rec, records) else "")


def _knob(row: dict[str, object]) -> str:
    return f" ({row['knob']} {row['value']})" if row["knob"] else ""


def _verdict(res: CaseResult) -> str:
    """The case in one line, beside its collapsed title."""
    shown_runs = outcomes(res.records)
    passing = [r for r in shown_runs if r.passed]
    if not passing:
        return f"no solver passes ({len(shown_runs)} tried)"
    best = passing[0]
    ties = tied_with(best, shown_runs)
    tie = f" (tied within {100 * TIE:.0f}% with {', '.join(r.solver for r in ties)})" if ties else ""
    ref = " (the reference)" if best.reference else f", error {error_text(best, ' m/s')}"
    how = steppings(res).get(best.solver, COMPILED)
    return (f"cheapest that passes: {label(best.solver, best.knob, best.value)}{ref}, {timed(best, how)} µs per "
            f"step{tie}; {len(passing)} of {len(shown_runs)} solvers pass")


def _trajectories_note(res: CaseResult) -> str:
    runs = outcomes(res.records)
    missing = [f"{label(r.solver, r.knob, r.value)} ({failing(r)})" for r in runs if r.series is None]
    text = ("Each solver at the knob value the summary shows: its smallest that passed (solid line), else its "
            "largest tried (dashed): the setting that answers the case, or the most effort a failing solver was "
            "given, to see how it fails. Dotted: the rigid rest height and the depth limit"
            + (", and below, the drift and turn limits of the boxes placed at rest." if _drifts(runs) else "."))
    if missing:
        text += " Not drawn: " + "; ".join(missing) + "."
    return f"<p class=note>{esc(text)}</p>"


def _drifts(runs: list[Record]) -> bool:
    """Whether the runs' series have drift (a planar scene with boxes placed at rest): the plot has its panels."""
    return any(r.series is not None and r.series.drift_x is not None for r in runs)


def _states_html(shots: list[Snapshot]) -> str:
    """The start and each shown run's final state, side by side, captioned and marked passed or failed."""
    figures = "".join(
        f'<figure class="state"><img src="{s.uri}" alt="{esc(s.caption)}"><figcaption'
        f'{"" if s.passed is None else (" class=pass" if s.passed else " class=fail")}>{esc(s.caption)}'
        "</figcaption></figure>" for s in shots)
    return (f'<div class="states">{figures}</div><p class=note>Drawn in one view, at one scale: the scene as it '
            "starts, then where each solver left it at the knob value the summary shows.</p>")


def _case_html(res: CaseResult, pictures: dict[str, str], states: list[Snapshot] | None = None) -> str:
    case, run = res.case, res.case.run
    crit = case.section.criteria
    contacts = run.scene.size() - len(run.scene.events())
    parts = [f'<details class="case" id="{esc(res.name)}"><summary><h2>{esc(res.name)}</h2>'
             f'<span class="verdict">{esc(_verdict(res))}</span></summary>',
             f"<p>{esc(case.spec.description)}</p>",
             f"<p class=note><code>{esc(case.spec.file)}</code>: {run.scene.size()} boxes, dt = {run.dt:.6g} s, "
             f"{run.steps} steps{''.join(f', {esc(repr(e))}' for e in run.scene.events())}. Holds: final depth "
             f"and final gap ≤ {crit.depth_limit:g} m, top box within {crit.rest_limit(contacts):.3g} m of its rigid "
             f"rest height ({crit.rest_factor:g} x {crit.slop:g} m x {contacts} contacts), reach ≤ {crit.reach:g}; "
             f"settled: RMS motion &lt; {crit.settle:g} m/s; never launched: ≤ {crit.launch:g} m/s upward, from "
             "positions.</p>"]
    if run.solver_cls.plugin_name in {p.solver for p in case.plans}:
        own = run.solver_params.model_dump(mode="json")
        parts.append(f"<p class=note>{esc(run.solver_cls.plugin_name)} runs with the config's own settings "
                     f"<code>{esc(json.dumps(own, sort_keys=True))}</code>; the others at their defaults.</p>")
    knobs = "; ".join(f"{p.solver}: {p.knob} {', '.join(map(str, p.values))}" if p.knob else f"{p.solver}: no knob"
                      for p in case.plans)
    parts.append(f"<p class=note>Knob values: {esc(knobs)}.</p>")
    if case.section.set:
        applied = ", ".join(p.solver for p in case.plans if p.applied) or "none"
        skipped = ", ".join(p.solver for p in case.plans if p.skipped) or "none"
        parts.append(f"<p class=note>Settings {esc(case.section.set)} given to: {esc(applied)}; not applicable to "
                     f"(run at their defaults): {esc(skipped)}.</p>")
    if res.left_out:
        parts.append(f"<p class=note>Left out: {esc('; '.join(f'{k}: {v}' for k, v in res.left_out.items()))}.</p>")
    if res.claim:
        parts.append(f"<p><b>Lab claim.</b> {esc(res.claim['text'])}</p>")
    parts.append("<h3>Against time</h3>")
    if "time" in pictures:
        drift = ", drift and turn" if _drifts(outcomes(res.records)) else ""
        parts.append(f'<p><img src="{pictures["time"]}" alt="top box height, largest depth{drift} against time, '
                     f'{esc(res.name)}"></p>' + _trajectories_note(res))
    else:
        parts.append("<p class=note>No picture: no run has a series to draw (every run blew up).</p>")
    if states:
        parts.append("<h3>Start and final states</h3>" + _states_html(states))
    if "drift" in pictures:
        parts.append(f'<h3>Drift of the boxes placed at rest</h3><p><img src="{pictures["drift"]}" alt="sideways '
                     f'drift and turn of each box placed at rest, against its height, {esc(res.name)}"></p>'
                     "<p class=note>Each box the scene places where it should stay, at the height it started, "
                     "and how far it ended sideways and turned, for each solver at the knob value the summary "
                     "shows; the axes span four times the limits (dotted), so millimetres show on a tall pile; "
                     "a box beyond them (toppled, slid off) is a triangle at the edge.</p>")
    parts.append("<h3>Speed against error</h3>")
    if "speed" in pictures:
        parts.append(f'<p class=note>Plotted at the top of the page: <a href="#{esc(_speed_id(res.name))}">speed '
                     f"against error, {esc(res.name)}</a>.</p>")
    else:
        parts.append("<p class=note>No plot: no run has both a time and an error against the exact solver.</p>")
    parts.append("<h3>Equal cost</h3>" + _equal_cost_html(res))
    if res.front:
        front = "; ".join(_front_run(r, res.records) for r in res.front)
        shaky = [label(r.solver, r.knob, r.value) for r in res.front if unstable(r)]
        rests = (f" It rests on unstable timings ({', '.join(shaky)}): another bench may draw it otherwise."
                 if shaky else f" Every time on it is stable; times within {100 * TIE:.0f}% count as the same cost,"
                 " and a run stays on it unless beaten beyond the timings' noise (borderline: another bench may "
                 "leave it off).")
        rests += (" Errors whose intervals (the error less and plus its uncertainty) overlap are tied: the "
                  "cheaper run is the front's; an error within its uncertainty reads '<= u'."
                  if any(uncertainty_spread(r.error) for r in res.front) else "")
        carrying = carrying_unsolved(res.front)
        if carrying:
            rests += (f" {len(carrying)} of its runs carry steps the reference left unsolved, measured against its "
                      "best answer there.")
        parts.append(f"<p class=note>Pareto front of the runs that passed, fastest first: {esc(front)}.{esc(rests)}</p>")
    else:
        parts.append("<p class=note>No Pareto front: no run that passed has both a time and an error.</p>")
    parts.append("<h3>Every run</h3>" + _records_html(res))
    parts.append("</details>")
    return "\n".join(parts)


def _speed_id(case: str) -> str:
    """The id of a case's speed-against-error figure at the top of the page (``#CASE`` is its section)."""
    return f"speed:{case}"


def _speed_html(results: list[CaseResult], pictures: dict[str, dict[str, str]]) -> str:
    """The page's opening: every case's speed-against-error plot, open, each captioned with the case's verdict
    and a link to its section; empty when no case has one."""
    figures = [f'<figure class="speed" id="{esc(_speed_id(res.name))}"><img src="{pictures[res.name]["speed"]}" '
               f'alt="speed against error, {esc(res.name)}"><figcaption><a href="#{esc(res.name)}">'
               f"{esc(res.name)}</a>: {esc(_verdict(res))}</figcaption></figure>"
               for res in results if "speed" in pictures.get(res.name, {})]
    if not figures:
        return ""
    return ("<details open class=speed><summary><h2>Speed against error</h2></summary>"
            "<p class=note>Each run timed and measured against the reference, log-log: microseconds per step "
            "across, RMS error (m/s) up; filled markers passed the case, hollow failed; a diamond carries steps "
            "the reference left unsolved (measured against its best answer); an error within its uncertainty "
            "is drawn at the uncertainty with an arrow down ('<='), others with a thin bar spanning it; the "
            "reference is the vertical line at its time per step. Lower left answers a case: as accurate for "
            "less time. Each case's section has the Pareto front and the fastest solver to reach each error level.</p>"
            f'<div class="speeds">{"".join(figures)}</div></details>')


def report_html(results: list[CaseResult], pictures: dict[str, dict[str, str]], command: str, wall_seconds: float,
                mach: dict[str, object], vers: dict[str, str],
                states: dict[str, list[Snapshot]] | None = None) -> str:
    """The page; ``pictures`` holds per case the ``data:`` URIs of its plots (``time``, ``speed``), ``states``
    the pictures of its start and final states, where it has them."""
    claims = [f"<li><b>{esc(res.name)}</b>: {esc(res.claim['text'])}</li>" for res in results if res.claim]
    defs = "".join(f"<li><b>{esc(k)}</b>: {esc(v)}</li>" for k, v in DEFINITIONS.items())
    blown = [r for res in results for r in res.records if r.blew_up]
    page = [
        "<!doctype html><html lang='en'><head><meta charset='utf-8'><link rel='icon' href='data:,'>"
        "<title>stackx bench</title>",
        f"<style>{CSS}</style></head><body>",
        "<h1>stackx bench</h1>",
        f"<p class=note><code>{esc(command)}</code> took {wall_seconds:.1f} s on {esc(mach['platform'])}, "
        f"{mach['cpus']} CPUs, compiled kernels {'on' if mach['compiled_kernels'] else 'off'}; "
        f"{esc(', '.join(f'{k} {v}' for k, v in vers.items()))}.</p>",
        _speed_html(results, pictures),
        "<h2 id=summary>Summary</h2>",
        summary_html(results),
        "<h2>Cases</h2>",
        "<p><button type=button onclick='openAll(true)'>open all</button> "
        "<button type=button onclick='openAll(false)'>close all</button></p>",
    ]
    page += [_case_html(res, pictures.get(res.name, {}), (states or {}).get(res.name, [])) for res in results]
    page += ["<details open><summary><h2>Stability matrix</h2></summary>",
             "<p class=note>Each cell: the knob values at which the solver passed all three criteria, or, when it "
             "passed at none, what failed at the largest knob value tried.</p>",
             _matrix_html(results)]
    if blown:
        page.append("<p class=note>Runs that blew up: " + "; ".join(
            f"{esc(label(r.solver, r.knob, r.value))} on {esc(r.case)} {esc(failing(r))}" for r in blown) + ".</p>")
    page += ["</details>",
             "<details open><summary><h2>Steps to recover / steps to settle</h2></summary>",
             "<p class=note>At each solver's largest knob value: the step from which no contact overlaps beyond the "
             "depth limit, and the step from which the column also has no gap beyond it and moves below the "
             "settled limit, to the end of the run ('-': not by the end). Cases that differ only in their number "
             "of boxes show how recovery grows with the height of the column.</p>",
             _timeline_html(results), "</details>"]
    if claims:
        page += ["<details open><summary><h2>The lab's claims, measured</h2></summary>",
                 "<ul>" + "".join(claims) + "</ul></details>"]
    page += ["<details><summary><h2>Definitions</h2></summary>", f"<ul>{defs}</ul></details>",
             f"<script>{SCRIPT}</script>", "</body></html>"]
    return "\n".join(page) + "\n"

