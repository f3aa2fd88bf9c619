"""The planar model's broad phase: which pairs of boxes are close enough for the narrow phase to look at.

Testing every pair of boxes costs ``n^2 / 2`` bounding-box tests, a millisecond a step at a few hundred
boxes. Here the boxes' bounding boxes (grown by half the contact margin each) are put on a **uniform grid**
whose cell is about one box across (the mean bounding size of the movable boxes plus the margin): a box
covers one to four cells, and only boxes sharing a cell are candidates, so a pile's cost grows with its boxes
and the pairs that touch, not with their square. A pair is reported once, from the lowest cell the two boxes
share. Boxes covering more than ``LARGE`` cells (a long ground slab, a ramp) are kept off the grid and tested
against every box directly, which costs ``n`` per such box instead of filling hundreds of cells. Two static
boxes are never a candidate: they never move, so they never need a contact.

The cells are found by hashing into a table of twice as many buckets as there are grid entries (a counting
sort: no per-cell lists), so memory is linear in the boxes wherever they are. Candidates are returned as keys
``i * n + j`` (``i < j``) sorted increasingly (``in_order``, a counting sort by ``i``): the narrow phase then visits pairs in index order, as a test of
every pair does, and a contact's place in the list does not depend on the grid. The grid only filters: it is
conservative (each bound is widened by a little more than rounding could move it), and the narrow phase
applies its own exact test to each candidate, so the contacts found are exactly those of the all-pairs test.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import kernel, leaf

LARGE = 16  # a box covering more cells than this is tested against every box instead of being gridded
FARTHEST = 1e12  # cells from the origin beyond which a box is tested against every box (no integer overflow)
ROUNDING = 1e-9  # relative widening of each bound: far above float64 rounding, far below any contact margin


@leaf
def bounds(angle: np.ndarray, hx: np.ndarray, hy: np.ndarray, cos: np.ndarray, sin: np.ndarray,
           reach_x: np.ndarray, reach_y: np.ndarray) -> None:
    """Each box's ``cos`` and ``sin`` of its angle and the half-sizes of its axis-aligned bounding box:
    ``reach_x = |cos| hx + |sin| hy``, and the same along y."""
    for i in range(angle.shape[0]):
        cos[i], sin[i] = np.cos(angle[i]), np.sin(angle[i])
        c, s = abs(cos[i]), abs(sin[i])
        reach_x[i] = c * hx[i] + s * hy[i]
        reach_y[i] = s * hx[i] + c * hy[i]


@kernel
def bucket(cx: int, cy: int, mask: int) -> int:
    """The hash bucket of cell ``(cx, cy)`` (``mask``: buckets - 1, buckets a power of two)."""
    return ((cx * 73856093) ^ (cy * 19349663)) & mask


@leaf
def overlap(lo_x: np.ndarray, hi_x: np.ndarray, lo_y: np.ndarray, hi_y: np.ndarray, i: int, j: int) -> bool:
    """Whether the widened bounding boxes of ``i`` and ``j`` overlap; a bound that is not a number overlaps
    everything (as it passes the narrow phase's own test)."""
    return not (lo_x[i] > hi_x[j] or lo_x[j] > hi_x[i] or lo_y[i] > hi_y[j] or lo_y[j] > hi_y[i])


@kernel
def candidate_pairs(x: np.ndarray, y: np.ndarray, reach_x: np.ndarray, reach_y: np.ndarray, static: np.ndarray,
                    margin: float, keys: np.ndarray) -> int:
    """The pairs whose bounding boxes, each grown by ``margin / 2``, overlap (two static boxes excepted), as
    sorted keys ``i * n + j`` with ``i < j`` in ``keys``; returns how many there are (more than ``keys``
    holds when it was too small: then only the count is right, and the caller asks again with more room)."""
    n = x.shape[0]
    size, movable, scale = 0.0, 0, 1.0
    for i in range(n):
        scale = max(scale, abs(x[i]) + reach_x[i], abs(y[i]) + reach_y[i])
        if not static[i]:
            size += 2.0 * max(reach_x[i], reach_y[i])
            movable += 1
    if movable == 0:
        return 0
    pad = 0.5 * margin + ROUNDING * scale
    cell = size / movable + margin + 2.0 * pad
    lo_x, hi_x, lo_y, hi_y = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    cells = np.empty((n, 4), np.int64)  # first and last cell along x, then y
    large = np.empty(n, np.int64)
    held, entries = 0, 0
    for i in range(n):
        lo_x[i], hi_x[i] = x[i] - reach_x[i] - pad, x[i] + reach_x[i] + pad
        lo_y[i], hi_y[i] = y[i] - reach_y[i] - pad, y[i] + reach_y[i] + pad
        span = LARGE + 1  # a box that is not a number, or too far out to number its cells, is not gridded
        if max(abs(lo_x[i]), abs(hi_x[i]), abs(lo_y[i]), abs(hi_y[i])) < FARTHEST * cell:
            cells[i, 0], cells[i, 1] = int(np.floor(lo_x[i] / cell)), int(np.floor(hi_x[i] / cell))
            cells[i, 2], cells[i, 3] = int(np.floor(lo_y[i] / cell)), int(np.floor(hi_y[i] / cell))
            span = (cells[i, 1] - cells[i, 0] + 1) * (cells[i, 3] - cells[i, 2] + 1)
        if span > LARGE:
            large[held] = i
            held += 1
            cells[i, 0], cells[i, 1], cells[i, 2], cells[i, 3] = 1, 0, 1, 0  # off the grid: it covers no cell
        else:
            entries += span
    buckets = 2
    while buckets < 2 * entries:
        buckets *= 2
    mask = buckets - 1
    start = np.zeros(buckets + 1, np.int64)
    for i in range(n):
        for cx in range(cells[i, 0], cells[i, 1] + 1):
            for cy in range(cells[i, 2], cells[i, 3] + 1):
                start[bucket(cx, cy, mask) + 1] += 1
    for k in range(buckets):
        start[k + 1] += start[k]
    fill = start[:buckets].copy()
    box = np.empty(entries, np.int64)
    where = np.empty((entries, 2), np.int64)
    for i in range(n):
        for cx in range(cells[i, 0], cells[i, 1] + 1):
            for cy in range(cells[i, 2], cells[i, 3] + 1):
                k = bucket(cx, cy, mask)
                e = fill[k]
                box[e], where[e, 0], where[e, 1] = i, cx, cy
                fill[k] = e + 1
    found = 0
    for k in range(buckets):
        for e in range(start[k], start[k + 1]):
            i, cx, cy = box[e], where[e, 0], where[e, 1]
            for f in range(e + 1, start[k + 1]):
                j = box[f]
                if where[f, 0] != cx or where[f, 1] != cy or (static[i] and static[j]):
                    continue
                # the lowest cell both cover reports the pair; the others skip it
                if cx != max(cells[i, 0], cells[j, 0]) or cy != max(cells[i, 2], cells[j, 2]):
                    continue
                if overlap(lo_x, hi_x, lo_y, hi_y, i, j):
                    if found < keys.shape[0]:
                        keys[found] = min(i, j) * n + max(i, j)
                    found += 1
    for h in range(held):
        i = large[h]
        for j in range(n):
            if j == i or (static[i] and static[j]):
                continue
            if cells[j, 0] > cells[j, 1] and j < i:  # both large: the pair comes once, from the smaller
                continue
            if overlap(lo_x, hi_x, lo_y, hi_y, i, j):
                if found < keys.shape[0]:
                    keys[found] = min(i, j) * n + max(i, j)
                found += 1
    if found <= keys.shape[0]:
        in_order(keys, found, n, np.zeros(n + 1, np.int64), np.empty(found, np.int64))
    return found


@leaf
def widen(x: np.ndarray, y: np.ndarray, reach_x: np.ndarray, reach_y: np.ndarray, fat: float,
          wide: np.ndarray) -> None:
    """Each box's bounding box grown by ``fat / 2``, into ``wide`` (``(bodies, 4)``: low x, high x, low y,
    high y): the bounds within which the candidates found with margin ``fat`` stay valid (``inside``)."""
    for i in range(x.shape[0]):
        wide[i, 0], wide[i, 1] = x[i] - reach_x[i] - 0.5 * fat, x[i] + reach_x[i] + 0.5 * fat
        wide[i, 2], wide[i, 3] = y[i] - reach_y[i] - 0.5 * fat, y[i] + reach_y[i] + 0.5 * fat


@leaf
def inside(x: np.ndarray, y: np.ndarray, reach_x: np.ndarray, reach_y: np.ndarray, margin: float,
           wide: np.ndarray) -> bool:
    """Whether every box's bounding box grown by ``margin / 2`` (and by ``ROUNDING`` of its distance from
    the origin, more than rounding could move a bound) lies inside its ``wide`` bounds; a bound that is
    not a number is outside."""
    for i in range(x.shape[0]):
        pad = 0.5 * margin + ROUNDING * (abs(x[i]) + abs(y[i]) + reach_x[i] + reach_y[i] + 1.0)
        if not (x[i] - reach_x[i] - pad >= wide[i, 0] and x[i] + reach_x[i] + pad <= wide[i, 1]
                and y[i] - reach_y[i] - pad >= wide[i, 2] and y[i] + reach_y[i] + pad <= wide[i, 3]):
            return False
    return True


@leaf
def in_order(keys: np.ndarray, count: int, n: int, first: np.ndarray, scratch: np.ndarray) -> None:
    """Sort the ``count`` pair keys ``i * n + j`` increasingly: a counting sort by ``i`` (``first``: ``n + 1``
    zeros), then each box's few partners by insertion. Linear in the pairs, where a comparison sort of keys
    coming in the grid's hash order costs a quarter of the broad phase."""
    for p in range(count):
        first[keys[p] // n + 1] += 1
    for i in range(n):
        first[i + 1] += first[i]
    for p in range(count):
        i = keys[p] // n
        scratch[first[i]] = keys[p]
        first[i] += 1
    begin = 0
    for i in range(n):
        end = first[i]  # after placing, first[i] is where box i's partners end
        for p in range(begin + 1, end):
            key = scratch[p]
            q = p - 1
            while q >= begin and scratch[q] > key:
                scratch[q + 1] = scratch[q]
                q -= 1
            scratch[q + 1] = key
        begin = end
    for p in range(count):
        keys[p] = scratch[p]
