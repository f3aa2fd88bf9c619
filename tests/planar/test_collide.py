"""Planar contact manifolds against answers worked out by hand from the geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stackx.models.planar.collide import collide


def _points(boxes: list[tuple[float, float, float, float, float]], margin: float = 0.0) -> list[tuple]:
    x, y, a, hx, hy = (np.array(v, dtype=np.float64) for v in zip(*boxes))
    room = 16
    out = (np.zeros(room, np.int64), np.zeros(room, np.int64), np.zeros((room, 2)), np.zeros((room, 2)),
           np.zeros(room), np.zeros(room, np.int64))
    n = collide(x, y, a, hx, hy, np.zeros(len(boxes), np.bool_), margin, *out)
    body_a, body_b, normal, point, depth, _ = out
    return [(int(body_a[k]), int(body_b[k]), tuple(normal[k]), tuple(point[k]), float(depth[k])) for k in range(n)]


def test_a_flat_box_sunk_1cm_touches_the_ground_at_both_bottom_corners() -> None:
    got = _points([(0.0, 0.49, 0.0, 0.5, 0.5)])
    assert [(a, b, n) for a, b, n, _, _ in got] == [(-1, 0, (0.0, 1.0))] * 2
    assert sorted(p[0] for _, _, _, p, _ in got) == [-0.5, 0.5]
    assert all(d == pytest.approx(0.01, abs=1e-15) for *_, d in got)


def test_a_box_on_its_corner_touches_at_one_point() -> None:
    got = _points([(0.0, 0.49, math.pi / 4, 0.5, 0.5)])
    assert len(got) == 1
    assert got[0][4] == pytest.approx(0.5 * math.sqrt(2.0) - 0.49, abs=1e-12)
    assert got[0][3][0] == pytest.approx(0.0, abs=1e-12)


def test_a_box_resting_offset_on_another_touches_at_both_ends_of_the_overlap() -> None:
    got = [p for p in _points([(0.0, 0.5, 0.0, 0.5, 0.5), (0.3, 1.48, 0.0, 0.5, 0.5)]) if p[0] == 0]
    assert [(a, b, n) for a, b, n, _, _ in got] == [(0, 1, (0.0, 1.0))] * 2
    assert sorted(p[0] for _, _, _, p, _ in got) == pytest.approx([-0.2, 0.5], abs=1e-12)
    assert all(d == pytest.approx(0.02, abs=1e-12) for *_, d in got)


def test_side_by_side_boxes_push_apart_horizontally_from_the_first_to_the_second() -> None:
    got = [p for p in _points([(0.0, 0.5, 0.0, 0.5, 0.5), (0.98, 0.5, 0.0, 0.5, 0.5)]) if p[0] == 0]
    assert [(a, b, n) for a, b, n, _, _ in got] == [(0, 1, (1.0, 0.0))] * 2
    assert all(d == pytest.approx(0.02, abs=1e-12) for *_, d in got)
    flipped = [p for p in _points([(0.98, 0.5, 0.0, 0.5, 0.5), (0.0, 0.5, 0.0, 0.5, 0.5)]) if p[0] == 0]
    assert all(n == pytest.approx((-1.0, 0.0)) for _, _, n, _, _ in flipped)


def test_boxes_apart_by_more_than_the_margin_have_no_point_and_within_it_negative_depth() -> None:
    apart = [(0.0, 0.5, 0.0, 0.5, 0.5), (0.0, 1.55, 0.0, 0.5, 0.5)]
    assert [p for p in _points(apart) if p[0] == 0] == []
    near = [p for p in _points(apart, margin=0.1) if p[0] == 0]
    assert len(near) == 2 and all(d == pytest.approx(-0.05, abs=1e-12) for *_, d in near)
