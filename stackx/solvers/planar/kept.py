"""The contacts a solver found where its last call ended, kept for its next call, in each row's own tables.

A solver finds the contacts where each step ends (they serve the step's monitors and the next step), so a call
of ``n`` steps needs ``n + 1`` collision tests: one where it starts, ``n`` where its steps end. The one where a
call starts is the one the last call ended with, unless something moved a box between the calls (a scene's
event, a removed box, another state). ``Kept`` holds, per batch row, the contact table the row's steps find
their contacts in (``ids`` and ``points``: ``collide``'s columns, ``NX`` to ``DEPTH``), the broad phase's
candidate pairs (``collide.collide_near``), and, once a call ends, how many points the table holds and the
positions, sizes and static flags they were found at. A call steps in the tables where they are: it takes
the points as they lie when every box is exactly where they were found, and the candidates when every box
has the same size and static flag (the broad phase checks the positions itself), and otherwise finds them
afresh. Contacts are a function of those arrays alone, so what a call takes back is, to the bit, what it
would have found.

A call of one step (a runner recording every step) thus pays one collision test instead of two: on a pile
of 210 boxes about 45 µs of a 190 µs step. The tables are the rows' own, not a copy: handing a call's
contacts on costs writing where the boxes are, and taking them back reading it (copying a 20-row pyramid's
800 points out at the end of a call and in at the start of the next cost about 7 µs a row).
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import leaf
from stackx.models.planar.layout import A, B, DEPTH, FEATURE, NX

# a row's table of points, besides its ids: a contact table's first columns, the ones ``collide`` fills
POINT_COLUMNS = DEPTH + 1
assert NX == 0, "the kept points are a contact table cut after DEPTH"
# where the boxes were: positions, then what the broad phase's candidates depend on
X, Y, ANGLE, HALF_X, HALF_Y, STATIC = range(6)


class Kept:
    """Per batch row: the contact table (``ids``, ``points``, room for ``room`` points), how many points it
    holds where the last call ended (``count`` -1: none to take back), where the boxes were then, and the
    broad phase's candidates (``near[b, 0]`` -1: none). Sized for ``batch`` rows of ``bodies`` boxes and
    ``room`` points.

    Made empty, not cleared: a row's points are read only up to its ``count`` and its candidates only
    when ``near[b, 0]`` says there are some, both written by a call first, so only those two are set.
    Clearing the room (8 MB for 64 rows of 210 boxes) took up to 6 ms of a fresh solver's first call, as
    long as a step of those rows."""

    def __init__(self, batch: int, bodies: int, room: int) -> None:
        self.ids = np.empty((batch, room, 3), np.int64)
        self.points = np.empty((batch, room, POINT_COLUMNS))
        self.count = np.full(batch, -1, np.int64)
        self.at = np.empty((batch, bodies, 6))
        self.near = np.empty((batch, 4 * bodies + 17), np.int64)  # ``contacts.near_workspace``'s room
        self.near[:, 0] = -1
        self.fat = np.empty((batch, bodies, 4))

    def fits(self, batch: int, bodies: int, room: int) -> bool:
        """Whether this holds rows of the given shape."""
        return self.ids.shape == (batch, room, 3) and self.at.shape[:2] == (batch, bodies)

    def forget(self) -> None:
        """Nothing kept: every row finds its contacts and candidates afresh."""
        self.count[:] = -1
        self.near[:, 0] = -1

    def arrays(self) -> tuple[np.ndarray, ...]:
        """``(ids, points, count, at, near, fat)``, as ``take_back`` and ``keep`` take them."""
        return self.ids, self.points, self.count, self.at, self.near, self.fat


@leaf
def take_back(x: np.ndarray, y: np.ndarray, angle: np.ndarray, hx: np.ndarray, hy: np.ndarray,
              inv_mass: np.ndarray, kept_count: int, at: np.ndarray, near: np.ndarray) -> int:
    """How many points one row's table holds that a collision test where the boxes are would find: its
    ``kept_count`` when every box is where they were found, else -1; the candidates ``near`` forgotten
    (``near[0] = -1``) unless every box has the size and static flag they were found with."""
    same_shape, same_place = True, True
    for i in range(x.shape[0]):
        if hx[i] != at[i, HALF_X] or hy[i] != at[i, HALF_Y] or (inv_mass[i] == 0.0) != (at[i, STATIC] != 0.0):
            same_shape = False
        if x[i] != at[i, X] or y[i] != at[i, Y] or angle[i] != at[i, ANGLE]:
            same_place = False
    if not same_shape:
        near[0] = -1
    return kept_count if same_shape and same_place else -1


@leaf
def keep(x: np.ndarray, y: np.ndarray, angle: np.ndarray, hx: np.ndarray, hy: np.ndarray, inv_mass: np.ndarray,
         ids: np.ndarray, table: np.ndarray, count: int, near: np.ndarray, fat: np.ndarray, kept_ids: np.ndarray,
         kept_points: np.ndarray, at: np.ndarray, kept_near: np.ndarray, kept_fat: np.ndarray) -> int:
    """One row's contacts and candidates found where its call ends, and where the boxes were, for the next
    call; returns the count kept (-1: more points than the room, none kept). The table and candidates are
    copied only where they are not the row's own (a call that outgrew them stepped in larger ones)."""
    for i in range(x.shape[0]):
        at[i, X], at[i, Y], at[i, ANGLE] = x[i], y[i], angle[i]
        at[i, HALF_X], at[i, HALF_Y], at[i, STATIC] = hx[i], hy[i], 1.0 if inv_mass[i] == 0.0 else 0.0
    if near.shape[0] != kept_near.shape[0]:
        kept_near[0] = -1
        if 0 <= near[0] < kept_near.shape[0]:
            for p in range(near[0] + 1):
                kept_near[p] = near[p]
            for i in range(x.shape[0]):
                for c in range(4):
                    kept_fat[i, c] = fat[i, c]
    if count > kept_ids.shape[0]:
        return -1
    if ids.shape[0] != kept_ids.shape[0]:
        for k in range(count):
            kept_ids[k, 0], kept_ids[k, 1], kept_ids[k, 2] = ids[k, A], ids[k, B], ids[k, FEATURE]
            for c in range(POINT_COLUMNS):
                kept_points[k, c] = table[k, c]
    return count
