"""Velocity passes on a step's contacts laid out in the order they visit them: accumulated impulses
(``planar-warm-start``) and the lab's per-visit impulses (``planar-pgs``).

``contacts.accumulated_iteration`` reads each point from the generic contact table: a row of 25 numbers
(200 bytes) of which a visit needs about half, rows reached in the wave order (``wavefront``) and so not one
after the other, and the bodies' velocities and masses from five arrays, with a test for the ground at every
visit. Box2D v3.1 does this work once a step instead (``contact_solver.c``, ``b2PrepareContactsTask``): per
manifold its normal, friction and per point the anchors relative to the centres, the normal and tangent
effective masses and the warm-start impulses, copied "to avoid cache misses during sub-stepping", the bodies'
velocities in one compact array and a static body read as an identity state. ``lay_out`` does the same:

- one row per manifold, in visiting order, with all its visits read and nothing else: the normal and
  friction, the 2 x 2 normal mass matrix of a two-point manifold and whether it is solved as a block, and
  per point its anchors, normal and tangent masses, target velocity, depth and impulses (``ROW_COLUMNS``);
- the bodies' velocities and inverse masses in one row each (``bodies``), the ground a row of zeros read as
  a body (its zeros enter the sums as ``u - 0.0``, which is ``u``, the numbers of skipping it) and a last
  row that a manifold on the ground writes its ground side to and nothing reads, so no visit tests for the
  ground.

A pass then visits the manifolds group by group (``visiting_order``). The odd groups are waves (``wavefront``:
manifolds that share no body): every manifold's normals (both at once for a two-point block), then every
first friction, then every second one; each manifold's visits keep their order and a wave's manifolds commute
exactly, while the processor overlaps a wave's visits, none of which waits for the one before it. The even
groups hold the manifolds whose points were all apart and held nothing when the step began (a brick wall's
side joints within the speculative margin: a third of its manifolds), each visited on its own between the
waves. Every body meets its manifolds in table order, so a pass gives the velocities and impulses of
``accumulated_iteration`` over the table in table order, to the bit. The lab's pass (``laid_pass`` with
``lab``) reads the same rows: each point's normal then its friction, a wave's first points then its second
ones, the numbers of the lab's visits (``pgs``) over the table from top to bottom.

Work is left out only where it cannot change a bit: a manifold apart whose visit would change nothing is
found so without writing anything (``stays_apart``: two points separating and no impulse held, so its block
keeps +0.0 and pushes zeros, and its frictions are bounded by zero); a block whose solve gives both points
what they had pushes zero impulses, which add a signed zero to each velocity and so change none that is
not zero itself (done anyway when one is); a manifold of that group that holds no impulse after its normals
has friction visits clamped to ``[-0, 0]`` that would change nothing (``idle``). On a pile at rest a pass
costs about 13 ns a point (``python3 -m benchmarks.planar``, a 20-row pyramid), against about 18 for the
table's pass, and the lab's about 8 against 13; a side joint passed over costs about a fifth of a resting
manifold's visit.
"""

from __future__ import annotations

import math

import numpy as np

from stackx.kernel import inlined, kernel, leaf
from stackx.models.planar.layout import A, B, DEPTH, FEATURE, NX, NY, PN, PT, PX, PY
from stackx.solvers.planar.contacts import BLOCK_CONDITION, effective_mass, gravity, recall, two_point_lcp
from stackx.solvers.planar.wavefront import manifold_starts, sort_by_group

