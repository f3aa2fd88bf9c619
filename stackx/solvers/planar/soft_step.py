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
from stackx.solvers.planar.base import PlanarMemorySolver
from stackx.solvers.planar.contacts import (A, B, DEPTH, NX, NY, PN, PT, PX, PY, contact_workspace,
                                            effective_mass, find_contacts, gravity, integrate_positions,
                                            observed_contacts, recall, remember)
from stackx.solvers.planar.substep import moved, step_start
from stackx.solvers.planar.wavefront import manifold_starts, wavefronts
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


# the pass's layout: per manifold, in visit order (ints)
M_A, M_B, M_FIRST, M_END, M_ROW, M_TABLE = range(6)
MANIFOLD_COLUMNS = 6
# per point, in visit order: normal, anchors, effective masses, friction, separation when found less what the
# anchors give along the normal, accumulated impulses
P_NX, P_NY, P_RAX, P_RAY, P_RBX, P_RBY, P_KN, P_KT, P_MU, P_BASE, P_PN, P_PT = range(12)
POINT_COLUMNS = 12


@leaf
def lay_out(x: np.ndarray, y: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, friction: np.ndarray,
            ids: np.ndarray, table: np.ndarray, first: np.ndarray, order: np.ndarray, m: int,
            manifolds: np.ndarray, points: np.ndarray) -> None:
    """The step's manifolds and points in the order the passes visit them (``order``, from ``wavefronts``),
    with all a visit reads that does not change within the step, found once: each point's anchors, normal
    and tangent effective masses, friction and base separation (``contacts.prepare`` and
    ``substep.base_separations``, the same arithmetic), its impulses as ``recall`` left them in the table, and
    each manifold's bodies and softness row (1: a static side). The passes then read one row after the other
    instead of hopping through the table by index."""
    p = 0
    for j in range(m):
        origin = order[j]
        k0, k1 = first[origin], first[origin + 1]
        a, b = ids[k0, A], ids[k0, B]
        imb, iib = inv_mass[b], inv_inertia[b]
        ima, iia = (inv_mass[a], inv_inertia[a]) if a >= 0 else (0.0, 0.0)
        manifolds[j, M_A], manifolds[j, M_B], manifolds[j, M_FIRST], manifolds[j, M_END] = a, b, p, p + k1 - k0
        manifolds[j, M_ROW] = 1 if a < 0 or ima == 0.0 or imb == 0.0 else 0
        manifolds[j, M_TABLE] = k0
        for k in range(k0, k1):
            nx, ny = table[k, NX], table[k, NY]
            px, py = table[k, PX], table[k, PY]
            rbx, rby = px - x[b], py - y[b]
            if a >= 0:
                rax, ray, mu = px - x[a], py - y[a], np.sqrt(friction[a] * friction[b])
            else:
                rax, ray, mu = 0.0, 0.0, friction[b]
            points[p, P_NX], points[p, P_NY] = nx, ny
            points[p, P_RAX], points[p, P_RAY], points[p, P_RBX], points[p, P_RBY] = rax, ray, rbx, rby
            points[p, P_KN] = effective_mass(ima, iia, rax, ray, imb, iib, rbx, rby, nx, ny)
            points[p, P_KT] = effective_mass(ima, iia, rax, ray, imb, iib, rbx, rby, -ny, nx)
            points[p, P_MU] = mu
            points[p, P_BASE] = -table[k, DEPTH] - ((rbx - rax) * nx + (rby - ray) * ny)
            points[p, P_PN], points[p, P_PT] = table[k, PN], table[k, PT]
            p += 1


@leaf
def give_back(table: np.ndarray, manifolds: np.ndarray, points: np.ndarray, m: int) -> None:
    """Each point's accumulated impulses back to its row of the table, where ``remember`` keeps them."""
    for j in range(m):
        k = manifolds[j, M_TABLE]
        for p in range(manifolds[j, M_FIRST], manifolds[j, M_END]):
            table[k, PN], table[k, PT] = points[p, P_PN], points[p, P_PT]
            k += 1


@leaf
def impulse_at(vax: float, vay: float, wa: float, vbx: float, vby: float, wb: float, grounded: bool,
               ima: float, iia: float, imb: float, iib: float, points: np.ndarray, p: int, px: float,
               py: float) -> tuple[float, float, float, float, float, float]:
    """``contacts.manifold_impulse`` on the pass's layout: the impulse ``(px, py)`` at point ``p`` on B and its
    opposite on A, on the manifold's velocities held in locals."""
    vbx += imb * px
    vby += imb * py
    wb += iib * (points[p, P_RBX] * py - points[p, P_RBY] * px)
    if not grounded:
        vax -= ima * px
        vay -= ima * py
        wa -= iia * (points[p, P_RAX] * py - points[p, P_RAY] * px)
    return vax, vay, wa, vbx, vby, wb


