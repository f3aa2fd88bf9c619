"""A benched case and how its records read: what is derived from them, the figures tables show, and the
definitions every output of the bench prints."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from stackx.bench.claims import finding
from stackx.bench.compare import TARGETS, TIE, equal_cost, pareto
from stackx.bench.markup import number
from stackx.bench.plan import Case
from stackx.bench.sweep import Record
from stackx.bench.timing import UNSTABLE
from stackx.bench.criteria import digits
from stackx.bench.uncertainty import error_text, figure
from stackx.models.touch import TOUCH_GAP
from stackx.models.column.measures import MOTION_WINDOW, STILL

UNSTABLE_MARK = "!"  # after a timing flagged unstable (see DEFINITIONS)

DEFINITIONS = {
    "holds": "in the final state every contact (the floor's included) overlaps by at most max_depth <= "
             "criteria.depth_factor x criteria.slop and has at most that much gap (max_gap: a column resting on "
             "air does not hold); the top box ends within |top_rest_error| <= criteria.rest_factor x criteria.slop "
             "x contacts of its rigid rest height; and no box ever passed half-way into its neighbour or below "
             "the floor (reach <= criteria.reach, 1 by default)",
    "settled": f"the RMS of the boxes' actual motion (y_now - y_prev)/dt over the last {MOTION_WINDOW} steps is "
               "below criteria.settle (stored velocities that move nothing do not count)",
    "never_launched": "no box moved upward faster than criteria.launch after it first touched something (a "
                      f"contact overlapping, at zero depth, or at most {TOUCH_GAP:g} m apart: a solver that leaves "
                      "its contacts exactly touching, or an engine that rests boxes on a skin, is judged too), "
                      "measured from positions after every step, (y_now - y_prev)/dt, the same way for every "
                      "solver: a position correction that throws a box up counts although it never touches a "
                      "velocity",
    "crushed": "a box passed half-way into its neighbour at some step (reach above criteria.reach): the column's "
               "order no longer says which box rests on which, so the run's depths, heights and errors are left "
               "out of the tables, the speed-against-error plot, Pareto fronts and equal-cost winners, its line "
               "against time stops at the step before (marked x), and its cell says where it was crushed",
    "error": "along the solver's own run, at every step: from the state before the step, the exact solver's "
             "velocity stage gives the step's exact velocities (gravity, then no contact approaching and none "
             "pulling, solved to machine precision); the error is the RMS over all steps and boxes of the "
             "solver's stored velocity after the step minus the exact one (m/s), with the largest difference and "
             "the step it came at (0-based). Comparing on the solver's own path measures how well each step is "
             "solved; running both side by side would compare two piles that part ways within a few steps. It "
             "includes what a solver does on purpose that a rigid contact does not (a bias pushing apart, soft "
             "contacts, substeps, speculative contacts). A crushed run's error stops where it was crushed. On the "
             "planar model the reference may fail to solve a step to its tolerance (it says so rather than guess): "
             "the error then measures those steps against its best answer, counts them in, and says how many "
             "and the largest residual left ('0.0124 (3 steps unsolved, residual <= 2.4e-6 m/s)'); the run stays "
             "in the plots (drawn as a diamond), fronts and winners, which name it. Shown with its uncertainty "
             "where measured: see uncertainty.",
    "uncertainty": "(planar) a step may have more than one exact answer (a pile resting on friction), and the "
                   "reference finds one: the error's uncertainty (error.spread in bench.json, m/s) is how far "
                   "apart the exact answers found lie, RMS over steps and boxes as the error (spread_max: "
                   "the largest for one box). An error above it reads '0.0124 ± 0.0004'; at or below it, "
                   "'<= 0.0024': it cannot be told from zero, is drawn at the uncertainty with an arrow down, "
                   "and reaches an error level only when the uncertainty does. Two runs whose intervals (the "
                   "error less and plus its uncertainty) overlap are tied on error: fronts and winners rank them "
                   "by cost; one is more accurate only when its interval lies wholly below. A column run has none "
                   "(0)",
    "violation": "(planar) the solver's own answer checked against each step's contact conditions, needing no "
                 "reference: on the step problem the error's reference sets, the impulses the solver's step "
                 "applied (a single velocity solve's accumulated impulses; the soft step's summed over its "
                 "substeps, which give its stored velocities on that problem exactly) give the largest violation "
                 "over points and steps of each condition, in m/s: penetration (a point approaching faster than "
                 "its target), pull (a negative normal impulse, as the speed it would give the point alone), "
                 "complementarity (a point pushing while it separates: the smaller of the two), box (friction "
                 "beyond mu times the normal impulse) and dissipation (a point slipping while its friction is "
                 "inside the box, or friction at the bound not opposing the slip). Shown: the largest, with its "
                 "condition; bench.json keeps each condition's (violation_max), the RMS over steps of each "
                 "step's worst (violation_rms) and the steps checked. 0 for an exact answer. A soft or "
                 "substepped contact reads as violating where it does on purpose what one rigid step does not "
                 "(pushing an overlap apart). '-' for a solver whose velocities no impulses on the step's "
                 "problem give (XPBD's come from positions) and for engines: see approach",
    "approach": "(planar) from the solver's stored velocities alone, for every solver and engine: the fastest "
                "any point approaches beyond its target on the step's problem (sinks faster than the step "
                "allows), largest over the run (approach_max; the RMS over steps is approach_rms), m/s; 0 for an "
                "exact answer",
    "steps_to_recover": "the step from which every contact overlaps by at most criteria.depth_factor x "
                        "criteria.slop to the end of the run; - when the run ends overlapping",
    "steps_to_settle": "the step from which every contact is within that depth and that gap and the RMS motion "
                       "of each step is below criteria.settle, to the end of the run; - when it never gets there",
    "us_per_step": "microseconds per step of one run alone, from the scene's start (up to bench.timing.steps "
                   "steps, before any scene event), stepped in one call, compiled, on one thread, timed by the "
                   "CPU time of that thread (time the machine gives other work is not counted): the fastest of "
                   "bench.timing.repeats runs after an untimed warm-up, every repeat kept in bench.json; with what "
                   "follows from them (equal cost, Pareto fronts, plots) the only numbers that change between two "
                   "benches of the same configs. Shown with its spread, e.g. '5.31 +2%'",
    "us_per_call": "the same, one step per call, as a game loop or an engine bound to Python is stepped: the "
                   "figure to set beside pymunk, Box2D or MuJoCo",
    "spread": "how far the median repeat is above the fastest, as a share of it ('+2%'): how much the figure "
              "could move in another bench",
    "unstable": f"a timing whose spread is above {100 * UNSTABLE:.0f}%, or whose µs/step came out above its "
                "µs/call (many steps in one call cannot cost more than one call per step but by noise): marked "
                f"'{UNSTABLE_MARK}', and a front or winner resting on it says so; bench again on a quieter "
                "machine, or raise bench.timing.repeats",
    "one_step_per_call": "an engine (pymunk, Box2D, MuJoCo) steps once per Python call and has no way to take "
                         "many steps in one, so it is timed per call only and its µs/step is its µs/call, marked "
                         "'*'; it includes copying the bodies' heights and velocities back into the column and the "
                         "column's monitors after every step",
    "knob": "each solver's cost knob (its 'knob' attribute, else its iterations or substeps parameter) runs at "
            "the values of bench.knob (or bench.knobs for that solver); the config's own solver also runs at "
            "the config's own value; a solver without a knob runs once",
    "top_rest_error": "final height of the top box minus its height on a rigid column (heights of the boxes "
                      "below plus its half-height); negative: the column sank",
    "top_p2p": f"peak-to-peak height of the top box over the last {MOTION_WINDOW} steps",
    "planar": "planar cases are judged by the same criteria with the checks that can fail on them: 'holds' "
              "adds drift_x <= criteria.drift and drift_angle <= criteria.turn for the boxes the scene places "
              "where they should stay; on a ramp, the outcome statics gives the box (stick, slide, tip over or "
              "pivot on its downhill corner, from tan(angle), mu and its width/height): slide_error <= criteria.slide and "
              "slide_turn <= criteria.turn where it sticks or slides, tip_turn >= criteria.tip where it goes over; "
              "on a skid, stop_error <= criteria.stops; top_rest_error is judged where "
              "a rigid pile gives the top box a rest height (stacks, pyramids, heavy on light), over the contacts "
              "under it (rest_contacts); max_gap is not measured; a box sliding down a ramp is not judged "
              "'settled' (a verdict with nothing to judge reads 'not judged')",
    "drift_x": "(planar) the largest horizontal distance a box placed at rest ended from where it started (m)",
    "drift_angle": "(planar) the largest angle a box placed at rest ended turned from how it started (rad); a "
                   "toppled box has turned by about 1.57",
    "slide_error": "(planar ramp) the box's acceleration down the slope, its final velocity along the slope over "
                   "the run's time from rest, minus the analytic answer: 0 where tan(angle) <= mu (it sticks), "
                   "g (sin a - mu cos a) where it slides (m/s^2)",
    "slide_turn": "(planar ramp) how far a box that sticks or slides flat ended turned from how it started (rad)",
    "tip_turn": "(planar ramp) how far a box that must tip or pivot over its downhill corner turned downhill (rad): "
                "about 1.57 once it lies on its next face",
    "stop_distance": "(planar skid) how far a box given a velocity on flat ground went before it stopped (m)",
    "stop_error": "(planar skid) how far the stopping distance lies outside the range from the model's stepped "
                  "distance to v^2 / (2 mu g), as a share of v^2 / (2 mu g); 0 inside it",
    "top_reversals": "(cases with a claim) how many times the top box's step-to-step motion changed direction "
                     f"over the whole run once it rested on something, steps under {STILL:g} m skipped",
    "top_rise": "(cases with a claim) the top box's fastest upward motion from positions, (y_next - y)/dt",
    "claim": "a lab claim is measured on pairs of runs, the case's setting and the lab's, for every solver that "
             "has the setting and every knob value; a pair bears it out when the case's setting still moves at "
             "the end (RMS motion at or above criteria.settle) where the lab's has settled",
    "equal_cost": f"for each error level ({', '.join(f'{t:g}' for t in TARGETS)} m/s), the solver whose cheapest "
                  "run at or below that error (its uncertainty too, where the error is within it) takes the "
                  "fewest microseconds per step, among runs that passed the case (a run that fails is no answer, "
                  "however fast and accurate its steps), with the solvers "
                  f"tied with it (a time at most {100 * TIE:.0f}% above the winner's, as measured, not moved by "
                  "its noise: the same cost, as timings go; a noisy time is flagged unstable instead); the "
                  "reference is left out "
                  "(its error is zero by definition) and its time shown beside",
    "pareto": "among runs that passed the case, those that no other passing run beats: at least as accurate "
              "(or tied with it on error: see uncertainty) and "
              f"more than {100 * TIE:.0f}% faster, or more accurate and not {100 * TIE:.0f}% slower (times "
              "closer than that are the same cost), with both times moved in the run's favour by their noise "
              "(their spread, at least 5%); a run beaten only without that move is on the front, marked "
              "borderline ('?'): another bench may leave it off. The reference is left out; runs that failed are "
              "drawn hollow but never on the front",
    "cheapest": "the case's answer in the summary: each solver at its smallest knob value that passed, and of "
                "those the one with the fewest microseconds per step, the reference included (its time is as "
                "real as any); the other solvers fail for the reasons their cells give, at the largest knob "
                "value they tried",
    "against_time": "the top box's height and the largest contact depth at some 200 evenly spaced steps of each "
                    "solver's run at the knob value the summary shows (its smallest passing one, else its "
                    "largest): the run that answers the case, or the most a failing solver was given, so the "
                    "picture shows how it fails",
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


MEASURES = ("max_depth", "max_gap", "peak_depth", "top_rest_error", "rms_motion", "top_p2p", "launch",
            "steps_to_recover", "steps_to_settle")


PER_CALL_MARK = "*"  # after an engine's µs/step: timed one step per call, the only way it can be stepped


def _timed(value: float | None, spread: float | None, rec: Record) -> str:
    if value is None:
        return "-"
    text = f"{value:.3g}" if value < 1000 else f"{value:.0f}"
    if spread is not None:
        text += f" +{100 * spread:.0f}%"
    return text + (UNSTABLE_MARK if rec.timing.get("unstable") else "")


def step_time(rec: Record) -> str:
    """A record's µs/step for a table, with its spread: ``5.31 +2%``; ``!`` after it when the timing is
    unstable; an engine's, which is its µs/call, marked ``*`` (see DEFINITIONS)."""
    text = _timed(rec.us_per_step, rec.timing.get("spread"), rec)
    return text + PER_CALL_MARK if rec.us_per_step is not None and rec.timing.get("one_step_per_call") else text


