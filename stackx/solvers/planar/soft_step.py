"""The soft step on planar boxes (Box2D v3): substeps, soft contacts with friction, and a relax pass.

Contacts are found once per step, within ``speculative`` of touching, each point with its anchors on both
bodies, its normal and tangent effective masses and its separation at the start of the step. Then, ``substeps``
times with ``h = dt / substeps``:

1. gravity: every movable box gains ``g h``;
2. warm start: every point applies the impulses it has accumulated so far (carried over from the last step
   when the same corners touch, matched by bodies and feature);
3. solve: each manifold's points, normal first then friction; the separation is measured again at every
   visit from how far each body has moved and turned since the step began (the normal is held), and an
   overlapping point is a stiff, heavily damped spring of ``contact_hertz`` (twice that against the ground
   or a static box) with damping ratio ``damping_ratio``; friction is clamped by the point's accumulated
   normal impulse times its ``mu`` (Coulomb, per point);
4. integrate positions and angles with the solved velocities;
5. relax: the same pass without the spring's bias, so the push-out speed does not stay in the boxes.

Restitution is 0. With ``w = 2 pi hertz``, ``z`` the damping ratio and ``h`` the substep the soft
coefficients are Box2D v3's (``stackx.solvers.column.soft_step.soft``, shared with the column): the separating
speed asked per metre of overlap ``w / (2z + h w)``, capped at ``push_out``, the share of the full impulse a
visit applies, and the share of the accumulated impulse it lets go. The contact frequency is capped at an
eighth of the substep rate, as from Box2D v3.1.1 (v3.0 and v3.1.0, and the column's soft step, allow a
quarter): at a quarter, 12 or 16 substeps left the 20-row pyramid jittering and drifting by 12-14 cm in
10 s, at an eighth it rests. At the defaults (4 substeps at 60 Hz) both caps allow the 30 Hz.

Published defaults (Box2D v3, ``b2DefaultWorldDef`` and the solver): 4 substeps at 60 Hz, one solve and one
relax pass per substep, contact hertz 30, damping ratio 10, push-out 3 m/s, speculative distance 4 x the
linear slop of 0.005 m = 0.02 m. A soft contact carries its load by sinking in: the steady overlap grows
with the weight above it, which is how a tall stack stays quiet without position iterations. The same
softness limits how tall a stack stands: a face's two corners resist tilting with springs of ``k w^2``
(``k`` the corner's effective mass), which do not grow with the load, so past some height the boxes above
lean over. At 30 Hz a stack of 1 m boxes topples from about 20 (Box2D v3.1 does the same at its defaults);
``contact_hertz: null`` makes contacts as stiff as the substeps allow, and 24 substeps (180 Hz) then hold 40
as well as the pyramid.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from stackx.kernel import kernel, leaf, prange
from stackx.models.planar.state import PlanarState
from stackx.registry import solvers
from stackx.solvers.planar.applied import add_applied, clear_applied
from stackx.solvers.planar.base import PlanarMemorySolver, StepImpulses
from stackx.solvers.planar.contacts import (A, B, KN, KT, MU, NX, NY, PN, PT, contact_workspace,
                                            find_contacts, gravity, integrate_positions, manifold_impulse,
                                            manifold_velocity, observed_contacts, prepare, recall, remember,
                                            warm_start)
from stackx.solvers.planar.substep import base_separations, manifold_end, moved, separation, step_start
from stackx.solvers.column.soft_step import STATIC_HERTZ, SoftStepParams, soft


SUBSTEP_HERTZ = 0.125  # the contact frequency is at most this share of the substep rate (Box2D v3.1.1 on)


class PlanarSoftStepParams(SoftStepParams):
    """The column's soft step knobs (substeps, damping ratio, push-out, relax, speculative, Box2D v3's
    defaults), a contact hertz that may follow the substeps, and warm starting."""

    contact_hertz: float | None = Field(30.0, gt=0, allow_inf_nan=False,
                                        description="stiffness of a contact as a spring frequency (Hz), capped "
                                                    "at an eighth of the substep rate; contacts with a static "
                                                    "side use twice it: higher sinks less under load and keeps "
                                                    "a tall stack from leaning over, but needs more substeps; "
                                                    "null: the cap, so stiffness grows with the substeps")
    warm_start: bool = Field(True, description="start each step from the impulses the same points carried at "
                                               "the end of the last one: off rebuilds every load from zero, and "
                                               "a tall stack sinks and sways")


@leaf
def soft_pass(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
              ids: np.ndarray, table: np.ndarray, count: int, base: np.ndarray, since: np.ndarray, h: float,
              use_bias: bool, push_out: float, softness: np.ndarray) -> None:
    """One pass over the manifolds in table order, each one's points normal first, then friction.

    A point still apart may close its gap within the substep but not more. An overlapping point, with the
    bias, asks for the spring's separating speed (at most ``push_out``), applies ``mass_scale`` of the full
    impulse and lets go ``impulse_scale`` of what it holds; without the bias it only stops approach. The
    normal total stays >= 0 and each point's friction total within ``mu`` times its normal total.
    ``softness`` holds ``(bias_rate, mass_scale, impulse_scale)`` for two movable bodies (row 0) and for a
    point with a static side, the ground or a static box (row 1). A manifold's two bodies' velocities and
    inverse masses are read once, held in locals over its points and written back once (as Box2D v3's
    contact solver does), which changes no number: its points share those two bodies and no others.
    """
    start = 0
    while start < count:
        end = manifold_end(ids, start, count)
        a, b = ids[start, A], ids[start, B]
        grounded = a < 0
        vax, vay, wa, ima, iia = 0.0, 0.0, 0.0, 0.0, 0.0
        if not grounded:
            vax, vay, wa, ima, iia = vx[a], vy[a], w[a], inv_mass[a], inv_inertia[a]
        vbx, vby, wb, imb, iib = vx[b], vy[b], w[b], inv_mass[b], inv_inertia[b]
        row = 1 if grounded or ima == 0.0 or imb == 0.0 else 0
        for k in range(start, end):
            s = separation(ids, table, base, since, k)
            target, mass_scale, impulse_scale = 0.0, 1.0, 0.0
            if s > 0.0:
                target = -s / h
            elif use_bias:
                target = min(-softness[row, 0] * s, push_out)
                mass_scale, impulse_scale = softness[row, 1], softness[row, 2]
            nx, ny = table[k, NX], table[k, NY]
            un = manifold_velocity(vax, vay, wa, vbx, vby, wb, grounded, table, k, nx, ny)
            old = table[k, PN]
            total = max(old + table[k, KN] * mass_scale * (target - un) - impulse_scale * old, 0.0)
            vax, vay, wa, vbx, vby, wb = manifold_impulse(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb, iib,
                                                          table, k, (total - old) * nx, (total - old) * ny)
            table[k, PN] = total
        for k in range(start, end):
            nx, ny = table[k, NX], table[k, NY]
            limit = table[k, MU] * table[k, PN]
            old = table[k, PT]
            total = old - table[k, KT] * manifold_velocity(vax, vay, wa, vbx, vby, wb, grounded, table, k, -ny, nx)
            total = min(max(total, -limit), limit)
            vax, vay, wa, vbx, vby, wb = manifold_impulse(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb, iib,
                                                          table, k, -(total - old) * ny, (total - old) * nx)
            table[k, PT] = total
        if not grounded:
            vx[a], vy[a], w[a] = vax, vay, wa
        vx[b], vy[b], w[b] = vbx, vby, wb
        start = end


@kernel
def soft_step_advance(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                      w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray, hy: np.ndarray,
                      friction: np.ndarray, g: np.ndarray, dt: np.ndarray, substeps: np.ndarray,
                      hertz: np.ndarray, damping_ratio: np.ndarray, push_out: np.ndarray, relax: np.ndarray,
                      warm: np.ndarray, speculative: np.ndarray, keys: np.ndarray, carried: np.ndarray,
                      held: np.ndarray, applied: np.ndarray, last: np.ndarray, peak: np.ndarray, reach: np.ndarray,
                      touched: np.ndarray, launch: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row, in place; ``keys``, ``carried`` and ``held`` carry each row's
    points and impulses from one step (and one call) to the next; ``applied`` gets what each step applied
    (``stackx.solvers.planar.applied``)."""
    for b in prange(x.shape[0]):
        xb, yb, ab, vxb, vyb, wb = x[b], y[b], angle[b], vx[b], vy[b], w[b]  # the row's views, made once
        im, ii, hxb, hyb, mub = inv_mass[b], inv_inertia[b], hx[b], hy[b], friction[b]
        n = x.shape[1]
        h = dt[b] / substeps[b]
        contact_hertz = min(hertz[b], SUBSTEP_HERTZ / h)
        softness = np.empty((2, 3))
        softness[0, 0], softness[0, 1], softness[0, 2] = soft(contact_hertz, damping_ratio[b], h)
        softness[1, 0], softness[1, 1], softness[1, 2] = soft(STATIC_HERTZ * contact_hertz, damping_ratio[b], h)
        ids, table = contact_workspace(keys.shape[1])
        base = np.empty(keys.shape[1])
        start = np.empty((n, 3))
        since = np.empty((n, 4))
        ids, table, count = find_contacts(xb, yb, ab, hxb, hyb, im, speculative[b], ids, table)
        for _ in range(steps):
            prepare(xb, yb, im, ii, mub, ids, table, count)
            if base.shape[0] < count:
                base = np.empty(ids.shape[0])
            base_separations(ids, table, count, base)
            if warm[b]:
                recall(ids, table, count, keys[b], carried[b], held[b])
            step_start(xb, yb, ab, start, since)
            clear_applied(applied[b], count)
            for _ in range(substeps[b]):
                gravity(vyb, im, g[b], h)
                warm_start(vxb, vyb, wb, im, ii, ids, table, count)
                soft_pass(vxb, vyb, wb, im, ii, ids, table, count, base, since, h, True, push_out[b], softness)
                integrate_positions(xb, yb, ab, vxb, vyb, wb, h)
                moved(xb, yb, ab, start, since)
                if relax[b]:
                    soft_pass(vxb, vyb, wb, im, ii, ids, table, count, base, since, h, False, push_out[b], softness)
                add_applied(table, count, applied[b])
            held[b] = remember(ids, table, count, keys[b], carried[b])
            ids, table, count = observed_contacts(xb, yb, ab, hxb, hyb, im, speculative[b], ids, table, dt[b],
                                                  last, peak, reach, touched, launch, b)