# a manifold's row: its normal, friction (one for both points: the same two bodies), normal mass matrix and
# its determinant, whether the block is solved (1.0) or its points visited one by one (0.0), whether its
# anchors, tangent masses and friction are moderate (``MODERATE``) and whether it is a block of two points
# apart (``stays_apart``); then each point's anchors on A and B, normal and tangent effective masses, target
# normal velocity, depth (for the lab's visits, which pass over a point not overlapping) and impulses
M_NX, M_NY, M_MU, M_K11, M_K12, M_K22, M_DET, M_BLOCK, M_MODERATE, M_OPEN = range(10)
Q_RAX, Q_RAY, Q_RBX, Q_RBY, Q_KN, Q_KT, Q_TARGET, Q_DEPTH, Q_PN, Q_PT = range(10)
FIRST, SECOND = 10, 20  # where each point's columns begin
ROW_COLUMNS = 30
MODERATE = 1e100  # velocities, anchors, masses and friction below this cannot overflow a visit's sums
# a manifold's ints: the body A is read from (the ground's row for the ground) and written to (the sink row
# for the ground), its body B, its first table row and its number of points
L_A, L_SINK, L_B, L_ROW, L_POINTS = range(5)
# a body's row: velocities, inverse mass and inertia
V_X, V_Y, V_W, INV_M, INV_I = range(5)


@kernel
def laid_workspace(room: int, bodies: int) -> tuple[np.ndarray, ...]:
    """Room for the layout of ``room`` points of ``bodies`` bodies: ``(first, order, group, tally, latest,
    links, rows, velocities)``; the bodies' rows are ``bodies + 2`` (the ground's, the sink)."""
    return (np.empty(room + 1, np.int64), np.empty(room, np.int64), np.empty(room, np.int64),
            np.empty(2 * room + 2, np.int64), np.empty(bodies, np.int64), np.empty((room, 5), np.uint64),
            np.empty((room, ROW_COLUMNS)), np.zeros((bodies + 2, 5)))


@leaf
def lay_out(x: np.ndarray, y: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, friction: np.ndarray,
            ids: np.ndarray, table: np.ndarray, first: np.ndarray, order: np.ndarray, m: int, dt: float,
            block: bool, links: np.ndarray, rows: np.ndarray) -> None:
    """The rows of the ``m`` manifolds (``first``: where each begins, ``order``: the visiting order from
    ``visiting_order``), with what ``contacts.prepare``, ``block_matrix`` and ``set_targets`` find (the same
    arithmetic) and the impulses the table holds (``recall``'s, or zeros). ``block``: whether a two-point
    manifold's normals may be solved together."""
    ground = x.shape[0]
    for j in range(m):
        k = first[order[j]]
        points = first[order[j] + 1] - k
        a, b = ids[k, A], ids[k, B]
        imb, iib = inv_mass[b], inv_inertia[b]
        if a >= 0:
            ima, iia, mu = inv_mass[a], inv_inertia[a], np.sqrt(friction[a] * friction[b])
        else:
            ima, iia, mu = 0.0, 0.0, friction[b]
        links[j, L_A], links[j, L_SINK] = (a, a) if a >= 0 else (ground, ground + 1)
        links[j, L_B], links[j, L_ROW], links[j, L_POINTS] = b, k, points
        nx, ny = table[k, NX], table[k, NY]
        rows[j, M_NX], rows[j, M_NY], rows[j, M_MU] = nx, ny, mu
        moderate = mu < MODERATE
        for q in range(points):
            c = FIRST if q == 0 else SECOND
            i = k + q
            px, py = table[i, PX], table[i, PY]
            rbx, rby = px - x[b], py - y[b]
            rax, ray = (px - x[a], py - y[a]) if a >= 0 else (0.0, 0.0)
            rows[j, c + Q_RAX], rows[j, c + Q_RAY], rows[j, c + Q_RBX], rows[j, c + Q_RBY] = rax, ray, rbx, rby
            rows[j, c + Q_KN] = effective_mass(ima, iia, rax, ray, imb, iib, rbx, rby, nx, ny)
            rows[j, c + Q_KT] = effective_mass(ima, iia, rax, ray, imb, iib, rbx, rby, -ny, nx)
            d = table[i, DEPTH]
            rows[j, c + Q_TARGET] = d / dt if d < 0.0 else 0.0
            rows[j, c + Q_DEPTH] = d
            rows[j, c + Q_PN], rows[j, c + Q_PT] = table[i, PN], table[i, PT]
            moderate = moderate and max(abs(rax), abs(ray), abs(rbx), abs(rby), rows[j, c + Q_KT]) < MODERATE
        if points == 1:  # no second point: nothing it holds
            rows[j, SECOND + Q_PN], rows[j, SECOND + Q_PT] = 0.0, 0.0
        rows[j, M_MODERATE] = 1.0 if moderate else 0.0
        rows[j, M_BLOCK] = 0.0
        if points == 2:
            k11, k22 = 1.0 / rows[j, FIRST + Q_KN], 1.0 / rows[j, SECOND + Q_KN]
            ca1 = rows[j, FIRST + Q_RAX] * ny - rows[j, FIRST + Q_RAY] * nx  # r x n
            ca2 = rows[j, SECOND + Q_RAX] * ny - rows[j, SECOND + Q_RAY] * nx
            cb1 = rows[j, FIRST + Q_RBX] * ny - rows[j, FIRST + Q_RBY] * nx
            cb2 = rows[j, SECOND + Q_RBX] * ny - rows[j, SECOND + Q_RBY] * nx
            k12 = ima + imb + iia * ca1 * ca2 + iib * cb1 * cb2
            det = k11 * k22 - k12 * k12
            rows[j, M_K11], rows[j, M_K12], rows[j, M_K22], rows[j, M_DET] = k11, k12, k22, det
            if block and k11 * k11 < BLOCK_CONDITION * det:
                rows[j, M_BLOCK] = 1.0
        rows[j, M_OPEN] = 1.0 if (rows[j, M_BLOCK] != 0.0 and moderate and rows[j, FIRST + Q_TARGET] < 0.0
                                  and rows[j, SECOND + Q_TARGET] < 0.0) else 0.0


