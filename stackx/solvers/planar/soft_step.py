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

How a step is laid out (Box2D v3.1's ``contact_solver.c`` and ``solver.c`` do the same work once a step:
anchors relative to the centres, normal and tangent masses, the separation when found, the softness, in
arrays the substeps walk in order, bodies' velocities in one compact array): once a step, ``lay_out``
writes every point's row with all a visit reads that does not change within the step, in the order the
passes visit them, and the bodies' velocities, masses and motion since the step began sit in one row each,
the ground as a last row of zeros. The order is ``wavefront``'s: manifolds in waves that share no body,
which gives the numbers of visiting them in table order to the bit (see that module) while each visit of a
wave's pass is independent of the one before it, so the processor overlaps them.

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
from stackx.solvers.planar.contacts import (A, B, DEPTH, NX, NY, PN, PT, PX, PY, contact_workspace,
                                            effective_mass, find_contacts, observed_contacts, recall, remember)
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


# the pass's layout, one row per point in the order the passes visit them: its two bodies (the ground is body
# ``n``, after the boxes) and its row of the table (ints), and (floats) its normal, anchors, effective masses,
# friction, separation when found less what the anchors give along the normal, its softness (bias rate, mass
# scale, impulse scale) and impulses
L_A, L_B, L_ROW = range(3)
P_NX, P_NY, P_RAX, P_RAY, P_RBX, P_RBY, P_KN, P_KT, P_MU, P_BASE, P_BIAS, P_SCALE, P_LET_GO, P_PN, P_PT = range(15)
POINT_COLUMNS = 15
# the bodies as the passes read them, one row each and the ground's last: velocities, inverse mass and
# inertia, and the motion since the step began (``substep.moved_body``: dx, dy, cosine and sine of the turn)
V_X, V_Y, V_W, INV_M, INV_I, D_X, D_Y, COS, SIN = range(9)
BODY_COLUMNS = 9


@kernel
def pass_workspace(room: int, bodies: int) -> tuple[np.ndarray, ...]:
    """Room for the layout of ``room`` points of ``bodies`` bodies: ``(first, order, wave, tally, ends,
    latest, links, points)``, the scratch of ``wavefront`` and ``lay_out``."""
    return (np.empty(room + 1, np.int64), np.empty(room, np.int64), np.empty(room, np.int64),
            np.empty(room + 1, np.int64), np.empty(room + 1, np.uint64), np.empty(bodies, np.int64),
            np.empty((room, 3), np.uint64), np.empty((POINT_COLUMNS, room)))


@leaf
def lay_out(x: np.ndarray, y: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, friction: np.ndarray,
            ids: np.ndarray, table: np.ndarray, first: np.ndarray, order: np.ndarray, waves: int,
            tally: np.ndarray, softness: np.ndarray, ends: np.ndarray, links: np.ndarray,
            points: np.ndarray) -> None:
    """The step's points in the order the passes visit them, with all a visit reads that does not change
    within the step, found once: wave by wave (``order``, ``tally`` from ``wavefronts``), each wave's
    manifolds' first points, then their second points; ``ends[v]``: where wave ``v``'s points end.

    Per point its bodies and table row (``links``) and its anchors, normal and tangent effective masses,
    friction and base separation (``contacts.prepare`` and ``substep.base_separations``, the same
    arithmetic), its softness (``softness`` row 1 where a side is static: the ground or a static box) and
    its impulses as ``recall`` left them in the table. The passes then read one row after the other."""
    ground = x.shape[0]
    p, begin = 0, 0
    for v in range(waves):
        most = 0
        for j in range(begin, tally[v]):
            most = max(most, first[order[j] + 1] - first[order[j]])
        for q in range(most):
            for j in range(begin, tally[v]):
                k = first[order[j]] + q
                if k >= first[order[j] + 1]:
                    continue
                a, b = ids[k, A], ids[k, B]
                imb, iib = inv_mass[b], inv_inertia[b]
                ima, iia = (inv_mass[a], inv_inertia[a]) if a >= 0 else (0.0, 0.0)
                row = 1 if a < 0 or ima == 0.0 or imb == 0.0 else 0
                nx, ny = table[k, NX], table[k, NY]
                px, py = table[k, PX], table[k, PY]
                rbx, rby = px - x[b], py - y[b]
                if a >= 0:
                    rax, ray, mu = px - x[a], py - y[a], np.sqrt(friction[a] * friction[b])
                else:
                    rax, ray, mu = 0.0, 0.0, friction[b]
                links[p, L_A], links[p, L_B], links[p, L_ROW] = a if a >= 0 else ground, b, k
                points[P_NX, p], points[P_NY, p] = nx, ny
                points[P_RAX, p], points[P_RAY, p], points[P_RBX, p], points[P_RBY, p] = rax, ray, rbx, rby
                points[P_KN, p] = effective_mass(ima, iia, rax, ray, imb, iib, rbx, rby, nx, ny)
                points[P_KT, p] = effective_mass(ima, iia, rax, ray, imb, iib, rbx, rby, -ny, nx)
                points[P_MU, p] = mu
                points[P_BASE, p] = -table[k, DEPTH] - ((rbx - rax) * nx + (rby - ray) * ny)
                points[P_BIAS, p], points[P_SCALE, p] = softness[row, 0], softness[row, 1]
                points[P_LET_GO, p] = softness[row, 2]
                points[P_PN, p], points[P_PT, p] = table[k, PN], table[k, PT]
                p += 1
        ends[v] = p
        begin = tally[v]


@leaf
def give_back(table: np.ndarray, links: np.ndarray, points: np.ndarray, count: int) -> None:
    """Each point's accumulated impulses back to its row of the table, where ``remember`` keeps them."""
    for p in range(count):
        k = links[p, L_ROW]
        table[k, PN], table[k, PT] = points[P_PN, p], points[P_PT, p]


@leaf
def load_bodies(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
                bodies: np.ndarray) -> None:
    """The bodies' rows as a step begins: velocities and inverse masses, not moved yet; the ground's row
    (last) all zeros and no turn. The ground's zeros enter a visit's sums as ``x - 0.0``, which is ``x``, so a
    visit reads the ground as a body without a test and gets the numbers of skipping it; nothing writes it."""
    n = vx.shape[0]
    for i in range(n + 1):
        if i < n:
            bodies[V_X, i], bodies[V_Y, i], bodies[V_W, i] = vx[i], vy[i], w[i]
            bodies[INV_M, i], bodies[INV_I, i] = inv_mass[i], inv_inertia[i]
        else:
            bodies[V_X, i], bodies[V_Y, i], bodies[V_W, i], bodies[INV_M, i], bodies[INV_I, i] = 0.0, 0.0, 0.0, 0.0, 0.0
        bodies[D_X, i], bodies[D_Y, i], bodies[COS, i], bodies[SIN, i] = 0.0, 0.0, 1.0, 0.0


@leaf
def store_velocities(bodies: np.ndarray, vx: np.ndarray, vy: np.ndarray, w: np.ndarray) -> None:
    """The velocities the step ends with, back to the state."""
    for i in range(vx.shape[0]):
        vx[i], vy[i], w[i] = bodies[V_X, i], bodies[V_Y, i], bodies[V_W, i]


@leaf
def body_gravity(bodies: np.ndarray, n: int, g: float, h: float) -> None:
    """``contacts.gravity`` on the bodies' rows: ``vy += g h`` for every movable body."""
    for i in range(n):
        if bodies[INV_M, i] > 0.0:
            bodies[V_Y, i] += g * h


@leaf
def integrate_moved(x: np.ndarray, y: np.ndarray, angle: np.ndarray, bodies: np.ndarray, start: np.ndarray,
                    h: float) -> None:
    """``contacts.integrate_positions`` then ``substep.moved_body`` for every body, in one walk: positions
    and angles move with the velocities over ``h``, and each body's row learns how far it has come since the
    step began (``start``)."""
    for i in range(x.shape[0]):
        x[i] += bodies[V_X, i] * h
        y[i] += bodies[V_Y, i] * h
        angle[i] += bodies[V_W, i] * h
        bodies[D_X, i], bodies[D_Y, i] = x[i] - start[i, 0], y[i] - start[i, 1]
        turn = angle[i] - start[i, 2]
        bodies[COS, i], bodies[SIN, i] = np.cos(turn), np.sin(turn)


@leaf
def velocity_at(bodies: np.ndarray, a: int, b: int, points: np.ndarray, p: int, dx: float, dy: float) -> float:
    """``contacts.relative_velocity`` on the pass's layout: ``((v_B + w_B x r_B) - (v_A + w_A x r_A)) . d`` at
    point ``p`` of bodies ``a`` and ``b``, the same arithmetic in the same order."""
    ux = bodies[V_X, b] - bodies[V_W, b] * points[P_RBY, p]
    uy = bodies[V_Y, b] + bodies[V_W, b] * points[P_RBX, p]
    ux -= bodies[V_X, a] - bodies[V_W, a] * points[P_RAY, p]
    uy -= bodies[V_Y, a] + bodies[V_W, a] * points[P_RAX, p]
    return ux * dx + uy * dy


@leaf
def impulse_at(bodies: np.ndarray, a: int, b: int, points: np.ndarray, p: int, px: float, py: float,
               ground: int) -> None:
    """``contacts.apply_impulse`` on the pass's layout: the impulse ``(px, py)`` at point ``p`` on body ``b``
    and its opposite on ``a`` (none on the ground)."""
    bodies[V_X, b] += bodies[INV_M, b] * px
    bodies[V_Y, b] += bodies[INV_M, b] * py
    bodies[V_W, b] += bodies[INV_I, b] * (points[P_RBX, p] * py - points[P_RBY, p] * px)
    if a != ground:
        bodies[V_X, a] -= bodies[INV_M, a] * px
        bodies[V_Y, a] -= bodies[INV_M, a] * py
        bodies[V_W, a] -= bodies[INV_I, a] * (points[P_RAX, p] * py - points[P_RAY, p] * px)


@leaf
def soft_warm_start(bodies: np.ndarray, links: np.ndarray, points: np.ndarray, count: int) -> None:
    """``contacts.warm_start`` on the pass's layout: every point's accumulated impulses applied to its bodies,
    in the layout's order (which keeps each body's order of points, so the same sums)."""
    ground = np.uint64(bodies.shape[1] - 1)
    for p in range(np.uint64(count)):
        pn, pt = points[P_PN, p], points[P_PT, p]
        if pn != 0.0 or pt != 0.0:
            nx, ny = points[P_NX, p], points[P_NY, p]
            impulse_at(bodies, links[p, L_A], links[p, L_B], points, p, pn * nx - pt * ny, pn * ny + pt * nx, ground)


@leaf
def separation_at(bodies: np.ndarray, a: int, b: int, points: np.ndarray, p: int) -> float:
    """``substep.separation`` on the pass's layout: the separation of point ``p`` now (m, negative: overlap),
    from how far bodies ``a`` and ``b`` have moved and turned since the step began."""
    r0x, r0y = points[P_RBX, p], points[P_RBY, p]
    sx = bodies[D_X, b] + (bodies[COS, b] * r0x - bodies[SIN, b] * r0y)
    sy = bodies[D_Y, b] + (bodies[SIN, b] * r0x + bodies[COS, b] * r0y)
    r0x, r0y = points[P_RAX, p], points[P_RAY, p]
    sx -= bodies[D_X, a] + (bodies[COS, a] * r0x - bodies[SIN, a] * r0y)
    sy -= bodies[D_Y, a] + (bodies[SIN, a] * r0x + bodies[COS, a] * r0y)
    return points[P_BASE, p] + sx * points[P_NX, p] + sy * points[P_NY, p]


@leaf
def soft_pass(bodies: np.ndarray, links: np.ndarray, points: np.ndarray, waves: int, ends: np.ndarray, h: float,
              use_bias: bool, push_out: float) -> None:
    """One pass over the points wave by wave (``wavefront``), normals first, then friction: within a wave
    every manifold's first normal, then every second normal, then the frictions the same way. A manifold's
    visits keep their order (its normals, then its frictions) and the manifolds of a wave share no body, so
    this is the pass over the manifolds in table order to the bit, with each visit independent of the one
    before it.

    A point's separation is measured again from how far its bodies have moved and turned since the step
    began. A point still apart may close its gap within the substep but not more. An overlapping point, with
    the bias, asks for the spring's separating speed (at most ``push_out``), applies ``mass_scale`` of the
    full impulse and lets go ``impulse_scale`` of what it holds; without the bias it only stops approach.
    The normal total stays >= 0 and each point's friction total within ``mu`` times its normal total.
    """
    ground = np.uint64(bodies.shape[1] - 1)
    begin = np.uint64(0)
    for v in range(waves):
        end = ends[v]
        for p in range(begin, end):
            a, b = links[p, L_A], links[p, L_B]
            s = separation_at(bodies, a, b, points, p)
            target, mass_scale, impulse_scale = 0.0, 1.0, 0.0
            if s > 0.0:
                target = -s / h
            elif use_bias:
                target = min(-points[P_BIAS, p] * s, push_out)
                mass_scale, impulse_scale = points[P_SCALE, p], points[P_LET_GO, p]
            nx, ny = points[P_NX, p], points[P_NY, p]
            un = velocity_at(bodies, a, b, points, p, nx, ny)
            old = points[P_PN, p]
            total = max(old + points[P_KN, p] * mass_scale * (target - un) - impulse_scale * old, 0.0)
            impulse_at(bodies, a, b, points, p, (total - old) * nx, (total - old) * ny, ground)
            points[P_PN, p] = total
        for p in range(begin, end):
            a, b = links[p, L_A], links[p, L_B]
            nx, ny = points[P_NX, p], points[P_NY, p]
            limit = points[P_MU, p] * points[P_PN, p]
            old = points[P_PT, p]
            total = old - points[P_KT, p] * velocity_at(bodies, a, b, points, p, -ny, nx)
            total = min(max(total, -limit), limit)
            impulse_at(bodies, a, b, points, p, -(total - old) * ny, (total - old) * nx, ground)
            points[P_PT, p] = total
        begin = end


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
    (``stackx.solvers.planar.applied``) when it has room for them (``watch_impulses``), else nothing."""
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
        first, order, wave, tally, ends, latest, links, points = pass_workspace(ids.shape[0], n)
        start = np.empty((n, 3))
        bodies = np.empty((BODY_COLUMNS, n + 1))
        ids, table, count = find_contacts(xb, yb, ab, hxb, hyb, im, speculative[b], ids, table)
        watched = applied.shape[1] > 0  # the step's impulses are summed only for a caller that reads them
        for _ in range(steps):
            if points.shape[1] < ids.shape[0]:
                first, order, wave, tally, ends, latest, links, points = pass_workspace(ids.shape[0], n)
            table[:count, PN] = 0.0
            table[:count, PT] = 0.0
            if warm[b]:
                recall(ids, table, count, keys[b], carried[b], held[b])
            m = manifold_starts(ids, count, first)
            waves = wavefronts(ids, first, m, latest, wave, tally, order)
            lay_out(xb, yb, im, ii, mub, ids, table, first, order, waves, tally, softness, ends, links, points)
            for i in range(n):
                start[i, 0], start[i, 1], start[i, 2] = xb[i], yb[i], ab[i]
            load_bodies(vxb, vyb, wb, im, ii, bodies)
            if watched:
                clear_applied(applied[b], count)
            for _ in range(substeps[b]):
                body_gravity(bodies, n, g[b], h)
                soft_warm_start(bodies, links, points, count)
                soft_pass(bodies, links, points, waves, ends, h, True, push_out[b])
                integrate_moved(xb, yb, ab, bodies, start, h)
                if relax[b]:
                    soft_pass(bodies, links, points, waves, ends, h, False, push_out[b])
                if watched:
                    add_applied(links[:, L_ROW], points[P_PN], points[P_PT], count, applied[b])
            store_velocities(bodies, vxb, vyb, wb)
            give_back(table, links, points, count)
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
        if held is None or not self.watched or self.applied is None:
            return None
        n = held.pn.shape[0]
        return StepImpulses(held.keys, self.applied[b, :n, 0].copy(), self.applied[b, :n, 1].copy())

    def advance(self, state: PlanarState, steps: int) -> None:
        s = state
        keys, carried, held = self.memory(state)
        room = keys.shape[1] if self.watched else 0
        if self.applied is None or self.applied.shape[:2] != (keys.shape[0], room):
            self.applied = np.zeros((keys.shape[0], room, 2))
        soft_step_advance(s.x, s.y, s.angle, s.vx, s.vy, s.w, s.inv_mass, s.inv_inertia, s.hx, s.hy, s.friction,
                          self.gravity, self.dt, self.substeps, self.hertz, self.damping_ratio, self.push_out,
                          self.relax, self.warm, self.speculative, keys, carried, held, self.applied, *s.monitors(),
                          steps)
