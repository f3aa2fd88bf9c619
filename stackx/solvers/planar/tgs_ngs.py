"""TGS NGS on planar boxes (Solver2D's ``TGS_NGS``): substeps of one rigid velocity pass and one nonlinear
Gauss-Seidel position pass.

Contacts are found once per step, within ``speculative`` of touching, with their anchors and effective masses
(``contacts.prepare``), each point's face plane and corner fixed to the bodies that carry them
(``contacts.anchor_locals``), and impulses carried over by ``(A, B, FEATURE)`` when ``warm_start``. Then
``substeps`` times with ``h = dt / substeps``:

1. gravity; warm start: every point's accumulated impulses applied at its anchors as they are now;
2. one velocity pass, manifold by manifold, normals then friction, **rigid and without bias**: a touching or
   overlapping point may not approach (target 0), a point still apart may close its gap within the substep,
   friction within ``mu`` times the point's normal impulse; velocities read and impulses applied at the
   anchors turned with the bodies (``tgs_soft.tgs_pass`` with its bias off);
3. positions and angles move with the velocities;
4. one position pass (``contacts.separation_push``, as ``planar-ngs``'s): each point's depth measured again
   from where its bodies are now, rotation included, and pushed apart by ``percent * (depth - slop)``, at
   most ``max_correction``, at its lever arms. Velocities are not touched, so the push adds no energy.

Not ``planar-ngs`` with a knob: that one solves velocities with ``iterations`` passes over the whole step, then
projects positions once; here every substep has one pass of each, with gravity and the warm start spread over
the substeps. Not the soft step either: its overlap is pushed out by a soft spring's velocity, here by moving
positions. Solver2D's defaults, the defaults here: 4 substeps, Box2D 2.x's percent 0.2, slop 0.005 m, at most
0.2 m a push. Solver2D notes that its warm start is too strong and makes collisions bouncy: each substep
applies the whole carried impulse again, and no relax pass takes back what it gave.

``step_impulses`` is None: the position passes move the boxes without velocities, and the impulses act at
anchors that turn within the step.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from stackx.kernel import kernel, prange
from stackx.models.planar.state import PlanarState
from stackx.registry import solvers
from stackx.solvers.contacts import speculative_field
from stackx.solvers.planar.base import PlanarMemorySolver, StepImpulses
from stackx.solvers.planar.contacts import (anchor_locals, contact_workspace, find_contacts, gravity,
                                            observed_contacts, remember, separation_push, warm_start)
from stackx.solvers.planar.tgs_soft import begin_step, move_bodies, tgs_pass, turn_anchors


class PlanarTGSNGSParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    substeps: int = Field(4, gt=0, le=10_000,
                          description="substeps per step, each one velocity pass and one position pass (Solver2D: "
                                      "4): more make contacts firmer and overlaps shallower, at linear cost")
    warm_start: bool = Field(True, description="start each step from the impulses the same points carried at "
                                               "the end of the last one, applied again every substep: holds "
                                               "loads with one pass a substep, but overshoots on impact "
                                               "(bouncy landings); off rebuilds every load from zero each step")
    speculative: float = speculative_field(0.02)
    percent: float = Field(0.2, gt=0, le=1, allow_inf_nan=False,
                           description="share of a point's depth beyond slop a position pass undoes: 1 "
                                       "overshoots as neighbours are pushed into each other, small values leave "
                                       "boxes sunk longer")
    slop: float = Field(0.005, ge=0, allow_inf_nan=False,
                        description="overlap (m) the position pass leaves alone: 0 corrects every resting point "
                                    "every substep")
    max_correction: float = Field(0.2, gt=0, allow_inf_nan=False,
                                  description="largest push of one visit (m): keeps a deep overlap from being "
                                              "thrown apart in one substep, at the cost of a slower recovery")


@kernel
def tgs_ngs_advance(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                    w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray, hy: np.ndarray,
                    friction: np.ndarray, g: np.ndarray, dt: np.ndarray, substeps: np.ndarray, warm: np.ndarray,
                    speculative: np.ndarray, percent: np.ndarray, slop: np.ndarray, max_correction: np.ndarray,
                    keys: np.ndarray, carried: np.ndarray, held: np.ndarray, last: np.ndarray, peak: np.ndarray,
                    reach: np.ndarray, touched: np.ndarray, launch: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row, in place; ``keys``, ``carried`` and ``held`` carry over."""
    for b in prange(x.shape[0]):
        xb, yb, ab, vxb, vyb, wb = x[b], y[b], angle[b], vx[b], vy[b], w[b]  # the row's views, made once
        im, ii, hxb, hyb, mub = inv_mass[b], inv_inertia[b], hx[b], hy[b], friction[b]
        n = x.shape[1]
        h = dt[b] / substeps[b]
        rigid = np.zeros((2, 3))  # no softness: the velocity pass runs without bias
        ids, table = contact_workspace(keys.shape[1])
        ids, table, count = find_contacts(xb, yb, ab, hxb, hyb, im, speculative[b], ids, table)
        now, base = table.copy(), np.empty(table.shape[0])
        start, since = np.empty((n, 3)), np.empty((n, 4))
        for _ in range(steps):
            if now.shape[0] < table.shape[0]:  # the table grew
                now, base = table.copy(), np.empty(table.shape[0])
            begin_step(xb, yb, ab, im, ii, mub, ids, table, count, warm[b], keys[b], carried[b], held[b], base,
                       start, since, now)
            anchor_locals(xb, yb, ab, ids, table, count)
            for _ in range(substeps[b]):
                gravity(vyb, im, g[b], h)
                warm_start(vxb, vyb, wb, im, ii, ids, now, count)
                tgs_pass(vxb, vyb, wb, im, ii, ids, table, now, count, base, since, h, False, 0.0, rigid)
                move_bodies(xb, yb, ab, vxb, vyb, wb, h, ids, table, count, start, since, now)
                separation_push(xb, yb, ab, im, ii, ids, table, count, slop[b], percent[b], max_correction[b])
                turn_anchors(xb, yb, ab, ids, table, count, start, since, now)
            held[b] = remember(ids, now, count, keys[b], carried[b])
            ids, table, count = observed_contacts(xb, yb, ab, hxb, hyb, im, speculative[b], ids, table, dt[b],
                                                  last, peak, reach, touched, launch, b)


@solvers.register("planar-tgs-ngs")
class PlanarTGSNGS(PlanarMemorySolver):
    """Substeps of one rigid velocity pass and one position pass that re-measures every separation (Solver2D's
    TGS NGS)."""

    Params = PlanarTGSNGSParams

    def __init__(self, params: list[PlanarTGSNGSParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.substeps = self.counts("substeps")
        self.warm = self.flags("warm_start")
        self.speculative = self.column("speculative")
        self.percent = self.column("percent")
        self.slop = self.column("slop")
        self.max_correction = self.column("max_correction")

    @classmethod
    def passes(cls, params: PlanarTGSNGSParams) -> int:
        return 2 * params.substeps

    def step_impulses(self, b: int) -> StepImpulses | None:
        """None: positions are pushed without velocities and impulses act at turning anchors (module text)."""
        return None

    def advance(self, state: PlanarState, steps: int) -> None:
        s = state
        tgs_ngs_advance(s.x, s.y, s.angle, s.vx, s.vy, s.w, s.inv_mass, s.inv_inertia, s.hx, s.hy, s.friction,
                        self.gravity, self.dt, self.substeps, self.warm, self.speculative, self.percent, self.slop,
                        self.max_correction, *self.memory(state), *s.monitors(), steps)
