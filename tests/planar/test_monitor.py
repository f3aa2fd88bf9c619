"""The planar monitors against hand-worked depths and motions."""

from __future__ import annotations

import numpy as np
import pytest

from stackx.models.planar.monitor import observe
from stackx.models.planar.state import PlanarState


def _state(boxes: list[tuple[float, float, float]], inv_mass: float = 1.0) -> PlanarState:
    """Unit boxes at ``(x, y, angle)``, one batch row."""
    row = lambda values: np.array([values], dtype=np.float64)  # noqa: E731
    n = len(boxes)
    x, y, a = (row(v) for v in zip(*boxes))
    half = row([0.5] * n)
    return PlanarState(x, y, a, row([0.0] * n), row([0.0] * n), row([0.0] * n), row([inv_mass] * n),
                       row([6.0 * inv_mass] * n), half, half.copy(), row([0.5] * n))


def test_a_new_state_starts_its_monitors_from_its_own_overlaps() -> None:
    s = _state([(0.0, 0.49, 0.0), (0.2, 1.46, 0.0)])
    assert s.peak_depth[0] == pytest.approx(0.03, abs=1e-12)  # box on box: 0.49 + 1 - 1.46
    assert s.reach[0] == pytest.approx(0.06, abs=1e-12)  # as a share of the half-size 0.5
    assert s.touched.tolist() == [[True, True]]
    assert s.launch[0] == -np.inf


def test_observe_measures_the_upward_motion_of_touched_boxes_only() -> None:
    s = _state([(0.0, 0.49, 0.0), (5.0, 3.0, 0.0)])  # box 1 is in the air
    s.y[0] += [0.02, 0.5]  # both rise over a step of 0.1 s
    observe(s.x[0], s.y[0], s.angle[0], s.hx[0], s.hy[0], s.inv_mass[0], 0.1, *s.monitors(), 0)
    assert s.launch[0] == pytest.approx(0.2, abs=1e-12)  # box 0's 0.02 m in 0.1 s; box 1 never touched
    assert s.last_y[0].tolist() == pytest.approx([0.51, 3.5])
    assert s.peak_depth[0] == pytest.approx(0.01, abs=1e-12)  # the start's overlap is still the deepest


def test_points_found_within_a_margin_give_the_monitors_of_touching_points_alone() -> None:
    """A solver passes the monitors its next step's points, found within its speculative margin: points
    further apart than the touching gap must change nothing, so the monitors are those of the points that
    touch (overlapping or at most ``TOUCH_GAP`` apart)."""
    from stackx.models.planar.collide import collide
    from stackx.models.planar.monitor import observe_points

    # made with one box sunk 2 cm into the ground, one 1 cm above it and one tilted clear of both; then every
    # box rises 1 cm: the first is sunk 1 cm, the second 1 cm above it (within the 2 cm touching gap), the
    # third's lowest corner 3.1 cm above the ground (within the 10 cm margin, but not touching)
    s = _state([(0.0, 0.48, 0.0), (0.3, 1.49, 0.0), (2.0, 0.62, 0.2)])
    s.y[0] += 0.01
    alone, within = s.copy(), s.copy()
    observe(s.x[0], s.y[0], s.angle[0], s.hx[0], s.hy[0], s.inv_mass[0], 0.1, *alone.monitors(), 0)
    room = 64
    out = (np.zeros(room, np.int64), np.zeros(room, np.int64), np.zeros((room, 2)), np.zeros((room, 2)),
           np.zeros(room), np.zeros(room, np.int64))
    count = collide(s.x[0], s.y[0], s.angle[0], s.hx[0], s.hy[0], s.inv_mass[0] == 0.0, 0.1, *out)
    assert (out[4][:count] < 0.0).sum() >= 2  # the margin found points still apart
    observe_points(out[0], out[1], out[4], count, s.y[0], s.hx[0], s.hy[0], s.inv_mass[0], 0.1,
                   *within.monitors(), 0)
    for name in PlanarState.MONITORS:
        np.testing.assert_array_equal(getattr(within, name), getattr(alone, name), err_msg=name)
    assert alone.touched.tolist() == [[True, True, False]]
    assert alone.launch[0] == pytest.approx(0.1)  # the touching boxes rose 1 cm in 0.1 s
