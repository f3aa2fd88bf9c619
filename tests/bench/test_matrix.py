"""The stability matrix cell of one solver on one case, from records judged by the hard cases' criteria."""

from __future__ import annotations

from stackx.bench.compare import cell
from stackx.bench.sweep import Record
from stackx.criteria import Criteria, judge, passed

CALM = {"max_depth": 0.005, "reach": 0.01, "rms_motion": 0.0, "launch": 0.0}


def _record(value: int, **measures: float) -> Record:
    rec = Record("tall-6", "pgs", "iterations", value, "case", {"iterations": value}, {**CALM, **measures})
    verdicts = judge(rec.measures, Criteria())
    rec.criteria = {name: v.as_dict() for name, v in verdicts.items()}
    rec.passed = passed(verdicts)
    return rec


def test_a_failing_cell_names_every_measure_that_failed_at_the_largest_knob() -> None:
    """Sunk 2.2 m, 4.4 half-heights deep and still moving: 'holds' fails on both its measures, 'settled' on its
    one; all three are named, in the order of the criteria."""
    sunk = {"max_depth": 2.2, "reach": 4.4, "rms_motion": 0.5}
    got = cell([_record(4, launch=3.0), _record(64, **sunk)])
    assert not got.passed and got.shown == 64
    assert got.short() == "FAIL max_depth reach rms_motion"
    assert got.text().startswith("FAIL at iterations 64: holds: max_depth 2.2 > 0.02; reach 4.4 > 1; settled:")


def test_a_passing_cell_gives_the_smallest_passing_knob_and_the_count() -> None:
    got = cell([_record(1, max_depth=0.5), _record(16), _record(4)])
    assert got.passed and got.passing == [4, 16] and got.short() == "pass 4 (2/3)"


def test_a_blown_up_cell_says_so() -> None:
    rec = Record("drop", "pgs", "iterations", 8, "case", {"iterations": 8}, blew_up="run 'x' blew up at step 3")
    rec.criteria = {name: {"passed": False, "failing": "blew up", "checks": []} for name in CALM}
    got = cell([rec])
    assert got.short() == "FAIL blew up" and got.failing == "blew up: at step 3"
