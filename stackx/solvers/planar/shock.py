"""Shock propagation on planar boxes: ``planar-warm-start``'s velocity solve, then a sweep up the pile in
which every support is treated as immovable (Guendelman, Bridson and Fedkiw, "Nonconvex rigid bodies with
stacking", SIGGRAPH 2003).

Gauss-Seidel passes move a load one contact per pass, and a light box under a heavy one barely moves the heavy
one at each visit: with too few passes for the pile's height or mass ratio, the part of the weight not yet
carried presses the supports into what they rest on, and the pile sinks or leans a little every step. The shock
pass ends the step's solve by visiting the contacts level by level from the ground up with the lower body of
each frozen (inverse mass and inertia zero): the body above takes the whole correction, so nothing is left
pushing down, and after one sweep no contact to a lower level approaches.

One step of one world:
1. ``passes.solve_laid``, as ``planar-warm-start`` steps it (gravity, warm start, ``iterations`` passes with
   block normals and over-relaxation ``relaxation``), on the points within ``speculative`` of touching or
   within what the fastest box can close in the step when that is more (``reach``, as ``planar-ngs``): the
   shock pass can stop a falling box only at a contact the step has found;
2. the bodies' levels (``order``): ``support``, breadth first over the step's contacts from the ground and
   the static boxes (level 0; a box touching them is level 1, ...; a group touching nothing static has no
   level and is left to the passes); or ``height``, every movable box its own level by the height of its
   centre, lowest first;
3. the shock pass, level 1 first: ``shock_passes`` visits of each contact whose upper body is on that level,
   friction then normals (a two-point manifold's together), with the lower body frozen; a contact between two
   bodies of the same level (boxes side by side) is visited as the passes visit it, both bodies moving.
   Normals last: each visit ends with the contact not approaching and the upper box turning with the lower,
   so a stack stays upright to rounding (with friction last, a 40-box stack and a 10-row pyramid were still
   moving at 1e-3 and 2e-4 m/s after 10 s, turned by 2e-3 rad);
4. positions, the lab's correction and the monitors, as ``planar-warm-start``.

**Velocities, not positions.** The paper propagates the shock in its position (contact) stage. Here the
sinking it is meant to stop comes from velocities: a support pressed down with speed is pushed back a share of
its overlap each step and pressed again the next. Freezing the supports in the velocity solve stops the
approach itself. Measured (``acts_on: positions``: the lab's correction level by level, the lower body
frozen), the position variant does not hold a box 1000 times as heavy on a light one (it sinks 4 cm and
bounces) nor the heavy slab (it topples), where the velocity variant holds both exactly.

**What it gives up.** A frozen support takes no reaction within the step: the shock pass removes momentum from
the top of the pile without passing it down. A box dropped on a stack is stopped by the stack as by the ground
instead of pressing it down, and a heavy box landing on a light one does not crush it; the load reaches the
supports over the next steps through the passes. The next step warm-starts from the passes' totals, not the
shock pass's: those were applied to the upper bodies only, and carried over as impulses on both bodies they
built a shear that slid a 40-box stack apart (17 m of drift in 10 s, against 1 mm). For the same reason the
totals do not give the step's velocities: ``step_impulses`` is None when the pass acts on velocities.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from stackx.kernel import inlined, kernel, leaf, prange
from stackx.models.planar.layout import A, B, DEPTH
from stackx.models.planar.state import PlanarState
from stackx.registry import solvers
from stackx.solvers.base import Correction, LabCorrection
from stackx.solvers.contacts import speculative_field
from stackx.solvers.planar.base import PlanarMemorySolver, StepImpulses, sequential_only
from stackx.solvers.planar.contacts import (BLOCK_CONDITION, contact_workspace, correct_point, correct_positions,
                                            effective_mass, find_contacts_near, integrate_positions, near_workspace,
                                            observe_contacts, two_point_lcp)
from stackx.solvers.planar.passes import (FIRST, INV_I, INV_M, L_A, L_B, L_POINTS, L_SINK, M_BLOCK, M_MU, M_NX,
                                          M_NY, Q_PN, Q_PT, Q_RAX, Q_RAY, Q_RBX, Q_RBY, Q_TARGET, SECOND, V_W, V_X,
                                          V_Y, along, give_velocities, laid_friction, laid_normals, laid_workspace,
                                          push, solve_laid)
from stackx.solvers.planar.reach import contact_margin
from stackx.solvers.planar.wavefront import manifold_starts

ORDERS = {"support": 0, "height": 1}
STAGES = {"velocities": 0, "positions": 1}
UNREACHED = 1 << 40  # the level of a box no chain of contacts links to the ground or a static box


class PlanarShockParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    iterations: int = Field(30, gt=0, le=100_000,
                            description="velocity passes per step before the shock pass (planar-warm-start's): "
                                        "more leave less for the shock pass to take from the top of the pile, "
                                        "and cost linearly more")
    shock_passes: int = Field(8, ge=0, le=10_000,
                              description="visits of each level's contacts in the shock pass, lowest level "
                                          "first, each costing about one velocity pass over them; they settle "
                                          "a box's several contacts with what it rests on, and friction with "
                                          "the normals: 1 holds a 10-box stack, pyramids and a slab on two "
                                          "posts, a 40-box stack keeps sliding apart (13 cm in 10 s at 1, "
                                          "9 mm and still moving at 4) and holds within 1 mm at 8; 0 is "
                                          "planar-warm-start with the contact reach")
    order: Literal["support", "height"] = Field(
        "support", description="how bodies are ranked: 'support', breadth first over the contacts from the ground "
                               "and static boxes (boxes side by side share a level and push each other); "
                               "'height', by the height of each box's centre (every box its own level, so of "
                               "two boxes side by side the lower is frozen for the other, and a group touching "
                               "nothing static is ranked too)")
    acts_on: Literal["velocities", "positions"] = Field(
        "velocities", description="what the shock pass corrects: 'velocities' after the velocity passes (stops "
                                  "the approach that sinks a support); 'positions', the lab's correction level by "
                                  "level with the lower body frozen (the paper's stage: moves boxes out of "
                                  "overlap only, so needs the correction on)")
    warm_start: bool = Field(True, description="start each step from the impulses each point carried at the end "
                                               "of the last one; off rebuilds every load from zero each step")
    speculative: float = speculative_field(0.02)
    relaxation: float = Field(1.0, gt=0, lt=2, allow_inf_nan=False,
                              description="over-relaxation of the velocity passes' normal steps (not of the "
                                          "shock pass): see planar-warm-start")
    block: bool = Field(True, description="solve a two-point manifold's normal impulses together, in the passes "
                                          "and in the shock pass")
    correction: LabCorrection = Field(
        default_factory=Correction,
        description="the lab's position correction (slop, percent; translation along each point's normal), or "
                    "'off' to leave overlap in place")

    _sequential = field_validator("correction")(sequential_only)

    @model_validator(mode="after")
    def _positions_need_correction(self) -> "PlanarShockParams":
        """The position variant is the correction stage: without it the knob would do nothing."""
        if self.acts_on == "positions" and self.correction is None and self.shock_passes > 0:
            raise ValueError("acts_on: positions runs the shock pass in the position correction: leave "
                             "'correction' on or set acts_on: velocities")
        return self


@kernel
def shock_workspace(bodies: int, room: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Room for the shock pass: ``(level, top, visit, starts)``: each body's level (the ground's after them),
    each manifold's or point's level, the manifolds or points in level order, where each level begins."""
    return (np.zeros(bodies + 2, np.int64), np.zeros(room, np.int64), np.zeros(room, np.int64),
            np.zeros(bodies + 3, np.int64))


