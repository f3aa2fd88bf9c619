"""A worked example of a local solver plugin: projected successive over-relaxation (SOR).

Dropped into a ``plugins/`` folder, this file is imported before configs are resolved, so a config can
say ``solver: {name: sor, omega: 1.3}`` without installing anything. It reuses the lab solver's stages and
changes one thing: each contact's impulse is scaled by ``omega`` before the clamp. ``omega`` > 1
over-relaxes (fewer passes for the same error on a stiff column, until it overshoots), ``omega`` < 1
damps; ``omega`` = 1 is exactly the lab solver.

It is written as every built-in solver is: the params packed into one array per batch row, and a stepping
loop of ``@kernel`` functions over the rows with ``prange``, so it runs plain or compiled with the same
numbers.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from stackx.kernel import kernel, prange
from stackx.models.column.monitor import observe
from stackx.registry import solvers
from stackx.solvers.base import Solver
from stackx.solvers.column.pgs import PGSParams, gravity, integrate_positions
from stackx.solvers.column.position import correct_column, position_workspace
from stackx.models.column.state import ColumnState


class SORParams(PGSParams):
    omega: float = Field(1.3, gt=0, lt=2, allow_inf_nan=False,
                         description="relaxation factor: >1 speeds convergence until it overshoots, <1 damps")


@kernel
def relaxed_pass(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, omega: float) -> None:
    """One Gauss-Seidel pass; each approaching contact gets ``omega`` times the impulse that would stop it."""
    if half[0] - y[0] > 0.0 and v[0] < 0.0 and inv[0] > 0.0:
        v[0] -= omega * v[0]
    for i in range(y.shape[0] - 1):
        depth = (half[i] + half[i + 1]) - (y[i + 1] - y[i])
        rv = v[i + 1] - v[i]
        total = inv[i] + inv[i + 1]
        if depth > 0.0 and rv < 0.0 and total > 0.0:
            j = -omega * rv / total
            v[i] -= j * inv[i]
            v[i + 1] += j * inv[i + 1]


@kernel
def sor_advance(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, g: np.ndarray, dt: np.ndarray,
                iterations: np.ndarray, omega: np.ndarray, corrects: np.ndarray, slop: np.ndarray,
                percent: np.ndarray, stage: np.ndarray, max_push: np.ndarray, last: np.ndarray,
                peak: np.ndarray, reach: np.ndarray, touched: np.ndarray, launch: np.ndarray,
                steps: int) -> None:
    """``steps`` steps of every batch row, in place: the lab's step with relaxed velocity passes."""
    for b in prange(y.shape[0]):
        yb, vb, ib, hb = y[b], v[b], inv[b], half[b]  # the row's views, made once
        pf, pi = position_workspace(y.shape[1])
        for _ in range(steps):
            gravity(vb, g[b], dt[b])
            for _ in range(iterations[b]):
                relaxed_pass(yb, vb, ib, hb, omega[b])
            integrate_positions(yb, vb, dt[b])
            if corrects[b]:
                correct_column(yb, ib, hb, slop[b], percent[b], stage[b], max_push[b] * dt[b], pf, pi)
            observe(yb, hb, dt[b], last, peak, reach, touched, launch, b)


@solvers.register("sor")
class SOR(Solver):
    """The lab solver with over-relaxed impulses (``omega``): fewer passes for the same depth, up to a point."""

    Params = SORParams

    def __init__(self, params: list[SORParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.iterations = self.counts("iterations")
        self.omega = self.column("omega")
        self.corrects, self.slop, self.percent, self.stage, self.max_push = self.corrections()

    def advance(self, state: ColumnState, steps: int) -> None:
        sor_advance(state.y, state.v, state.inv_mass, state.half, self.gravity, self.dt, self.iterations,
                    self.omega, self.corrects, self.slop, self.percent, self.stage, self.max_push,
                    *state.monitors(), steps)
