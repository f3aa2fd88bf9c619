"""XPBD with small steps on planar boxes (Macklin et al. 2019 and 2020): positions projected every substep,
velocities derived from positions, Coulomb friction at the position level while it holds.

Contacts are found once per step, within ``speculative`` of touching, or within what the fastest box can close
in the step when that is more (``reach_in_step``: a corner of a falling box moves 0.1 m per step at 6 m/s,
and one found only when already deep would be pushed out a step late) (``contacts.find_contacts``); their
separations are measured again from the bodies' poses at every visit (``substep.separation``: anchors move
and turn with their bodies, the normal is held). Then, ``substeps`` times with ``h = dt / substeps``:

1. remember the poses; gravity; move and turn every box with its velocities over ``h``;
2. project, one pass over the manifolds in table order. The overlapping points of a manifold are pushed
   to touching by position impulses along the normal, both points of a face together (a 2x2 solve, so a
   box landing flat is not tipped by whichever corner came first), with the generalized inverse masses
   ``1/m + (r x n)^2 / I`` of the anchors as they are now, so a push at a corner also turns the box; with
   ``compliance`` each impulse is ``-separation / (w + compliance / h^2)``. Overlap that the substep's own
   motion made is removed whole; overlap already there when the substep began loses at most ``max_push``
   times ``h`` (the velocity a push gives is kept in step 3, so a deep overlap removed in one substep of
   1/1200 s would leave at depth x 1200 m/s). Then **static friction**, per
   point: the slip of the two anchored points along the tangent since the step began is undone by a
   tangential position impulse of at most ``mu`` times the point's normal one;
3. velocities are what the boxes did: ``v = (x - x_before)/h``, ``w = (angle - angle_before)/h``;
4. velocity pass over the manifolds the projection pushed: stop the approach of their points within
   ``speculative`` of touching (restitution 0; a push-out keeps the speed it gave; a point further apart may
   close its gap in the next substep), then **dynamic friction**: each point's tangential velocity is opposed
   with whatever is left of ``mu`` times its normal impulse ``dl / h`` after static friction's share.

So each point's friction in a substep is at most ``mu`` times its normal impulse (Coulomb's box, one ``mu``
for sticking and sliding): a box on a ramp sticks while ``tan(angle) < mu`` and otherwise slides with
``g (sin - mu cos)``. Two choices differ from Macklin et al.'s text, both measured on stacks and ramps:
static friction is clamped at ``mu`` times the normal impulse instead of applied only when it fits (a
face's load is shared by two corners, and all-or-nothing at each corner let a box creep down a ramp well
below ``atan(mu)``), and the slip it undoes is counted from the step's start rather than the substep's
(a stack of boxes on offset creeps ten times less). There is no memory between steps and no velocity solve
of the contacts: a resting box sinks by ``g h^2`` in a substep and is put back, and what one pass leaves
unsolved shows as drift that falls with ``h^2``, so more substeps make contacts firmer and stacks quieter,
at linear cost.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from stackx.kernel import kernel, leaf, prange
from stackx.models.planar.monitor import contact_room
from stackx.models.planar.state import PlanarState
from stackx.registry import solvers
from stackx.solvers.contacts import speculative_field
from stackx.solvers.planar.base import PlanarSolver, StepImpulses
from stackx.solvers.planar.reach import contact_margin
from stackx.solvers.planar.contacts import (A, B, MU, NX, NY, PN, PT, RAX, RAY, RBX, RBY, apply_impulse,
                                            contact_workspace, effective_mass, find_contacts, gravity,
                                            integrate_positions, observed_contacts, prepare, relative_velocity,
                                            two_point_lcp)
from stackx.solvers.planar.substep import anchor, base_separations, moved, moved_body, separation, step_start
from stackx.solvers.planar.wavefront import manifold_end
from stackx.solvers.column.xpbd import XPBDParams


class PlanarXPBDParams(XPBDParams):
    """The column's XPBD knobs (substeps, compliance) and how far apart contacts are followed."""

    speculative: float = speculative_field(
        0.05, " Here: points within this gap when the step begins are followed through its substeps; a box "
              "closing faster than this per step reaches its neighbour unseen and is pushed out a step late; "
              "the margin grows to what the fastest box can close in the step when that is more")
    max_push: float = Field(0.5, gt=0, allow_inf_nan=False,
                            description="fastest a projection may push out an overlap that was there when the "
                                        "substep began (m/s): it removes at most max_push x h of it per substep, "
                                        "since the velocity derived from a push is kept; removed whole, 5 cm in "
                                        "1/1200 s would leave at 60 m/s. Overlap a substep's own motion made is "
                                        "removed whole (that only stops the approach)")