@leaf
def load_velocities(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray,
                    inv_inertia: np.ndarray, bodies: np.ndarray) -> None:
    """The bodies' rows from the state; the ground's row (``n``) stays all zeros."""
    for i in range(vx.shape[0]):
        bodies[i, V_X], bodies[i, V_Y], bodies[i, V_W] = vx[i], vy[i], w[i]
        bodies[i, INV_M], bodies[i, INV_I] = inv_mass[i], inv_inertia[i]


@leaf
def give_velocities(bodies: np.ndarray, vx: np.ndarray, vy: np.ndarray, w: np.ndarray) -> None:
    """The velocities the passes leave, back to the state."""
    for i in range(vx.shape[0]):
        vx[i], vy[i], w[i] = bodies[i, V_X], bodies[i, V_Y], bodies[i, V_W]


@leaf
def along(vax: float, vay: float, wa: float, vbx: float, vby: float, wb: float, rows: np.ndarray, j: int,
          c: int, dx: float, dy: float) -> float:
    """``contacts.manifold_velocity`` at the point whose columns begin at ``c`` of row ``j``: the same
    arithmetic in the same order (A's part subtracted even for the ground, whose zeros leave ``u`` as is)."""
    ux = vbx - wb * rows[j, c + Q_RBY]
    uy = vby + wb * rows[j, c + Q_RBX]
    ux -= vax - wa * rows[j, c + Q_RAY]
    uy -= vay + wa * rows[j, c + Q_RAX]
    return ux * dx + uy * dy


@leaf
def push(vax: float, vay: float, wa: float, vbx: float, vby: float, wb: float, ima: float, iia: float, imb: float,
         iib: float, rows: np.ndarray, j: int, c: int, px: float,
         py: float) -> tuple[float, float, float, float, float, float]:
    """``contacts.manifold_impulse`` at the point whose columns begin at ``c`` of row ``j``: the impulse
    ``(px, py)`` on B and its opposite on A (on the ground it lands in the sink)."""
    vbx += imb * px
    vby += imb * py
    wb += iib * (rows[j, c + Q_RBX] * py - rows[j, c + Q_RBY] * px)
    vax -= ima * px
    vay -= ima * py
    wa -= iia * (rows[j, c + Q_RAX] * py - rows[j, c + Q_RAY] * px)
    return vax, vay, wa, vbx, vby, wb


