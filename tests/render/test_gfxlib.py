"""The drawing toolbox: lines, rectangles, clipping and PNG bytes."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from stackx.render.gfxlib import Canvas
from tests.lab.reference import read_png

W = (255, 255, 255)


def lit(c: Canvas) -> set[tuple[int, int]]:
    return {(x, y) for y in range(c.h) for x in range(c.w) if c.get(x, y) != (0, 0, 0)}


@given(st.integers(-5, 20), st.integers(-5, 20), st.integers(-5, 20), st.integers(-5, 20))
def test_line_is_connected_and_includes_end_points(x0: int, y0: int, x1: int, y1: int) -> None:
    c = Canvas(16, 16)
    c.line(x0, y0, x1, y1, W)
    full = Canvas(64, 64)
    full.line(x0 + 20, y0 + 20, x1 + 20, y1 + 20, W)
    points = {(x - 20, y - 20) for x, y in lit(full)}
    assert (x0, y0) in points and (x1, y1) in points
    assert len(points) == max(abs(x1 - x0), abs(y1 - y0)) + 1  # one pixel per step of the longer axis
    assert lit(c) == {(x, y) for x, y in points if 0 <= x < 16 and 0 <= y < 16}  # clipping drops, never moves


def test_fill_rect_includes_corners_and_clips() -> None:
    c = Canvas(10, 8)
    c.fill_rect(7, 5, 12, -3, W)
    assert lit(c) == {(x, y) for x in range(7, 10) for y in range(0, 6)}


def test_png_round_trip_and_determinism() -> None:
    c = Canvas(5, 3, (20, 20, 28))
    c.set(4, 2, (1, 2, 3))
    data = c.png_bytes()
    w, h, rows = read_png(data)
    assert (w, h) == (5, 3)
    assert rows[2][4] == (1, 2, 3) and rows[0][0] == (20, 20, 28)
    assert data == c.png_bytes()


@pytest.mark.parametrize("bad", [(256, 0, 0), (1, 2), (-1, 0, 0), (0.5, 0, 0)])
def test_bad_colours_are_refused(bad: tuple) -> None:
    with pytest.raises(ValueError):
        Canvas(2, 2, bad)
