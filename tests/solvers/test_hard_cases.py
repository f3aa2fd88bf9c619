"""Which solver holds which hard case, pinned on the cases that stay small (dt = 1/60 throughout).

A solver passes a case when it holds (final depth <= 2 x the lab's slop, no box ever half-way into its
neighbour), has settled (RMS of actual motion over the last 60 steps below 1e-4 m/s) and never launched (no
box faster than 1 m/s upward after touching). The tall cases start the boxes 1 mm apart and 1 mm above the
floor; the ratio cases put a box of mass 100 or 1000 on four boxes of mass 1.
"""

from __future__ import annotations

from typing import Any

import pytest

from tests.solvers.columns import SLOP, Verdict, judge, resting

HEAVY_ON_LIGHT = {"ratio-100": 100.0, "ratio-1000": 1000.0}


def tall(count: int, name: str, **params: Any) -> Verdict:
    return judge(name, resting(count), 600 if count <= 20 else 1200, **params)


def ratio(case: str, name: str, **params: Any) -> Verdict:
    return judge(name, resting(5, [1.0, 1.0, 1.0, 1.0, HEAVY_ON_LIGHT[case]]), 600, **params)


def test_the_lab_solver_is_crushed_by_twenty_boxes() -> None:
    got = tall(20, "pgs", iterations=15)
    assert got.top < 5.0  # resting, the top box is at 19.5
    assert got.reach > 1.0  # boxes pushed more than half-way into each other
    assert not got.passes


def test_the_lab_solver_is_crushed_by_a_heavy_box_on_light_ones() -> None:
    got = ratio("ratio-100", "pgs", iterations=15)
    assert got.top < 0.0  # the heavy box ends below the floor, through the four light ones
    assert not got.passes


@pytest.mark.parametrize("name, params", [
    ("warm-start", {}),
    ("exact", {}),
    ("exact", {"speculative": 0.0}),
    ("xpbd", {}),
    ("soft-step", {}),
])
def test_holds_twenty_boxes(name: str, params: dict[str, Any]) -> None:
    got = tall(20, name, **params)
    assert got.passes, got
    assert got.max_depth <= 2 * SLOP and abs(got.top - 19.5) < 0.25


@pytest.mark.parametrize("name, params", [
    ("baumgarte", {}),  # its bias throws boxes up while the load builds (launch 3.4 m/s)
    ("ngs", {}),  # still creeping at the end
    ("jacobi", {}),  # half steps: the load reaches the floor too slowly
    ("split-impulse", {}),  # its position pass throws boxes up at 1.25 m/s, seen from positions
])
def test_does_not_pass_twenty_boxes_at_its_defaults(name: str, params: dict[str, Any]) -> None:
    assert not tall(20, name, **params).passes


@pytest.mark.parametrize("name, params, case", [
    ("warm-start", {"iterations": 20}, "ratio-100"),
    ("exact", {}, "ratio-100"),
    ("exact", {}, "ratio-1000"),
    ("exact", {"speculative": 0.0}, "ratio-1000"),
    ("xpbd", {}, "ratio-100"),
])
def test_holds_heavy_on_light(name: str, params: dict[str, Any], case: str) -> None:
    got = ratio(case, name, **params)
    assert got.passes, got


def test_warm_start_at_ten_iterations_has_not_settled_heavy_on_light() -> None:
    got = ratio("ratio-100", "warm-start", iterations=10)
    assert not got.launched and got.max_depth < 3 * SLOP  # close: it sinks a little and is still moving
    assert not got.settled


def test_soft_contacts_sink_under_a_heavy_box() -> None:
    """Box2D v3's soft step at its defaults is quiet but soft: a 100 kg load presses the 30 Hz contacts in."""
    got = ratio("ratio-100", "soft-step")
    assert got.settled and not got.launched
    assert 2 * SLOP < got.max_depth < 10 * SLOP


def test_baumgarte_turns_the_correction_into_a_launch() -> None:
    assert ratio("ratio-100", "baumgarte").launched


def test_exact_needs_speculative_contacts_for_a_hundred_boxes() -> None:
    """Touching-only contacts stop a falling column one contact per step, so the upper boxes land hard and
    the overlap is still being undone at the end; contacts within 2 cm that may close their gap stop the
    whole column in its first step."""
    lab_rule = tall(100, "exact", speculative=0.0)
    assert not lab_rule.passes and not lab_rule.settled
    speculative = tall(100, "exact")  # its default margin, 0.02 m
    assert speculative.passes, speculative
    assert speculative.max_depth < 1e-9 and abs(speculative.top - 99.5) < 1e-9