@leaf
def laid_warm_start(bodies: np.ndarray, links: np.ndarray, rows: np.ndarray, m: int) -> None:
    """``contacts.warm_start`` on the layout: every point's impulses applied to its bodies, manifold by
    manifold in visiting order, which keeps each body's order of points and so gives the same sums."""
    for j in range(np.uint64(m)):
        a, sink, b = links[j, L_A], links[j, L_SINK], links[j, L_B]
        nx, ny = rows[j, M_NX], rows[j, M_NY]
        for q in range(np.int64(links[j, L_POINTS])):
            c = FIRST if q == 0 else SECOND
            pn, pt = rows[j, c + Q_PN], rows[j, c + Q_PT]
            if pn != 0.0 or pt != 0.0:
                px, py = pn * nx - pt * ny, pn * ny + pt * nx
                (bodies[sink, V_X], bodies[sink, V_Y], bodies[sink, V_W], bodies[b, V_X], bodies[b, V_Y],
                 bodies[b, V_W]) = push(bodies[a, V_X], bodies[a, V_Y], bodies[a, V_W], bodies[b, V_X],
                                        bodies[b, V_Y], bodies[b, V_W], bodies[a, INV_M], bodies[a, INV_I],
                                        bodies[b, INV_M], bodies[b, INV_I], rows, j, c, px, py)


@inlined
def laid_normals(bodies: np.ndarray, links: np.ndarray, rows: np.ndarray, j: int, relaxation: float) -> None:
    """Manifold ``j``'s normal totals: both at once where its row says block (``contacts.block_step``), else
    point by point (``contacts.normal_step``), the same arithmetic; kept >= 0."""
    a, sink, b = links[j, L_A], links[j, L_SINK], links[j, L_B]
    vax, vay, wa, ima, iia = bodies[a, V_X], bodies[a, V_Y], bodies[a, V_W], bodies[a, INV_M], bodies[a, INV_I]
    vbx, vby, wb, imb, iib = bodies[b, V_X], bodies[b, V_Y], bodies[b, V_W], bodies[b, INV_M], bodies[b, INV_I]
    nx, ny = rows[j, M_NX], rows[j, M_NY]
    solved = False
    if rows[j, M_BLOCK] != 0.0:
        k11, k12, k22 = rows[j, M_K11], rows[j, M_K12], rows[j, M_K22]
        a1, a2 = rows[j, FIRST + Q_PN], rows[j, SECOND + Q_PN]
        b1 = along(vax, vay, wa, vbx, vby, wb, rows, j, FIRST, nx, ny) - rows[j, FIRST + Q_TARGET] - (
            k11 * a1 + k12 * a2)
        b2 = along(vax, vay, wa, vbx, vby, wb, rows, j, SECOND, nx, ny) - rows[j, SECOND + Q_TARGET] - (
            k12 * a1 + k22 * a2)
        x1, x2, solved = two_point_lcp(k11, k12, k22, b1, b2, True)
        if solved:
            x1, x2 = max(a1 + relaxation * (x1 - a1), 0.0), max(a2 + relaxation * (x2 - a2), 0.0)
            d1, d2 = x1 - a1, x2 - a2
            # pushes of zero add a signed zero to each velocity, which changes none that is not zero itself
            if d1 != 0.0 or d2 != 0.0 or not (vax != 0.0 and vay != 0.0 and wa != 0.0 and vbx != 0.0
                                              and vby != 0.0 and wb != 0.0):
                vax, vay, wa, vbx, vby, wb = push(vax, vay, wa, vbx, vby, wb, ima, iia, imb, iib, rows, j, FIRST,
                                                  d1 * nx, d1 * ny)
                vax, vay, wa, vbx, vby, wb = push(vax, vay, wa, vbx, vby, wb, ima, iia, imb, iib, rows, j, SECOND,
                                                  d2 * nx, d2 * ny)
            rows[j, FIRST + Q_PN], rows[j, SECOND + Q_PN] = x1, x2
    if not solved:
        for q in range(np.int64(links[j, L_POINTS])):
            c = FIRST if q == 0 else SECOND
            old = rows[j, c + Q_PN]
            gap = rows[j, c + Q_TARGET] - along(vax, vay, wa, vbx, vby, wb, rows, j, c, nx, ny)
            total = max(old + relaxation * rows[j, c + Q_KN] * gap, 0.0)
            if total != old:
                step = total - old
                rows[j, c + Q_PN] = total
                vax, vay, wa, vbx, vby, wb = push(vax, vay, wa, vbx, vby, wb, ima, iia, imb, iib, rows, j, c,
                                                  step * nx, step * ny)
    bodies[sink, V_X], bodies[sink, V_Y], bodies[sink, V_W] = vax, vay, wa
    bodies[b, V_X], bodies[b, V_Y], bodies[b, V_W] = vbx, vby, wb


