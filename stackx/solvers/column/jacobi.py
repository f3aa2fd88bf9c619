"""Jacobi: every contact solved from the same velocities, then all impulses applied at once.

Gauss-Seidel (the lab's order) lets each contact see what the contacts before it just did; Jacobi computes
every contact's impulse from the velocities at the start of the pass and applies them together, so the
contacts of a pass could be solved in parallel. Each box has two contacts (below and above) that both
correct it from the same old velocity, so a full Jacobi step overshoots and the overshoot alternates from
contact to contact; ``relaxation`` scales every change before the clamp. 1/2 (one over the contacts a box
has) never overshoots a box but makes half the progress per pass; 1 converges on a column too, but the
alternating error dies slowly. Either way it needs more passes than Gauss-Seidel for the same error.
Accumulated, warm-started impulses and the lab's position correction, as in ``warm-start``.

One step:
1. gravity;
2. prepare contacts;
3. warm start (or forget the impulses);
4. Jacobi velocity iterations;
5. integrate positions;
6. position correction (the lab's, or none).
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from stackx.kernel import kernel, prange
from stackx.models.column.monitor import observe
from stackx.registry import solvers
from stackx.solvers.base import Correction, LabCorrection
from stackx.solvers.contacts import (ImpulseParams, ImpulseSolver, prepare, push,
                                    relative_velocity, speculative_field, warm_start)
from stackx.solvers.column.position import correct_column, position_workspace
from stackx.solvers.column.pgs import gravity, integrate_positions
from stackx.models.column.state import ColumnState


class JacobiParams(ImpulseParams):
    relaxation: float = Field(0.5, gt=0, le=1, allow_inf_nan=False,
                              description="share of each contact's computed change applied per pass: 1/2 (one "
                                          "over the contacts per box) never overshoots a box but halves the "
                                          "progress; 1 is faster but leaves an alternating error that dies "
                                          "slowly")
    correction: LabCorrection = Field(
        default_factory=Correction,
        description="position handling: the lab's position correction (slop, percent), or 'off'")
    speculative: float = speculative_field(0.02)


@kernel
def jacobi_iteration(v: np.ndarray, inv: np.ndarray, impulse: np.ndarray, mass: np.ndarray, target: np.ndarray,
                     relaxation: float, change: np.ndarray) -> None:
    """One Jacobi pass: every change from the same velocities, scaled, clamped as a sum, then all applied."""
    n = v.shape[0]
    for k in range(n):
        change[k] = 0.0
        if mass[k] > 0.0:
            total = max(impulse[k] + relaxation * mass[k] * (target[k] - relative_velocity(v, k)), 0.0)
            change[k] = total - impulse[k]
    for k in range(n):
        if change[k] != 0.0:
            push(v, inv, k, change[k])
            impulse[k] += change[k]


@kernel
def jacobi_advance(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, g: np.ndarray,
                   dt: np.ndarray, iterations: np.ndarray, carry: np.ndarray, speculative: np.ndarray,
                   relaxation: np.ndarray, corrects: np.ndarray, slop: np.ndarray, percent: np.ndarray, stage: np.ndarray, max_push: np.ndarray,
                   impulse: np.ndarray, last: np.ndarray, peak: np.ndarray, reach: np.ndarray, touched: np.ndarray,
                   launch: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row, in place; ``impulse`` carries over between calls."""
    for b in prange(y.shape[0]):
        yb, vb, ib, hb, pb = y[b], v[b], inv[b], half[b], impulse[b]  # the row's views, made once
        n = y.shape[1]
        pf, pi = position_workspace(n)
        mass = np.zeros(n)
        target = np.zeros(n)
        change = np.zeros(n)
        for _ in range(steps):
            gravity(vb, g[b], dt[b])
            prepare(yb, ib, hb, dt[b], speculative[b], 0.0, 0.0, np.inf, pb, mass, target)
            warm_start(vb, ib, pb, carry[b])
            for _ in range(iterations[b]):
                jacobi_iteration(vb, ib, pb, mass, target, relaxation[b], change)
            integrate_positions(yb, vb, dt[b])
            if corrects[b]:
                correct_column(yb, ib, hb, slop[b], percent[b], stage[b], max_push[b] * dt[b], pf, pi)
            observe(yb, hb, dt[b], last, peak, reach, touched, launch, b)


@solvers.register("jacobi")
class Jacobi(ImpulseSolver):
    """Contacts solved in parallel from the same velocities, relaxed: parallel-friendly, slower to converge."""

    Params = JacobiParams

    def __init__(self, params: list[JacobiParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.iterations = self.counts("iterations")
        self.carry = self.flags("warm_start")
        self.relaxation = self.column("relaxation")
        self.corrects, self.slop, self.percent, self.stage, self.max_push = self.corrections()

    def advance(self, state: ColumnState, steps: int) -> None:
        jacobi_advance(state.y, state.v, state.inv_mass, state.half, self.gravity, self.dt, self.iterations,
                       self.carry, self.speculative, self.relaxation, self.corrects, self.slop, self.percent, self.stage, self.max_push,
                       self.memory(state), *state.monitors(), steps)
