"""The position stage: undoing overlap after the velocity solve, contact by contact or the whole column at once.

Two stages share one ``correction`` section (``slop``, ``percent``, ``stage``, ``max_push``):

- ``sequential`` is the lab's: ``correct()`` on the floor, then on each pair bottom-up, each depth measured
  after the corrections before it. A contact only learns of an overlap below it through the moves of its
  neighbours, so a column overlapping at every contact recovers from its ends inwards: the number of steps
  grows with the square of its height.
- ``global`` asks every contact at once for the separation ``correct()`` would give it alone,
  ``percent * (depth - slop)``, and lets contacts within slop (or apart) close up to slop but no further. The
  smallest mass-weighted move that satisfies them all is the column's ordered projection
  (``stackx.solvers.column.isotonic``), exact in O(n): the position analogue of the ``exact`` solver's velocity
  solve. A box high up rises by the sum of the separations below it in one step.

That sum is why a speed limit belongs with it: undoing the overlap of a thousand contacts at once would move
the top box metres in a step, a launch made of positions. ``max_push`` (m/s) caps the largest move of the
stage at ``max_push * dt`` by scaling the whole move down, which keeps its shape: every overlapping contact
still separates, and no gap closes past slop (a bound ``>= target`` with ``target <= 0`` holds for any
share of a move that met it). Recovery then takes the time the top box needs to travel the column's total
overlap at ``max_push``: linear in the height, the least any capped stage can do. Box2D v3 caps its push-out
at 3 m/s (``contactPushMaxVelocity``); below the bench's launch limit (1 m/s) a capped stage never launches.
"""

from __future__ import annotations

import numpy as np

from stackx.solvers.correct import correct
from stackx.kernel import kernel
from stackx.solvers.column.isotonic import solve_column

SEQUENTIAL, GLOBAL = 0, 1
STAGES = {"sequential": SEQUENTIAL, "global": GLOBAL}


@kernel
def position_workspace(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Scratch for ``correct_column`` on ``n`` boxes, ``(floats, indices)``, made once per row and call: rows
    0-6 of ``floats`` and both of ``indices`` are ``solve_column``'s; 7-11 hold the contacts' flags, targets
    and impulses, the move and the heights before the stage."""
    return np.empty((12, n + 2)), np.empty((2, n + 2), dtype=np.int64)


@kernel
def correct_positions(y: np.ndarray, inv: np.ndarray, half: np.ndarray, slop: float, percent: float) -> None:
    """The lab's stage: push overlapping contacts apart with ``correct()``, floor first, then pairs bottom-up."""
    _, up = correct(half[0] - y[0], slop, percent, 0.0, inv[0])
    y[0] += up
    for i in range(y.shape[0] - 1):
        down, up = correct((half[i] + half[i + 1]) - (y[i + 1] - y[i]), slop, percent, inv[i], inv[i + 1])
        y[i] -= down
        y[i + 1] += up


@kernel
def project_positions(y: np.ndarray, inv: np.ndarray, half: np.ndarray, slop: float, percent: float,
                      floats: np.ndarray, indices: np.ndarray) -> None:
    """The global stage: every contact's separation asked for at once, solved as one ordered projection.

    Contact ``k`` (0 the floor, ``k`` the pair ``k-1, k``) with depth ``d`` asks for a separation of at least
    ``percent * (d - slop)`` when ``d > slop``, else allows closing by ``slop - d`` at most (up to slop of
    overlap). A contact between two immovable things sits out.
    """
    n = y.shape[0]
    take, target, impulse, move = floats[7], floats[8], floats[9], floats[10][:n]
    for k in range(n):
        if k == 0:
            d = half[0] - y[0]
            total = inv[0]
        else:
            d = (half[k - 1] + half[k]) - (y[k] - y[k - 1])
            total = inv[k - 1] + inv[k]
        take[k] = 1.0 if total > 0.0 else 0.0
        target[k] = percent * (d - slop) if d > slop else d - slop
        move[k] = 0.0
    solve_column(move, inv, take, target, impulse, floats, indices)
    for i in range(n):
        y[i] += move[i]


@kernel
def correct_column(y: np.ndarray, inv: np.ndarray, half: np.ndarray, slop: float, percent: float, stage: int,
                   max_move: float, floats: np.ndarray, indices: np.ndarray) -> None:
    """One position stage (``SEQUENTIAL`` or ``GLOBAL``), its largest move capped at ``max_move`` (m; inf for
    no cap) by scaling every box's move by the same factor."""
    n = y.shape[0]
    capped = max_move < np.inf
    before = floats[11]
    if capped:
        for i in range(n):
            before[i] = y[i]
    if stage == GLOBAL:
        project_positions(y, inv, half, slop, percent, floats, indices)
    else:
        correct_positions(y, inv, half, slop, percent)
    if capped:
        largest = 0.0
        for i in range(n):
            largest = max(largest, abs(y[i] - before[i]))
        if largest > max_move:
            share = max_move / largest
            for i in range(n):
                y[i] = before[i] + (y[i] - before[i]) * share