@leaf
def apart(k11: float, k12: float, k22: float, det: float, b1: float, b2: float) -> bool:
    """Whether the first answer of ``contacts.two_point_lcp`` (both points pressing, ``(N1, N2) / det`` with
    ``det > 0`` for a block) fails, found without its divisions: it does when a numerator is negative by more
    than ``det`` times the smallest normal number, so that the quotient is negative and not a zero. False
    where that is not sure."""
    margin = det * 1e-300
    return k12 * b2 - k22 * b1 < -margin or k12 * b1 - k11 * b2 < -margin


@inlined
def stays_apart(bodies: np.ndarray, links: np.ndarray, rows: np.ndarray, j: int) -> bool:
    """Whether the visit of manifold ``j`` (a block of two points apart, ``M_OPEN``) would change nothing,
    decided without most of its work and without writing: so when it holds nothing (both totals +0.0, no
    friction), both points separate (``b1, b2 > 0`` as ``contacts.block_step`` finds them) and the first
    answer fails (``apart``). Every other answer of ``two_point_lcp`` is then a zero, and relaxing from +0.0
    gives +0.0, so the block keeps its totals and pushes zeros, which change no velocity that is not zero
    (all six are checked), and its frictions are bounded by zero (``idle``: the velocities checked
    moderate)."""
    a1, a2 = rows[j, FIRST + Q_PN], rows[j, SECOND + Q_PN]
    if a1 != 0.0 or a2 != 0.0 or rows[j, FIRST + Q_PT] != 0.0 or rows[j, SECOND + Q_PT] != 0.0:
        return False
    if math.copysign(1.0, a1) < 0.0 or math.copysign(1.0, a2) < 0.0:
        return False
    a, b = links[j, L_A], links[j, L_B]
    vax, vay, wa = bodies[a, V_X], bodies[a, V_Y], bodies[a, V_W]
    vbx, vby, wb = bodies[b, V_X], bodies[b, V_Y], bodies[b, V_W]
    speeds = abs(vax), abs(vay), abs(wa), abs(vbx), abs(vby), abs(wb)
    if not (min(speeds) > 0.0 and max(speeds) < MODERATE):  # a NaN fails the comparisons below
        return False
    nx, ny = rows[j, M_NX], rows[j, M_NY]
    # block_step's b: the velocity less the target less K times the totals, which are +0.0 (K finite here)
    b1 = along(vax, vay, wa, vbx, vby, wb, rows, j, FIRST, nx, ny) - rows[j, FIRST + Q_TARGET]
    b2 = along(vax, vay, wa, vbx, vby, wb, rows, j, SECOND, nx, ny) - rows[j, SECOND + Q_TARGET]
    return b1 > 0.0 and b2 > 0.0 and apart(rows[j, M_K11], rows[j, M_K12], rows[j, M_K22], rows[j, M_DET], b1, b2)