@leaf
def support_levels(ids: np.ndarray, count: int, inv_mass: np.ndarray, level: np.ndarray) -> None:
    """``level[i]``: the fewest contacts between body ``i`` and the ground or a static box (0 for those, the
    ground at ``level[n]``), ``UNREACHED`` for a box no chain of contacts links to them. Sweeps over the
    table until nothing changes: a pile's levels are found in about as many sweeps as it has levels out of
    table order (the table lists pairs by body, usually bottom up: one or two)."""
    n = inv_mass.shape[0]
    for i in range(n):
        level[i] = 0 if inv_mass[i] == 0.0 else UNREACHED
    level[n] = 0
    changed = True
    while changed:
        changed = False
        for k in range(count):
            a, b = ids[k, A], ids[k, B]
            la = level[a] if a >= 0 else 0
            if la + 1 < level[b]:
                level[b] = la + 1
                changed = True
            elif a >= 0 and level[b] + 1 < la:
                level[a] = level[b] + 1
                changed = True


@kernel
def height_levels(y: np.ndarray, inv_mass: np.ndarray, level: np.ndarray) -> None:
    """``level[i]``: 0 for the ground (``level[n]``) and static boxes, else 1 + the box's rank among the
    movable ones by the height of its centre (ties by index)."""
    n = inv_mass.shape[0]
    ranked = np.argsort(y, kind="mergesort")
    rank = 1
    for j in range(n):
        i = ranked[j]
        if inv_mass[i] == 0.0:
            level[i] = 0
        else:
            level[i] = rank
            rank += 1
    level[n] = 0


