"""The pass criteria of the hard cases (notes/hard-cases.md), judged from measures made up in the test."""

from __future__ import annotations

import numpy as np
import pytest

from stackx import kernel
from stackx.bench.criteria import Criteria, judge, passed
from stackx.models.column.monitor import observe
from stackx.models.column.state import ColumnState

LAB = Criteria()  # the hard cases' definitions: 2 x slop 0.01, RMS motion below 1e-4 m/s, launch up to 1 m/s


def measures(depth: float = 0.01, reach: float = 0.1, motion: float = 0.0, launch: float = 0.0, gap: float = 0.0,
             rest: float = -0.05, boxes: int = 5) -> dict[str, float]:
    return {"max_depth": depth, "reach": reach, "rms_motion": motion, "launch": launch, "max_gap": gap,
            "top_rest_error": rest, "boxes": boxes}


def test_defaults_are_the_hard_cases_definitions() -> None:
    assert LAB.depth_limit == pytest.approx(0.02)
    assert (LAB.settle, LAB.launch, LAB.reach) == (1e-4, 1.0, 1.0)


@pytest.mark.parametrize("depth, holds", [(0.0, True), (0.02, True), (0.0201, False), (0.5, False)])
def test_holds_allows_twice_the_slop(depth: float, holds: bool) -> None:
    v = judge(measures(depth=depth), LAB)
    assert v["holds"].passed is holds
    assert v["settled"].passed and v["never_launched"].passed


@pytest.mark.parametrize("reach, holds", [(0.99, True), (1.0, True), (1.01, False), (30.0, False)])
def test_holds_fails_once_a_box_passed_half_way(reach: float, holds: bool) -> None:
    """A final depth inside the limit does not save a run whose boxes once passed half-way into each other."""
    assert judge(measures(depth=0.0, reach=reach), LAB)["holds"].passed is holds


@pytest.mark.parametrize("motion, settled", [(0.0, True), (9.99e-5, True), (1e-4, False), (0.3, False)])
def test_settled_needs_motion_strictly_below(motion: float, settled: bool) -> None:
    assert judge(measures(motion=motion), LAB)["settled"].passed is settled


@pytest.mark.parametrize("launch, ok", [(0.0, True), (1.0, True), (1.0001, False), (12.0, False)])
def test_launch_above_one_metre_per_second_fails(launch: float, ok: bool) -> None:
    assert judge(measures(launch=launch), LAB)["never_launched"].passed is ok


def test_failing_names_the_measure_and_its_limit() -> None:
    v = judge(measures(depth=1.42, reach=2.8, motion=1.02, launch=3.9), LAB)
    assert not passed(v)
    assert v["holds"].failing == "max_depth 1.42 > 0.02; reach 2.8 > 1"
    assert v["settled"].failing == "rms_motion 1.02 >= 0.0001"
    assert v["never_launched"].failing == "launch 3.9 > 1"
    assert passed(judge(measures(), LAB))


def test_limits_come_from_the_section() -> None:
    loose = Criteria(slop=0.05, depth_factor=1.0, settle=1e-2, launch=5.0)
    v = judge(measures(depth=0.04, motion=5e-3, launch=4.0), loose)
    assert passed(v)
    assert not judge(measures(depth=0.04, motion=5e-3, launch=4.0), LAB)["holds"].passed


def test_a_nan_measure_never_passes() -> None:
    v = judge(measures(depth=float("nan"), motion=float("nan"), launch=float("nan")), LAB)
    assert not any(x.passed for x in v.values())


def _observed(y: list[float], v: list[float], dt: float = 0.5) -> dict[str, float]:
    """Monitors of a column after one observed step that started at ``y`` (where touching boxes count as having
    touched) and moved each box by ``v * dt``: the launch is that motion, whatever velocity was stored."""
    state = ColumnState(np.array([y]), np.zeros((1, len(y))), np.ones((1, len(y))), np.full((1, len(y)), 0.5))
    state.y[0] += np.array(v) * dt
    with kernel.compiled(False):  # one call: the plain path, no compiler to load
        observe(state.y[0], state.half[0], dt, *state.monitors(), 0)
    return {**measures(depth=float(state.penetration()[0].max()), reach=float(state.reach[0]),
                       launch=float(state.launch[0]), boxes=len(y))}


def test_criteria_read_the_monitors_as_the_hard_cases_mean_them() -> None:
    """Box 1 sunk 0.6 into box 0 (more than half of a 0.5 half-height): reach 1.2, 'holds' fails; a box
    that has touched and moves up at 2 m/s launches; a box moving up before it ever touched does not."""
    sunk = _observed([0.5, 0.9], [0.0, 0.0])
    assert sunk["reach"] == pytest.approx(0.6 / 0.5)
    assert not judge(sunk, LAB)["holds"].passed
    thrown = _observed([0.49, 1.48], [0.0, 2.0])  # touching at the start, 1 m higher after the step of 0.5 s
    assert thrown["launch"] == pytest.approx(2.0)
    assert not judge(thrown, LAB)["never_launched"].passed
    free = _observed([0.5, 3.0], [0.0, 2.0])
    assert judge(free, LAB)["never_launched"].passed


@pytest.mark.parametrize("gap, holds", [(0.0, True), (0.02, True), (0.0201, False), (0.05, False)])
def test_holds_fails_on_a_gap_beyond_twice_the_slop(gap: float, holds: bool) -> None:
    """A column resting on air (an engine's contact skin) does not hold, however small its depths."""
    v = judge(measures(depth=0.0, gap=gap, rest=gap), LAB)
    assert v["holds"].passed is holds
    assert not holds or v["holds"].failing == ""
    assert holds or v["holds"].failing.startswith(f"max_gap {gap:.3g} > 0.02")


@pytest.mark.parametrize("rest, boxes, holds", [(-0.075, 5, True), (0.075, 5, True), (-0.0751, 5, False),
                                                (-1.5, 100, True), (-1.51, 100, False)])
def test_holds_bounds_the_top_box_by_one_and_a_half_slop_per_contact(rest: float, boxes: int, holds: bool) -> None:
    """Every contact within twice the slop, but all of them sunk by more than 1.5 slop on average: the top box
    is too low, and 'holds' says so (1.5 x 0.01 m x contacts)."""
    v = judge(measures(depth=0.019, rest=rest, boxes=boxes), LAB)
    assert v["holds"].passed is holds
