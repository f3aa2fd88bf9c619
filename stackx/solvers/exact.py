"""The step's velocity problem solved exactly: the ground truth for every iterative solver.

After gravity, the velocity solve of a step asks for impulses ``lam >= 0`` on the contacts that take part,
such that every such contact ends with relative velocity ``w >= target`` and a contact only pushes while
``w = target`` (``lam * (w - target) = 0``): a linear complementarity problem (LCP) with the matrix
``A = J M^-1 J^T``, tridiagonal in a column. The lab solver's Gauss-Seidel passes converge to its solution
as the number of iterations grows.

In a column the same problem is a weighted isotonic regression. Each contact bounds the difference of two
neighbouring velocities from below (``v[k] - v[k-1] >= target[k]``, the floor ``v[0] >= target[0]``), and
the impulses that satisfy it with the least kinetic-energy change are the KKT multipliers of
``min sum m_i (v_i - u_i)^2`` under those bounds. Shifting each velocity by the targets below it turns the
bounds into "non-decreasing upwards", which the pool-adjacent-violators algorithm solves exactly in O(n):
walk up the column, and while a block of boxes would approach the block below, merge them and give the
merged block its mass-weighted mean velocity (momentum is conserved inside a block; a block resting on the
floor, or on an immovable box, takes that support's velocity). Contacts inside a block are exactly tight,
contacts between blocks exactly slack; the impulses follow from the momentum changes, summed from the free
end of each block. No iteration count, no tolerance: the answer is exact up to rounding.

Immovable boxes (inverse mass 0) keep their velocity and pin the block they belong to; a contact between two
immovable things sits out, as in the lab solver.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from stackx.kernel import kernel, prange
from stackx.monitor import observe
from stackx.registry import solvers
from stackx.solvers.base import Correction, LabCorrection, Solver
from stackx.solvers.contacts import prepare, speculative_field
from stackx.solvers.pgs import correct_positions, gravity, integrate_positions
from stackx.state import ColumnState


class ExactParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    correction: LabCorrection = Field(
        default_factory=Correction,
        description="position correction after the exact velocity solve, the lab's (slop, percent), or 'off'; "
                    "the same as the lab solver's, so the two differ only in how well the velocities are solved")
    speculative: float = speculative_field(
        0.02, "; at 0 the solve is exactly the limit of the lab solver's iterations")


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


@kernel
def exact_velocities(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, dt: float,
                     speculative: float) -> tuple[np.ndarray, np.ndarray]:
    """Ground truth of one column's velocity solve: ``(velocities, impulses)`` after it; inputs untouched.

    Float64 arrays of one row: ``y`` the positions at the start of the step, ``v`` the velocities after its
    gravity. Contacts take part as in the lab (depth > 0) with ``speculative`` 0, or within ``speculative``
    of touching. The result is what the lab solver's velocity iterations tend to as their number grows.
    """
    n = y.shape[0]
    mass = np.zeros(n)
    target = np.zeros(n)
    impulse = np.zeros(n)
    out = v.copy()
    floats, indices = workspace(n)
    prepare(y, inv, half, dt, speculative, 0.0, 0.0, np.inf, impulse, mass, target)
    solve_column(out, inv, mass, target, impulse, floats, indices)
    return out, impulse


@kernel
def exact_advance(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, g: np.ndarray,
                  dt: np.ndarray, slop: np.ndarray, percent: np.ndarray, corrects: np.ndarray,
                  speculative: np.ndarray, peak: np.ndarray, reach: np.ndarray, touched: np.ndarray,
                  launch: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row, in place: gravity, exact velocity solve, positions, correction."""
    for b in prange(y.shape[0]):
        yb, vb, ib, hb = y[b], v[b], inv[b], half[b]  # the row's views, made once, not at every stage call
        n = y.shape[1]
        mass = np.zeros(n)
        target = np.zeros(n)
        impulse = np.zeros(n)
        floats, indices = workspace(n)
        for _ in range(steps):
            gravity(vb, g[b], dt[b])
            prepare(yb, ib, hb, dt[b], speculative[b], 0.0, 0.0, np.inf, impulse, mass, target)
            solve_column(vb, ib, mass, target, impulse, floats, indices)
            integrate_positions(yb, vb, dt[b])
            if corrects[b]:
                correct_positions(yb, ib, hb, slop[b], percent[b])
            observe(yb, vb, hb, peak, reach, touched, launch, b)


@solvers.register("exact")
class Exact(Solver):
    """The velocity problem of every step solved exactly (O(n)): the limit of the lab solver's iterations."""

    Params = ExactParams

    def __init__(self, params: list[ExactParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.corrects, self.slop, self.percent = self.corrections()
        self.speculative = self.column("speculative")

    def advance(self, state: ColumnState, steps: int) -> None:
        exact_advance(state.y, state.v, state.inv_mass, state.half, self.gravity, self.dt, self.slop,
                      self.percent, self.corrects, self.speculative, *state.monitors(), steps)
