"""The run tables show a run's own-answer figures beside its error: the largest violation with its condition,
and the fastest approach; '-' where a solver exposes no impulses, and for a run that broke."""

from __future__ import annotations

from stackx.bench.result import shown
from stackx.bench.sweep import Record


def _record(error: dict, blew_up: str | None = None) -> Record:
    return Record("stack", "planar-pgs", "iterations", 4, "", {}, error=error, blew_up=blew_up)


def test_the_largest_violation_is_shown_with_its_condition_and_the_approach_beside_it() -> None:
    worst = {"penetration": 0.125, "pull": 0.0, "complementarity": 0.5, "box": 0.0, "dissipation": 0.25}
    f = shown(_record({"rms": 0.1, "violation_max": worst, "violation_worst": "complementarity",
                       "approach_max": 0.125}))
    assert (f["violation"], f["approach"]) == ("0.5 complementarity", "0.125")


def test_an_answer_that_breaks_nothing_names_no_condition() -> None:
    f = shown(_record({"rms": 0.0, "violation_max": dict.fromkeys(("penetration", "pull"), 0.0),
                       "violation_worst": "penetration", "approach_max": 0.0}))
    assert (f["violation"], f["approach"]) == ("0", "0")


def test_without_impulses_only_the_approach_is_shown() -> None:
    f = shown(_record({"rms": 0.1, "violation_max": None, "violation_worst": None, "approach_max": 0.0625}))
    assert (f["violation"], f["approach"]) == ("-", "0.0625")
    f = shown(_record({"rms": 0.1}))  # the column's step log has neither
    assert (f["violation"], f["approach"]) == ("-", "-")
    f = shown(_record({"rms": 0.1, "approach_max": 0.0625}, blew_up="box 3 too fast"))
    assert (f["violation"], f["approach"]) == ("-", "-")