@leaf
def by_level(top: np.ndarray, m: int, levels: int, visit: np.ndarray, starts: np.ndarray) -> None:
    """Counting sort of ``m`` items by ``top`` (``0 <= top < levels``, or -1 for left out): ``visit`` the
    items level by level (in their own order within a level), ``starts[L]`` where level ``L`` begins."""
    for L in range(levels + 1):
        starts[L] = 0
    for j in range(m):
        if top[j] >= 0:
            starts[top[j] + 1] += 1
    for L in range(levels):
        starts[L + 1] += starts[L]
    for j in range(m):
        t = top[j]
        if t >= 0:
            visit[starts[t]] = j
            starts[t] += 1
    for L in range(levels - 1, -1, -1):  # back from ends to beginnings
        starts[L + 1] = starts[L]
    starts[0] = 0


@leaf
def manifold_levels(links: np.ndarray, m: int, level: np.ndarray, top: np.ndarray) -> int:
    """Each laid manifold's level, that of its upper body (-1 when neither is linked to the ground or a static
    box); returns one more than the highest."""
    highest = 0
    for j in range(m):
        t = max(level[np.int64(links[j, L_A])], level[np.int64(links[j, L_B])])
        top[j] = t if t < UNREACHED else -1
        highest = max(highest, top[j])
    return highest + 1


@leaf
def frozen_pair(bodies: np.ndarray, links: np.ndarray, j: int,
                a_frozen: bool) -> tuple[int, int, float, float, float, float, float, float, float, float, float, float]:
    """Manifold ``j``'s two bodies, their velocities and their inverse masses and inertias, the lower body's
    (``a_frozen``: body A is the lower) made 0: frozen, so only the upper body moves."""
    a, b = np.int64(links[j, L_A]), np.int64(links[j, L_B])
    ima, iia, imb, iib = bodies[a, INV_M], bodies[a, INV_I], bodies[b, INV_M], bodies[b, INV_I]
    if a_frozen:
        ima, iia = 0.0, 0.0
    else:
        imb, iib = 0.0, 0.0
    return (a, b, bodies[a, V_X], bodies[a, V_Y], bodies[a, V_W], bodies[b, V_X], bodies[b, V_Y], bodies[b, V_W],
            ima, iia, imb, iib)