@leaf
def idle(bodies: np.ndarray, links: np.ndarray, rows: np.ndarray, j: int) -> bool:
    """Whether manifold ``j``'s friction visits would change nothing, found without them: every impulse it
    holds is zero, so each friction bound is zero and a visit's total, clamped to ``[-0, 0]``, stays what it
    was, unless the visit's sums overflow, which moderate anchors, masses, friction and velocities (below
    ``MODERATE``) rule out. A speculative point still apart, the bulk of a brick wall's side joints, is one."""
    if rows[j, FIRST + Q_PN] != 0.0 or rows[j, FIRST + Q_PT] != 0.0 or rows[j, M_MODERATE] == 0.0:
        return False
    if rows[j, SECOND + Q_PN] != 0.0 or rows[j, SECOND + Q_PT] != 0.0:
        return False
    a, b = links[j, L_A], links[j, L_B]
    return max(abs(bodies[a, V_X]), abs(bodies[a, V_Y]), abs(bodies[a, V_W]), abs(bodies[b, V_X]),
               abs(bodies[b, V_Y]), abs(bodies[b, V_W])) < MODERATE


@inlined
def laid_friction(bodies: np.ndarray, links: np.ndarray, rows: np.ndarray, j: int, c: int) -> None:
    """``contacts.friction_step`` at the point of row ``j`` whose columns begin at ``c``: its tangent total
    moved towards stopping its sliding, kept within ``mu`` times its normal total."""
    nx, ny = rows[j, M_NX], rows[j, M_NY]
    limit = rows[j, M_MU] * rows[j, c + Q_PN]
    old = rows[j, c + Q_PT]
    a, b = links[j, L_A], links[j, L_B]
    vax, vay, wa, vbx, vby, wb = (bodies[a, V_X], bodies[a, V_Y], bodies[a, V_W], bodies[b, V_X], bodies[b, V_Y],
                                  bodies[b, V_W])
    total = old - rows[j, c + Q_KT] * along(vax, vay, wa, vbx, vby, wb, rows, j, c, -ny, nx)
    total = min(max(total, -limit), limit)
    if total != old:
        step = total - old
        rows[j, c + Q_PT] = total
        sink = links[j, L_SINK]
        (bodies[sink, V_X], bodies[sink, V_Y], bodies[sink, V_W], bodies[b, V_X], bodies[b, V_Y],
         bodies[b, V_W]) = push(vax, vay, wa, vbx, vby, wb, bodies[a, INV_M], bodies[a, INV_I], bodies[b, INV_M],
                                bodies[b, INV_I], rows, j, c, -step * ny, step * nx)


@inlined
def lab_visit(bodies: np.ndarray, links: np.ndarray, rows: np.ndarray, j: int, c: int) -> None:
    """The lab's visit (``pgs``) of the point of row ``j`` whose columns begin at ``c``: stop the approach, then
    friction within ``mu`` times this visit's normal impulse; the point's ``PN``/``PT`` add up what the visits
    gave."""
    if rows[j, c + Q_DEPTH] <= 0.0:
        return
    a, sink, b = links[j, L_A], links[j, L_SINK], links[j, L_B]
    vax, vay, wa, ima, iia = bodies[a, V_X], bodies[a, V_Y], bodies[a, V_W], bodies[a, INV_M], bodies[a, INV_I]
    vbx, vby, wb, imb, iib = bodies[b, V_X], bodies[b, V_Y], bodies[b, V_W], bodies[b, INV_M], bodies[b, INV_I]
    nx, ny = rows[j, M_NX], rows[j, M_NY]
    un = along(vax, vay, wa, vbx, vby, wb, rows, j, c, nx, ny)
    pn = 0.0
    if un < 0.0:
        pn = -un * rows[j, c + Q_KN]
        vax, vay, wa, vbx, vby, wb = push(vax, vay, wa, vbx, vby, wb, ima, iia, imb, iib, rows, j, c, pn * nx,
                                          pn * ny)
        rows[j, c + Q_PN] += pn
    limit = rows[j, M_MU] * pn
    if limit > 0.0:
        pt = -along(vax, vay, wa, vbx, vby, wb, rows, j, c, -ny, nx) * rows[j, c + Q_KT]
        pt = min(max(pt, -limit), limit)
        vax, vay, wa, vbx, vby, wb = push(vax, vay, wa, vbx, vby, wb, ima, iia, imb, iib, rows, j, c, -pt * ny,
                                          pt * nx)
        rows[j, c + Q_PT] += pt
    bodies[sink, V_X], bodies[sink, V_Y], bodies[sink, V_W] = vax, vay, wa
    bodies[b, V_X], bodies[b, V_Y], bodies[b, V_W] = vbx, vby, wb


