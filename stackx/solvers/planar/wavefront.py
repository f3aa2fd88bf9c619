"""An order of a pass's manifolds that changes no number and lets the processor overlap their work.

A Gauss-Seidel pass visits manifolds one after the other, each reading and writing its two bodies'
velocities. In ``collide``'s order (by body ``A``, then ``B``) one manifold after the next shares body ``A``,
so each visit waits for the one before it: the pass runs at the latency of its arithmetic, not at the rate
the processor can issue it. Two visits that share no body commute exactly, so any order that keeps, for
every body, the order of the manifolds that touch it gives the same velocities and impulses to the bit.

``wavefronts`` finds one: a manifold's wave is one more than the latest wave among the earlier manifolds
that share a body with it (the ground, which no visit moves, links none), and the manifolds are visited
wave by wave, in table order within a wave. The manifolds of one wave share no body, so a processor works
on several at once. On a pyramid of 20 rows (400 manifolds) there are 57 waves, about 7 manifolds each.
Box2D v3 gets its independent work from graph colouring instead, which reorders the visits of a body and so
changes the numbers.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import kernel, leaf
from stackx.models.planar.layout import A, B


@leaf
def manifold_end(ids: np.ndarray, start: int, count: int) -> int:
    """One past the last point of the manifold (the same two bodies) that begins at ``start``."""
    end = start + 1
    while end < count and ids[end, A] == ids[start, A] and ids[end, B] == ids[start, B]:
        end += 1
    return end


@leaf
def manifold_starts(ids: np.ndarray, count: int, first: np.ndarray) -> int:
    """Where each manifold (the consecutive points of the same two bodies) begins: ``first[0..m]``, with
    ``first[m] = count``; returns ``m``. ``first`` has room for ``count + 1``."""
    m, k = 0, 0
    while k < count:
        first[m] = k
        m += 1
        k = manifold_end(ids, k, count)
    first[m] = count
    return m


@leaf
def sort_by_group(group: np.ndarray, m: int, groups: int, tally: np.ndarray, order: np.ndarray) -> None:
    """``order[0..m]``: the manifolds ``0..m-1`` by ``group``, table order within a group (a counting sort).
    On entry ``tally[g + 1]`` holds group ``g``'s count (``tally[0]`` 0); on exit ``tally[g]`` is where group ``g``
    ends in ``order``."""
    for g in range(1, groups + 1):  # tally[g]: where group g begins
        tally[g] += tally[g - 1]
    for j in range(m):  # tally[g] moves from where group g begins to where it ends
        order[tally[group[j]]] = j
        tally[group[j]] += 1


@leaf
def wavefronts(ids: np.ndarray, first: np.ndarray, m: int, latest: np.ndarray, wave: np.ndarray,
               tally: np.ndarray, order: np.ndarray) -> int:
    """``order[0..m]``: the manifolds (numbered as in ``first``) wave by wave, table order within a wave;
    returns the number of waves, and ``tally[v]`` is where wave ``v`` ends in ``order``.

    Scratch: ``latest`` ``(bodies,)``, the last wave that touched each body; ``wave`` ``(m,)``; ``tally``
    ``(m + 1,)``. A counting sort by wave, so linear in the manifolds."""
    for i in range(latest.shape[0]):
        latest[i] = 0
    for v in range(m + 1):
        tally[v] = 0
    waves = 0
    for j in range(m):
        a, b = ids[first[j], A], ids[first[j], B]
        now = latest[b]
        if a >= 0 and latest[a] > now:
            now = latest[a]
        now += 1
        latest[b] = now
        if a >= 0:
            latest[a] = now
        wave[j] = now - 1
        tally[now] += 1
        if now > waves:
            waves = now
    sort_by_group(wave, m, waves, tally, order)
    return waves


@kernel
def manifold_order(ids: np.ndarray, count: int, bodies: int) -> np.ndarray:
    """The first points of the table's ``count`` points' manifolds, wave by wave (``wavefronts``): the order
    a pass that allocates per step visits them in (``contacts.accumulated_iteration``).
    A wave of a 20-row pyramid's manifolds overlaps in the processor: about a quarter off a pass."""
    first = np.empty(count + 1, np.int64)
    m = manifold_starts(ids, count, first)
    order = np.empty(m, np.int64)
    wavefronts(ids, first, m, np.empty(bodies, np.int64), np.empty(m, np.int64), np.empty(m + 1, np.int64), order)
    return first[order]
