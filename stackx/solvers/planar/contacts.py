"""The stages every planar solver is made of: contact points as per-point arrays, impulses, positions.

A world's contact points live in a **contact table** made by ``contact_workspace``: ``ids`` ``(room, 3)``
int64 with columns ``A``, ``B`` (the two bodies; ``A`` is -1 for the ground) and ``FEATURE`` (which corners
and faces touch, from ``collide``), and ``table`` ``(room, COLUMNS)`` float64 with one named column per
quantity. An impulse ``pn * n + pt * t`` acts on body ``B`` at the point and its opposite on ``A``; the tangent
is ``t = (-ny, nx)`` and the relative velocity at a point is ``(v_B + w_B x r_B) - (v_A + w_A x r_A)``, as in
the reference solver's contact problem. The ground is infinitely heavy and never moves.

Functions, in the order a step uses them:

- ``contact_workspace(room)``: an empty table with room for ``room`` points;
- ``gravity(vy, inv_mass, g, dt)``: ``vy += g * dt`` for every movable body;
- ``find_contacts(...)``: fill the table from ``collide`` (points within ``margin`` of touching), growing it
  when the world has more points than room; returns the (maybe new) table and the count;
- ``find_contacts_near(...)``: the same, keeping the broad phase's candidates from one call to the next
  while the boxes stay within ``LOOSENESS`` of where they were found (``near_workspace`` makes the room);
- ``observed_contacts(...)``: ``find_contacts`` where a step ended, the list serving both the step's monitors
  and the next step (which starts at the same positions): one collision test a step, not one per use;
- ``prepare(...)``: per point the anchors ``r_A``, ``r_B`` (the point minus each centre), the effective normal
  and tangent masses ``k = 1 / (m_A^-1 + m_B^-1 + I_A^-1 (r_A x d)^2 + I_B^-1 (r_B x d)^2)`` for ``d = n, t``
  and the point's friction (``sqrt(mu_A mu_B)``; against the ground the box's own ``mu``); per two-point
  manifold its normal mass matrix (``block_matrix``): what the passes read, found once a step;
- ``anchor_locals(...)``: each point's face plane and touching corner in the frames of the bodies that carry
  them, so a position stage can measure the separation again after the bodies moved and turned (NGS);
- ``relative_velocity(...)``: the relative velocity of a point along a direction;
- ``apply_impulse(...)``: an impulse at a point to both bodies' linear and angular velocities;
- ``set_targets(...)``: the slowest normal velocity each point accepts: ``depth/dt`` (negative) for a point
  still apart, so it may close its gap within the step but not more, and 0 for one touching;
- ``recall(...)`` / ``remember(...)``: warm start: the impulses of the last step's points found again by
  ``(A, B, FEATURE)``, and the impulses of this step kept for the next; ``same_pairs`` tells a step whose
  points are between the same bodies as the last step's, in the same order (its manifolds are the same);
- ``warm_start(...)``: apply the carried impulses before the first iteration;
- ``normal_visit``, ``block_normal``, ``friction_visit``: one point's normal total, the two normal totals of
  a two-point manifold solved together (Box2D 2.x's block solver), or one point's friction total, with
  accumulated clamping: the normal total >= 0, the friction total within ``[-mu pn, mu pn]``;
- ``manifold_order(...)`` (``wavefront``'s): the order a pass visits the manifolds in: table order for every
  body (so the numbers of a table-order sweep), manifolds that share no body side by side so they overlap;
- ``accumulated_iteration(...)``: one Gauss-Seidel pass over the manifolds, normals then friction, each
  normal step optionally over-relaxed;
- ``solve_velocities(...)``: the velocity half of a step with accumulated impulses on the step's points, the
  stages above in order: gravity, anchors and masses, targets, warm start (or none), iterations, remember;
  ``passes.solve_laid`` gives the same numbers from the step's manifolds laid out once in visiting order
  (what ``planar-warm-start`` steps with); the table's passes here are the plain statement it is tested
  against;
- ``integrate_positions(...)``: positions and angles move with the velocities over ``dt``;
- ``separation_push(...)``: one nonlinear Gauss-Seidel pass on positions (Box2D 2.x's position solve): each
  point's separation measured again from where its bodies are now (``anchor_locals``), and the point pushed
  apart at its lever arms, turning the bodies, by ``percent * (depth - slop)``, at most ``max_correction``;
- ``correct_positions(...)``: the lab's position correction carried over: each overlapping point, in table
  order, pushes its bodies apart along its normal by ``percent * max(depth - slop, 0)``, shared by inverse
  masses, translation only, each depth measured after the pushes before it.

Translation only: the lab's correction moves boxes, it does not turn them; a push at the centre keeps the
correction from ever adding a spin the velocity solve did not ask for (a stage that turns boxes by the lever
arm of the point is NGS, ``stackx.solvers.planar.ngs``).
"""

from __future__ import annotations

import numpy as np

from stackx.solvers.correct import correct
from stackx.kernel import inlined, kernel, leaf
from stackx.models.planar.collide import collide, collide_near
from stackx.models.planar.monitor import observe, observe_points
from stackx.models.touch import TOUCH_GAP
from stackx.models.planar.layout import (A, B, COLUMNS, CONDITIONED, DEPTH, FEATURE, K11, K12, K22, KN, KT,  # noqa: F401
                                           LFX, LFY, LNX, LNY, LQX, LQY, MU, NX, NY, PN, PT, PX, PY, RAX, RAY,
                                           RBX, RBY, TARGET)