@leaf
def visiting_order(ids: np.ndarray, table: np.ndarray, first: np.ndarray, m: int, latest: np.ndarray,
                   group: np.ndarray, tally: np.ndarray, order: np.ndarray) -> int:
    """``order[0..m]``: the manifolds (numbered as in ``first``) in the order the passes visit them, group by
    group; returns the number of groups, and ``tally[g]`` is where group ``g`` ends in ``order``.

    ``wavefront``'s waves, with the manifolds still apart taken out of them: a manifold whose points are all
    apart and hold no impulse (a brick wall's side joints) mostly changes nothing, yet as a wave's member it
    would hold every later manifold of its two bodies one wave back (the 65-brick wall: 55 waves, 45 without
    them). Such a manifold goes instead to the group just before the wave in which either
    of its bodies is next visited by another manifold (even groups: ``2 v``, before wave ``v``, the odd group
    ``2 v + 1``), where the pass visits it on its own, and groups of such manifolds one after the other in
    table order. Every body still meets its manifolds in table order (a manifold goes after all earlier ones
    of its bodies and before all later ones), so the numbers are those of the table-order pass whatever such
    a manifold does; which ones are set apart only changes how fast."""
    for i in range(latest.shape[0]):
        latest[i] = 0
    for g in range(2 * m + 2):
        tally[g] = 0
    groups = 0
    for j in range(m):
        k = first[j]
        a, b = ids[k, A], ids[k, B]
        now = latest[b]
        if a >= 0 and latest[a] > now:
            now = latest[a]
        still = True
        for i in range(k, first[j + 1]):
            still = still and table[i, DEPTH] < 0.0 and table[i, PN] == 0.0 and table[i, PT] == 0.0
        if still:
            g = 2 * now  # before wave ``now``: after every earlier manifold of its bodies
        else:
            now += 1
            g = 2 * now - 1  # wave ``now - 1``
        latest[b] = now
        if a >= 0:
            latest[a] = now
        group[j] = g
        tally[g + 1] += 1
        if g + 1 > groups:
            groups = g + 1
    sort_by_group(group, m, groups, tally, order)
    return groups


