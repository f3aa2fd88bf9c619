"""The lab's claims about its settings, measured: the case's setting against the lab's, run for run.

A claim (``bench.claim``) says a setting makes a settled stack keep moving: percent 1.0 oscillates, slop 0
jitters. Every solver that has the setting runs each knob value twice, with the case's setting and with
the lab's (the claim's baseline). A pair bears the claim out when the case's setting is still moving at the
end (RMS motion at or above the ``settled`` limit) while the lab's setting has settled. The finding, and
every number in it, is written from the measurements.
"""

from __future__ import annotations

import statistics
from typing import Any

from stackx.bench.plan import BASELINE, CASE, Case
from stackx.bench.sweep import Record
from stackx.models.column.measures import MOTION_WINDOW

COMPARED = ("rms_motion", "top_p2p", "top_reversals", "top_rise", "max_depth", "launch")


def pairs(records: list[Record]) -> list[tuple[Record, Record]]:
    """(case setting, lab setting) records of the same solver and knob value, neither blown up nor crushed."""
    base = {(r.solver, r.value): r for r in records if r.variant == BASELINE and not r.broke}
    return [(r, base[(r.solver, r.value)]) for r in records
            if r.variant == CASE and not r.broke and (r.solver, r.value) in base]


def _settings(values: dict[str, Any]) -> str:
    return ", ".join(f"{k} = {v}" for k, v in values.items())


def _numbers(rec: Record) -> str:
    m = rec.measures
    return (f"RMS motion {m['rms_motion']:.3g} m/s, top-box peak-to-peak {m['top_p2p']:.3g} m over the last "
            f"{MOTION_WINDOW} steps, final depth {m['max_depth']:.3g} m, fastest launch {m['launch']:.3g} m/s; "
            f"over the run the top box changed direction {_n(int(m['top_reversals']), 'time')} and rose at most "
            f"{m['top_rise']:.3g} m/s")


def finding(case: Case, records: list[Record]) -> dict[str, Any] | None:
    """The claim of ``case`` measured: counts, the config's own solver at its own setting, and a verdict text."""
    claim = case.section.claim
    if claim is None:
        return None
    settle = case.section.criteria.settle
    found = pairs(records)
    borne = [(a, b) for a, b in found if a.measures["rms_motion"] >= settle > b.measures["rms_motion"]]
    both = [(a, b) for a, b in found if a.measures["rms_motion"] >= settle and b.measures["rms_motion"] >= settle]
    more = [(a, b) for a, b in found if a.measures["top_p2p"] > b.measures["top_p2p"]]
    setting, baseline = _settings(case.section.set), _settings(claim.baseline)
    own = {p.solver: p.own for p in case.plans if p.own is not None}
    lines = [f"The lab says: {claim.text}. Measured on {case.name} with {setting} against the lab's {baseline}, "
             f"on {len(found)} pairs of runs (every solver with the setting, every knob value)."]
    for a, b in found:
        if a.solver in own and own[a.solver] == a.value:
            lines.append(f"At the config's own setting ({a.solver}, {a.knob} {a.value}): with {setting}: "
                         f"{_numbers(a)}; with {baseline}: {_numbers(b)}.")
    p2p = (statistics.median(a.measures["top_p2p"] for a, _ in found),
           statistics.median(b.measures["top_p2p"] for _, b in found)) if found else (0.0, 0.0)
    if not found:
        verdict = "not measured: no chosen solver has the setting"
    elif len(borne) == len(found):
        verdict = f"borne out in every pair: {setting} keeps moving where {baseline} settles"
    elif borne:
        verdict = (f"borne out in {_n(len(borne), 'pair')} of {len(found)} ({_where(borne)}): {setting} keeps "
                   f"moving where {baseline} settles")
    elif 2 * len(more) > len(found):
        verdict = (f"seen only below the settled limit: the top box moves more with {setting} in {len(more)} of "
                   f"{len(found)} pairs (median peak-to-peak {p2p[0]:.3g} m against {p2p[1]:.3g} m), but in no "
                   f"pair does it keep moving at {settle:g} m/s or more where {baseline} settles")
    else:
        verdict = (f"not borne out: in no pair does {setting} keep moving (RMS motion >= {settle:g} m/s) where "
                   f"{baseline} settles, and the top box moves more with it in only {len(more)} of {len(found)}")
    if both:
        verdict += f"; in {_n(len(both), 'pair')} both settings keep moving ({_where(both)})"
    if found:
        verdict = f"at the end, {verdict}; during the run, {_bounces(found, setting)}"
    lines.append(f"The top box moves more (peak-to-peak over the last {MOTION_WINDOW} steps) with {setting} than with "
                 f"{baseline} in {len(more)} of {len(found)} pairs; medians {p2p[0]:.3g} m and {p2p[1]:.3g} m.")
    lines.append(f"Finding: {verdict}.")
    return {"claim": claim.text, "setting": case.section.set, "baseline": claim.baseline, "pairs": len(found),
            "borne_out": len(borne), "both_moving": len(both), "top_moves_more": len(more),
            "borne_out_at": _where(borne), "verdict": verdict, "text": " ".join(lines),
            "rows": [{"solver": a.solver, "knob": a.knob, "value": a.value,
                      "case": {k: a.measures[k] for k in COMPARED}, "baseline": {k: b.measures[k] for k in COMPARED}}
                     for a, b in found]}


def _bounces(found: list[tuple[Record, Record]], setting: str) -> str:
    """Whole-run comparison: how often the top box changes direction, and how fast it rises."""
    more = [(a, b) for a, b in found if a.measures["top_reversals"] > b.measures["top_reversals"]]
    turns = (statistics.median(a.measures["top_reversals"] for a, _ in found),
             statistics.median(b.measures["top_reversals"] for _, b in found))
    rise = (max(a.measures["top_rise"] for a, _ in found), max(b.measures["top_rise"] for _, b in found))
    how = "more often" if 2 * len(more) > len(found) else "no more often"
    return (f"the top box changes direction {how} with {setting} (more in {len(more)} of {len(found)} pairs; "
            f"median {turns[0]:g} against {turns[1]:g} times) and rises at most {rise[0]:.3g} m/s against "
            f"{rise[1]:.3g} m/s")


def _n(count: int, word: str) -> str:
    return f"{count} {word}{'' if count == 1 else 's'}"


def _where(found: list[tuple[Record, Record]]) -> str:
    by: dict[str, list[str]] = {}
    for a, _ in found:
        by.setdefault(a.solver, []).append(str(a.value))
    return "; ".join(f"{s} at {', '.join(v)}" for s, v in by.items())
