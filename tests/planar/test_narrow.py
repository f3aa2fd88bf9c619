"""The narrow phase's compiled shortcuts change no bit: ``collide`` gives, byte for byte, the points of the
method written out plainly here (every face of both boxes projected on its own normal, every face of the
incident box tried, every pair of boxes tested with a call per pair), on jumbles of turned boxes, on
axis-aligned stacks whose normals have zero components, and on boxes that are not numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stackx import kernel
from stackx.models.planar.collide import (ABSOLUTE_BIAS, COLUMNS, CORNER, FACE, REFERENCE_BIAS, X, Y, collide,
                                          separation, shapes)
from tests.planar.test_broad import every_pair


def face_separation(a: int, b: int, x: np.ndarray, y: np.ndarray, corners: np.ndarray, faces: np.ndarray,
                    margin: float) -> tuple[float, int]:
    """Per face of a, on its own normal, the deepest corner of b; the first face beyond ``margin`` at once,
    else the face separating most (the first of equals)."""
    best, best_face = -np.inf, 0
    for face in range(4):
        nx, ny, extent = faces[a, face, 0], faces[a, face, 1], faces[a, face, 2]
        low = np.inf
        for corner in range(4):
            d = (corners[b, corner, 0] - x[a]) * nx + (corners[b, corner, 1] - y[a]) * ny - extent
            if d < low:
                low = d
        if low > margin:
            return low, face
        if low > best:
            best, best_face = low, face
    return best, best_face


def manifold(i: int, j: int, x: np.ndarray, y: np.ndarray, corners: np.ndarray, faces: np.ndarray,
             margin: float) -> list[tuple]:
    """The points of boxes i and j: reference face, incident face (all four tried), clipping, ends kept."""
    sep_i, face_i = face_separation(i, j, x, y, corners, faces, margin)
    if sep_i > margin:
        return []
    sep_j, face_j = face_separation(j, i, x, y, corners, faces, margin)
    if sep_j > margin:
        return []
    flip = sep_j > REFERENCE_BIAS * sep_i + ABSOLUTE_BIAS
    r, k = (j, i) if flip else (i, j)
    face = face_j if flip else face_i
    nx, ny, extent, width = faces[r, face]
    tx, ty = -ny, nx
    incident, lowest = 0, np.inf
    for f in range(4):
        d = faces[k, f, 0] * nx + faces[k, f, 1] * ny
        if d < lowest:
            incident, lowest = f, d
    fx, fy, e, w = faces[k, incident]
    gx, gy = -fy, fx
    ends = [[x[k] + fx * e + gx * w, y[k] + fy * e + gy * w], [x[k] + fx * e - gx * w, y[k] + fy * e - gy * w]]
    u = [(px - x[r]) * tx + (py - y[r]) * ty for px, py in ends]
    for bound in (-width, width):
        out = [u[0] < bound, u[1] < bound] if bound < 0 else [u[0] > bound, u[1] > bound]
        if out[0] and out[1]:
            return []
        if out[0] or out[1]:
            t = (bound - u[0]) / (u[1] - u[0])
            cut = [ends[0][0] + t * (ends[1][0] - ends[0][0]), ends[0][1] + t * (ends[1][1] - ends[0][1])]
            side = 0 if out[0] else 1
            ends[side], u[side] = cut, bound
    sign = -1.0 if flip else 1.0
    points = []
    for end, (ex, ey) in enumerate(ends):
        sep = (ex - x[r]) * nx + (ey - y[r]) * ny - extent
        if sep <= margin:
            feature = (64 if flip else 0) + face * 16 + incident * 4 + end
            points.append((i, j, sign * nx, sign * ny, ex - 0.5 * sep * nx, ey - 0.5 * sep * ny, -sep, feature))
    return points


def written_out_pair(i: int, j: int, boxes: np.ndarray, margin: float, n: int, *out: np.ndarray) -> int:
    """``manifold``'s points stored as ``box_points`` stores them, after the ``n`` already there, from the
    boxes' centres, corners and faces in their rows of ``shapes``."""
    x, y = boxes[:, X], boxes[:, Y]
    corners = boxes[:, CORNER:CORNER + 8].reshape(-1, 4, 2)
    faces = boxes[:, FACE:FACE + 16].reshape(-1, 4, 4)
    for point in manifold(i, j, x, y, corners, faces, margin):
        a, b, nx, ny, px, py, depth, feature = point
        out[0][n], out[1][n], out[2][n], out[3][n], out[4][n], out[5][n] = a, b, (nx, ny), (px, py), depth, feature
        n += 1
    return n