@leaf
def current_anchors(ids: np.ndarray, table: np.ndarray, since: np.ndarray, k: int, now: np.ndarray) -> None:
    """Point ``k``'s anchors as its bodies have turned, into ``now`` (a table whose anchor columns follow
    the bodies, so the shared impulse and velocity stages act at the points where they are now)."""
    b = ids[k, B]
    now[k, RBX], now[k, RBY] = anchor(table, since, b, k, RBX)
    a = ids[k, A]
    if a >= 0:
        now[k, RAX], now[k, RAY] = anchor(table, since, a, k, RAX)


@leaf
def point_mass(ids: np.ndarray, now: np.ndarray, k: int, inv_mass: np.ndarray, inv_inertia: np.ndarray,
               dx: float, dy: float) -> float:
    """``1 / w`` of point ``k`` along ``(dx, dy)`` at its current anchors: the generalized mass."""
    a, b = ids[k, A], ids[k, B]
    ima, iia = (inv_mass[a], inv_inertia[a]) if a >= 0 else (0.0, 0.0)
    return effective_mass(ima, iia, now[k, RAX], now[k, RAY], inv_mass[b], inv_inertia[b], now[k, RBX],
                          now[k, RBY], dx, dy)


@leaf
def shove(x: np.ndarray, y: np.ndarray, angle: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
          ids: np.ndarray, now: np.ndarray, k: int, px: float, py: float, start: np.ndarray,
          since: np.ndarray) -> None:
    """A position impulse ``(px, py)`` at point ``k``: moves and turns body B by it and A by its opposite,
    and records their new motion since the step began."""
    apply_impulse(x, y, angle, inv_mass, inv_inertia, ids, now, k, px, py)
    moved_body(x, y, angle, start, since, ids[k, B])
    if ids[k, A] >= 0:
        moved_body(x, y, angle, start, since, ids[k, A])


@leaf
def slip(ids: np.ndarray, table: np.ndarray, since: np.ndarray, before: np.ndarray, k: int) -> float:
    """How far the anchored point of B has slid along the tangent relative to A's since the substep began."""
    a, b = ids[k, A], ids[k, B]
    rx, ry = anchor(table, since, b, k, RBX)
    qx, qy = anchor(table, before, b, k, RBX)
    dx, dy = since[b, 0] + rx - before[b, 0] - qx, since[b, 1] + ry - before[b, 1] - qy
    if a >= 0:
        rx, ry = anchor(table, since, a, k, RAX)
        qx, qy = anchor(table, before, a, k, RAX)
        dx -= since[a, 0] + rx - before[a, 0] - qx
        dy -= since[a, 1] + ry - before[a, 1] - qy
    return -dx * table[k, NY] + dy * table[k, NX]


@kernel
def pair_solve(k11: float, k12: float, k22: float, s1: float, s2: float) -> tuple[float, float]:
    """Impulses ``l1, l2 >= 0`` that leave both points of a two-point manifold apart or touching, pushing
    only the points that end touching (``two_point_lcp`` with ``b = s``); a degenerate ``K`` (the two points
    on one line through both centres) is not inverted, and when no case fits in rounding the first point
    is solved alone, then the second with what is left."""
    det = k11 * k22 - k12 * k12
    l1, l2, found = two_point_lcp(k11, k12, k22, s1, s2, det > 1e-12 * k11 * k22)
    if found:
        return l1, l2
    l1 = max(-s1 / k11, 0.0)
    return l1, max(-(s2 + k12 * l1) / k22, 0.0)


