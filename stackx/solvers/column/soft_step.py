"""The soft step (Box2D v3): substeps, a soft contact bias, and a relax pass without bias.

Each step is cut into ``substeps``; within each, gravity is applied, the contacts' impulses are warm-started,
one pass solves them with a soft bias, positions move, and one relax pass solves them again without bias so
that the push-out speed does not stay in the boxes. The bias treats an overlapping contact as a stiff,
heavily damped spring of ``contact_hertz`` (the floor, being static, twice that) with damping ratio
``damping_ratio``; with ``h`` the substep, ``w = 2 pi hertz`` and ``z`` the damping ratio:

- ``bias_rate = w / (2z + h w)``: separating speed asked per metre of depth;
- ``mass_scale = h w (2z + h w) / (1 + h w (2z + h w))``: how much of the full impulse each visit applies;
- ``impulse_scale = 1 / (1 + h w (2z + h w))``: how much of the accumulated impulse each visit lets go.

The push-out speed is capped at ``push_out``. A contact that is still apart (speculative) may close its gap
within the substep but not more. Which contacts take part is decided once per step; their depths are
measured again at every visit. Box2D v3 defaults: 4 substeps, 30 Hz (at most a quarter of the substep
rate), damping ratio 10, push-out 3 m/s, speculative distance 0.02 m; restitution is 0 here.

A soft contact holds a load by sinking in: the steady depth grows with the weight above it. A column has one
contact per pair where a box face in a 2D engine has two contact points sharing the load, so at the same
hertz a column here sinks about twice as far as in Box2D.

One step: prepare contacts; then ``substeps`` times: gravity (integrate velocities), warm start, solve (soft
bias), integrate positions, relax (no bias).
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from stackx.kernel import kernel, prange
from stackx.models.column.monitor import observe
from stackx.registry import solvers
from stackx.solvers.contacts import (ImpulseSolver, depth, prepare, push, relative_velocity, speculative_field,
                                    warm_start)
from stackx.solvers.column.pgs import gravity, integrate_positions
from stackx.models.column.state import ColumnState

STATIC_HERTZ = 2.0  # contacts with a static side (the floor) are this much stiffer (Box2D v3)
SUBSTEP_HERTZ = 0.25  # the contact frequency is at most this share of the substep rate (Box2D v3)


class SoftStepParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    substeps: int = Field(4, gt=0, le=10_000,
                          description="substeps per step, each with one solve and one relax pass: more make "
                                      "contacts stiffer and heavy-on-light columns firmer, at linear cost")
    contact_hertz: float = Field(30.0, gt=0, allow_inf_nan=False,
                                 description="stiffness of a contact as a spring frequency (Hz), capped at a "
                                             "quarter of the substep rate: higher sinks less under load but "
                                             "needs smaller substeps to stay stable")
    damping_ratio: float = Field(10.0, ge=0, allow_inf_nan=False,
                                 description="damping of the contact spring: high values (10) push out without "
                                             "bouncing, low ones spring back")
    push_out: float = Field(3.0, gt=0, allow_inf_nan=False,
                            description="largest separating speed the bias may ask for (m/s): keeps a deep "
                                        "overlap from launching boxes, at the cost of a slower recovery")
    relax: bool = Field(True, description="after positions move, solve once more without bias so the push-out "
                                          "speed leaves the boxes; off keeps it (boxes bounce off overlap)")
    speculative: float = speculative_field(0.02)


@kernel
def soft(hertz: float, damping_ratio: float, h: float) -> tuple[float, float, float]:
    """``(bias_rate, mass_scale, impulse_scale)`` of a soft contact over a substep ``h``."""
    w = 2.0 * math.pi * hertz
    a1 = 2.0 * damping_ratio + h * w
    a2 = h * w * a1
    a3 = 1.0 / (1.0 + a2)
    return w / a1, a2 * a3, a3


@kernel
def soft_iteration(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, impulse: np.ndarray,
                   mass: np.ndarray, h: float, use_bias: bool, push_out: float, softness: np.ndarray) -> None:
    """One pass, floor first then pairs bottom-up, with each depth measured from the current positions.

    ``softness`` holds ``(bias_rate, mass_scale, impulse_scale)`` for the floor (row 0) and the pairs (row 1).
    Without bias, an overlapping contact only stops approach; a contact still apart may close its gap.
    """
    for k in range(y.shape[0]):
        if mass[k] > 0.0:
            d = depth(y, half, k)
            target, mass_scale, impulse_scale = 0.0, 1.0, 0.0
            if d < 0.0:
                target = d / h
            elif use_bias:
                row = 0 if k == 0 else 1
                target = min(softness[row, 0] * d, push_out)
                mass_scale, impulse_scale = softness[row, 1], softness[row, 2]
            change = mass[k] * mass_scale * (target - relative_velocity(v, k)) - impulse_scale * impulse[k]
            total = max(impulse[k] + change, 0.0)
            push(v, inv, k, total - impulse[k])
            impulse[k] = total


@kernel
def soft_step_advance(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, g: np.ndarray,
                      dt: np.ndarray, substeps: np.ndarray, hertz: np.ndarray, damping_ratio: np.ndarray,
                      push_out: np.ndarray, relax: np.ndarray, speculative: np.ndarray, impulse: np.ndarray,
                      last: np.ndarray, peak: np.ndarray, reach: np.ndarray, touched: np.ndarray, launch: np.ndarray,
                      steps: int) -> None:
    """``steps`` steps of every batch row, in place; ``impulse`` carries over between calls."""
    for b in prange(y.shape[0]):
        yb, vb, ib, hb, pb = y[b], v[b], inv[b], half[b], impulse[b]  # the row's views, made once
        n = y.shape[1]
        mass = np.zeros(n)
        target = np.zeros(n)
        h = dt[b] / substeps[b]
        contact_hertz = min(hertz[b], SUBSTEP_HERTZ / h)
        softness = np.zeros((2, 3))
        softness[0, 0], softness[0, 1], softness[0, 2] = soft(STATIC_HERTZ * contact_hertz, damping_ratio[b], h)
        softness[1, 0], softness[1, 1], softness[1, 2] = soft(contact_hertz, damping_ratio[b], h)
        for _ in range(steps):
            prepare(yb, ib, hb, dt[b], speculative[b], 0.0, 0.0, np.inf, pb, mass, target)
            for _ in range(substeps[b]):
                gravity(vb, g[b], h)
                warm_start(vb, ib, pb, True)
                soft_iteration(yb, vb, ib, hb, pb, mass, h, True, push_out[b], softness)
                integrate_positions(yb, vb, h)
                if relax[b]:
                    soft_iteration(yb, vb, ib, hb, pb, mass, h, False, push_out[b], softness)
            observe(yb, hb, dt[b], last, peak, reach, touched, launch, b)


@solvers.register("soft-step")
class SoftStep(ImpulseSolver):
    """Box2D v3's substepped soft contacts with relax: firm and quiet, soft under heavy loads."""

    Params = SoftStepParams

    def __init__(self, params: list[SoftStepParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.substeps = self.counts("substeps")
        self.hertz = self.column("contact_hertz")
        self.damping_ratio = self.column("damping_ratio")
        self.push_out = self.column("push_out")
        self.relax = self.flags("relax")

    @classmethod
    def passes(cls, params: SoftStepParams) -> int:
        return params.substeps * (2 if params.relax else 1)

    def advance(self, state: ColumnState, steps: int) -> None:
        soft_step_advance(state.y, state.v, state.inv_mass, state.half, self.gravity, self.dt, self.substeps,
                          self.hertz, self.damping_ratio, self.push_out, self.relax, self.speculative,
                          self.memory(state), *state.monitors(), steps)