@inlined
def frozen_normals(bodies: np.ndarray, links: np.ndarray, rows: np.ndarray, j: int, a_frozen: bool,
                   block: bool) -> None:
    """Manifold ``j``'s normal totals with its lower body frozen (``a_frozen``: body A is the lower): both at
    once where ``block`` and the two-point matrix of the upper body alone is well conditioned, else point by
    point, kept >= 0; only the upper body's velocities change."""
    a, b, vax, vay, wa, vbx, vby, wb, ima, iia, imb, iib = frozen_pair(bodies, links, j, a_frozen)
    nx, ny = rows[j, M_NX], rows[j, M_NY]
    points = np.int64(links[j, L_POINTS])
    solved = False
    if block and points == 2 and rows[j, M_BLOCK] != 0.0:
        k11 = 1.0 / effective_mass(ima, iia, rows[j, FIRST + Q_RAX], rows[j, FIRST + Q_RAY], imb, iib,
                                   rows[j, FIRST + Q_RBX], rows[j, FIRST + Q_RBY], nx, ny)
        k22 = 1.0 / effective_mass(ima, iia, rows[j, SECOND + Q_RAX], rows[j, SECOND + Q_RAY], imb, iib,
                                   rows[j, SECOND + Q_RBX], rows[j, SECOND + Q_RBY], nx, ny)
        ca1 = rows[j, FIRST + Q_RAX] * ny - rows[j, FIRST + Q_RAY] * nx
        ca2 = rows[j, SECOND + Q_RAX] * ny - rows[j, SECOND + Q_RAY] * nx
        cb1 = rows[j, FIRST + Q_RBX] * ny - rows[j, FIRST + Q_RBY] * nx
        cb2 = rows[j, SECOND + Q_RBX] * ny - rows[j, SECOND + Q_RBY] * nx
        k12 = ima + imb + iia * ca1 * ca2 + iib * cb1 * cb2
        det = k11 * k22 - k12 * k12
        if k11 * k11 < BLOCK_CONDITION * det:
            a1, a2 = rows[j, FIRST + Q_PN], rows[j, SECOND + Q_PN]
            b1 = along(vax, vay, wa, vbx, vby, wb, rows, j, FIRST, nx, ny) - rows[j, FIRST + Q_TARGET] - (
                k11 * a1 + k12 * a2)
            b2 = along(vax, vay, wa, vbx, vby, wb, rows, j, SECOND, nx, ny) - rows[j, SECOND + Q_TARGET] - (
                k12 * a1 + k22 * a2)
            x1, x2, solved = two_point_lcp(k11, k12, k22, b1, b2, True)
            if solved:
                d1, d2 = x1 - a1, x2 - a2
                vax, vay, wa, vbx, vby, wb = push(vax, vay, wa, vbx, vby, wb, ima, iia, imb, iib, rows, j, FIRST,
                                                  d1 * nx, d1 * ny)
                vax, vay, wa, vbx, vby, wb = push(vax, vay, wa, vbx, vby, wb, ima, iia, imb, iib, rows, j, SECOND,
                                                  d2 * nx, d2 * ny)
                rows[j, FIRST + Q_PN], rows[j, SECOND + Q_PN] = x1, x2
    if not solved:
        for q in range(points):
            c = FIRST if q == 0 else SECOND
            kn = effective_mass(ima, iia, rows[j, c + Q_RAX], rows[j, c + Q_RAY], imb, iib, rows[j, c + Q_RBX],
                                rows[j, c + Q_RBY], nx, ny)
            old = rows[j, c + Q_PN]
            total = max(old + kn * (rows[j, c + Q_TARGET] - along(vax, vay, wa, vbx, vby, wb, rows, j, c, nx, ny)),
                        0.0)
            if total != old:
                step = total - old
                rows[j, c + Q_PN] = total
                vax, vay, wa, vbx, vby, wb = push(vax, vay, wa, vbx, vby, wb, ima, iia, imb, iib, rows, j, c,
                                                  step * nx, step * ny)
    upper_write(bodies, links, j, a_frozen, vax, vay, wa, vbx, vby, wb)