from stackx.solvers.planar.wavefront import manifold_end, manifold_order

FLIPPED = 64  # collide's features from 64 up: the reference face is on body B
LOOSENESS = 0.05  # m a side the kept candidates' bounds are grown by (Box2D v3's B2_MAX_AABB_MARGIN)
BLOCK_CONDITION = 1000.0  # largest condition (k11^2 / det) a two-point block is solved at (Box2D 2.x's)


@kernel
def contact_workspace(room: int) -> tuple[np.ndarray, np.ndarray]:
    """An empty contact table for ``room`` points: ``(ids, table)``."""
    return np.zeros((room, 3), np.int64), np.zeros((room, COLUMNS))


@leaf
def gravity(vy: np.ndarray, inv_mass: np.ndarray, g: float, dt: float) -> None:
    """``vy += g * dt`` for every movable body (static boxes stay still)."""
    for i in range(vy.shape[0]):
        if inv_mass[i] > 0.0:
            vy[i] += g * dt


@kernel
def find_contacts(x: np.ndarray, y: np.ndarray, angle: np.ndarray, hx: np.ndarray, hy: np.ndarray,
                  inv_mass: np.ndarray, margin: float, ids: np.ndarray,
                  table: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """The world's contact points within ``margin`` of touching: ``(ids, table, count)``; the table is
    replaced by a larger one when the points do not fit."""
    static = inv_mass == 0.0
    while True:
        count = collide(x, y, angle, hx, hy, static, margin, ids[:, A], ids[:, B], table[:, NX:NY + 1],
                        table[:, PX:PY + 1], table[:, DEPTH], ids[:, FEATURE])
        if count <= ids.shape[0]:
            return ids, table, count
        ids, table = contact_workspace(count)


@kernel
def near_workspace(bodies: int) -> tuple[np.ndarray, np.ndarray]:
    """Room for the broad phase's candidates kept between a step's collision tests (``find_contacts_near``):
    ``(near, wide)``, none kept yet."""
    near = np.empty(4 * bodies + 17, np.int64)
    near[0] = -1
    return near, np.empty((bodies, 4))


@kernel
def find_contacts_near(x: np.ndarray, y: np.ndarray, angle: np.ndarray, hx: np.ndarray, hy: np.ndarray,
                       inv_mass: np.ndarray, margin: float, near: np.ndarray, wide: np.ndarray, ids: np.ndarray,
                       table: np.ndarray) -> tuple[np.ndarray, np.ndarray, int, np.ndarray]:
    """``find_contacts``, the same points in the same order, with the broad phase's candidates kept in
    ``near`` and ``wide`` (``near_workspace``) from one call to the next while no box moved out of its
    bounds grown by ``LOOSENESS`` a side (``collide.collide_near``): a pile at rest, tested two or three
    times a step, finds its candidate pairs once. Returns ``(ids, table, count, near)``."""
    static = inv_mass == 0.0
    while True:
        count, near = collide_near(x, y, angle, hx, hy, static, margin, margin + 2.0 * LOOSENESS, near, wide,
                                   ids[:, A], ids[:, B], table[:, NX:NY + 1], table[:, PX:PY + 1],
                                   table[:, DEPTH], ids[:, FEATURE])
        if count <= ids.shape[0]:
            return ids, table, count, near
        ids, table = contact_workspace(count)


@kernel
def observed_contacts(x: np.ndarray, y: np.ndarray, angle: np.ndarray, hx: np.ndarray, hy: np.ndarray,
                      inv_mass: np.ndarray, margin: float, ids: np.ndarray, table: np.ndarray, dt: float,
                      last: np.ndarray, peak: np.ndarray, reach: np.ndarray, touched: np.ndarray,
                      launch: np.ndarray, b: int) -> tuple[np.ndarray, np.ndarray, int]:
    """The contacts where a step ended, found once for two uses: the monitors of row ``b`` for this step
    (``monitor.observe_points``) and the next step, which starts where this one ended (the solver passes
    the table on instead of finding it again). Returns ``find_contacts``'s ``(ids, table, count)``.

    A box counts as touching up to ``TOUCH_GAP`` apart (``stackx.models.touch``). While some movable box has
    not touched anything yet and ``margin`` is narrower than that gap, the solver's list cannot tell, so the
    monitors take the model's own collision test (``monitor.observe``) instead; once every box has touched,
    the one list serves both."""
    ids, table, count = find_contacts(x, y, angle, hx, hy, inv_mass, margin, ids, table)
    observe_contacts(x, y, angle, hx, hy, inv_mass, margin, ids, table, count, dt, last, peak, reach, touched,
                     launch, b)
    return ids, table, count


@kernel
def observe_contacts(x: np.ndarray, y: np.ndarray, angle: np.ndarray, hx: np.ndarray, hy: np.ndarray,
                     inv_mass: np.ndarray, margin: float, ids: np.ndarray, table: np.ndarray, count: int, dt: float,
                     last: np.ndarray, peak: np.ndarray, reach: np.ndarray, touched: np.ndarray,
                     launch: np.ndarray, b: int) -> None:
    """The monitors of row ``b`` for a step that ended where the table's ``count`` points (found within
    ``margin``) were found: ``observed_contacts`` for a caller that already holds that table."""
    if margin < TOUCH_GAP and untouched(touched, inv_mass, b):
        observe(x, y, angle, hx, hy, inv_mass, dt, last, peak, reach, touched, launch, b)
    else:
        observe_points(ids[:, A], ids[:, B], table[:, DEPTH], count, y, hx, hy, inv_mass, dt, last, peak, reach,
                       touched, launch, b)


@leaf
def untouched(touched: np.ndarray, inv_mass: np.ndarray, b: int) -> bool:
    """Whether some movable body of row ``b`` has not touched anything yet."""
    for i in range(inv_mass.shape[0]):
        if inv_mass[i] != 0.0 and not touched[b, i]:
            return True
    return False


@kernel
def effective_mass(ima: float, iia: float, rax: float, ray: float, imb: float, iib: float, rbx: float,
                   rby: float, dx: float, dy: float) -> float:
    """``1 / (d . K d)`` of a point along the unit direction ``d``; 0 when nothing can move."""
    ca = rax * dy - ray * dx
    cb = rbx * dy - rby * dx
    total = ima + imb + iia * ca * ca + iib * cb * cb
    return 1.0 / total if total > 0.0 else 0.0


@leaf
def prepare(x: np.ndarray, y: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, friction: np.ndarray,
            ids: np.ndarray, table: np.ndarray, count: int) -> None:
    """Anchors, effective normal and tangent masses and friction of every point; impulses set to 0."""
    for k in range(count):
        a, b = ids[k, A], ids[k, B]
        nx, ny = table[k, NX], table[k, NY]
        px, py = table[k, PX], table[k, PY]
        rbx, rby = px - x[b], py - y[b]
        if a >= 0:
            rax, ray = px - x[a], py - y[a]
            ima, iia, mu = inv_mass[a], inv_inertia[a], np.sqrt(friction[a] * friction[b])
        else:
            rax, ray, ima, iia, mu = 0.0, 0.0, 0.0, 0.0, friction[b]
        imb, iib = inv_mass[b], inv_inertia[b]
        table[k, RAX], table[k, RAY], table[k, RBX], table[k, RBY] = rax, ray, rbx, rby
        table[k, KN] = effective_mass(ima, iia, rax, ray, imb, iib, rbx, rby, nx, ny)
        table[k, KT] = effective_mass(ima, iia, rax, ray, imb, iib, rbx, rby, -ny, nx)
        table[k, MU] = mu
        table[k, TARGET] = 0.0
        table[k, PN] = 0.0
        table[k, PT] = 0.0
    k = 0
    while k < count:
        if k + 1 < count and ids[k + 1, A] == ids[k, A] and ids[k + 1, B] == ids[k, B]:
            block_matrix(inv_mass, inv_inertia, ids, table, k)
            k += 2
        else:
            k += 1


@leaf
def block_matrix(inv_mass: np.ndarray, inv_inertia: np.ndarray, ids: np.ndarray, table: np.ndarray,
                 k: int) -> None:
    """The normal mass matrix ``K = [[k11, k12], [k12, k22]]`` of the two-point manifold at ``k`` (how much a
    unit normal impulse at one point opens each), into its first row, and whether ``k11^2 < BLOCK_CONDITION
    det K`` (Box2D 2.x's test before it inverts ``K``). It depends on the anchors and masses only, so the
    passes read it instead of finding it again at every visit (Box2D 2.x keeps it in its velocity
    constraint for the same reason)."""
    nx, ny = table[k, NX], table[k, NY]
    j = k + 1
    a, b = ids[k, A], ids[k, B]
    ima, iia = (inv_mass[a], inv_inertia[a]) if a >= 0 else (0.0, 0.0)
    k11, k22 = 1.0 / table[k, KN], 1.0 / table[j, KN]
    ca1, ca2 = table[k, RAX] * ny - table[k, RAY] * nx, table[j, RAX] * ny - table[j, RAY] * nx  # r x n
    cb1, cb2 = table[k, RBX] * ny - table[k, RBY] * nx, table[j, RBX] * ny - table[j, RBY] * nx
    k12 = ima + inv_mass[b] + iia * ca1 * ca2 + inv_inertia[b] * cb1 * cb2
    det = k11 * k22 - k12 * k12
    table[k, K11], table[k, K12], table[k, K22] = k11, k12, k22
    table[k, CONDITIONED] = 1.0 if k11 * k11 < BLOCK_CONDITION * det else 0.0


@leaf
def anchor_locals(x: np.ndarray, y: np.ndarray, angle: np.ndarray, ids: np.ndarray, table: np.ndarray,
                  count: int) -> None:
    """Each point's reference face (normal and a point of its plane) in the frame of the body that owns the
    face, and the touching corner in the frame of the other (the incident body); the ground's frame is the
    world's. The corner sits ``depth/2`` behind the point along the face normal, the plane ``depth/2`` ahead."""
    for k in range(count):
        a, b, feature = ids[k, A], ids[k, B], ids[k, FEATURE]
        nx, ny, d = table[k, NX], table[k, NY], table[k, DEPTH]
        qax, qay = table[k, PX] + 0.5 * d * nx, table[k, PY] + 0.5 * d * ny  # on A's surface
        qbx, qby = table[k, PX] - 0.5 * d * nx, table[k, PY] - 0.5 * d * ny  # on B's surface
        if a >= 0 and feature >= FLIPPED:  # B owns the face, whose normal points from B to A
            r, i, fnx, fny, fx, fy, qx, qy = b, a, -nx, -ny, qbx, qby, qax, qay
        else:
            r, i, fnx, fny, fx, fy, qx, qy = a, b, nx, ny, qax, qay, qbx, qby
        if r >= 0:
            c, s = np.cos(angle[r]), np.sin(angle[r])
            fx, fy = fx - x[r], fy - y[r]
            fnx, fny, fx, fy = c * fnx + s * fny, -s * fnx + c * fny, c * fx + s * fy, -s * fx + c * fy
        c, s = np.cos(angle[i]), np.sin(angle[i])
        qx, qy = qx - x[i], qy - y[i]
        table[k, LNX], table[k, LNY] = fnx, fny
        table[k, LFX], table[k, LFY] = fx, fy
        table[k, LQX], table[k, LQY] = c * qx + s * qy, -s * qx + c * qy


@leaf
def relative_velocity(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, ids: np.ndarray, table: np.ndarray, k: int,
                      dx: float, dy: float) -> float:
    """``((v_B + w_B x r_B) - (v_A + w_A x r_A)) . d`` at point ``k`` (m/s)."""
    b = ids[k, B]
    ux = vx[b] - w[b] * table[k, RBY]
    uy = vy[b] + w[b] * table[k, RBX]
    a = ids[k, A]
    if a >= 0:
        ux -= vx[a] - w[a] * table[k, RAY]
        uy -= vy[a] + w[a] * table[k, RAX]
    return ux * dx + uy * dy


@leaf
def apply_impulse(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
                  ids: np.ndarray, table: np.ndarray, k: int, px: float, py: float) -> None:
    """The impulse ``(px, py)`` at point ``k`` on body B, and its opposite on body A."""
    b = ids[k, B]
    vx[b] += inv_mass[b] * px
    vy[b] += inv_mass[b] * py
    w[b] += inv_inertia[b] * (table[k, RBX] * py - table[k, RBY] * px)
    a = ids[k, A]
    if a >= 0:
        vx[a] -= inv_mass[a] * px
        vy[a] -= inv_mass[a] * py
        w[a] -= inv_inertia[a] * (table[k, RAX] * py - table[k, RAY] * px)


@leaf
def manifold_velocity(vax: float, vay: float, wa: float, vbx: float, vby: float, wb: float, grounded: bool,
                      table: np.ndarray, k: int, dx: float, dy: float) -> float:
    """``relative_velocity`` from a manifold's two body velocities held in locals (``grounded``: A is the
    ground), the same arithmetic in the same order, so the same number: a pass that visits a manifold's points
    one after the other keeps its bodies' velocities in registers instead of reading them back each visit."""
    ux = vbx - wb * table[k, RBY]
    uy = vby + wb * table[k, RBX]
    if not grounded:
        ux -= vax - wa * table[k, RAY]
        uy -= vay + wa * table[k, RAX]
    return ux * dx + uy * dy


@leaf
def manifold_impulse(vax: float, vay: float, wa: float, vbx: float, vby: float, wb: float, grounded: bool,
                     ima: float, iia: float, imb: float, iib: float, table: np.ndarray, k: int, px: float,
                     py: float) -> tuple[float, float, float, float, float, float]:
    """``apply_impulse`` on a manifold's two body velocities held in locals: the six velocities after the
    impulse ``(px, py)`` at point ``k`` on B and its opposite on A (A's unchanged when ``grounded``)."""
    vbx += imb * px
    vby += imb * py
    wb += iib * (table[k, RBX] * py - table[k, RBY] * px)
    if not grounded:
        vax -= ima * px
        vay -= ima * py
        wa -= iia * (table[k, RAX] * py - table[k, RAY] * px)
    return vax, vay, wa, vbx, vby, wb


@leaf
def set_targets(table: np.ndarray, count: int, dt: float) -> None:
    """The slowest normal velocity each point accepts: ``depth/dt`` for a point still apart (a speculative
    point may close its gap within the step, no more), 0 for a touching one (no approach)."""
    for k in range(count):
        d = table[k, DEPTH]
        table[k, TARGET] = d / dt if d < 0.0 else 0.0


@leaf
def recall(ids: np.ndarray, table: np.ndarray, count: int, keys: np.ndarray, carried: np.ndarray,
           held: int) -> None:
    """Warm start values: each point's impulses from the last step's point with the same ``(A, B, FEATURE)``,
    0 for a new point, into the table's ``PN`` and ``PT`` (``recall_impulses``)."""
    recall_impulses(ids, count, keys, carried, held, table[:, PN:PT + 1])


@leaf
def recall_impulses(ids: np.ndarray, count: int, keys: np.ndarray, carried: np.ndarray, held: int,
                    impulses: np.ndarray) -> bool:
    """``recall`` into ``impulses`` ``(room, 2)``: each point's normal and tangent impulses from the last
    step's point with the same ``(A, B, FEATURE)``, 0 for a new point (written: no clearing needed first).
    ``collide`` lists points by ``(A, B)`` in increasing order (the ground's first), and so does the memory,
    so one walk down both lists finds every match. A step lists each ``(A, B, FEATURE)`` once, so a point
    whose key is the memory's at its own place (a pile at rest, the same corners touching) is that match,
    found without the walk. Returns ``same_pairs``, found on the way."""
    same = count == held
    j = 0
    for k in range(count):
        a, b, f = ids[k, A], ids[k, B], ids[k, FEATURE]
        if k < held and keys[k, 0] == a and keys[k, 1] == b:
            if keys[k, 2] == f:
                impulses[k, 0], impulses[k, 1] = carried[k, 0], carried[k, 1]
                continue
        else:
            same = False
        while j < held and (keys[j, 0] < a or (keys[j, 0] == a and keys[j, 1] < b)):
            j += 1
        i = j
        pn, pt = 0.0, 0.0
        while i < held and keys[i, 0] == a and keys[i, 1] == b:
            if keys[i, 2] == f:
                pn, pt = carried[i, 0], carried[i, 1]
                break
            i += 1
        impulses[k, 0], impulses[k, 1] = pn, pt
    return same


@leaf
def same_pairs(ids: np.ndarray, count: int, keys: np.ndarray, held: int) -> bool:
    """Whether the table's ``count`` points are, one by one, between the same two bodies as the memory's
    ``held`` (their features may differ): then the manifolds, and the order of visiting them that
    ``wavefront`` finds from ``A`` and ``B`` alone, are the last step's. A pile at rest keeps its pairs step
    after step, while a box's two corners on the ground may swap places in the list."""
    if count != held:
        return False
    for k in range(count):
        if ids[k, A] != keys[k, 0] or ids[k, B] != keys[k, 1]:
            return False
    return True


@leaf
def remember(ids: np.ndarray, table: np.ndarray, count: int, keys: np.ndarray, carried: np.ndarray) -> int:
    """Keep this step's points and impulses for the next (as many as the memory holds); returns how many."""
    held = min(count, keys.shape[0])
    for k in range(held):
        keys[k, 0], keys[k, 1], keys[k, 2] = ids[k, A], ids[k, B], ids[k, FEATURE]
        carried[k, 0], carried[k, 1] = table[k, PN], table[k, PT]
    return held


@leaf
def warm_start(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
               ids: np.ndarray, table: np.ndarray, count: int) -> None:
    """Apply every point's carried impulses (``PN``, ``PT``) to the velocities."""
    for k in range(count):
        pn, pt = table[k, PN], table[k, PT]
        if pn != 0.0 or pt != 0.0:
            nx, ny = table[k, NX], table[k, NY]
            apply_impulse(vx, vy, w, inv_mass, inv_inertia, ids, table, k, pn * nx - pt * ny, pn * ny + pt * nx)


@leaf
def friction_step(vax: float, vay: float, wa: float, vbx: float, vby: float, wb: float, grounded: bool,
                  ima: float, iia: float, imb: float, iib: float, table: np.ndarray,
                  k: int) -> tuple[float, float, float, float, float, float]:
    """Point ``k``'s tangent total moved towards stopping its sliding, kept within ``mu`` times its normal
    total so far: a point never holds more sideways than it is pressed. On a manifold's two body velocities
    held in locals (``manifold_velocity``); returns them after the visit."""
    nx, ny = table[k, NX], table[k, NY]
    limit = table[k, MU] * table[k, PN]
    old = table[k, PT]
    total = old - table[k, KT] * manifold_velocity(vax, vay, wa, vbx, vby, wb, grounded, table, k, -ny, nx)
    total = min(max(total, -limit), limit)
    if total != old:
        step = total - old
        table[k, PT] = total
        return manifold_impulse(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb, iib, table, k, -step * ny,
                                step * nx)
    return vax, vay, wa, vbx, vby, wb


@leaf
def normal_step(vax: float, vay: float, wa: float, vbx: float, vby: float, wb: float, grounded: bool,
                ima: float, iia: float, imb: float, iib: float, table: np.ndarray, k: int,
                relaxation: float) -> tuple[float, float, float, float, float, float]:
    """Point ``k``'s normal total moved to meet its target (times ``relaxation``), kept >= 0: the increment
    may be negative (an earlier visit pushed too hard), only the total may not pull. On a manifold's two body
    velocities held in locals; returns them after the visit."""
    nx, ny = table[k, NX], table[k, NY]
    old = table[k, PN]
    gap = table[k, TARGET] - manifold_velocity(vax, vay, wa, vbx, vby, wb, grounded, table, k, nx, ny)
    total = max(old + relaxation * table[k, KN] * gap, 0.0)
    if total != old:
        step = total - old
        table[k, PN] = total
        return manifold_impulse(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb, iib, table, k, step * nx,
                                step * ny)
    return vax, vay, wa, vbx, vby, wb


@leaf
def friction_visit(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
                   ids: np.ndarray, table: np.ndarray, k: int) -> None:
    """``friction_step`` on the bodies' velocity arrays."""
    a, b = ids[k, A], ids[k, B]
    grounded = a < 0
    vax, vay, wa, ima, iia = 0.0, 0.0, 0.0, 0.0, 0.0
    if not grounded:
        vax, vay, wa, ima, iia = vx[a], vy[a], w[a], inv_mass[a], inv_inertia[a]
    vax, vay, wa, vx[b], vy[b], w[b] = friction_step(vax, vay, wa, vx[b], vy[b], w[b], grounded, ima, iia,
                                                     inv_mass[b], inv_inertia[b], table, k)
    if not grounded:
        vx[a], vy[a], w[a] = vax, vay, wa


@leaf
def normal_visit(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
                 ids: np.ndarray, table: np.ndarray, k: int, relaxation: float) -> None:
    """``normal_step`` on the bodies' velocity arrays."""
    a, b = ids[k, A], ids[k, B]
    grounded = a < 0
    vax, vay, wa, ima, iia = 0.0, 0.0, 0.0, 0.0, 0.0
    if not grounded:
        vax, vay, wa, ima, iia = vx[a], vy[a], w[a], inv_mass[a], inv_inertia[a]
    vax, vay, wa, vx[b], vy[b], w[b] = normal_step(vax, vay, wa, vx[b], vy[b], w[b], grounded, ima, iia,
                                                   inv_mass[b], inv_inertia[b], table, k, relaxation)
    if not grounded:
        vx[a], vy[a], w[a] = vax, vay, wa


@kernel
def two_point_lcp(k11: float, k12: float, k22: float, b1: float, b2: float, pair: bool) -> tuple[float, float, bool]:
    """The two-point complementarity problem ``x >= 0``, ``K x + b >= 0``, ``x . (K x + b) = 0`` with
    ``K = [[k11, k12], [k12, k22]]`` (how much a unit impulse at one point opens each): its four candidate
    answers in order, both pressing (only when ``pair``, i.e. ``K`` is safely invertible), the first alone,
    the second alone, neither; the first that meets every condition, and True. (0, 0, False) when none does,
    which happens only in rounding (Box2D 2.x's block solver takes the same four cases)."""
    if pair:
        det = k11 * k22 - k12 * k12
        x1 = (k12 * b2 - k22 * b1) / det
        x2 = (k12 * b1 - k11 * b2) / det
        if x1 >= 0.0 and x2 >= 0.0:
            return x1, x2, True
    x1 = -b1 / k11
    if x1 >= 0.0 and k12 * x1 + b2 >= 0.0:
        return x1, 0.0, True
    x2 = -b2 / k22
    if x2 >= 0.0 and k12 * x2 + b1 >= 0.0:
        return 0.0, x2, True
    if b1 >= 0.0 and b2 >= 0.0:
        return 0.0, 0.0, True
    return 0.0, 0.0, False


@inlined
def block_step(vax: float, vay: float, wa: float, vbx: float, vby: float, wb: float, grounded: bool,
               ima: float, iia: float, imb: float, iib: float, table: np.ndarray, k: int,
               relaxation: float) -> tuple[bool, float, float, float, float, float, float]:
    """The normal totals of points ``k`` and ``k + 1`` (one manifold: same bodies, same normal) solved together.

    The two points' complementarity problem (``two_point_lcp``, ``K`` the 2 x 2 normal mass matrix) is solved
    for the totals, and the change from the current totals is applied.
    A box resting flat then has its load shared by both corners as the exact solve shares it, where visiting
    the corners one after the other lets the first take too much and the box rock. With ``relaxation`` w the
    totals move ``w`` times the way to that answer (kept >= 0). On a manifold's two body velocities held in
    locals: returns whether it was solved, and the velocities after. Not solved (nothing done) when ``K`` is
    too ill-conditioned to invert (the two points nearly on one line through the bodies' lever arms) or no
    case fits in rounding; the caller then visits the points one by one.
    """
    if table[k, CONDITIONED] == 0.0:
        return False, vax, vay, wa, vbx, vby, wb
    nx, ny = table[k, NX], table[k, NY]
    j = k + 1
    k11, k12, k22 = table[k, K11], table[k, K12], table[k, K22]  # from prepare (block_matrix)
    a1, a2 = table[k, PN], table[j, PN]
    b1 = manifold_velocity(vax, vay, wa, vbx, vby, wb, grounded, table, k, nx, ny) - table[k, TARGET] - (
        k11 * a1 + k12 * a2)
    b2 = manifold_velocity(vax, vay, wa, vbx, vby, wb, grounded, table, j, nx, ny) - table[j, TARGET] - (
        k12 * a1 + k22 * a2)
    x1, x2, found = two_point_lcp(k11, k12, k22, b1, b2, True)
    if not found:
        return False, vax, vay, wa, vbx, vby, wb
    x1, x2 = max(a1 + relaxation * (x1 - a1), 0.0), max(a2 + relaxation * (x2 - a2), 0.0)
    d1, d2 = x1 - a1, x2 - a2
    vax, vay, wa, vbx, vby, wb = manifold_impulse(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb, iib, table,
                                                  k, d1 * nx, d1 * ny)
    vax, vay, wa, vbx, vby, wb = manifold_impulse(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb, iib, table,
                                                  j, d2 * nx, d2 * ny)
    table[k, PN], table[j, PN] = x1, x2
    return True, vax, vay, wa, vbx, vby, wb


@leaf
def block_normal(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
                 ids: np.ndarray, table: np.ndarray, k: int, relaxation: float) -> bool:
    """``block_step`` on the bodies' velocity arrays: whether it was solved."""
    a, b = ids[k, A], ids[k, B]
    grounded = a < 0
    vax, vay, wa, ima, iia = 0.0, 0.0, 0.0, 0.0, 0.0
    if not grounded:
        vax, vay, wa, ima, iia = vx[a], vy[a], w[a], inv_mass[a], inv_inertia[a]
    solved, vax, vay, wa, vx[b], vy[b], w[b] = block_step(vax, vay, wa, vx[b], vy[b], w[b], grounded, ima, iia,
                                                          inv_mass[b], inv_inertia[b], table, k, relaxation)
    if not grounded:
        vx[a], vy[a], w[a] = vax, vay, wa
    return solved


@leaf
def accumulated_iteration(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray,
                          inv_inertia: np.ndarray, ids: np.ndarray, table: np.ndarray, count: int,
                          order: np.ndarray, block: bool, relaxation: float) -> None:
    """One Gauss-Seidel pass over the manifolds (a manifold: the one or two consecutive points of the same
    two bodies), visited in ``order`` (``manifold_order``: table order for every body, the same numbers as a
    table-order sweep) with accumulated clamping: the normals first, both at once (``block_normal``) when
    ``block`` and there are two, else point by point; then each point's friction, bounded by the normal total
    just found (Box2D v3's order), so after every visit ``pn >= 0`` and ``|pt| <= mu pn`` hold.

    ``relaxation`` w scales each normal step (successive over-relaxation, 0 < w < 2). Plain Gauss-Seidel
    (w = 1) moves a load one contact per pass against the sweep, and the bending of a tall stack, the slowest
    of its modes, needs passes growing with the square of its height; w near 2 shortens that to about the
    height. The price: a lone contact's error then shrinks only by ``|1 - w|`` per pass instead of vanishing
    in one, so a fresh impact is resolved over more passes (warm starting carries the rest into the next step).
    """
    for m in range(order.shape[0]):
        k = order[m]
        end = manifold_end(ids, k, count)
        a, b = ids[k, A], ids[k, B]
        grounded = a < 0  # the manifold's two bodies' velocities held in locals over its points
        vax, vay, wa, ima, iia = 0.0, 0.0, 0.0, 0.0, 0.0
        if not grounded:
            vax, vay, wa, ima, iia = vx[a], vy[a], w[a], inv_mass[a], inv_inertia[a]
        vbx, vby, wb, imb, iib = vx[b], vy[b], w[b], inv_mass[b], inv_inertia[b]
        solved = False
        if block and end - k == 2:
            solved, vax, vay, wa, vbx, vby, wb = block_step(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb,
                                                            iib, table, k, relaxation)
        if not solved:
            for i in range(k, end):
                vax, vay, wa, vbx, vby, wb = normal_step(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb, iib,
                                                         table, i, relaxation)
        for i in range(k, end):
            vax, vay, wa, vbx, vby, wb = friction_step(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb, iib,
                                                       table, i)
        if not grounded:
            vx[a], vy[a], w[a] = vax, vay, wa
        vx[b], vy[b], w[b] = vbx, vby, wb


@kernel
def solve_velocities(x: np.ndarray, y: np.ndarray, vx: np.ndarray, vy: np.ndarray, w: np.ndarray,
                     inv_mass: np.ndarray, inv_inertia: np.ndarray, friction: np.ndarray, g: float, dt: float,
                     carry: bool, iterations: int, block: bool, relaxation: float, ids: np.ndarray,
                     table: np.ndarray, count: int, keys: np.ndarray, carried: np.ndarray, held: int) -> int:
    """The velocity half of a step with accumulated impulses, on the step's contact points (the first
    ``count`` of the table, found within the solver's speculative margin where the step starts): gravity;
    the points' anchors, masses and targets; the last step's impulses found again and applied (``carry``;
    otherwise every point starts from zero); ``iterations`` passes (two-point manifolds' normals together
    when ``block``); this step's impulses kept.
    ``relaxation`` scales every normal step (1: plain Gauss-Seidel; see ``accumulated_iteration``).
    Returns how many points the memory now holds."""
    gravity(vy, inv_mass, g, dt)
    prepare(x, y, inv_mass, inv_inertia, friction, ids, table, count)
    set_targets(table, count, dt)
    if carry:
        recall(ids, table, count, keys, carried, held)
        warm_start(vx, vy, w, inv_mass, inv_inertia, ids, table, count)
    order = manifold_order(ids, count, vx.shape[0])
    for _ in range(iterations):
        accumulated_iteration(vx, vy, w, inv_mass, inv_inertia, ids, table, count, order, block, relaxation)
    return remember(ids, table, count, keys, carried)


@leaf
def integrate_positions(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                        w: np.ndarray, dt: float) -> None:
    """Move every body with its velocities over ``dt`` (static bodies have none)."""
    for i in range(x.shape[0]):
        x[i] += vx[i] * dt
        y[i] += vy[i] * dt
        angle[i] += w[i] * dt


@leaf
def correct_positions(x: np.ndarray, y: np.ndarray, inv_mass: np.ndarray, ids: np.ndarray, table: np.ndarray,
                      count: int, slop: float, percent: float, shift: np.ndarray) -> bool:
    """The lab's correction on the touching points of the table (found after the positions moved), in table
    order; returns whether it moved any body.

    Points still apart (depth < 0, in a table found within a speculative margin) are passed over: the
    touching points of such a table are, in the same order, the table found with no margin, so a solver
    whose next step wants the speculative table finds it once and, when nothing was moved, keeps it.

    Each point's depth is the table's less what the pushes before it have already opened along its normal
    (``shift``, ``(bodies, 2)`` scratch: how far each body was pushed in this stage), which is exact for pushes
    that only translate. ``correct`` gives the two moves (split by inverse mass; none within slop).
    """
    shift[:, :] = 0.0
    moved = False
    for k in range(count):
        if table[k, DEPTH] < 0.0:
            continue
        a = ids[k, A]
        pushed = correct_point(x, y, ids, table, k, inv_mass[a] if a >= 0 else 0.0, inv_mass[ids[k, B]], slop,
                               percent, shift)
        moved = moved or pushed
    return moved


@leaf
def correct_point(x: np.ndarray, y: np.ndarray, ids: np.ndarray, table: np.ndarray, k: int, ima: float,
                  imb: float, slop: float, percent: float, shift: np.ndarray) -> bool:
    """Point ``k``'s share of the lab's correction, its bodies' inverse masses given (0 holds a side still):
    its depth less what the pushes before it opened along its normal (``shift``), split by ``correct``,
    applied to the positions and to ``shift``; returns whether it moved a body."""
    a, b = ids[k, A], ids[k, B]
    nx, ny = table[k, NX], table[k, NY]
    opened = shift[b, 0] * nx + shift[b, 1] * ny
    if a >= 0:
        opened -= shift[a, 0] * nx + shift[a, 1] * ny
    down, up = correct(table[k, DEPTH] - opened, slop, percent, ima, imb)
    if down != 0.0:
        x[a] -= down * nx
        y[a] -= down * ny
        shift[a, 0] -= down * nx
        shift[a, 1] -= down * ny
    if up != 0.0:
        x[b] += up * nx
        y[b] += up * ny
        shift[b, 0] += up * nx
        shift[b, 1] += up * ny
    return down != 0.0 or up != 0.0


@leaf
def separation_push(x: np.ndarray, y: np.ndarray, angle: np.ndarray, inv_mass: np.ndarray,
                    inv_inertia: np.ndarray, ids: np.ndarray, table: np.ndarray, count: int, slop: float,
                    percent: float, max_correction: float) -> float:
    """One pass over the points in table order, pushing each apart where it is now; returns the deepest
    depth the pass measured.

    A point's face plane and corner (``anchor_locals``) are carried by their bodies, so the depth is measured
    from the current positions and angles, rotation included, after every push before it. The push
    ``percent * (depth - slop)``, at most ``max_correction``, is a position impulse along the face normal at
    the middle of corner and plane, shared by the bodies' inverse mass and inertia (the point's effective
    mass for the current lever arms): a box tilted into its support is turned back, which a push at the
    centre cannot do.
    """
    deepest = -np.inf
    for k in range(count):
        a, b = ids[k, A], ids[k, B]
        if a >= 0 and ids[k, FEATURE] >= FLIPPED:
            r, i = b, a
        else:
            r, i = a, b
        fnx, fny, fx, fy = table[k, LNX], table[k, LNY], table[k, LFX], table[k, LFY]
        imr, iir = 0.0, 0.0
        if r >= 0:
            c, s = np.cos(angle[r]), np.sin(angle[r])
            fnx, fny = c * fnx - s * fny, s * fnx + c * fny
            fx, fy = x[r] + c * fx - s * fy, y[r] + s * fx + c * fy
            imr, iir = inv_mass[r], inv_inertia[r]
        c, s = np.cos(angle[i]), np.sin(angle[i])
        qx = x[i] + c * table[k, LQX] - s * table[k, LQY]
        qy = y[i] + s * table[k, LQX] + c * table[k, LQY]
        depth = -((qx - fx) * fnx + (qy - fy) * fny)
        deepest = max(deepest, depth)
        move = min(percent * (depth - slop), max_correction)
        if move <= 0.0:
            continue
        px, py = 0.5 * (qx + fx), 0.5 * (qy + fy)
        rix, riy = px - x[i], py - y[i]
        ci = rix * fny - riy * fnx
        total = inv_mass[i] + inv_inertia[i] * ci * ci
        cr = 0.0
        if r >= 0:
            rrx, rry = px - x[r], py - y[r]
            cr = rrx * fny - rry * fnx
            total += imr + iir * cr * cr
        if total <= 0.0:
            continue
        p = move / total
        x[i] += inv_mass[i] * p * fnx
        y[i] += inv_mass[i] * p * fny
        angle[i] += inv_inertia[i] * p * ci
        if r >= 0:
            x[r] -= imr * p * fnx
            y[r] -= imr * p * fny
            angle[r] -= iir * p * cr
    return deepest
