"""The planar model's broad phase: which pairs of boxes are close enough for the narrow phase to look at.

Testing every pair of boxes costs ``n^2 / 2`` bounding-box tests, a millisecond a step at a few hundred boxes.
Here the boxes' bounding boxes (grown by half the contact margin each) are put on a **uniform grid** whose cell
is about one box across (the mean bounding size of the movable boxes plus the margin): a box covers one to four
cells, and only boxes sharing a cell are candidates, so a pile's cost grows with its boxes and the pairs that
touch, not with their square. A pair is reported once, from the first cell of the two boxes' shared ones that
the earlier box visits (each box marks the later boxes it has met). Boxes covering more than ``LARGE`` cells (a
long ground slab, a ramp) are kept off the grid and tested against every box directly, which costs ``n`` per
such box instead of filling hundreds of cells. Two static boxes are never a candidate: they never move, so they
never need a contact.

A pile's span of cells is numbered as it lies (a counting sort of the entries by cell: no per-cell lists);
boxes spread far apart, whose span would be mostly empty cells, are hashed into twice as many buckets as
there are grid entries instead, so memory is linear in the boxes wherever they are. Candidates are found
box by box, each box's few partners (the later boxes in the cells it covers, and those off the grid) put in
order by insertion, so they come out as keys ``i * n + j`` (``i < j``) sorted increasingly with no sort of
the whole list: the narrow phase then visits pairs in index order, as a test of every pair does, and a
contact's place in the list does not depend on the grid. The grid only filters: it is conservative (each
bound is widened by a little more than rounding could move it, and boxes that share a point share that
point's cell), and the narrow phase applies its own exact test to each candidate, so the contacts found are
exactly those of the all-pairs test.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import kernel, leaf

LARGE = 16  # a box covering more cells than this is tested against every box instead of being gridded
FARTHEST = 1e12  # cells from the origin beyond which a box is tested against every box (no integer overflow)
ROUNDING = 1e-9  # relative widening of each bound: far above float64 rounding, far below any contact margin


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
    per = 1.0 / cell  # cells found by one rounding: boxes sharing a point share that point's cell
    lo_x, hi_x, lo_y, hi_y = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    cells = np.empty((n, 4), np.int64)  # first and last cell along x, then y
    large = np.empty(n + 1, np.int64)
    held, entries = 0, 0
    left, right, low, high = 0, -1, 0, -1  # the gridded boxes' span of cells
    for i in range(n):
        lo_x[i], hi_x[i] = x[i] - reach_x[i] - pad, x[i] + reach_x[i] + pad
        lo_y[i], hi_y[i] = y[i] - reach_y[i] - pad, y[i] + reach_y[i] + pad
        span = LARGE + 1  # a box that is not a number, or too far out to number its cells, is not gridded
        if max(abs(lo_x[i]), abs(hi_x[i]), abs(lo_y[i]), abs(hi_y[i])) < FARTHEST * cell:
            cells[i, 0], cells[i, 1] = int(np.floor(lo_x[i] * per)), int(np.floor(hi_x[i] * per))
            cells[i, 2], cells[i, 3] = int(np.floor(lo_y[i] * per)), int(np.floor(hi_y[i] * per))
            span = (cells[i, 1] - cells[i, 0] + 1) * (cells[i, 3] - cells[i, 2] + 1)
        if span > LARGE:
            large[held] = i
            held += 1
            cells[i, 0], cells[i, 1], cells[i, 2], cells[i, 3] = 1, 0, 1, 0  # off the grid: it covers no cell
        else:
            if entries == 0:
                left, right, low, high = cells[i, 0], cells[i, 1], cells[i, 2], cells[i, 3]
            left, right = min(left, cells[i, 0]), max(right, cells[i, 1])
            low, high = min(low, cells[i, 2]), max(high, cells[i, 3])
            entries += span
    large[held] = n  # past the last: the scan of the large boxes after a box stops there
    across = right - left + 1
    # a pile's span of cells is numbered as it lies (no two cells share a slot, so a slot's entries are one
    # cell's); boxes spread out are hashed into twice as many slots as entries
    dense = float(across) * float(high - low + 1) <= 2.0 * entries + 64.0
    if dense:
        slots, mask = across * (high - low + 1), 0
    else:
        slots = 2
        while slots < 2 * entries:
            slots *= 2
        mask = slots - 1
    slot_of = np.empty(entries, np.int64)  # each box's cells' slots, box after box
    first = np.empty(n + 1, np.int64)  # box i's from first[i] on
    e = 0
    for i in range(n):
        first[i] = e
        for cx in range(cells[i, 0], cells[i, 1] + 1):
            for cy in range(cells[i, 2], cells[i, 3] + 1):
                slot_of[e] = slot(cx, cy, dense, left, low, across, mask)
                e += 1
    first[n] = e
    start = np.zeros(slots + 1, np.int64)
    for e in range(entries):
        start[slot_of[e] + 1] += 1
    for k in range(slots):
        start[k + 1] += start[k]
    fill = start[:slots].copy()
    box = np.empty(entries, np.int64)  # each slot's boxes in increasing order: filled box by box
    for i in range(n):
        for e in range(first[i], first[i + 1]):
            k = slot_of[e]
            box[fill[k]] = i
            fill[k] += 1
    partners = np.empty(n, np.int64)
    seen = np.full(n, -1, np.int64)  # the last box that met each box in a cell
    found, next_large = 0, 0
    for i in range(n):  # box by box: the keys come out sorted, each box's few partners put in order
        m = 0
        for c in range(first[i], first[i + 1]):
            k = slot_of[c]
            for e in range(start[k + 1] - 1, start[k] - 1, -1):  # the slot's boxes after i, from the last
                j = box[e]
                if j <= i:
                    break
                if seen[j] == i:  # met in another cell both cover (or, hashed, sharing a slot)
                    continue
                seen[j] = i
                if not (static[i] and static[j]) and overlap(lo_x, hi_x, lo_y, hi_y, i, j):
                    partners[m] = j
                    m += 1
        while large[next_large] <= i:
            next_large += 1
        if cells[i, 0] > cells[i, 1]:  # off the grid: every later box
            for j in range(i + 1, n):
                if not (static[i] and static[j]) and overlap(lo_x, hi_x, lo_y, hi_y, i, j):
                    partners[m] = j
                    m += 1
        else:  # the later boxes off the grid
            for h in range(next_large, held):
                j = large[h]
                if not (static[i] and static[j]) and overlap(lo_x, hi_x, lo_y, hi_y, i, j):
                    partners[m] = j
                    m += 1
        for p in range(1, m):  # a few partners: by insertion
            j = partners[p]
            q = p - 1
            while q >= 0 and partners[q] > j:
                partners[q + 1] = partners[q]
                q -= 1
            partners[q + 1] = j
        for p in range(m):
            if found < keys.shape[0]:
                keys[found] = i * n + partners[p]
            found += 1
    return found


@kernel
def slot(cx: int, cy: int, dense: bool, left: int, low: int, across: int, mask: int) -> int:
    """The slot of cell ``(cx, cy)``: its place in the span of cells from ``(left, low)``, ``across`` cells
    wide (``dense``), else its hash bucket (``mask``: buckets - 1, buckets a power of two)."""
    if dense:
        return (cy - low) * across + (cx - left)
    return ((cx * 73856093) ^ (cy * 19349663)) & mask


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