@leaf
def upper_write(bodies: np.ndarray, links: np.ndarray, j: int, a_frozen: bool, vax: float, vay: float, wa: float,
                vbx: float, vby: float, wb: float) -> None:
    """The upper body's velocities back to its row; the frozen body's row is left as it was."""
    if a_frozen:
        b = np.int64(links[j, L_B])
        bodies[b, V_X], bodies[b, V_Y], bodies[b, V_W] = vbx, vby, wb
    else:
        a = np.int64(links[j, L_SINK])
        bodies[a, V_X], bodies[a, V_Y], bodies[a, V_W] = vax, vay, wa


@inlined
def frozen_friction(bodies: np.ndarray, links: np.ndarray, rows: np.ndarray, j: int, c: int,
                    a_frozen: bool) -> None:
    """The friction total of the point of row ``j`` whose columns begin at ``c``, moved towards stopping its
    sliding with the lower body frozen, within ``mu`` times its normal total."""
    a, b, vax, vay, wa, vbx, vby, wb, ima, iia, imb, iib = frozen_pair(bodies, links, j, a_frozen)
    nx, ny = rows[j, M_NX], rows[j, M_NY]
    kt = effective_mass(ima, iia, rows[j, c + Q_RAX], rows[j, c + Q_RAY], imb, iib, rows[j, c + Q_RBX],
                        rows[j, c + Q_RBY], -ny, nx)
    limit = rows[j, M_MU] * rows[j, c + Q_PN]
    old = rows[j, c + Q_PT]
    total = min(max(old - kt * along(vax, vay, wa, vbx, vby, wb, rows, j, c, -ny, nx), -limit), limit)
    if total != old:
        step = total - old
        rows[j, c + Q_PT] = total
        vax, vay, wa, vbx, vby, wb = push(vax, vay, wa, vbx, vby, wb, ima, iia, imb, iib, rows, j, c, -step * ny,
                                          step * nx)
        upper_write(bodies, links, j, a_frozen, vax, vay, wa, vbx, vby, wb)


@leaf
def shock_velocities(bodies: np.ndarray, links: np.ndarray, rows: np.ndarray, level: np.ndarray, visit: np.ndarray,
                     starts: np.ndarray, levels: int, passes: int, block: bool) -> None:
    """The shock pass on the laid manifolds, level 1 up (``visit``, ``starts``: ``by_level``'s): ``passes``
    visits of each level's manifolds. A manifold to a lower level: friction, then normals, the lower body
    frozen (normals last, so the visit ends with no approach and the upper box turning with the lower); two
    bodies of one level: the passes' visit, both moving."""
    for L in range(1, levels):
        for _ in range(passes):
            for i in range(starts[L], starts[L + 1]):
                j = visit[i]
                la, lb = level[np.int64(links[j, L_A])], level[np.int64(links[j, L_B])]
                if la == lb:
                    laid_normals(bodies, links, rows, j, 1.0)
                    laid_friction(bodies, links, rows, j, FIRST)
                    if links[j, L_POINTS] == 2:
                        laid_friction(bodies, links, rows, j, SECOND)
                else:
                    a_frozen = la < lb
                    frozen_friction(bodies, links, rows, j, FIRST, a_frozen)
                    if links[j, L_POINTS] == 2:
                        frozen_friction(bodies, links, rows, j, SECOND, a_frozen)
                    frozen_normals(bodies, links, rows, j, a_frozen, block)


@leaf
def point_levels(ids: np.ndarray, count: int, level: np.ndarray, top: np.ndarray) -> int:
    """Each point's level, that of its upper body (-1 for a point of a group linked to nothing static);
    returns one more than the highest."""
    highest = 0
    n = level.shape[0] - 2
    for k in range(count):
        a = ids[k, A]
        t = max(level[a] if a >= 0 else level[n], level[ids[k, B]])
        top[k] = t if t < UNREACHED else -1
        highest = max(highest, top[k])
    return highest + 1


