"""The stability matrix cell of one solver on one case, from records judged by the hard cases' criteria."""

from __future__ import annotations

from stackx.bench.compare import cell, chosen, equal_cost, pareto, why
from stackx.bench.sweep import Record
from stackx.bench.criteria import Criteria, judge, passed

CALM = {"max_depth": 0.005, "max_gap": 0.0, "top_rest_error": -0.03, "boxes": 6, "reach": 0.01, "rms_motion": 0.0,
        "launch": 0.0}


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
    assert got.short() == "FAIL overlaps, crushed, moving"  # the words the report's summary uses
    assert got.text().startswith("FAIL at iterations 64: holds: max_depth 2.2 > 0.02; reach 4.4 > 1; settled:")


def test_a_passing_cell_gives_the_smallest_passing_knob_and_the_count() -> None:
    got = cell([_record(1, max_depth=0.5), _record(16), _record(4)])
    assert got.passed and got.passing == [4, 16] and got.short() == "pass 4 (2/3)"


def test_a_blown_up_cell_says_so() -> None:
    rec = Record("drop", "pgs", "iterations", 8, "case", {"iterations": 8}, blew_up="run 'x' blew up at step 3")
    rec.criteria = {name: {"passed": False, "failing": "blew up", "checks": []}
                    for name in ("holds", "settled", "never_launched")}
    got = cell([rec])
    assert got.short() == "FAIL blew up at step 3" and got.failing == "blew up: at step 3"


def test_a_crushed_cell_says_where_and_shows_no_figure() -> None:
    rec = _record(64, max_depth=114.0, reach=228.0, top_rest_error=-3228.0)
    rec.crushed_at = 40
    got = cell([_record(4, launch=3.0), rec])
    assert not got.passed and got.short() == "FAIL crushed at step 40" and got.crushed_at == 40
    assert got.text() == ("FAIL at iterations 64: crushed at step 40 (boxes passed through each other; its figures "
                          "are left out)")


def _timed(solver: str, value: int | None, us: float, error: float, crushed_at: int | None = None) -> Record:
    rec = _record(value or 0)
    rec.solver, rec.value, rec.us_per_step, rec.error, rec.crushed_at = solver, value, us, {"rms": error}, crushed_at
    rec.reference = solver == "exact"  # the column's reference, as the sweep marks it
    return rec


def test_fronts_and_winners_leave_out_the_reference_and_crushed_runs() -> None:
    """exact is error 0 by definition and a crushed run's error describes no column: neither may win."""
    records = [_timed("exact", None, 0.1, 0.0), _timed("pgs", 4, 0.2, 1e-7, crushed_at=12),
               _timed("pgs", 16, 1.0, 1e-3), _timed("warm-start", 8, 0.5, 1e-2)]
    assert [(r.solver, r.value) for r in pareto(records)] == [("warm-start", 8), ("pgs", 16)]
    rows = {row["target"]: row for row in equal_cost(records)}
    assert rows[1e-2]["winner"] == "warm-start" and rows[1e-3]["winner"] == "pgs"
    assert rows[1e-6]["winner"] is None
    assert all(s["solver"] != "exact" for row in rows.values() for s in row["solvers"])


def test_fronts_and_winners_leave_out_runs_that_failed() -> None:
    """A run faster and more accurate than every other, whose column sank (max_depth 0.5 m > 0.02 m): it fails
    the case, so it is on no front and wins no error level."""
    sunk = _record(4, max_depth=0.5)
    sunk.solver, sunk.us_per_step, sunk.error = "jacobi", 0.05, {"rms": 1e-7}
    assert not sunk.passed
    records = [sunk, _timed("pgs", 16, 1.0, 1e-3), _timed("warm-start", 8, 0.5, 1e-2)]
    assert [(r.solver, r.value) for r in pareto(records)] == [("warm-start", 8), ("pgs", 16)]
    rows = {row["target"]: row for row in equal_cost(records)}
    assert rows[1e-6]["winner"] is None and rows[1e-3]["winner"] == "pgs" and rows[1e-2]["winner"] == "warm-start"
    assert all(s["solver"] != "jacobi" for row in rows.values() for s in row["solvers"])


def test_summary_words_name_what_failed() -> None:
    """A sunk, still moving run reads 'overlaps, sunk, moving' (the top box 0.5 m low); a crushed one says
    where; the shown run is the smallest passing knob value, else the largest."""
    low = _record(64, max_depth=0.5, top_rest_error=-0.5, rms_motion=0.1)
    assert why(low) == "overlaps, sunk, moving"
    high = _record(64, top_rest_error=0.5)
    assert why(high) == "high"
    crushed = _record(64, reach=3.0)
    crushed.crushed_at = 40
    assert why(crushed) == "crushed at step 40"
    assert chosen([_record(1, max_depth=0.5), _record(16), _record(4)]).value == 4
    assert chosen([_record(1, max_depth=0.5), _record(16, max_depth=0.5)]).value == 16