@leaf
def coupling(ids: np.ndarray, now: np.ndarray, k: int, j: int, inv_mass: np.ndarray, inv_inertia: np.ndarray,
             dx: float, dy: float) -> float:
    """How far a unit impulse along ``(dx, dy)`` at point ``j`` opens point ``k`` of the same two bodies
    along that direction: the off-diagonal of ``J M^-1 J^T``."""
    a, b = ids[k, A], ids[k, B]
    out = inv_mass[b] + inv_inertia[b] * (now[k, RBX] * dy - now[k, RBY] * dx) * (now[j, RBX] * dy - now[j, RBY] * dx)
    if a >= 0:
        out += inv_mass[a] + inv_inertia[a] * ((now[k, RAX] * dy - now[k, RAY] * dx)
                                               * (now[j, RAX] * dy - now[j, RAY] * dx))
    return out


@leaf
def normal_impulses(ids: np.ndarray, now: np.ndarray, start: int, end: int, inv_mass: np.ndarray,
                    inv_inertia: np.ndarray, s1: float, s2: float, soft: float) -> tuple[float, float]:
    """Normal impulses of the manifold's one or two points that bring ``s`` (separations, or normal
    velocities) to zero where they are negative, both points solved together; ``soft`` is added to the
    diagonal (compliance over ``h^2``; 0 is rigid)."""
    nx, ny = now[start, NX], now[start, NY]
    k11 = 1.0 / point_mass(ids, now, start, inv_mass, inv_inertia, nx, ny) + soft
    if end - start == 1:
        return max(-s1 / k11, 0.0), 0.0
    k22 = 1.0 / point_mass(ids, now, start + 1, inv_mass, inv_inertia, nx, ny) + soft
    k12 = coupling(ids, now, start, start + 1, inv_mass, inv_inertia, nx, ny)
    return pair_solve(k11, k12, k22, s1, s2)


@kernel
def held_back(held: np.ndarray, k: int, push: float) -> float:
    """The separation (m, at most 0) the projection leaves point ``k`` at: an overlap ``-held[k]`` that was
    there when the substep began is undone by at most ``push`` (``max_push`` times ``h``); one the substep's
    own motion made is undone whole."""
    return min(min(held[k], 0.0) + push, 0.0)


@kernel
def separations(ids: np.ndarray, table: np.ndarray, base: np.ndarray, since: np.ndarray, count: int,
                out: np.ndarray) -> None:
    """Every point's separation now, into ``out``."""
    for k in range(count):
        out[k] = separation(ids, table, base, since, k)


@leaf
def project(x: np.ndarray, y: np.ndarray, angle: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
            ids: np.ndarray, table: np.ndarray, count: int, base: np.ndarray, start: np.ndarray,
            since: np.ndarray, before: np.ndarray, now: np.ndarray, stiffness: float, held: np.ndarray,
            push: float) -> None:
    """One projection pass over the manifolds in table order: the overlapping points of each pushed to
    touching together (``stiffness``: compliance over ``h^2``; 0 is rigid), then each point's slip undone
    while that takes at most ``mu`` times its normal impulse. ``PN``, ``PT`` receive this pass's position
    impulses."""
    first = 0
    while first < count:
        end = manifold_end(ids, first, count)
        s1 = separation(ids, table, base, since, first) - held_back(held, first, push)
        s2 = separation(ids, table, base, since, first + 1) - held_back(held, first + 1, push) if end - first == 2 else 0.0
        for k in range(first, end):
            table[k, PN], table[k, PT] = 0.0, 0.0
        if s1 < 0.0 or s2 < 0.0:
            nx, ny = table[first, NX], table[first, NY]
            for k in range(first, end):
                current_anchors(ids, table, since, k, now)
            l1, l2 = normal_impulses(ids, now, first, end, inv_mass, inv_inertia, s1, s2, stiffness)
            table[first, PN] = l1
            if end - first == 2:
                table[first + 1, PN] = l2
                apply_impulse(x, y, angle, inv_mass, inv_inertia, ids, now, first + 1, l2 * nx, l2 * ny)
            shove(x, y, angle, inv_mass, inv_inertia, ids, now, first, l1 * nx, l1 * ny, start, since)
            for k in range(first, end):
                dl = table[k, PN]
                if dl <= 0.0:
                    continue
                current_anchors(ids, table, since, k, now)
                limit = table[k, MU] * dl
                dlt = -slip(ids, table, since, before, k) * point_mass(ids, now, k, inv_mass, inv_inertia, -ny, nx)
                dlt = min(max(dlt, -limit), limit)
                shove(x, y, angle, inv_mass, inv_inertia, ids, now, k, -dlt * ny, dlt * nx, start, since)
                table[k, PT] = dlt
        first = end