@leaf
def shock_positions(x: np.ndarray, y: np.ndarray, inv_mass: np.ndarray, ids: np.ndarray, table: np.ndarray,
                    level: np.ndarray, visit: np.ndarray, starts: np.ndarray, levels: int, passes: int, slop: float,
                    percent: float, shift: np.ndarray) -> bool:
    """The lab's correction (``contacts.correct_point``: each depth less what earlier pushes opened along
    its normal) level by level from the ground up, ``passes`` times a level, with the lower body of each
    point frozen so the upper takes the whole push; returns whether it moved any body."""
    shift[:, :] = 0.0
    n = inv_mass.shape[0]
    moved = False
    for L in range(1, levels):
        for _ in range(passes):
            for i in range(starts[L], starts[L + 1]):
                k = visit[i]
                if table[k, DEPTH] < 0.0:
                    continue
                a, b = ids[k, A], ids[k, B]
                ima, la = 0.0, level[n]
                if a >= 0:
                    ima, la = inv_mass[a], level[a]
                imb = inv_mass[b]
                if la < level[b]:
                    ima = 0.0
                elif level[b] < la:
                    imb = 0.0
                pushed = correct_point(x, y, ids, table, k, ima, imb, slop, percent, shift)
                moved = moved or pushed
    return moved


@kernel
def positions_by_level(x: np.ndarray, y: np.ndarray, inv_mass: np.ndarray, ids: np.ndarray, table: np.ndarray,
                       count: int, order: int, level: np.ndarray, top: np.ndarray, visit: np.ndarray,
                       starts: np.ndarray, passes: int, slop: float, percent: float, shift: np.ndarray) -> bool:
    """The position variant of the shock pass on the table found after the positions moved: the levels, the
    points in level order, then ``shock_positions``; returns whether it moved any body."""
    find_levels(y, inv_mass, ids, count, order, level)
    levels = point_levels(ids, count, level, top)
    by_level(top, count, levels, visit, starts)
    return shock_positions(x, y, inv_mass, ids, table, level, visit, starts, levels, passes, slop, percent, shift)


@kernel
def find_levels(y: np.ndarray, inv_mass: np.ndarray, ids: np.ndarray, count: int, order: int,
                level: np.ndarray) -> None:
    """The bodies' levels by ``order`` (``ORDERS``): ``support_levels`` or ``height_levels``."""
    if order == 0:
        support_levels(ids, count, inv_mass, level)
    else:
        height_levels(y, inv_mass, level)