@leaf
def velocity_at(vax: float, vay: float, wa: float, vbx: float, vby: float, wb: float, grounded: bool,
                points: np.ndarray, p: int, dx: float, dy: float) -> float:
    """``contacts.manifold_velocity`` on the pass's layout: the relative velocity at point ``p`` along ``d``."""
    ux = vbx - wb * points[p, P_RBY]
    uy = vby + wb * points[p, P_RBX]
    if not grounded:
        ux -= vax - wa * points[p, P_RAY]
        uy -= vay + wa * points[p, P_RAX]
    return ux * dx + uy * dy


@leaf
def soft_warm_start(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
                    manifolds: np.ndarray, points: np.ndarray, m: int) -> None:
    """``contacts.warm_start`` on the pass's layout: every point's accumulated impulses applied to its bodies,
    in the order of the passes (which keeps each body's order, so the same sums)."""
    for j in range(m):
        a, b = manifolds[j, M_A], manifolds[j, M_B]
        grounded = a < 0
        vax, vay, wa, ima, iia = 0.0, 0.0, 0.0, 0.0, 0.0
        if not grounded:
            vax, vay, wa, ima, iia = vx[a], vy[a], w[a], inv_mass[a], inv_inertia[a]
        vbx, vby, wb, imb, iib = vx[b], vy[b], w[b], inv_mass[b], inv_inertia[b]
        for p in range(manifolds[j, M_FIRST], manifolds[j, M_END]):
            pn, pt = points[p, P_PN], points[p, P_PT]
            if pn != 0.0 or pt != 0.0:
                nx, ny = points[p, P_NX], points[p, P_NY]
                vax, vay, wa, vbx, vby, wb = impulse_at(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb, iib,
                                                        points, p, pn * nx - pt * ny, pn * ny + pt * nx)
        if not grounded:
            vx[a], vy[a], w[a] = vax, vay, wa
        vx[b], vy[b], w[b] = vbx, vby, wb


@leaf
def soft_pass(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
              manifolds: np.ndarray, points: np.ndarray, m: int, since: np.ndarray, h: float, use_bias: bool,
              push_out: float, softness: np.ndarray) -> None:
    """One pass over the manifolds in the layout's order, each one's points normal first, then friction.

    A point's separation is measured again from how far its bodies have moved and turned since the step
    began (``substep.separation``, the same arithmetic). A point still apart may close its gap within the
    substep but not more. An overlapping point, with the bias, asks for the spring's separating speed (at
    most ``push_out``), applies ``mass_scale`` of the full impulse and lets go ``impulse_scale`` of what it
    holds; without the bias it only stops approach. The normal total stays >= 0 and each point's friction
    total within ``mu`` times its normal total. ``softness`` holds ``(bias_rate, mass_scale,
    impulse_scale)`` for two movable bodies (row 0) and for a point with a static side, the ground or a
    static box (row 1). A manifold's two bodies' velocities, inverse masses and motions are read once, held
    in locals over its points and its velocities written back once (as Box2D v3's contact solver does),
    which changes no number: its points share those two bodies and no others.
    """
    for j in range(m):
        a, b = manifolds[j, M_A], manifolds[j, M_B]
        start, end, row = manifolds[j, M_FIRST], manifolds[j, M_END], manifolds[j, M_ROW]
        grounded = a < 0
        vax, vay, wa, ima, iia = 0.0, 0.0, 0.0, 0.0, 0.0
        dax, day, ca, sa = 0.0, 0.0, 1.0, 0.0
        if not grounded:
            vax, vay, wa, ima, iia = vx[a], vy[a], w[a], inv_mass[a], inv_inertia[a]
            dax, day, ca, sa = since[a, 0], since[a, 1], since[a, 2], since[a, 3]
        vbx, vby, wb, imb, iib = vx[b], vy[b], w[b], inv_mass[b], inv_inertia[b]
        dbx, dby, cb, sb = since[b, 0], since[b, 1], since[b, 2], since[b, 3]
        bias, scale, let_go = softness[row, 0], softness[row, 1], softness[row, 2]
        for p in range(start, end):
            nx, ny = points[p, P_NX], points[p, P_NY]
            r0x, r0y = points[p, P_RBX], points[p, P_RBY]
            sx, sy = dbx + (cb * r0x - sb * r0y), dby + (sb * r0x + cb * r0y)
            if not grounded:
                r0x, r0y = points[p, P_RAX], points[p, P_RAY]
                sx -= dax + (ca * r0x - sa * r0y)
                sy -= day + (sa * r0x + ca * r0y)
            s = points[p, P_BASE] + sx * nx + sy * ny
            target, mass_scale, impulse_scale = 0.0, 1.0, 0.0
            if s > 0.0:
                target = -s / h
            elif use_bias:
                target = min(-bias * s, push_out)
                mass_scale, impulse_scale = scale, let_go
            un = velocity_at(vax, vay, wa, vbx, vby, wb, grounded, points, p, nx, ny)
            old = points[p, P_PN]
            total = max(old + points[p, P_KN] * mass_scale * (target - un) - impulse_scale * old, 0.0)
            vax, vay, wa, vbx, vby, wb = impulse_at(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb, iib,
                                                    points, p, (total - old) * nx, (total - old) * ny)
            points[p, P_PN] = total
        for p in range(start, end):
            nx, ny = points[p, P_NX], points[p, P_NY]
            limit = points[p, P_MU] * points[p, P_PN]
            old = points[p, P_PT]
            total = old - points[p, P_KT] * velocity_at(vax, vay, wa, vbx, vby, wb, grounded, points, p, -ny, nx)
            total = min(max(total, -limit), limit)
            vax, vay, wa, vbx, vby, wb = impulse_at(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb, iib,
                                                    points, p, -(total - old) * ny, (total - old) * nx)
            points[p, P_PT] = total
        if not grounded:
            vx[a], vy[a], w[a] = vax, vay, wa
        vx[b], vy[b], w[b] = vbx, vby, wb