@leaf
def derive_velocities(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                      w: np.ndarray, inv_mass: np.ndarray, poses: np.ndarray, h: float) -> None:
    """Each movable box's velocities are what it did over the substep (from ``poses``: x, y, angle)."""
    for i in range(x.shape[0]):
        if inv_mass[i] > 0.0:
            vx[i] = (x[i] - poses[i, 0]) / h
            vy[i] = (y[i] - poses[i, 1]) / h
            w[i] = (angle[i] - poses[i, 2]) / h


@kernel
def gap(ids: np.ndarray, table: np.ndarray, base: np.ndarray, since: np.ndarray, k: int, near: float) -> float:
    """How far apart point ``k`` is now when that is more than ``near`` (m), else 0."""
    s = separation(ids, table, base, since, k)
    return s if s > near else 0.0


@leaf
def velocity_pass(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
                  ids: np.ndarray, table: np.ndarray, count: int, base: np.ndarray, since: np.ndarray,
                  now: np.ndarray, h: float, near: float) -> None:
    """Over the manifolds the projection pushed: stop the approach of their points, both together (the
    velocity a push-out gave is kept, as the derived velocity of any position change is), then oppose each
    point's tangential velocity with at most ``mu`` times its normal impulse (dynamic friction)."""
    first = 0
    while first < count:
        end = manifold_end(ids, first, count)
        pushed = table[first, PN] > 0.0 or (end - first == 2 and table[first + 1, PN] > 0.0)
        if pushed:
            nx, ny = table[first, NX], table[first, NY]
            for k in range(first, end):
                current_anchors(ids, table, since, k, now)
            # a point within ``near`` of touching has its approach stopped; one further apart (found only
            # because something moves fast) may close its gap within the next substep
            u1 = relative_velocity(vx, vy, w, ids, now, first, nx, ny) + gap(ids, table, base, since, first, near) / h
            u2 = 0.0
            if end - first == 2:
                u2 = relative_velocity(vx, vy, w, ids, now, first + 1, nx, ny) + gap(ids, table, base, since,
                                                                                    first + 1, near) / h
            p1, p2 = normal_impulses(ids, now, first, end, inv_mass, inv_inertia, u1, u2, 0.0)
            apply_impulse(vx, vy, w, inv_mass, inv_inertia, ids, now, first, p1 * nx, p1 * ny)
            if end - first == 2:
                apply_impulse(vx, vy, w, inv_mass, inv_inertia, ids, now, first + 1, p2 * nx, p2 * ny)
            for k in range(first, end):
                limit = max(table[k, MU] * table[k, PN] - abs(table[k, PT]), 0.0) / h
                ut = relative_velocity(vx, vy, w, ids, now, k, -ny, nx)
                pt = min(max(-ut * point_mass(ids, now, k, inv_mass, inv_inertia, -ny, nx), -limit), limit)
                apply_impulse(vx, vy, w, inv_mass, inv_inertia, ids, now, k, -pt * ny, pt * nx)
        first = end