@leaf
def laid_pass(bodies: np.ndarray, links: np.ndarray, rows: np.ndarray, groups: int, tally: np.ndarray,
              relaxation: float, lab: bool) -> None:
    """One Gauss-Seidel pass over the layout, group by group (``visiting_order``; ``tally[g]``: where group
    ``g`` ends). Accumulated (``contacts.accumulated_iteration``'s numbers, see the module doc): an even
    group's manifolds one after the other, each its normals then its frictions; an odd group's (a wave's)
    every manifold's normals, then every first friction, then every second. With ``lab``, the lab's visits
    (a table-order lab pass's numbers; ``relaxation`` unused): each point's normal then friction, in a wave every
    first point, then every second."""
    begin = np.uint64(0)
    for g in range(groups):
        end = np.uint64(tally[g])
        if lab:
            for q in range(2 if g % 2 == 1 else 1):  # a wave: its first points, then its second
                for j in range(begin, end):
                    if g % 2 == 0 or q == 0:
                        lab_visit(bodies, links, rows, j, FIRST)
                    if links[j, L_POINTS] == 2 and (g % 2 == 0 or q == 1):
                        lab_visit(bodies, links, rows, j, SECOND)
        elif g % 2 == 0:
            for j in range(begin, end):
                if rows[j, M_OPEN] != 0.0 and stays_apart(bodies, links, rows, j):
                    continue
                laid_normals(bodies, links, rows, j, relaxation)
                if not idle(bodies, links, rows, j):
                    laid_friction(bodies, links, rows, j, FIRST)
                    if links[j, L_POINTS] == 2:
                        laid_friction(bodies, links, rows, j, SECOND)
        else:
            for j in range(begin, end):
                laid_normals(bodies, links, rows, j, relaxation)
            for j in range(begin, end):
                laid_friction(bodies, links, rows, j, FIRST)
            for j in range(begin, end):
                if links[j, L_POINTS] == 2:
                    laid_friction(bodies, links, rows, j, SECOND)
        begin = end


@leaf
def laid_remember(ids: np.ndarray, links: np.ndarray, rows: np.ndarray, m: int, count: int, keys: np.ndarray,
                  carried: np.ndarray) -> int:
    """``contacts.remember`` from the layout: this step's points (in table order) and impulses kept for the
    next, as many as the memory holds; returns how many."""
    held = min(count, keys.shape[0])
    for k in range(held):
        keys[k, 0], keys[k, 1], keys[k, 2] = ids[k, A], ids[k, B], ids[k, FEATURE]
    for j in range(np.uint64(m)):
        for q in range(np.int64(links[j, L_POINTS])):
            k = np.int64(links[j, L_ROW]) + q
            if k < held:
                c = FIRST if q == 0 else SECOND
                carried[k, 0], carried[k, 1] = rows[j, c + Q_PN], rows[j, c + Q_PT]
    return held


@kernel
def solve_laid(x: np.ndarray, y: np.ndarray, vx: np.ndarray, vy: np.ndarray, w: np.ndarray,
               inv_mass: np.ndarray, inv_inertia: np.ndarray, friction: np.ndarray, g: float, dt: float,
               carry: bool, iterations: int, block: bool, relaxation: float, ids: np.ndarray, table: np.ndarray,
               count: int, keys: np.ndarray, carried: np.ndarray, held: int, first: np.ndarray, order: np.ndarray,
               group: np.ndarray, tally: np.ndarray, latest: np.ndarray, links: np.ndarray, rows: np.ndarray,
               bodies: np.ndarray) -> int:
    """``contacts.solve_velocities`` on the layout (``laid_workspace``'s room, at least ``count`` points), the
    same numbers: gravity; the last step's impulses found again (``carry``) and the step laid out; warm start;
    ``iterations`` passes; the velocities back to the state and this step's impulses kept. Returns how many
    points the memory now holds."""
    gravity(vy, inv_mass, g, dt)
    table[:count, PN] = 0.0
    table[:count, PT] = 0.0
    if carry:
        recall(ids, table, count, keys, carried, held)
    m = manifold_starts(ids, count, first)
    groups = visiting_order(ids, table, first, m, latest, group, tally, order)
    lay_out(x, y, inv_mass, inv_inertia, friction, ids, table, first, order, m, dt, block, links, rows)
    load_velocities(vx, vy, w, inv_mass, inv_inertia, bodies)
    if carry:
        laid_warm_start(bodies, links, rows, m)
    for _ in range(iterations):
        laid_pass(bodies, links, rows, groups, tally, relaxation, False)
    give_velocities(bodies, vx, vy, w)
    return laid_remember(ids, links, rows, m, count, keys, carried)