@kernel
def soft_step_advance(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                      w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray, hy: np.ndarray,
                      friction: np.ndarray, g: np.ndarray, dt: np.ndarray, substeps: np.ndarray,
                      hertz: np.ndarray, damping_ratio: np.ndarray, push_out: np.ndarray, relax: np.ndarray,
                      warm: np.ndarray, speculative: np.ndarray, keys: np.ndarray, carried: np.ndarray,
                      held: np.ndarray, last: np.ndarray, peak: np.ndarray, reach: np.ndarray, touched: np.ndarray,
                      launch: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row, in place; ``keys``, ``carried`` and ``held`` carry each row's
    points and impulses from one step (and one call) to the next."""
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
        room = ids.shape[0]
        first, order, wave, tally = np.empty(room + 1, np.int64), np.empty(room, np.int64), np.empty(
            room, np.int64), np.empty(room + 1, np.int64)
        manifolds, points = np.empty((room, MANIFOLD_COLUMNS), np.int64), np.empty((room, POINT_COLUMNS))
        latest = np.empty(n, np.int64)
        start = np.empty((n, 3))
        since = np.empty((n, 4))
        ids, table, count = find_contacts(xb, yb, ab, hxb, hyb, im, speculative[b], ids, table)
        for _ in range(steps):
            if room < ids.shape[0]:
                room = ids.shape[0]
                first, order, wave, tally = np.empty(room + 1, np.int64), np.empty(room, np.int64), np.empty(
                    room, np.int64), np.empty(room + 1, np.int64)
                manifolds, points = np.empty((room, MANIFOLD_COLUMNS), np.int64), np.empty((room, POINT_COLUMNS))
            table[:count, PN] = 0.0
            table[:count, PT] = 0.0
            if warm[b]:
                recall(ids, table, count, keys[b], carried[b], held[b])
            m = manifold_starts(ids, count, first)
            wavefronts(ids, first, m, latest, wave, tally, order)
            lay_out(xb, yb, im, ii, mub, ids, table, first, order, m, manifolds, points)
            step_start(xb, yb, ab, start, since)
            for _ in range(substeps[b]):
                gravity(vyb, im, g[b], h)
                soft_warm_start(vxb, vyb, wb, im, ii, manifolds, points, m)
                soft_pass(vxb, vyb, wb, im, ii, manifolds, points, m, since, h, True, push_out[b], softness)
                integrate_positions(xb, yb, ab, vxb, vyb, wb, h)
                moved(xb, yb, ab, start, since)
                if relax[b]:
                    soft_pass(vxb, vyb, wb, im, ii, manifolds, points, m, since, h, False, push_out[b], softness)
            give_back(table, manifolds, points, m)
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

    @classmethod
    def passes(cls, params: PlanarSoftStepParams) -> int:
        return params.substeps * (2 if params.relax else 1)

    def advance(self, state: PlanarState, steps: int) -> None:
        s = state
        soft_step_advance(s.x, s.y, s.angle, s.vx, s.vy, s.w, s.inv_mass, s.inv_inertia, s.hx, s.hy, s.friction,
                          self.gravity, self.dt, self.substeps, self.hertz, self.damping_ratio, self.push_out,
                          self.relax, self.warm, self.speculative, *self.memory(state), *s.monitors(), steps)
