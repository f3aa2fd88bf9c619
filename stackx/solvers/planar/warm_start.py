"""Warm-started sequential impulses on planar boxes: accumulated clamping, Coulomb friction, speculative points.

The lab solver forgets every impulse at the end of a step, so each step its passes rebuild every load from
zero, and friction, clamped by single visits, is weak. Here each contact point keeps its accumulated normal
and tangent impulses (the totals are clamped, ``pn >= 0`` and ``|pt| <= mu pn``, not each visit's
increment), and the next step starts from them, matched by the two bodies and the touching feature, so a
resting pile is held by last step's impulses and the passes only fix what changed.

One step of one world (the velocity half is ``passes.solve_laid``: ``contacts.solve_velocities``'s
numbers, on the step's manifolds laid out in the order the passes visit them; then positions):
1. gravity;
2. the points within ``speculative`` of touching (Box2D v3's 4 x its linear slop, 0.02 m, by default): a
   point still apart may close its gap within the step and no more, so a box is stopped where it lands
   instead of one step later and already overlapping;
3. warm start: the last step's impulses of the same ``(A, B, feature)`` applied to the velocities;
4. ``iterations`` Gauss-Seidel passes over the manifolds: the normals (a two-point manifold's both at once,
   ``block``), then each point's friction within ``mu`` times its normal total; ``relaxation`` over-relaxes
   the normal steps;
5. positions and angles move with the velocities;
6. the lab's position correction (slop, percent), translation only, on the touching points of the contacts
   found where the positions moved; when it moves nothing (a pile at rest), those contacts are the next
   step's and the step needs one collision test, not two.

Why the lab's correction and not a Baumgarte bias: a bias is a velocity, so every push-out becomes momentum
that the warm start carries into the next step (the lab's "common mistake"); the lab's stage moves positions
only and adds no energy. With speculative points a resting box stops where it touches, so the correction
rarely acts at all. Tried on the 40-box stack, a bias (0.2, slop 0 or 0.005) did not help: what topples a
tall stack here is not overlap but the velocity solve's convergence. Plain Gauss-Seidel needs passes growing
with the square of the height to settle the stack's bending; short of that, the unsettled part acts as a
softness under which the stack leans further every step. Measured (dt = 1/60, 600 steps, 1 m boxes, mu 0.6,
seeded x offsets up to 5 cm): 30 passes topple it (0.1 rad near step 550), 500 passes hold it within 4 mm,
1000 within 2 mm; over-relaxed (``relaxation: 1.9``) 100 passes hold it within 2 mm (offsets up to 10 cm:
9 mm) and a 20-row pyramid within 1.3 mm.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from stackx.kernel import kernel, prange
from stackx.models.planar.state import PlanarState
from stackx.registry import solvers
from stackx.solvers.base import Correction, LabCorrection
from stackx.solvers.contacts import speculative_field
from stackx.solvers.planar.base import PlanarMemorySolver, sequential_only
from stackx.solvers.planar.passes import laid_workspace, solve_laid
from stackx.solvers.planar.contacts import (contact_workspace, correct_positions, find_contacts_near,
                                            integrate_positions, near_workspace, observe_contacts)


class PlanarWarmStartParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    iterations: int = Field(30, gt=0, le=100_000,
                            description="velocity passes per step: more converge further towards the exact "
                                        "solve and cost linearly more; with warm start they only fix what "
                                        "changed since the last step, but a new load still needs about one "
                                        "pass per box it must reach")
    warm_start: bool = Field(True, description="start each step from the impulses each point carried at the end "
                                               "of the last one: what lets a pass count far below the pile's "
                                               "height hold it; off rebuilds every load from zero each step")
    speculative: float = speculative_field(0.02)
    relaxation: float = Field(1.0, gt=0, lt=2, allow_inf_nan=False,
                              description="over-relaxation of the normal steps (1: plain Gauss-Seidel): near 2 a "
                                          "tall stack's loads settle in passes growing with its height instead "
                                          "of its square (a 40-box stack holds at 100 passes with 1.9, needs "
                                          "about 1000 at 1), while a single fresh contact converges more slowly "
                                          "(its error shrinks by |1 - relaxation| per pass)")
    block: bool = Field(True, description="solve the two normal impulses of a two-point manifold together "
                                          "(Box2D 2.x's block solver): a box resting flat shares its load "
                                          "between its corners as the exact solve does; off visits the corners "
                                          "one after the other, the first takes too much, and a tall stack "
                                          "rocks and leans")
    correction: LabCorrection = Field(
        default_factory=Correction,
        description="the lab's position correction (slop, percent; translation along each point's normal), or "
                    "'off' to leave overlap in place")

    _sequential = field_validator("correction")(sequential_only)


@kernel
def planar_warm_start_advance(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                              w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray,
                              hy: np.ndarray, friction: np.ndarray, g: np.ndarray, dt: np.ndarray,
                              iterations: np.ndarray, carry: np.ndarray, block: np.ndarray,
                              relaxation: np.ndarray, speculative: np.ndarray,
                              corrects: np.ndarray, slop: np.ndarray, percent: np.ndarray, keys: np.ndarray,
                              carried: np.ndarray, held: np.ndarray, last: np.ndarray, peak: np.ndarray,
                              reach: np.ndarray, touched: np.ndarray, launch: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row, in place; ``keys``, ``carried`` and ``held`` carry over."""
    for b in prange(x.shape[0]):
        xb, yb, ab, vxb, vyb, wb = x[b], y[b], angle[b], vx[b], vy[b], w[b]  # the row's views, made once
        im, ii, hxb, hyb, mub = inv_mass[b], inv_inertia[b], hx[b], hy[b], friction[b]
        ids, table = contact_workspace(keys.shape[1])
        near, wide = near_workspace(x.shape[1])  # the candidate pairs, kept while the boxes stay near
        shift = np.zeros((x.shape[1], 2))
        ids, table, count, near = find_contacts_near(xb, yb, ab, hxb, hyb, im, speculative[b], near, wide, ids,
                                                     table)
        first, order, group, tally, latest, links, rows, bodies = laid_workspace(ids.shape[0], x.shape[1])
        for _ in range(steps):
            if rows.shape[0] < ids.shape[0]:  # the table grew
                first, order, group, tally, latest, links, rows, bodies = laid_workspace(ids.shape[0], x.shape[1])
            held[b] = solve_laid(xb, yb, vxb, vyb, wb, im, ii, mub, g[b], dt[b], carry[b], iterations[b], block[b],
                                 relaxation[b], ids, table, count, keys[b], carried[b], held[b], first, order, group,
                                 tally, latest, links, rows, bodies)
            integrate_positions(xb, yb, ab, vxb, vyb, wb, dt[b])
            moved = True
            if corrects[b]:  # the speculative table's touching points are the correction's (correct_positions)
                ids, table, count, near = find_contacts_near(xb, yb, ab, hxb, hyb, im, speculative[b], near, wide,
                                                             ids, table)
                moved = correct_positions(xb, yb, im, ids, table, count, slop[b], percent[b], shift)
            if moved:  # a correction that moved nothing leaves the table the next step wants
                ids, table, count, near = find_contacts_near(xb, yb, ab, hxb, hyb, im, speculative[b], near, wide,
                                                             ids, table)
            observe_contacts(xb, yb, ab, hxb, hyb, im, speculative[b], ids, table, count, dt[b], last, peak, reach,
                             touched, launch, b)


@solvers.register("planar-warm-start")
class PlanarWarmStart(PlanarMemorySolver):
    """Accumulated, warm-started impulses with friction: the planar pile holder."""

    Params = PlanarWarmStartParams

    def __init__(self, params: list[PlanarWarmStartParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.iterations = self.counts("iterations")
        self.carry = self.flags("warm_start")
        self.block = self.flags("block")
        self.relaxation = self.column("relaxation")
        self.speculative = self.column("speculative")
        self.corrects, self.slop, self.percent = self.lab_correction()

    def advance(self, state: PlanarState, steps: int) -> None:
        s = state
        planar_warm_start_advance(s.x, s.y, s.angle, s.vx, s.vy, s.w, s.inv_mass, s.inv_inertia, s.hx, s.hy,
                                  s.friction, self.gravity, self.dt, self.iterations, self.carry, self.block,
                                  self.relaxation,
                                  self.speculative, self.corrects, self.slop, self.percent, *self.memory(state),
                                  *s.monitors(), steps)
