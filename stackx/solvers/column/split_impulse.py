"""Split impulses: overlap undone by a pseudo-velocity that moves positions and is then thrown away.

Baumgarte's bias pushes overlapping boxes apart through their real velocity, so the push-out stays in them
as energy. Here the velocity iterations only stop approach (no bias), and a second, separate velocity, the
pseudo-velocity, is solved for the overlap with the same bias ``beta/dt * max(depth - slop, 0)``. Positions
move by both; the pseudo-velocity and its impulses are discarded at the end of the step, so the momentum the
boxes carry into the next step is clean. Catto used this in the Box2D 1.x era.

One step:
1. the velocity half (``contacts.solve_velocities``): gravity; prepare contacts (no approach, no bias);
   warm start (or forget the impulses); velocity iterations;
2. pseudo-velocity iterations for the overlap's bias, from zero pseudo-velocity and zero pseudo impulses;
3. integrate positions with the velocity and the pseudo-velocity.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from stackx.kernel import kernel, prange
from stackx.models.column.monitor import observe
from stackx.registry import solvers
from stackx.solvers.contacts import ImpulseParams, ImpulseSolver, prepare, solve_velocities, velocity_iteration
from stackx.solvers.column.pgs import integrate_positions
from stackx.models.column.state import ColumnState


class SplitImpulseParams(ImpulseParams):
    position_iterations: int = Field(10, gt=0, le=100_000,
                                     description="pseudo-velocity passes per step: more undo overlap deep in a "
                                                 "column in fewer steps, at the cost of one more pass each")
    beta: float = Field(0.2, gt=0, le=1, allow_inf_nan=False,
                        description="share of the overlap beyond slop removed per step by the pseudo-velocity: "
                                    "1 removes it at once (no energy is added, but neighbours are shoved); "
                                    "small values creep out slowly")
    slop: float = Field(0.01, ge=0, allow_inf_nan=False,
                        description="overlap (m) left alone: 0 corrects every resting contact every step")


@kernel
def pseudo_solve(y: np.ndarray, inv: np.ndarray, half: np.ndarray, dt: float, beta: float, slop: float,
                 iterations: int, pseudo: np.ndarray, impulse: np.ndarray, mass: np.ndarray,
                 target: np.ndarray) -> None:
    """Solve the pseudo-velocity ``pseudo`` for the overlap of the positions ``y``; velocities are untouched."""
    for i in range(pseudo.shape[0]):
        pseudo[i] = 0.0
    prepare(y, inv, half, dt, 0.0, beta, slop, np.inf, impulse, mass, target)
    for i in range(pseudo.shape[0]):
        impulse[i] = 0.0
    for _ in range(iterations):
        velocity_iteration(pseudo, inv, impulse, mass, target)


@kernel
def split_impulse_advance(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, g: np.ndarray,
                          dt: np.ndarray, iterations: np.ndarray, carry: np.ndarray, speculative: np.ndarray,
                          position_iterations: np.ndarray, beta: np.ndarray, slop: np.ndarray,
                          impulse: np.ndarray, last: np.ndarray, peak: np.ndarray, reach: np.ndarray, touched: np.ndarray,
                          launch: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row, in place; ``impulse`` carries over between calls."""
    for b in prange(y.shape[0]):
        yb, vb, ib, hb, pb = y[b], v[b], inv[b], half[b], impulse[b]  # the row's views, made once
        n = y.shape[1]
        mass = np.zeros(n)
        target = np.zeros(n)
        pseudo = np.zeros(n)
        pseudo_impulse = np.zeros(n)
        pseudo_mass = np.zeros(n)
        pseudo_target = np.zeros(n)
        for _ in range(steps):
            solve_velocities(yb, vb, ib, hb, g[b], dt[b], speculative[b], 0.0, 0.0, np.inf, carry[b],
                             iterations[b], pb, mass, target)
            pseudo_solve(yb, ib, hb, dt[b], beta[b], slop[b], position_iterations[b], pseudo,
                         pseudo_impulse, pseudo_mass, pseudo_target)
            integrate_positions(yb, vb, dt[b])
            integrate_positions(yb, pseudo, dt[b])
            observe(yb, hb, dt[b], last, peak, reach, touched, launch, b)


@solvers.register("split-impulse")
class SplitImpulse(ImpulseSolver):
    """Overlap undone by a throw-away pseudo-velocity: positions recover, momentum stays clean."""

    Params = SplitImpulseParams

    def __init__(self, params: list[SplitImpulseParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.iterations = self.counts("iterations")
        self.carry = self.flags("warm_start")
        self.position_iterations = self.counts("position_iterations")
        self.beta = self.column("beta")
        self.slop = self.column("slop")

    @classmethod
    def passes(cls, params: SplitImpulseParams) -> int:
        return params.iterations + params.position_iterations

    def advance(self, state: ColumnState, steps: int) -> None:
        split_impulse_advance(state.y, state.v, state.inv_mass, state.half, self.gravity, self.dt,
                              self.iterations, self.carry, self.speculative, self.position_iterations, self.beta,
                              self.slop, self.memory(state), *state.monitors(), steps)