def jumble(seed: int, boxes: int) -> tuple[np.ndarray, ...]:
    """Boxes of mixed sizes at any angle over a few square metres, many overlapping, a few static."""
    rng = np.random.default_rng(seed)
    side = math.sqrt(boxes) * 0.7
    return (rng.uniform(-side, side, boxes), rng.uniform(0.0, 2 * side, boxes),
            rng.uniform(-math.pi, math.pi, boxes), rng.uniform(0.05, 0.8, boxes), rng.uniform(0.05, 0.8, boxes),
            rng.uniform(size=boxes) < 0.1)


def stack(seed: int) -> tuple[np.ndarray, ...]:
    """A wall of unit boxes exactly touching or a few millimetres apart, most at angles of quarter turns
    (normals with components that are exactly zero), some at eighth turns or nudged."""
    rng = np.random.default_rng(seed)
    xs, ys = np.meshgrid(np.arange(6) * 1.0, np.arange(5) * 1.0 + 0.5)
    x, y = xs.ravel() + rng.choice([0.0, 0.0, 0.003, -0.004], xs.size), ys.ravel() - rng.choice([0.0, 0.01], xs.size)
    angle = rng.choice([0.0, 0.0, math.pi / 2, math.pi, -math.pi / 2, math.pi / 4, -3 * math.pi / 4, 1e-3], xs.size)
    half = np.full(xs.size, 0.5)
    return x, y, angle, half, half.copy(), np.zeros(xs.size, np.bool_)


def not_numbers() -> tuple[np.ndarray, ...]:
    """A small pile where one box's position, one's angle and one's size are not numbers, and one is flat."""
    x, y, angle, hx, hy, static = stack(0)
    x[3], angle[8], hx[14], hy[20] = np.nan, np.nan, np.nan, 0.0
    y[25] = np.inf
    return x, y, angle, hx, hy, static


SCENES = {"jumble 0": lambda: jumble(0, 150), "jumble 1": lambda: jumble(1, 150), "stack 0": lambda: stack(0),
          "stack 1": lambda: stack(1), "not numbers": not_numbers}


@pytest.mark.parametrize("compiled", [False, True])
@pytest.mark.parametrize("margin", [0.0, 0.02, 0.3])
@pytest.mark.parametrize("name", list(SCENES))
def test_collide_gives_the_bytes_of_the_method_written_out(name: str, margin: float, compiled: bool) -> None:
    x, y, angle, hx, hy, static = SCENES[name]()
    room = 6000
    got = (np.zeros(room, np.int64), np.zeros(room, np.int64), np.zeros((room, 2)), np.zeros((room, 2)),
           np.zeros(room), np.zeros(room, np.int64))
    with np.errstate(all="ignore"):  # the boxes that are not numbers
        count, want = every_pair(x, y, angle, hx, hy, static, margin, room, written_out_pair)
        with kernel.compiled(compiled):
            n = collide(x, y, angle, hx, hy, static, margin, *got)
    assert n == count > 20
    if name.startswith("jumble"):  # pairs where either box is the reference
        assert {int(f) >> 6 for f in want[5][:n]} == {0, 1}
    for g, w in zip(got, want):
        assert g[:n].tobytes() == w[:n].tobytes()


@pytest.mark.parametrize("compiled", [False, True])
def test_separation_is_per_face_the_deepest_corner_also_for_extents_that_are_not_finite(compiled: bool) -> None:
    """``separation`` takes least and greatest projections where a box's extents are finite; where they are
    not numbers or infinite it still gives, per face, the deepest corner's separation as defined."""
    x, y, angle, hx, hy, _ = stack(2)
    hx[4], hy[9], hx[13], hy[13] = np.nan, np.inf, np.inf, 0.0
    boxes = np.empty((len(x), COLUMNS))
    with kernel.compiled(False):
        shapes(x, y, angle, hx, hy, boxes)
    corners, faces = boxes[:, CORNER:CORNER + 8].reshape(-1, 4, 2), boxes[:, FACE:FACE + 16].reshape(-1, 4, 4)
    with np.errstate(all="ignore"):
        for a in range(len(x)):
            for b in range(len(x)):
                lows = []
                for face in range(4):
                    low = np.inf
                    for corner in range(4):
                        d = ((corners[b, corner, 0] - x[a]) * faces[a, face, 0]
                             + (corners[b, corner, 1] - y[a]) * faces[a, face, 1] - faces[a, face, 2])
                        if d < low:
                            low = d
                    lows.append(low)
                with kernel.compiled(compiled):
                    got, got_face = separation(a, b, boxes)
                want, want_face = lows[0], 0
                for f in range(1, 4):
                    if lows[f] > want:
                        want, want_face = lows[f], f
                assert got_face == want_face and (got == want or (np.isnan(got) and np.isnan(want)))
