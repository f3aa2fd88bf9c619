"""XPBD with small steps (Macklin et al. 2019): positions projected every substep, velocities derived.

Each step is cut into ``substeps``. In each, the boxes are moved by their velocity plus gravity, then one pass
over the contacts, floor first then pairs bottom-up, projects every overlapping contact back to touching, the
lighter side moving more; the velocity is then what the box actually did, ``(y - y_before)/h``. There is no
velocity solve and no impulse memory: a contact pushes only when it overlaps, so a box resting on another
sinks by ``g h^2`` in a substep and is put back. Compliance makes a contact a spring: with
``a = compliance/h^2`` and ``w`` the inverse-mass sum, a visit undoes ``w/(w + a)`` of the depth; 0 is rigid.
Macklin et al. found that ``n`` substeps of one pass beat one step of ``n`` passes in both constraint error
and damping; the cost is one pass per substep either way.

Overlap that is there at the start of a substep is projected out within it, and the derived velocity keeps
the push-out: boxes spawned deep in each other are thrown apart.

One step, ``substeps`` times: remember positions; gravity; integrate positions; project contacts; derive
velocities.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from stackx.solvers.correct import correct
from stackx.kernel import kernel, prange
from stackx.models.column.monitor import observe
from stackx.registry import solvers
from stackx.solvers.base import Solver
from stackx.solvers.contacts import depth, inverse_mass_sum
from stackx.solvers.column.pgs import gravity, integrate_positions
from stackx.models.column.state import ColumnState


class XPBDParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    substeps: int = Field(20, gt=0, le=100_000,
                          description="substeps per step, one projection pass each: more make contacts firmer "
                                      "and reach further down a column per step, at linear cost (Macklin et "
                                      "al. use tens per frame and give no single default; 20 is ours)")
    compliance: float = Field(0.0, ge=0, allow_inf_nan=False,
                              description="inverse stiffness of a contact (m/N): 0 is rigid; a positive value "
                                          "lets a loaded contact sink in like a spring, independent of the "
                                          "number of substeps")


@kernel
def project(y: np.ndarray, inv: np.ndarray, half: np.ndarray, stiffness: float) -> None:
    """One pass of position projection, each depth measured after the visits before it; velocities untouched.

    A visit undoes ``w/(w + stiffness)`` of the depth, with ``w`` the contact's inverse-mass sum and
    ``stiffness`` the compliance over ``h^2``: the lab's ``correct`` with no slop and that share as percent.
    """
    for k in range(y.shape[0]):
        w = inverse_mass_sum(inv, k)
        if w > 0.0:
            share = w / (w + stiffness)
            if k == 0:
                _, up = correct(depth(y, half, 0), 0.0, share, 0.0, inv[0])
            else:
                down, up = correct(depth(y, half, k), 0.0, share, inv[k - 1], inv[k])
                y[k - 1] -= down
            y[k] += up


@kernel
def derive_velocities(y: np.ndarray, before: np.ndarray, v: np.ndarray, h: float) -> None:
    """The velocity is what the box did over the substep."""
    for i in range(y.shape[0]):
        v[i] = (y[i] - before[i]) / h


@kernel
def xpbd_advance(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, g: np.ndarray,
                 dt: np.ndarray, substeps: np.ndarray, compliance: np.ndarray, last: np.ndarray, peak: np.ndarray,
                 reach: np.ndarray, touched: np.ndarray, launch: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row, in place."""
    for b in prange(y.shape[0]):
        yb, vb, ib, hb = y[b], v[b], inv[b], half[b]  # the row's views, made once, not at every stage call
        before = np.zeros(y.shape[1])
        h = dt[b] / substeps[b]
        stiffness = compliance[b] / (h * h)
        for _ in range(steps):
            for _ in range(substeps[b]):
                before[:] = yb
                gravity(vb, g[b], h)
                integrate_positions(yb, vb, h)
                project(yb, ib, hb, stiffness)
                derive_velocities(yb, before, vb, h)
            observe(yb, hb, dt[b], last, peak, reach, touched, launch, b)


@solvers.register("xpbd")
class XPBD(Solver):
    """Small steps of position projection, velocities derived from positions (Macklin et al. 2019)."""

    Params = XPBDParams

    def __init__(self, params: list[XPBDParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.substeps = self.counts("substeps")
        self.compliance = self.column("compliance")

    def advance(self, state: ColumnState, steps: int) -> None:
        xpbd_advance(state.y, state.v, state.inv_mass, state.half, self.gravity, self.dt, self.substeps,
                     self.compliance, *state.monitors(), steps)
