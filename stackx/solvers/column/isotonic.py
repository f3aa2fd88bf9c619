"""The ordered projection of a column: the least mass-weighted change that keeps every contact's bound.

Both of the column's exact stages are the same problem. Given values ``u`` per box (velocities after gravity,
or a zero displacement), find ``x`` minimising ``sum m_i (x_i - u_i)^2`` such that every contact that takes
part keeps ``x[k] - x[k-1] >= target[k]`` (the floor: ``x[0] >= target[0]``). For velocities the bound is
"no approach faster than the target"; for positions it is "separate by at least this much". Shifting each
value by the targets below it turns the bounds into "non-decreasing upwards": a weighted isotonic
regression, which the pool-adjacent-violators algorithm solves exactly in O(n) (see ``solve_column``).
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import kernel


@kernel
def workspace(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Scratch for ``solve_column`` on a column of ``n`` boxes, ``(floats, indices)``: made once per column and
    reused at every step, instead of nine arrays allocated per step (on a small column, about 30% of
    the step's time). ``floats`` rows are ``u``, ``shift``, ``weight``, ``momentum``, ``pins``, ``pinned``,
    ``value``; ``indices`` rows are ``first``, ``block``. A solve writes every element it reads before reading
    it, so nothing is carried from one step to the next and the arrays need no zeroing.
    """
    return np.empty((7, n + 2)), np.empty((2, n + 2), dtype=np.int64)


@kernel
def solve_column(v: np.ndarray, inv: np.ndarray, mass: np.ndarray, target: np.ndarray, impulse: np.ndarray,
                 floats: np.ndarray, indices: np.ndarray) -> None:
    """Solve the velocity LCP of one column in place: ``v`` in is after gravity, out is after the solve.

    ``mass[k] > 0`` marks the contacts that take part and ``target[k]`` is the slowest relative velocity each
    accepts (``stackx.solvers.contacts.prepare`` fills both); ``impulse`` receives each contact's impulse.
    ``floats`` and ``indices`` are the scratch ``workspace(n)`` makes.
    """
    n = v.shape[0]
    u = floats[0]  # the velocities before the solve
    for i in range(n):
        u[i] = v[i]
    shift = floats[1]  # sum of the targets of the contacts below each box, within its chain
    # blocks of the pool-adjacent-violators stack; element -1 is the floor
    first = indices[0]  # the block's lowest box (-1: the floor)
    weight = floats[2]  # total mass of the movable boxes in the block
    momentum = floats[3]  # their total mass * shifted velocity
    pins = floats[4]  # immovable members (the floor, boxes of inverse mass 0)
    pinned = floats[5]  # sum of the pinned members' shifted velocities
    value = floats[6]  # the block's shifted velocity
    block = indices[1]  # the block each box ends in
    top = -1
    bottom = 0  # blocks below this index belong to a finished chain and never merge again
    running = 0.0
    for i in range(n):
        if mass[i] > 0.0:
            running += target[i]
            if i == 0:
                top += 1
                first[top] = -1
                weight[top], momentum[top], pins[top], pinned[top], value[top] = 0.0, 0.0, 1.0, 0.0, 0.0
        else:
            running = 0.0
            bottom = top + 1
        shift[i] = running
        s = u[i] - running
        top += 1
        first[top] = i
        if inv[i] > 0.0:
            weight[top], momentum[top], pins[top], pinned[top] = 1.0 / inv[i], s / inv[i], 0.0, 0.0
        else:
            weight[top], momentum[top], pins[top], pinned[top] = 0.0, 0.0, 1.0, s
        value[top] = s
        while top > bottom and value[top - 1] > value[top]:
            weight[top - 1] += weight[top]
            momentum[top - 1] += momentum[top]
            pins[top - 1] += pins[top]
            pinned[top - 1] += pinned[top]
            top -= 1
            value[top] = pinned[top] / pins[top] if pins[top] > 0.0 else momentum[top] / weight[top]
    first[top + 1] = n
    for b in range(top + 1):
        for i in range(max(first[b], 0), first[b + 1]):
            block[i] = b
            if inv[i] > 0.0 and first[b + 1] - first[b] > 1:
                v[i] = value[b] + shift[i]
    column_impulses(v, u, inv, mass, block, first, impulse)


@kernel
def column_impulses(v: np.ndarray, u: np.ndarray, inv: np.ndarray, mass: np.ndarray, block: np.ndarray,
                    first: np.ndarray, impulse: np.ndarray) -> None:
    """Impulses from the momentum changes: zero between blocks, summed from a free end inside a block.

    A run of movable boxes a..b inside one block is bounded below by the floor or an immovable box
    (``pinned below``) or by a slack contact, and likewise above. Going down from the top of the run, each
    contact carries the impulse above it plus the momentum change of the box on it. The impulse on the top
    contact is 0 when the top is slack, the one that makes the bottom contact 0 when only the top is pinned,
    and the least that keeps every impulse >= 0 when both are pinned (the split is then not unique).
    """
    n = v.shape[0]
    for k in range(n):
        impulse[k] = 0.0
    i = n - 1
    while i >= 0:
        if inv[i] == 0.0:
            i -= 1
            continue
        b = i
        a = i
        while a > 0 and inv[a - 1] > 0.0 and mass[a] > 0.0 and block[a - 1] == block[a]:
            a -= 1
        top_pinned = b + 1 < n and mass[b + 1] > 0.0 and block[b + 1] == block[b]
        bottom_pinned = mass[a] > 0.0 and (first[block[a]] == -1 if a == 0 else block[a - 1] == block[a])
        total = 0.0
        lowest = 0.0
        for k in range(b, a - 1, -1):
            total += (v[k] - u[k]) / inv[k]
            impulse[k] = total
            lowest = min(lowest, total)
        carried = 0.0
        if top_pinned and not bottom_pinned:
            carried = -total
        elif top_pinned:
            carried = -lowest
        if top_pinned:
            impulse[b + 1] = carried
        for k in range(a, b + 1):
            impulse[k] += carried
        if not bottom_pinned:
            impulse[a] = 0.0
        i = a - 1
