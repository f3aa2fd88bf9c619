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
from stackx.models.column.monitor import observe
from stackx.registry import solvers
from stackx.solvers.base import Correction, LabCorrection, Solver
from stackx.solvers.contacts import depth, inverse_mass_sum, prepare, relative_velocity, speculative_field
from stackx.solvers.column.isotonic import solve_column, workspace
from stackx.solvers.column.position import correct_column, position_workspace
from stackx.solvers.column.pgs import gravity, integrate_positions
from stackx.models.column.state import ColumnState


class ExactParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    correction: LabCorrection = Field(
        default_factory=Correction,
        description="position correction after the exact velocity solve, the lab's (slop, percent), or 'off'; "
                    "the same as the lab solver's, so the two differ only in how well the velocities are solved")
    speculative: float = speculative_field(
        0.02, "; at 0 the solve is exactly the limit of the lab solver's iterations")
    swept: bool = Field(False, description="let a contact join the step when the solved velocities would close "
                                           "its gap within it, and solve again: no landing ever penetrates, at "
                                           "any speed (continuous contact); off, a box faster than "
                                           "speculative/dt lands inside the one below, for position correction "
                                           "to undo")


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
    solve_step(y, out, inv, half, dt, speculative, False, mass, target, impulse, floats, indices, np.zeros(n))
    return out, impulse


@kernel
def join_closing(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, dt: float, mass: np.ndarray,
                 target: np.ndarray) -> bool:
    """Make every contact that sits the step out but whose gap ``v`` would close within ``dt`` take part, as a
    speculative contact; True when one joined."""
    joined = False
    for k in range(y.shape[0]):
        total = inverse_mass_sum(inv, k)
        if mass[k] == 0.0 and total > 0.0:
            d = depth(y, half, k)
            if d + (-relative_velocity(v, k)) * dt > 0.0:
                mass[k] = 1.0 / total
                target[k] = min(d, 0.0) / dt
                joined = True
    return joined


@kernel
def solve_step(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, dt: float, speculative: float,
               swept: bool, mass: np.ndarray, target: np.ndarray, impulse: np.ndarray, floats: np.ndarray,
               indices: np.ndarray, start: np.ndarray) -> None:
    """The exact velocity stage of one column, ``v`` after gravity in, solved out. ``swept``: contacts the
    solved velocities would close join and the solve starts again from ``start`` (scratch for the velocities
    after gravity); each round adds a contact, so it ends. To need few rounds, a swept step starts with every
    contact within the distance the column's spread of velocities (the floor's 0 included) covers in ``dt``:
    no solved relative velocity is usually faster than that spread, so the rounds only mend the rare miss."""
    margin = speculative
    if swept:
        low, high = 0.0, 0.0
        for i in range(v.shape[0]):
            start[i] = v[i]
            low, high = min(low, v[i]), max(high, v[i])
        margin = max(speculative, (high - low) * dt)
    prepare(y, inv, half, dt, margin, 0.0, 0.0, np.inf, impulse, mass, target)
    solve_column(v, inv, mass, target, impulse, floats, indices)
    while swept and join_closing(y, v, inv, half, dt, mass, target):
        for i in range(v.shape[0]):
            v[i] = start[i]
        solve_column(v, inv, mass, target, impulse, floats, indices)


@kernel
def exact_advance(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, g: np.ndarray,
                  dt: np.ndarray, slop: np.ndarray, percent: np.ndarray, stage: np.ndarray, max_push: np.ndarray,
                  corrects: np.ndarray, speculative: np.ndarray, swept: np.ndarray, last: np.ndarray,
                  peak: np.ndarray, reach: np.ndarray, touched: np.ndarray, launch: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row, in place: gravity, exact velocity solve, positions, correction."""
    for b in prange(y.shape[0]):
        yb, vb, ib, hb = y[b], v[b], inv[b], half[b]  # the row's views, made once, not at every stage call
        n = y.shape[1]
        pf, pi = position_workspace(n)
        mass = np.zeros(n)
        target = np.zeros(n)
        impulse = np.zeros(n)
        start = np.zeros(n)
        floats, indices = workspace(n)
        for _ in range(steps):
            gravity(vb, g[b], dt[b])
            solve_step(yb, vb, ib, hb, dt[b], speculative[b], swept[b], mass, target, impulse, floats, indices,
                       start)
            integrate_positions(yb, vb, dt[b])
            if corrects[b]:
                correct_column(yb, ib, hb, slop[b], percent[b], stage[b], max_push[b] * dt[b], pf, pi)
            observe(yb, hb, dt[b], last, peak, reach, touched, launch, b)


@solvers.register("exact")
class Exact(Solver):
    """The velocity problem of every step solved exactly (O(n)): the limit of the lab solver's iterations."""

    Params = ExactParams

    def __init__(self, params: list[ExactParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.corrects, self.slop, self.percent, self.stage, self.max_push = self.corrections()
        self.speculative = self.column("speculative")
        self.swept = self.flags("swept")

    def advance(self, state: ColumnState, steps: int) -> None:
        exact_advance(state.y, state.v, state.inv_mass, state.half, self.gravity, self.dt, self.slop,
                      self.percent, self.stage, self.max_push, self.corrects, self.speculative, self.swept,
                      *state.monitors(), steps)