def call_time(rec: Record) -> str:
    """A record's µs/call for a table, with its spread, as ``step_time``."""
    return _timed(rec.us_per_call, rec.timing.get("call_spread"), rec)


def unstable_note(res: CaseResult) -> str:
    """The line under a case's table when a timing in it is unstable; empty otherwise."""
    flagged = [r for r in res.records if r.timing.get("unstable")]
    if not flagged:
        return ""
    first = flagged[0]
    return (f"{UNSTABLE_MARK} {len(flagged)} timing{'s' if len(flagged) > 1 else ''} unstable (e.g. {first.solver}"
            f"{f' {first.value}' if first.knob else ''}: {first.timing['unstable']}): fronts and winners resting "
            "on them may differ in another bench")


def per_call_note(res: CaseResult) -> str:
    """The line under a case's table when an engine is in it; empty otherwise."""
    if not any(r.timing.get("one_step_per_call") for r in res.records):
        return ""
    return f"{PER_CALL_MARK} an engine, stepped once per Python call: its µs/step is its µs/call"


def shown(rec: Record) -> dict[str, str]:
    """A record's figures as a table shows them: '-' where there is none, and none of a run that broke (a
    crushed run keeps only its reach, which says by how much)."""
    if rec.broke:
        figures = {k: "-" for k in ("error", "error_max", "worst_step", "violation", "approach", *MEASURES)}
        figures["reach"] = "-" if rec.blew_up else number(rec.measures.get("reach"))
        return figures
    m, e = rec.measures, rec.error
    figures = {"error": error_text(e), "error_max": figure(e.get("max"), e.get("spread_max")),
               "worst_step": number(e.get("worst_step"), "d"), "reach": number(m.get("reach"))}
    worst = e.get("violation_worst")
    largest = None if worst is None else e["violation_max"][worst]
    figures["violation"] = "-" if worst is None else number(largest) + (f" {worst}" if largest else "")
    figures["approach"] = number(e.get("approach_max"))
    for k in MEASURES:
        figures[k] = number(m.get(k), "g" if k.startswith("steps_") else ".3g")
    for verdict in rec.criteria.values():  # a measure judged against a limit shows the digits that tell them apart
        for check in verdict["checks"]:
            key = check["measure"].strip("|")
            if key in figures and m.get(key) is not None:
                figures[key] = format(m[key], f".{digits(check['value'], check['limit'])}g")
    return figures