@solvers.register("planar-soft-step")
class PlanarSoftStep(PlanarMemorySolver):
    """Box2D v3's substepped soft contacts with friction and relax, on rotating boxes."""

    Params = PlanarSoftStepParams

    def __init__(self, params: list[PlanarSoftStepParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.substeps = self.counts("substeps")
        self.hertz = self.column("contact_hertz", np.inf)
        self.damping_ratio = self.column("damping_ratio")
        self.push_out = self.column("push_out")
        self.relax = self.flags("relax")
        self.warm = self.flags("warm_start")
        self.speculative = self.column("speculative")
        self.applied: np.ndarray | None = None  # per row and point, what the last step applied (applied.py)

    @classmethod
    def passes(cls, params: PlanarSoftStepParams) -> int:
        return params.substeps * (2 if params.relax else 1)

    def step_impulses(self, b: int) -> StepImpulses | None:
        """The impulses of the last step summed over its substeps (``stackx.solvers.planar.applied``: what
        that means and what it cannot show); None as ``PlanarMemorySolver``'s."""
        held = super().step_impulses(b)
        if held is None or self.applied is None:
            return None
        n = held.pn.shape[0]
        return StepImpulses(held.keys, self.applied[b, :n, 0].copy(), self.applied[b, :n, 1].copy())

    def advance(self, state: PlanarState, steps: int) -> None:
        s = state
        keys, carried, held = self.memory(state)
        if self.applied is None or self.applied.shape[:2] != keys.shape[:2]:
            self.applied = np.zeros(keys.shape[:2] + (2,))
        soft_step_advance(s.x, s.y, s.angle, s.vx, s.vy, s.w, s.inv_mass, s.inv_inertia, s.hx, s.hy, s.friction,
                          self.gravity, self.dt, self.substeps, self.hertz, self.damping_ratio, self.push_out,
                          self.relax, self.warm, self.speculative, keys, carried, held, self.applied, *s.monitors(),
                          steps)
