"""planar-ngs: position passes that re-measure separations and turn boxes, against geometry by hand."""

from __future__ import annotations

import math

from stackx.solvers.planar.ngs import PlanarNGSParams
from tests.planar.worlds import deepest, lowest_corner, run, world


def test_a_box_dropped_flat_rests_within_three_slops_without_turning() -> None:
    s = run("planar-ngs", world([{"x": 0.0, "y": 0.6}]), 120)
    assert 0.0 <= deepest(s) <= 3 * PlanarNGSParams().slop
    assert abs(s.angle[0, 0]) < 1e-9 and abs(s.x[0, 0]) < 1e-9


def test_a_tilted_box_sunk_on_a_corner_is_pushed_out_and_turned_back() -> None:
    # no gravity, at rest: only the position passes act; one corner is 0.05 deep
    angle = 0.1
    y = 0.5 * math.sin(angle) + 0.5 * math.cos(angle) - 0.05
    s = run("planar-ngs", world([{"x": 0.0, "y": y, "angle": angle}]), 60, g=0.0)
    slop = PlanarNGSParams().slop
    assert -lowest_corner(s.x[0, 0], s.y[0, 0], s.angle[0, 0], 0.5, 0.5) <= 3 * slop
    assert s.angle[0, 0] < angle  # the push at the corner turned it towards flat
    # the lab's correction on warm-start pushes at the centre: it undoes the depth but not the tilt
    lab = run("planar-warm-start", world([{"x": 0.0, "y": y, "angle": angle}]), 60, g=0.0)
    assert lab.angle[0, 0] == angle


def test_a_deep_overlap_rises_by_at_most_max_correction_per_visit() -> None:
    params = PlanarNGSParams()
    s = run("planar-ngs", world([{"x": 0.0, "y": 0.2}]), 1, {"speculative": 0.0}, g=0.0)
    rise = s.y[0, 0] - 0.2
    visits = 2 * params.position_iterations  # two ground points
    assert 0.0 < rise <= visits * params.max_correction + 1e-12
    assert deepest(s) < 0.3 - 0.5 * rise  # the corners were pushed out; the box may have turned a little
