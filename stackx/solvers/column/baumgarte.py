"""Baumgarte stabilisation: overlap is undone by a bias velocity inside the velocity solve.

Instead of moving positions after the velocity solve, each overlapping contact asks for a separating speed
``beta/dt * max(depth - slop, 0)``: the velocity iterations push the boxes apart and the position update
carries them out of the overlap. The correction becomes a force (the lab's "common mistake 1"): the push-out
speed stays in the boxes after the overlap is gone, so a deep overlap throws boxes up, and the bias fights
the load of a resting column. box2d-lite works this way (beta 0.2, slop 0.01, 10 iterations, accumulated
impulses with warm start); Solver2D caps the bias at 4 m/s.

One step:
1. the velocity half (``contacts.solve_velocities``): gravity; prepare contacts, each with its bias; warm
   start (or forget the impulses); velocity iterations towards the biased targets;
2. integrate positions.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from stackx.kernel import kernel, prange
from stackx.models.column.monitor import observe
from stackx.registry import solvers
from stackx.solvers.contacts import ImpulseParams, ImpulseSolver, solve_velocities
from stackx.solvers.column.pgs import integrate_positions
from stackx.models.column.state import ColumnState


class BaumgarteParams(ImpulseParams):
    beta: float = Field(0.2, gt=0, le=1, allow_inf_nan=False,
                        description="share of the overlap beyond slop turned into separating speed per step: "
                                    "larger recovers faster but adds more energy and bounces")
    slop: float = Field(0.01, ge=0, allow_inf_nan=False,
                        description="overlap (m) the bias leaves alone: 0 keeps pushing on every resting "
                                    "contact and jitters")
    max_bias: float | None = Field(None, gt=0, allow_inf_nan=False,
                                   description="largest separating speed the bias may ask for (m/s); null for no "
                                               "cap (box2d-lite); a cap (Solver2D: 4) keeps a deep overlap from "
                                               "launching boxes but recovers it more slowly")


@kernel
def baumgarte_advance(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, g: np.ndarray,
                      dt: np.ndarray, iterations: np.ndarray, carry: np.ndarray, speculative: np.ndarray,
                      beta: np.ndarray, slop: np.ndarray, max_bias: np.ndarray, impulse: np.ndarray,
                      last: np.ndarray, peak: np.ndarray, reach: np.ndarray, touched: np.ndarray, launch: np.ndarray,
                      steps: int) -> None:
    """``steps`` steps of every batch row, in place; ``impulse`` carries over between calls."""
    for b in prange(y.shape[0]):
        yb, vb, ib, hb, pb = y[b], v[b], inv[b], half[b], impulse[b]  # the row's views, made once
        n = y.shape[1]
        mass = np.zeros(n)
        target = np.zeros(n)
        for _ in range(steps):
            solve_velocities(yb, vb, ib, hb, g[b], dt[b], speculative[b], beta[b], slop[b], max_bias[b],
                             carry[b], iterations[b], pb, mass, target)
            integrate_positions(yb, vb, dt[b])
            observe(yb, hb, dt[b], last, peak, reach, touched, launch, b)


@solvers.register("baumgarte")
class Baumgarte(ImpulseSolver):
    """Overlap undone by a bias velocity in the velocity solve: simple, but the correction is a force."""

    Params = BaumgarteParams

    def __init__(self, params: list[BaumgarteParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.iterations = self.counts("iterations")
        self.carry = self.flags("warm_start")
        self.beta = self.column("beta")
        self.slop = self.column("slop")
        self.max_bias = self.column("max_bias", np.inf)

    def advance(self, state: ColumnState, steps: int) -> None:
        baumgarte_advance(state.y, state.v, state.inv_mass, state.half, self.gravity, self.dt, self.iterations,
                          self.carry, self.speculative, self.beta, self.slop, self.max_bias, self.memory(state),
                          *state.monitors(), steps)
