"""The lab's solver: sequential impulses with no memory between steps, then position correction.

One step, in the lab's order (changing the order changes the numbers):
1. gravity: ``v += g*dt``;
2. ``iterations`` velocity passes, each visiting the floor contact then the pairs bottom-up, every contact
   seeing the velocities the earlier ones left (Gauss-Seidel); a contact only stops approach (restitution 0);
3. position update: ``y += v*dt``;
4. position correction with ``correct()``, floor first then pairs bottom-up, each depth measured after the
   corrections before it. It moves positions only: touching velocities here would turn it into a force.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from stackx.kernel import kernel, prange
from stackx.models.column.monitor import observe
from stackx.registry import solvers
from stackx.solvers.base import Correction, LabCorrection, Solver
from stackx.solvers.column.position import correct_column, position_workspace
from stackx.models.column.state import ColumnState


class PGSParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    iterations: int = Field(10, gt=0, le=100_000,
                            description="velocity passes per step: more makes a pile more solid and costs "
                                        "linearly more")
    correction: LabCorrection = Field(
        default_factory=Correction,
        description="position correction; 'off' (or null) leaves overlap to sink in")


@kernel
def gravity(v: np.ndarray, g: float, dt: float) -> None:
    for i in range(v.shape[0]):
        v[i] += g * dt


@kernel
def velocity_pass(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray) -> None:
    """One Gauss-Seidel pass over the contacts, floor first, clamping each to no approach."""
    if half[0] - y[0] > 0.0 and v[0] < 0.0 and inv[0] > 0.0:
        v[0] = 0.0
    for i in range(y.shape[0] - 1):
        depth = (half[i] + half[i + 1]) - (y[i + 1] - y[i])
        rv = v[i + 1] - v[i]
        total = inv[i] + inv[i + 1]
        if depth > 0.0 and rv < 0.0 and total > 0.0:
            j = -rv / total
            v[i] -= j * inv[i]
            v[i + 1] += j * inv[i + 1]


@kernel
def integrate_positions(y: np.ndarray, v: np.ndarray, dt: float) -> None:
    for i in range(y.shape[0]):
        y[i] += v[i] * dt


@kernel
def pgs_advance(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, g: np.ndarray,
                dt: np.ndarray, iterations: np.ndarray, slop: np.ndarray, percent: np.ndarray,
                corrects: np.ndarray, stage: np.ndarray, max_push: np.ndarray,
                last: np.ndarray, peak: np.ndarray, reach: np.ndarray, touched: np.ndarray,
                launch: np.ndarray, steps: int) -> None:
    """``steps`` lab steps of every batch row, in place."""
    for b in prange(y.shape[0]):
        yb, vb, ib, hb = y[b], v[b], inv[b], half[b]  # the row's views, made once, not at every stage call
        pf, pi = position_workspace(y.shape[1])
        for _ in range(steps):
            gravity(vb, g[b], dt[b])
            for _ in range(iterations[b]):
                velocity_pass(yb, vb, ib, hb)
            integrate_positions(yb, vb, dt[b])
            if corrects[b]:
                correct_column(yb, ib, hb, slop[b], percent[b], stage[b], max_push[b] * dt[b], pf, pi)
            observe(yb, hb, dt[b], last, peak, reach, touched, launch, b)


@solvers.register("pgs")
class PGS(Solver):
    """The lab's projected Gauss-Seidel: ``iterations`` trade CPU for how solid the pile is."""

    Params = PGSParams

    def __init__(self, params: list[PGSParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.iterations = self.counts("iterations")
        self.corrects, self.slop, self.percent, self.stage, self.max_push = self.corrections()

    def advance(self, state: ColumnState, steps: int) -> None:
        pgs_advance(state.y, state.v, state.inv_mass, state.half, self.gravity, self.dt, self.iterations,
                    self.slop, self.percent, self.corrects, self.stage, self.max_push, *state.monitors(), steps)
