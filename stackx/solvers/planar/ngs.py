"""Nonlinear Gauss-Seidel (NGS) on planar boxes: velocity iterations, then position iterations that measure
every separation again, rotation included (Box2D 2.x's solver).

One step of one world:
1. the velocity half (``passes.solve_laid``: ``contacts.solve_velocities``' numbers on the contacts laid out
   in visiting order, as ``planar-warm-start``'s): gravity; the points within ``speculative`` of touching,
   or within what the fastest box can close in the step when that is more (``reach``);
   warm start by ``(A, B, feature)``; ``iterations`` passes with accumulated clamping, Coulomb friction and
   two-point manifolds' normals solved together (``block``);
2. each point's face plane and corner fixed to the bodies that carry them (``contacts.anchor_locals``);
3. positions and angles move with the velocities;
4. up to ``position_iterations`` passes of ``contacts.separation_push``: each point's depth measured from the
   current positions and angles, then pushed apart by ``percent * (depth - slop)``, at most
   ``max_correction``, at its lever arms, so boxes turn as well as move; the passes stop once no point is
   deeper than 3 x slop. Velocities are not touched, so the push adds no energy.

Box2D 2.x's numbers, the defaults here: 8 velocity and 3 position iterations, percent (its Baumgarte factor)
0.2, slop 0.005 m (its linear slop), at most 0.2 m per push. Where the lab's correction pushes at the centre
and leaves a box tilted into its support, this pass turns it back, which is what keeps a tall stack from
leaning over step after step.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from stackx.kernel import kernel, prange
from stackx.models.planar.state import PlanarState
from stackx.registry import solvers
from stackx.solvers.contacts import speculative_field
from stackx.solvers.planar.base import PlanarMemorySolver
from stackx.solvers.planar.contacts import (anchor_locals, contact_workspace, find_contacts, integrate_positions,
                                            observed_contacts, separation_push)
from stackx.solvers.planar.passes import laid_workspace, solve_laid
from stackx.solvers.planar.reach import contact_margin

SOLVED = 3.0  # position passes stop once no point is deeper than this many slops (Box2D 2.x)


class PlanarNGSParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    iterations: int = Field(8, gt=0, le=100_000,
                            description="velocity passes per step (Box2D 2.x: 8): more converge further towards "
                                        "the exact solve and cost linearly more")
    position_iterations: int = Field(3, gt=0, le=100_000,
                                     description="most position passes per step (Box2D 2.x: 3); they stop early "
                                                 "once every depth is within 3 x slop: more undo a deep overlap "
                                                 "in fewer steps")
    warm_start: bool = Field(True, description="start each step from the impulses each point carried at the end "
                                               "of the last one; off rebuilds every load from zero each step")
    block: bool = Field(True, description="solve the two normal impulses of a two-point manifold together "
                                          "(Box2D 2.x's block solver); off visits the corners one by one")
    speculative: float = speculative_field(0.02, " Here it grows to what the fastest box can close in the step "
                                                 "(stackx.solvers.planar.reach), so a fast box is found before "
                                                 "it is inside what it hits")
    percent: float = Field(0.2, gt=0, le=1, allow_inf_nan=False,
                           description="share of a point's depth beyond slop undone per visit: 1 overshoots as "
                                       "neighbours are pushed into each other, small values need more passes")
    slop: float = Field(0.005, ge=0, allow_inf_nan=False,
                        description="overlap (m) left alone (Box2D 2.x linear slop): 0 corrects every resting "
                                    "point every step")
    max_correction: float = Field(0.2, gt=0, allow_inf_nan=False,
                                  description="largest push of one visit (m): keeps a deep overlap from being "
                                              "thrown apart in one step, at the cost of a slower recovery")


@kernel
def planar_ngs_advance(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                       w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray,
                       hy: np.ndarray, friction: np.ndarray, g: np.ndarray, dt: np.ndarray, iterations: np.ndarray,
                       carry: np.ndarray, block: np.ndarray, speculative: np.ndarray,
                       position_iterations: np.ndarray, percent: np.ndarray, slop: np.ndarray,
                       max_correction: np.ndarray, keys: np.ndarray, carried: np.ndarray, held: np.ndarray,
                       last: np.ndarray, peak: np.ndarray, reach: np.ndarray, touched: np.ndarray,
                       launch: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row, in place; ``keys``, ``carried`` and ``held`` carry over."""
    for b in prange(x.shape[0]):
        xb, yb, ab, vxb, vyb, wb = x[b], y[b], angle[b], vx[b], vy[b], w[b]  # the row's views, made once
        im, ii, hxb, hyb, mub = inv_mass[b], inv_inertia[b], hx[b], hy[b], friction[b]
        ids, table = contact_workspace(keys.shape[1])
        margin = contact_margin(speculative[b], vxb, vyb, wb, im, hxb, hyb, g[b], dt[b])
        ids, table, count = find_contacts(xb, yb, ab, hxb, hyb, im, margin, ids, table)
        first, order, group, tally, latest, links, rows, bodies = laid_workspace(ids.shape[0], x.shape[1])
        for _ in range(steps):
            if rows.shape[0] < ids.shape[0]:  # the table grew
                first, order, group, tally, latest, links, rows, bodies = laid_workspace(ids.shape[0], x.shape[1])
            held[b] = solve_laid(xb, yb, vxb, vyb, wb, im, ii, mub, g[b], dt[b], carry[b], iterations[b], block[b],
                                 1.0, ids, table, count, keys[b], carried[b], held[b], first, order, group, tally,
                                 latest, links, rows, bodies)
            anchor_locals(xb, yb, ab, ids, table, count)
            integrate_positions(xb, yb, ab, vxb, vyb, wb, dt[b])
            for _ in range(position_iterations[b]):
                deepest = separation_push(xb, yb, ab, im, ii, ids, table, count, slop[b], percent[b],
                                          max_correction[b])
                if deepest <= SOLVED * slop[b]:
                    break
            margin = contact_margin(speculative[b], vxb, vyb, wb, im, hxb, hyb, g[b], dt[b])
            ids, table, count = observed_contacts(xb, yb, ab, hxb, hyb, im, margin, ids, table, dt[b], last,
                                                  peak, reach, touched, launch, b)


@solvers.register("planar-ngs")
class PlanarNGS(PlanarMemorySolver):
    """Velocity iterations, then position passes that re-measure every separation (Box2D 2.x)."""

    Params = PlanarNGSParams
    speculative_reach = True  # contacts looked for as far as the fastest box closes (stackx.solvers.planar.reach)

    def __init__(self, params: list[PlanarNGSParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.iterations = self.counts("iterations")
        self.carry = self.flags("warm_start")
        self.block = self.flags("block")
        self.speculative = self.column("speculative")
        self.position_iterations = self.counts("position_iterations")
        self.percent = self.column("percent")
        self.slop = self.column("slop")
        self.max_correction = self.column("max_correction")

    @classmethod
    def passes(cls, params: PlanarNGSParams) -> int:
        return params.iterations + params.position_iterations

    def advance(self, state: PlanarState, steps: int) -> None:
        s = state
        planar_ngs_advance(s.x, s.y, s.angle, s.vx, s.vy, s.w, s.inv_mass, s.inv_inertia, s.hx, s.hy, s.friction,
                           self.gravity, self.dt, self.iterations, self.carry, self.block, self.speculative,
                           self.position_iterations, self.percent, self.slop, self.max_correction,
                           *self.memory(state), *s.monitors(), steps)
