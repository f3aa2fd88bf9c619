"""Accumulated impulses with warm start, then the lab's position correction.

The lab solver forgets every impulse at the end of a step, so each step its iterations must rebuild the
load of the whole column from zero; load reaches box ``i`` from the top only after about ``n - i`` passes,
and a tall or heavy-on-light column sinks. Here each contact keeps its accumulated impulse (the sum is
clamped at 0, not each visit) and the next step starts from it: a resting column is held by the impulses of
the step before, and the iterations only have to fix what changed.

One step:
1. the velocity half (``contacts.solve_velocities``): gravity; prepare contacts (which take part; a contact
   that left forgets its impulse); warm start, applying the carried impulses; velocity iterations
   (Gauss-Seidel on the accumulated impulses, floor first then pairs bottom-up);
2. integrate positions;
3. position correction, the lab's (slop, percent), or none.

Contacts within ``speculative`` (0.02 m, Box2D v3's distance, by default) of touching take part too, so a
column resting with small gaps is stopped in one step instead of one contact per step.

With ``warm_start`` off and ``speculative`` 0 this is the lab solver again, computed through accumulated
impulses: on a column the lab's per-visit clamp never has to take an impulse back, so the two agree.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from stackx.kernel import kernel, prange
from stackx.models.column.monitor import observe
from stackx.registry import solvers
from stackx.solvers.base import Correction, LabCorrection
from stackx.solvers.contacts import (ImpulseParams, ImpulseSolver, solve_velocities,
                                    speculative_field)
from stackx.solvers.column.position import correct_column, position_workspace
from stackx.solvers.column.pgs import integrate_positions
from stackx.models.column.state import ColumnState


class WarmStartParams(ImpulseParams):
    correction: LabCorrection = Field(
        default_factory=Correction,
        description="position handling: the lab's position correction (slop, percent), or 'off' to leave "
                    "overlap in place")
    speculative: float = speculative_field(0.02)


@kernel
def warm_start_advance(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, g: np.ndarray,
                       dt: np.ndarray, iterations: np.ndarray, carry: np.ndarray, speculative: np.ndarray,
                       corrects: np.ndarray, slop: np.ndarray, percent: np.ndarray, stage: np.ndarray, max_push: np.ndarray, impulse: np.ndarray,
                       last: np.ndarray, peak: np.ndarray, reach: np.ndarray, touched: np.ndarray, launch: np.ndarray,
                       steps: int) -> None:
    """``steps`` steps of every batch row, in place; ``impulse`` carries over between calls."""
    for b in prange(y.shape[0]):
        yb, vb, ib, hb, pb = y[b], v[b], inv[b], half[b], impulse[b]  # the row's views, made once
        n = y.shape[1]
        pf, pi = position_workspace(n)
        mass = np.zeros(n)
        target = np.zeros(n)
        for _ in range(steps):
            solve_velocities(yb, vb, ib, hb, g[b], dt[b], speculative[b], 0.0, 0.0, np.inf, carry[b],
                             iterations[b], pb, mass, target)
            integrate_positions(yb, vb, dt[b])
            if corrects[b]:
                correct_column(yb, ib, hb, slop[b], percent[b], stage[b], max_push[b] * dt[b], pf, pi)
            observe(yb, hb, dt[b], last, peak, reach, touched, launch, b)


@solvers.register("warm-start")
class WarmStart(ImpulseSolver):
    """Accumulated, warm-started impulses: few iterations hold a column the lab solver lets sink."""

    Params = WarmStartParams

    def __init__(self, params: list[WarmStartParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.iterations = self.counts("iterations")
        self.carry = self.flags("warm_start")
        self.corrects, self.slop, self.percent, self.stage, self.max_push = self.corrections()

    def advance(self, state: ColumnState, steps: int) -> None:
        warm_start_advance(state.y, state.v, state.inv_mass, state.half, self.gravity, self.dt, self.iterations,
                           self.carry, self.speculative, self.corrects, self.slop, self.percent, self.stage, self.max_push,
                           self.memory(state), *state.monitors(), steps)
