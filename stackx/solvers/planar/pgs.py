"""The lab's rules carried over to planar boxes: sequential impulses with no memory, then correction.

One step of one world, in the lab's order:
1. gravity: ``vy += g*dt`` for every movable box;
2. contacts: the points that overlap now (depth > 0), with anchors and effective masses (``contacts``);
3. ``iterations`` velocity passes, each visiting the points in table order (ground points first, then pairs
   by index), every point seeing the velocities the earlier visits left (Gauss-Seidel; visits that share no
   body may swap, which changes no number: ``wavefront.manifold_order``). A visit stops the point's approach
   along the normal (restitution 0) with an impulse clamped at 0 on its own, then applies
   friction clamped by that same visit's normal impulse: the lab has no accumulated impulse, so a visit that
   finds the point already separating (no normal impulse) holds nothing sideways either;
4. positions and angles move with the velocities;
5. the lab's position correction (slop, percent) on the points that overlap after the move, translation
   only, each depth measured after the pushes before it; it moves positions only.

Nothing is kept between steps, so as on the column every step's iterations rebuild the loads from zero: a
tall stack needs about one pass per box to be held, and friction, bounded by visits that mostly find the
point at rest, is weak where a load must be carried sideways.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from stackx.kernel import kernel, prange
from stackx.models.planar.monitor import contact_room
from stackx.models.planar.state import PlanarState
from stackx.registry import solvers
from stackx.solvers.base import Correction, LabCorrection
from stackx.solvers.planar.base import PlanarMemorySolver, StepImpulses, sequential_only
from stackx.solvers.planar.passes import (give_velocities, laid_pass, laid_remember, laid_workspace, lay_out,
                                               load_velocities, visiting_order)
from stackx.solvers.planar.contacts import (PN, PT, contact_workspace, correct_positions, find_contacts_near, gravity,
                                            integrate_positions, near_workspace, observe_contacts)
from stackx.solvers.planar.wavefront import manifold_starts


class PlanarPGSParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    iterations: int = Field(10, gt=0, le=100_000,
                            description="velocity passes per step: more makes a pile more solid and costs "
                                        "linearly more")
    correction: LabCorrection = Field(
        default_factory=Correction,
        description="the lab's position correction (slop, percent; translation along each point's normal); "
                    "'off' (or null) leaves overlap to sink in. Only the sequential stage exists here: "
                    "'global' and max_push are the column's")

    _sequential = field_validator("correction")(sequential_only)


@kernel
def planar_pgs_advance(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                       w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray,
                       hy: np.ndarray, friction: np.ndarray, g: np.ndarray, dt: np.ndarray, iterations: np.ndarray,
                       corrects: np.ndarray, slop: np.ndarray, percent: np.ndarray, keys: np.ndarray,
                       carried: np.ndarray, held: np.ndarray, record: bool, last: np.ndarray, peak: np.ndarray,
                       reach: np.ndarray, touched: np.ndarray, launch: np.ndarray, steps: int) -> None:
    """``steps`` lab steps of every batch row, in place; with ``record``, ``keys``, ``carried`` and ``held``
    get each step's impulses (for a caller that reads them: no step starts from them)."""
    for b in prange(x.shape[0]):
        xb, yb, ab, vxb, vyb, wb = x[b], y[b], angle[b], vx[b], vy[b], w[b]  # the row's views, made once
        im, ii, hxb, hyb, mub = inv_mass[b], inv_inertia[b], hx[b], hy[b], friction[b]
        ids, table = contact_workspace(contact_room(x.shape[1]))
        near, wide = near_workspace(x.shape[1])  # the candidate pairs, kept while the boxes stay near
        shift = np.zeros((x.shape[1], 2))
        ids, table, count, near = find_contacts_near(xb, yb, ab, hxb, hyb, im, 0.0, near, wide, ids, table)
        first, order, group, tally, latest, links, rows, bodies = laid_workspace(ids.shape[0], x.shape[1])
        for _ in range(steps):
            if rows.shape[0] < ids.shape[0]:  # the table grew
                first, order, group, tally, latest, links, rows, bodies = laid_workspace(ids.shape[0], x.shape[1])
            gravity(vyb, im, g[b], dt[b])
            table[:count, PN] = 0.0  # what the step's visits give, from zero
            table[:count, PT] = 0.0
            m = manifold_starts(ids, count, first)
            groups = visiting_order(ids, table, first, m, latest, group, tally, order)
            lay_out(xb, yb, im, ii, mub, ids, table, first, order, m, dt[b], False, links, rows)
            load_velocities(vxb, vyb, wb, im, ii, bodies)
            for _ in range(iterations[b]):
                laid_pass(bodies, links, rows, groups, tally, 1.0, True)
            give_velocities(bodies, vxb, vyb, wb)
            if record:
                held[b] = laid_remember(ids, links, rows, m, count, keys[b], carried[b])
            integrate_positions(xb, yb, ab, vxb, vyb, wb, dt[b])
            moved = True
            if corrects[b]:
                ids, table, count, near = find_contacts_near(xb, yb, ab, hxb, hyb, im, 0.0, near, wide, ids, table)
                moved = correct_positions(xb, yb, im, ids, table, count, slop[b], percent[b], shift)
            if moved:  # the contacts where the step ends, the next step's; unchanged if nothing was pushed
                ids, table, count, near = find_contacts_near(xb, yb, ab, hxb, hyb, im, 0.0, near, wide, ids, table)
            observe_contacts(xb, yb, ab, hxb, hyb, im, 0.0, ids, table, count, dt[b], last, peak, reach, touched,
                             launch, b)


@solvers.register("planar-pgs")
class PlanarPGS(PlanarMemorySolver):
    """The lab's projected Gauss-Seidel on planar boxes: ``iterations`` trade CPU for how solid a pile is."""

    Params = PlanarPGSParams

    def __init__(self, params: list[PlanarPGSParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.iterations = self.counts("iterations")
        self.corrects, self.slop, self.percent = self.lab_correction()

    def advance(self, state: PlanarState, steps: int) -> None:
        s = state
        planar_pgs_advance(s.x, s.y, s.angle, s.vx, s.vy, s.w, s.inv_mass, s.inv_inertia, s.hx, s.hy, s.friction,
                           self.gravity, self.dt, self.iterations, self.corrects, self.slop, self.percent,
                           *self.memory(state), self.watched, *s.monitors(), steps)

    def step_impulses(self, b: int) -> StepImpulses | None:
        """What row ``b``'s last step's passes gave, once a caller watches them (``watch_impulses``); None
        before."""
        return super().step_impulses(b) if self.watched else None