@kernel
def xpbd_advance(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray, w: np.ndarray,
                 inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray, hy: np.ndarray,
                 friction: np.ndarray, g: np.ndarray, dt: np.ndarray, substeps: np.ndarray,
                 compliance: np.ndarray, speculative: np.ndarray, max_push: np.ndarray, last: np.ndarray, peak: np.ndarray,
                 reach: np.ndarray, touched: np.ndarray, launch: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row, in place."""
    for b in prange(x.shape[0]):
        xb, yb, ab, vxb, vyb, wb = x[b], y[b], angle[b], vx[b], vy[b], w[b]  # the row's views, made once
        im, ii, hxb, hyb, mub = inv_mass[b], inv_inertia[b], hx[b], hy[b], friction[b]
        n = x.shape[1]
        h = dt[b] / substeps[b]
        stiffness = compliance[b] / (h * h)
        ids, table = contact_workspace(contact_room(n))
        now = table.copy()
        base = np.empty(table.shape[0])
        held = np.empty(table.shape[0])  # each point's separation as the substep begins
        start, poses = np.empty((n, 3)), np.empty((n, 3))
        since, before = np.empty((n, 4)), np.empty((n, 4))
        margin = contact_margin(speculative[b], vxb, vyb, wb, im, hxb, hyb, g[b], dt[b])
        ids, table, count = find_contacts(xb, yb, ab, hxb, hyb, im, margin, ids, table)
        for _ in range(steps):
            prepare(xb, yb, im, ii, mub, ids, table, count)
            if base.shape[0] < count:
                base = np.empty(table.shape[0])
                held = np.empty(table.shape[0])
            if now.shape[0] < count:
                now = table.copy()
            now[:count] = table[:count]
            base_separations(ids, table, count, base)
            step_start(xb, yb, ab, start, since)
            before[:, :] = since
            for _ in range(substeps[b]):
                for i in range(n):
                    poses[i, 0], poses[i, 1], poses[i, 2] = xb[i], yb[i], ab[i]
                separations(ids, table, base, since, count, held)
                gravity(vyb, im, g[b], h)
                integrate_positions(xb, yb, ab, vxb, vyb, wb, h)
                moved(xb, yb, ab, start, since)
                project(xb, yb, ab, im, ii, ids, table, count, base, start, since, before, now, stiffness, held,
                        max_push[b] * h)
                derive_velocities(xb, yb, ab, vxb, vyb, wb, im, poses, h)
                velocity_pass(vxb, vyb, wb, im, ii, ids, table, count, base, since, now, h, speculative[b])
            margin = contact_margin(speculative[b], vxb, vyb, wb, im, hxb, hyb, g[b], dt[b])
            ids, table, count = observed_contacts(xb, yb, ab, hxb, hyb, im, margin, ids, table, dt[b], last,
                                                  peak, reach, touched, launch, b)


@solvers.register("planar-xpbd")
class PlanarXPBD(PlanarSolver):
    """Small steps of position projection with static and dynamic friction, velocities derived from
    positions (Macklin et al.)."""

    Params = PlanarXPBDParams
    speculative_reach = True  # contacts looked for as far as the fastest box closes (stackx.solvers.planar.reach)

    def __init__(self, params: list[PlanarXPBDParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.substeps = self.counts("substeps")
        self.compliance = self.column("compliance")
        self.speculative = self.column("speculative")
        self.max_push = self.column("max_push")

    @classmethod
    def passes(cls, params: PlanarXPBDParams) -> int:
        return 2 * params.substeps

    def step_impulses(self, b: int) -> StepImpulses | None:
        """None: XPBD's velocities are its positions' motion over the last substep, pushed at anchors that turn
        with their bodies; no impulses on the step's contact problem give them, so the bench checks what
        its velocities alone show (``stackx.solvers.planar.conditions.approach``)."""
        return None

    def advance(self, state: PlanarState, steps: int) -> None:
        s = state
        xpbd_advance(s.x, s.y, s.angle, s.vx, s.vy, s.w, s.inv_mass, s.inv_inertia, s.hx, s.hy, s.friction,
                     self.gravity, self.dt, self.substeps, self.compliance, self.speculative,
                     self.max_push, *s.monitors(), steps)