@kernel
def planar_shock_advance(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                         w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray,
                         hy: np.ndarray, friction: np.ndarray, g: np.ndarray, dt: np.ndarray, iterations: np.ndarray,
                         carry: np.ndarray, block: np.ndarray, relaxation: np.ndarray, speculative: np.ndarray,
                         shock_passes: np.ndarray, order: np.ndarray, stage: np.ndarray, corrects: np.ndarray,
                         slop: np.ndarray, percent: np.ndarray, keys: np.ndarray, carried: np.ndarray,
                         held: np.ndarray, last: np.ndarray, peak: np.ndarray, reach: np.ndarray,
                         touched: np.ndarray, launch: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row, in place; ``keys``, ``carried`` and ``held`` carry over."""
    for b in prange(x.shape[0]):
        xb, yb, ab, vxb, vyb, wb = x[b], y[b], angle[b], vx[b], vy[b], w[b]  # the row's views, made once
        im, ii, hxb, hyb, mub = inv_mass[b], inv_inertia[b], hx[b], hy[b], friction[b]
        n = x.shape[1]
        ids, table = contact_workspace(keys.shape[1])
        near, wide = near_workspace(n)
        shift = np.zeros((n, 2))
        margin = contact_margin(speculative[b], vxb, vyb, wb, im, hxb, hyb, g[b], dt[b])
        ids, table, count, near = find_contacts_near(xb, yb, ab, hxb, hyb, im, margin, near, wide, ids, table)
        first, order_, group, tally, latest, links, rows, bodies = laid_workspace(ids.shape[0], n)
        level, top, visit, starts = shock_workspace(n, ids.shape[0])
        shocks = shock_passes[b] > 0
        for _ in range(steps):
            if rows.shape[0] < ids.shape[0]:  # the table grew
                first, order_, group, tally, latest, links, rows, bodies = laid_workspace(ids.shape[0], n)
                level, top, visit, starts = shock_workspace(n, ids.shape[0])
            held[b] = solve_laid(xb, yb, vxb, vyb, wb, im, ii, mub, g[b], dt[b], carry[b], iterations[b], block[b],
                                 relaxation[b], ids, table, count, keys[b], carried[b], held[b], first, order_,
                                 group, tally, latest, links, rows, bodies)
            if shocks and stage[b] == 0:
                m = manifold_starts(ids, count, first)  # solve_laid's manifolds, as it laid them out
                find_levels(yb, im, ids, count, order[b], level)
                levels = manifold_levels(links, m, level, top)
                by_level(top, m, levels, visit, starts)
                shock_velocities(bodies, links, rows, level, visit, starts, levels, shock_passes[b], block[b])
                give_velocities(bodies, vxb, vyb, wb)  # the memory keeps the passes' totals (module doc)
            integrate_positions(xb, yb, ab, vxb, vyb, wb, dt[b])
            margin = contact_margin(speculative[b], vxb, vyb, wb, im, hxb, hyb, g[b], dt[b])
            moved = True
            if corrects[b]:  # the table's touching points are the correction's (correct_positions)
                ids, table, count, near = find_contacts_near(xb, yb, ab, hxb, hyb, im, margin, near, wide, ids,
                                                             table)
                if shocks and stage[b] == 1:
                    if top.shape[0] < ids.shape[0]:
                        level, top, visit, starts = shock_workspace(n, ids.shape[0])
                    moved = positions_by_level(xb, yb, im, ids, table, count, order[b], level, top, visit, starts,
                                               shock_passes[b], slop[b], percent[b], shift)
                else:
                    moved = correct_positions(xb, yb, im, ids, table, count, slop[b], percent[b], shift)
            if moved:  # a correction that moved nothing leaves the table the next step wants
                ids, table, count, near = find_contacts_near(xb, yb, ab, hxb, hyb, im, margin, near, wide, ids,
                                                             table)
            observe_contacts(xb, yb, ab, hxb, hyb, im, margin, ids, table, count, dt[b], last, peak, reach, touched,
                             launch, b)


@solvers.register("planar-shock")
class PlanarShock(PlanarMemorySolver):
    """Shock propagation: warm-started passes, then a sweep up the pile, supports frozen."""

    Params = PlanarShockParams
    speculative_reach = True  # contacts looked for as far as the fastest box closes (stackx.solvers.planar.reach)

    def __init__(self, params: list[PlanarShockParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.iterations = self.counts("iterations")
        self.carry = self.flags("warm_start")
        self.block = self.flags("block")
        self.relaxation = self.column("relaxation")
        self.speculative = self.column("speculative")
        self.shock_passes = self.counts("shock_passes")
        self.order = np.array([ORDERS[p.order] for p in params], dtype=np.int64)
        self.stage = np.array([STAGES[p.acts_on] for p in params], dtype=np.int64)
        self.corrects, self.slop, self.percent = self.lab_correction()

    @classmethod
    def passes(cls, params: PlanarShockParams) -> int:
        return params.iterations + params.shock_passes

    def step_impulses(self, b: int) -> StepImpulses | None:
        """None where the shock pass acts on velocities: its impulses moved the upper bodies only, so the
        contacts' totals do not give the velocities; otherwise the velocity passes' totals."""
        if self.shock_passes[b] > 0 and self.stage[b] == STAGES["velocities"]:
            return None
        return super().step_impulses(b)

    def advance(self, state: PlanarState, steps: int) -> None:
        s = state
        planar_shock_advance(s.x, s.y, s.angle, s.vx, s.vy, s.w, s.inv_mass, s.inv_inertia, s.hx, s.hy, s.friction,
                             self.gravity, self.dt, self.iterations, self.carry, self.block, self.relaxation,
                             self.speculative, self.shock_passes, self.order, self.stage, self.corrects, self.slop,
                             self.percent, *self.memory(state), *s.monitors(), steps)
