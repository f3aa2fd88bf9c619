"""The broad phase filters pairs, it never changes contacts: ``collide`` finds exactly the points, in exactly
the order, of testing every pair of boxes (the narrow phase run on all ``n^2 / 2`` pairs, written out here)."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from stackx import kernel
from stackx.models.planar.broad import candidate_pairs
from stackx.models.planar.collide import COLUMNS, GROUND, box_points, collide, shapes


def lowest_corners(i: int, x: float, y: float, c: float, s: float, hx: float, hy: float, margin: float, n: int,
                   *out: np.ndarray) -> int:
    """Box ``i``'s points on the ground, written out: its (at most two) lowest corners (the first of equals)
    within ``margin`` of it, normal straight up, placed half-way down, stored after the ``n`` already there."""
    heights = []
    for corner in range(4):
        px = hx if corner == 0 or corner == 3 else -hx
        py = hy if corner < 2 else -hy
        heights.append((x + c * px - s * py, y + s * px + c * py, corner))
    lowest = [h for h in heights if h[1] < np.inf]  # a corner whose height is not a number is never lowest
    lowest.sort(key=lambda h: (h[1], h[2]))
    for cx, cy, corner in lowest[:2]:
        if cy <= margin:
            out[0][n], out[1][n], out[2][n], out[3][n], out[4][n], out[5][n] = (
                GROUND, i, (0.0, 1.0), (cx, 0.5 * cy), -cy, corner)
            n += 1
    return n


def every_pair(x: np.ndarray, y: np.ndarray, angle: np.ndarray, hx: np.ndarray, hy: np.ndarray,
               static: np.ndarray, margin: float, room: int,
               pair: Callable[..., int] = box_points) -> tuple[int, tuple[np.ndarray, ...]]:
    """The contact points of testing every pair, in index order: ground first, then ``(i, j)``, ``i < j``, each
    pair's points stored by ``pair`` (``box_points``'s arguments and answer)."""
    out = (np.zeros(room, np.int64), np.zeros(room, np.int64), np.zeros((room, 2)), np.zeros((room, 2)),
           np.zeros(room), np.zeros(room, np.int64))
    n = 0
    bodies = len(x)
    cos, sin = np.cos(angle), np.sin(angle)
    reach_x = [abs(cos[i]) * hx[i] + abs(sin[i]) * hy[i] for i in range(bodies)]
    reach_y = [abs(sin[i]) * hx[i] + abs(cos[i]) * hy[i] for i in range(bodies)]
    boxes = np.empty((bodies, COLUMNS))
    with kernel.compiled(False):
        shapes(x, y, angle, hx, hy, boxes)
        for i in range(bodies):
            if not static[i] and y[i] - reach_y[i] <= margin:
                n = lowest_corners(i, x[i], y[i], cos[i], sin[i], hx[i], hy[i], margin, n, *out)
        for i in range(bodies):
            for j in range(i + 1, bodies):
                if static[i] and static[j]:
                    continue
                if (abs(x[i] - x[j]) > reach_x[i] + reach_x[j] + margin
                        or abs(y[i] - y[j]) > reach_y[i] + reach_y[j] + margin):
                    continue
                n = pair(i, j, boxes, margin, n, *out)
    return n, out


def scene(seed: int, boxes: int) -> tuple[np.ndarray, ...]:
    """A jumble of boxes of mixed sizes and angles over a few square metres (many overlap, some far apart),
    a few static, one a long static slab and one a long movable plank (both off the grid)."""
    rng = np.random.default_rng(seed)
    side = math.sqrt(boxes) * 0.8
    x, y = rng.uniform(-side, side, boxes), rng.uniform(0.0, 2 * side, boxes)
    angle = rng.uniform(-math.pi, math.pi, boxes)
    hx, hy = rng.uniform(0.05, 0.8, boxes), rng.uniform(0.05, 0.8, boxes)
    static = rng.uniform(size=boxes) < 0.1
    x[0], y[0], angle[0], hx[0], hy[0], static[0] = 0.0, side, 0.1, 3 * side, 0.3, True
    x[1], y[1], angle[1], hx[1], hy[1], static[1] = 0.5, side + 0.4, -0.05, 2 * side, 0.2, False
    return x, y, angle, hx, hy, static


@pytest.mark.parametrize("compiled", [False, True])
@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("margin", [0.0, 0.02, 0.3])
def test_collide_finds_the_points_of_testing_every_pair(seed: int, margin: float, compiled: bool) -> None:
    x, y, angle, hx, hy, static = scene(seed, 120)
    room = 4000
    want_n, want = every_pair(x, y, angle, hx, hy, static, margin, room)
    got = (np.zeros(room, np.int64), np.zeros(room, np.int64), np.zeros((room, 2)), np.zeros((room, 2)),
           np.zeros(room), np.zeros(room, np.int64))
    with kernel.compiled(compiled):
        n = collide(x, y, angle, hx, hy, static, margin, *got)
    assert want_n > 100  # the jumble has many contacts, on the ground, between boxes and on both long bodies
    assert n == want_n
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g[:n], w[:n])


def test_a_pile_of_touching_unit_boxes_gives_each_touching_pair_once_in_index_order() -> None:
    # a 3 x 3 grid of unit boxes 0.5 cm apart: within a 1 cm margin each touches its 2 to 4 side neighbours
    # and its diagonal ones' bounding boxes as well (the grid is about bounding boxes, not shapes)
    xs, ys = np.meshgrid(np.arange(3) * 1.005, np.arange(3) * 1.005 + 0.5)
    x, y = xs.ravel().copy(), ys.ravel().copy()
    reach = np.full(9, 0.5)
    keys = np.zeros(100, np.int64)
    with kernel.compiled(False):
        count = candidate_pairs(x, y, reach, reach, np.zeros(9, np.bool_), 0.01, keys)
    want = sorted(i * 9 + j for i in range(9) for j in range(i + 1, 9)
                  if abs(i % 3 - j % 3) <= 1 and abs(i // 3 - j // 3) <= 1)
    assert keys[:count].tolist() == want


def test_two_static_boxes_are_never_a_candidate_and_a_small_room_reports_the_count() -> None:
    x, y = np.array([0.0, 0.5, 1.0]), np.array([0.5, 0.5, 0.5])
    reach = np.full(3, 0.5)
    keys = np.zeros(1, np.int64)
    with kernel.compiled(False):
        assert candidate_pairs(x, y, reach, reach, np.array([True, True, False]), 0.0, keys) == 2
        keys = np.zeros(2, np.int64)
        assert candidate_pairs(x, y, reach, reach, np.array([True, True, False]), 0.0, keys) == 2
    assert keys.tolist() == [0 * 3 + 2, 1 * 3 + 2]


@pytest.mark.parametrize("compiled", [False, True])
def test_kept_candidates_give_the_points_of_testing_every_pair_while_boxes_drift_and_jump(compiled: bool) -> None:
    """``collide_near`` reuses its candidates while every box stays within its widened bounds and finds them
    again when one leaves: over drifts of a millimetre (kept), of 3 cm (some leave the 5 cm looseness) and a
    jump across the scene, its points are those of testing every pair, each time."""
    from stackx.models.planar.collide import collide_near

    x, y, angle, hx, hy, static = scene(3, 80)
    rng = np.random.default_rng(7)
    room, margin, fat = 3000, 0.02, 0.12
    near, wide = np.empty(4 * len(x) + 17, np.int64), np.empty((len(x), 4))
    near[0] = -1
    refound = 0
    for step in range(12):
        size = 0.001 if step < 6 else 0.03
        move = ~static
        x[move] += rng.uniform(-size, size, move.sum())
        y[move] += rng.uniform(-size, size, move.sum())
        angle[move] += rng.uniform(-size, size, move.sum())
        if step == 9:
            x[5] += 4.0  # a jump: far out of its bounds
        before = near[0], near[1:near[0] + 1].copy()
        got = (np.zeros(room, np.int64), np.zeros(room, np.int64), np.zeros((room, 2)), np.zeros((room, 2)),
               np.zeros(room), np.zeros(room, np.int64))
        with kernel.compiled(compiled):
            n, near = collide_near(x, y, angle, hx, hy, static, margin, fat, near, wide, *got)
        refound += before[0] != near[0] or not np.array_equal(before[1], near[1:near[0] + 1])
        want_n, want = every_pair(x, y, angle, hx, hy, static, margin, room)
        assert n == want_n > 50
        for g, w in zip(got, want):
            np.testing.assert_array_equal(g[:n], w[:n])
    assert 2 <= refound < 12  # found at the first call and again after the jump, kept at least once


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_touching_points_of_a_speculative_test_are_those_of_a_test_with_no_margin(seed: int) -> None:
    """What lets a solver correct positions on its speculative contacts (``contacts.correct_positions`` passes
    over points still apart): the points with depth >= 0 of a test within a margin are, in the same order,
    all the points of the test with none."""
    x, y, angle, hx, hy, static = scene(seed, 120)
    room = 4000
    found = {}
    for margin in (0.0, 0.02, 0.3):
        out = (np.zeros(room, np.int64), np.zeros(room, np.int64), np.zeros((room, 2)), np.zeros((room, 2)),
               np.zeros(room), np.zeros(room, np.int64))
        with kernel.compiled(True):
            n = collide(x, y, angle, hx, hy, static, margin, *out)
        touching = out[4][:n] >= 0.0
        found[margin] = [column[:n][touching] for column in out]
        assert margin == 0.0 or not touching.all()  # the margin did add points still apart
    for margin in (0.02, 0.3):
        for got, want in zip(found[margin], found[0.0]):
            np.testing.assert_array_equal(got, want)


def grown_overlaps(x: np.ndarray, y: np.ndarray, reach_x: np.ndarray, reach_y: np.ndarray, static: np.ndarray,
                   margin: float) -> list[int]:
    """Every pair's keys whose bounding boxes grown by ``margin / 2`` overlap, two static boxes excepted: the
    broad phase's answer found by testing every pair."""
    n, pad = len(x), 0.5 * margin
    return [i * n + j for i in range(n) for j in range(i + 1, n) if not (static[i] and static[j])
            and abs(x[i] - x[j]) <= reach_x[i] + reach_x[j] + 2 * pad
            and abs(y[i] - y[j]) <= reach_y[i] + reach_y[j] + 2 * pad]


@pytest.mark.parametrize("compiled", [False, True])
@pytest.mark.parametrize("apart", [0.0, 1000.0])
def test_candidates_are_the_overlapping_grown_bounds_of_a_pile_and_of_groups_far_apart(apart: float,
                                                                                      compiled: bool) -> None:
    """A pile's cells are numbered as they lie; the same pile split into two groups a kilometre apart spans
    mostly empty cells and is hashed: both give every overlapping pair once, in key order."""
    x, y, angle, hx, hy, static = scene(4, 120)
    x[60:] += apart
    reach_x = np.abs(np.cos(angle)) * hx + np.abs(np.sin(angle)) * hy
    reach_y = np.abs(np.sin(angle)) * hx + np.abs(np.cos(angle)) * hy
    keys = np.zeros(2000, np.int64)
    with kernel.compiled(compiled):
        count = candidate_pairs(x, y, reach_x, reach_y, static, 0.12, keys)
    want = grown_overlaps(x, y, reach_x, reach_y, static, 0.12)
    assert len(want) > 80
    assert keys[:count].tolist() == want
