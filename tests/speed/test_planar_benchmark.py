"""The planar benchmark's batched line says which way a ratio goes."""

from __future__ import annotations

import math

from benchmarks.planar import against


def test_a_batch_slower_than_box2d_is_said_to_cost_more_not_fewer() -> None:
    assert against(50.0, 175.0) == "3.5x fewer than Box2D"
    assert against(208.6, 175.9) == "1.2x more than Box2D"  # not "0.8x fewer"
    assert against(175.0, 175.0) == "1.0x fewer than Box2D"


def test_a_missing_figure_makes_no_ratio() -> None:
    assert against(math.nan, 175.0) == "no comparison"
    assert against(50.0, math.nan) == "no comparison"
