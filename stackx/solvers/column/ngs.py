"""Nonlinear Gauss-Seidel (NGS): position iterations that measure each depth again at every visit.

After the velocity solve and the position update, a few passes go over the contacts, floor first then pairs
bottom-up, and push each overlapping pair apart by ``percent`` of its depth beyond ``slop``, at most
``max_correction`` per visit; every visit measures the depth as the visits before it left it. The lab's
position correction is one such pass without the cap; NGS repeats it and so reaches further down a column in
one step. Velocities are not touched, so no energy is added. Box2D 2.x: 8 velocity and 3 position iterations,
percent (its Baumgarte factor) 0.2, slop 0.005, at most 0.2 m per visit, and the passes stop early once no
contact is deeper than 3 x slop.

One step:
1. the velocity half (``contacts.solve_velocities``): gravity; prepare contacts; warm start (or forget the
   impulses); velocity iterations;
2. integrate positions;
3. position iterations.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from stackx.solvers.correct import correct
from stackx.kernel import kernel, prange
from stackx.models.column.monitor import observe
from stackx.registry import solvers
from stackx.solvers.contacts import ImpulseParams, ImpulseSolver, depth, solve_velocities
from stackx.solvers.column.pgs import integrate_positions
from stackx.models.column.state import ColumnState

SOLVED = 3.0  # position passes stop once no contact is deeper than this many slops (Box2D 2.x)


class NGSParams(ImpulseParams):
    iterations: int = Field(8, gt=0, le=100_000,
                            description="velocity passes per step (Box2D 2.x: 8): more converge further "
                                        "towards the exact solve and cost linearly more")
    position_iterations: int = Field(3, gt=0, le=100_000,
                                     description="most position passes per step (Box2D 2.x: 3); they stop early "
                                                 "once every depth is within 3 x slop: more reach deeper into a "
                                                 "sunk column in one step")
    percent: float = Field(0.2, gt=0, le=1, allow_inf_nan=False,
                           description="share of a contact's depth beyond slop undone per visit: 1 overshoots "
                                       "as neighbours are pushed into each other, small values need more passes")
    slop: float = Field(0.005, ge=0, allow_inf_nan=False,
                        description="overlap (m) left alone (Box2D 2.x linear slop): 0 corrects every "
                                    "resting contact every step")
    max_correction: float = Field(0.2, gt=0, allow_inf_nan=False,
                                  description="largest move of one visit (m): keeps a deep overlap from being "
                                              "thrown apart in one step, at the cost of a slower recovery")


@kernel
def position_iteration(y: np.ndarray, inv: np.ndarray, half: np.ndarray, slop: float, percent: float,
                       max_correction: float) -> float:
    """One pass of capped corrections, each depth measured after the visits before it; returns the deepest.

    The cap enters as a depth: ``correct`` of ``min(depth, slop + max_correction/percent)`` moves
    ``min(percent*(depth - slop), max_correction)`` in total.
    """
    deepest = -np.inf
    cap = slop + max_correction / percent
    for k in range(y.shape[0]):
        d = depth(y, half, k)
        deepest = max(deepest, d)
        if k == 0:
            _, up = correct(min(d, cap), slop, percent, 0.0, inv[0])
        else:
            down, up = correct(min(d, cap), slop, percent, inv[k - 1], inv[k])
            y[k - 1] -= down
        y[k] += up
    return deepest


@kernel
def ngs_advance(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, g: np.ndarray,
                dt: np.ndarray, iterations: np.ndarray, carry: np.ndarray, speculative: np.ndarray,
                position_iterations: np.ndarray, percent: np.ndarray, slop: np.ndarray,
                max_correction: np.ndarray, impulse: np.ndarray, last: np.ndarray, peak: np.ndarray, reach: np.ndarray,
                touched: np.ndarray, launch: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row, in place; ``impulse`` carries over between calls."""
    for b in prange(y.shape[0]):
        yb, vb, ib, hb, pb = y[b], v[b], inv[b], half[b], impulse[b]  # the row's views, made once
        n = y.shape[1]
        mass = np.zeros(n)
        target = np.zeros(n)
        for _ in range(steps):
            solve_velocities(yb, vb, ib, hb, g[b], dt[b], speculative[b], 0.0, 0.0, np.inf, carry[b],
                             iterations[b], pb, mass, target)
            integrate_positions(yb, vb, dt[b])
            for _ in range(position_iterations[b]):
                if position_iteration(yb, ib, hb, slop[b], percent[b], max_correction[b]) <= SOLVED * slop[b]:
                    break
            observe(yb, hb, dt[b], last, peak, reach, touched, launch, b)


@solvers.register("ngs")
class NGS(ImpulseSolver):
    """Velocity iterations, then position passes that re-measure every depth (Box2D 2.x)."""

    Params = NGSParams

    def __init__(self, params: list[NGSParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.iterations = self.counts("iterations")
        self.carry = self.flags("warm_start")
        self.position_iterations = self.counts("position_iterations")
        self.percent = self.column("percent")
        self.slop = self.column("slop")
        self.max_correction = self.column("max_correction")

    @classmethod
    def passes(cls, params: NGSParams) -> int:
        return params.iterations + params.position_iterations

    def advance(self, state: ColumnState, steps: int) -> None:
        ngs_advance(state.y, state.v, state.inv_mass, state.half, self.gravity, self.dt, self.iterations,
                    self.carry, self.speculative, self.position_iterations, self.percent, self.slop,
                    self.max_correction, self.memory(state), *state.monitors(), steps)
