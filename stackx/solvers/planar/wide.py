"""The soft step's passes over a wave's manifolds several at a time, in the lanes of the processor's vectors.

The manifolds of one wave (``wavefront``) share no body, so their visits commute exactly: they may be done
side by side, and Box2D v3 does just that with the manifolds of one graph colour (``contact_solver.c``: each
``b2ContactConstraintWide`` holds one manifold per lane of a SIMD register, 8 lanes of single floats with
AVX2; the constraint data is written lane by lane once a step, with zero masses and impulses where a lane has
no manifold or a manifold no second point, and each visit gathers the lanes' bodies' velocities into wide
registers, solves, and scatters them back). This module does the same in double precision with numba:

- once a step, ``lay_out`` writes each wave's manifolds in **blocks** of ``LANES``, one record of ``FIELDS``
  x ``LANES`` floats per block, field by field, so a field of the block's lanes is ``LANES`` consecutive
  numbers: what a visit reads that does not change within the step (masses, normal, anchors, effective
  masses, friction, softness, base separation of both points) and the impulses;
- a pass walks the waves in order; for a wave it **gathers** its blocks' bodies' velocities (and their
  motion since the step began, when the bodies moved since the last pass) into the records, **solves**
  both normals of every lane in one loop over the wave's blocks and lanes, then both frictions in another,
  each loop reading and writing only the records at fixed offsets from a block's start, which LLVM turns
  into vector instructions, and **scatters** the velocities back to the bodies.

Each lane does the arithmetic of the scalar visit (``soft_step``'s module doc) in the same order and with the
same roundings: no fused multiply-add (numba compiles without fastmath), and what a lane without a second
point or without a movable side would change is kept by a select, not added as a zero (``x + 0.0`` turns a
``-0.0`` into ``0.0``, and ``0 * x`` is NaN for an infinite ``x``). A manifold's visits keep their order
(its normals, then its frictions), so a pass gives the numbers of visiting the manifolds in table order to
the bit (``wavefront``).

The selects are taken on numbers in registers, never written back where the kept number already lies: a loop's
visits read a lane's velocities once, carry them through both points' visits and write them once
(``put_velocities``), each visit writes its point's impulse whether the lane has the point or not (a lane without
it holds zeros that nothing reads back), and the tests that choose a lane's numbers read their fields whatever
the outcome (``&``, not ``and``). Written the other way (``record[f] = new if keep else record[f]``), LLVM drops
the store where the number would not change and vectorizes what is left as a masked store, which writes only the
kept lanes: cheap on recent Intel cores, slow on AMD's Zen (as published instruction tables list it). On a 2-core
AMD EPYC (znver3, AVX2) each build of the pass's walk had 15 to 27 masked stores (in its LLVM IR), which alone
took a seventh of its time in a profile; without them the batch of ``benchmarks.planar_batch`` costs about a
quarter less (the numbers are the same).

``LANES`` trades padding for width: a wave of ``c`` manifolds takes ``ceil(c / LANES)`` blocks, the last
one partly empty, and an empty lane costs what a full one does; 4 lanes fill one AVX2 register of doubles.
On a 20-row pyramid (400 manifolds in 57 waves, 124 blocks of 4) a pass costs about 7 µs, 9 ns a point,
against 11.5 µs for the same visits one manifold at a time; 8 lanes cost about a fifth more (padding), 2
lanes twice as much, and solving a lane's normals and frictions in one loop a tenth more (each block's
visits then wait on each other).
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import inlined, kernel, leaf
from stackx.solvers.planar.contacts import A, B, DEPTH, FEATURE, NX, NY, PX, PY, effective_mass

LANES = 4  # manifolds a block solves side by side

# a block's record, field by field, each field ``LANES`` numbers (one a lane); the names are each field's
# offset from the block's start. Per manifold, found once a step: its bodies' inverse masses and inertias,
# friction, softness (bias rate, mass scale, impulse scale), whether side ``A`` is a body the impulses move
# (not the ground) and whether it has a second point; then per point (the second point's fields ``SECOND``
# after the first's) its normal, anchors, normal and tangent effective masses, separation when found less
# what the anchors give along the normal, impulses, and its separation as last measured; then, gathered
# from the bodies for a pass, the velocities of both sides and their motion since the step began
FIELDS = 48
BLOCK = FIELDS * LANES
(R_IMA, R_IIA, R_IMB, R_IIB, R_MU, R_BIAS, R_SCALE, R_LET_GO, R_MOVES_A, R_TWO,
 R_NX, R_NY, R_RAX, R_RAY, R_RBX, R_RBY, R_KN, R_KT, R_BASE, R_PN, R_PT, R_S) = (
    np.uint64(f * LANES) for f in range(22))
SECOND = np.uint64(12 * LANES)
(R_VAX, R_VAY, R_WA, R_VBX, R_VBY, R_WB, R_DXA, R_DYA, R_CA, R_SA, R_DXB, R_DYB, R_CB, R_SB) = (
    np.uint64(f * LANES) for f in range(34, FIELDS))

# the bodies as the passes read them, one row each and the ground's last: velocities and the motion since the
# step began (``substep.moved_body``: dx, dy, cosine and sine of the turn), padded to 64 bytes, so a body a
# block gathers is one cache line
V_X, V_Y, V_W, D_X, D_Y, COS, SIN = range(7)
BODY_COLUMNS = 8
LINE = 8  # numbers in a cache line of 64 bytes


@kernel
def line_aligned(size: int) -> np.ndarray:
    """``size`` unfilled numbers, the first beginning a cache line. numpy's arrays begin 16 bytes past one
    (numba's on any 32-byte boundary), and a record there has each field of a block's lanes (``LANES``
    numbers, 32 bytes) across the two halves of a line or across two lines, which every vector load and store
    of a pass pays for: passes over records 16 bytes past a line cost about a tenth more. Body rows of 64
    bytes each fill one line only when they begin one."""
    raw = np.empty(size + LINE)
    skip = -(raw.ctypes.data // 8) % LINE
    return raw[skip:skip + size]


@kernel
def block_workspace(blocks: int) -> tuple[np.ndarray, np.ndarray]:
    """Room for ``blocks`` blocks: ``(record, sides)``: the records (``line_aligned``) and each lane's two
    bodies."""
    return line_aligned(blocks * BLOCK), np.empty((blocks * LANES, 2), np.uint64)


@leaf
def lay_out(x: np.ndarray, y: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, friction: np.ndarray,
            ids: np.ndarray, table: np.ndarray, impulses: np.ndarray, first: np.ndarray, order: np.ndarray,
            waves: int, tally: np.ndarray, softness: np.ndarray, place: np.ndarray, offset: int, ground: int,
            whole: bool, sides: np.ndarray, slots: np.ndarray, record: np.ndarray) -> None:
    """One world's manifolds in lanes, wave by wave (``order``, ``tally`` from ``wavefronts``), with all a
    visit reads that does not change within the step, found once: wave ``v``'s manifolds in consecutive lanes
    from lane ``place[v]`` (lane ``l`` is lane ``l % LANES`` of block ``l // LANES``). The world's bodies are
    the passes' body rows ``offset`` on and the ground is row ``ground``, so several worlds laid out in one
    set of blocks share no body and a wave's blocks may hold manifolds of several; ``slots[k]``: the point
    slot (``point_at``) of the world's point ``k``. The arithmetic of ``contacts.prepare`` and
    ``substep.base_separations``, and each point's separation where the step begins as ``measure`` finds it,
    so the step's first pass neither gathers the bodies' motion nor measures; softness row 1 where a side is
    static (the ground or a static box); impulses as ``recall_impulses`` left them in ``impulses`` (the table
    holds the points as ``collide`` found them: its columns ``NX`` to ``DEPTH``). A
    missing second point has zeros; lanes without a manifold are ``empty_lanes``' and the effective masses
    ``effective_masses``', once the blocks are full. Not ``whole``: the blocks hold this layout of the same
    manifolds from the last step (the same pairs in the same lanes), so what depends on the pairs alone
    (bodies, masses, friction, softness, point slots), which no pass writes, is there already; only what
    the points' positions and impulses give is written."""
    none = np.uint64(ground)
    begin = 0
    for v in range(waves):
        for jj in range(begin, tally[v]):
            slot = np.uint64(place[v] + (jj - begin))
            k0, k1 = first[order[jj]], first[order[jj] + 1]
            a, b = ids[k0, A], ids[k0, B]
            at = (slot // np.uint64(LANES)) * np.uint64(BLOCK) + slot % np.uint64(LANES)
            if whole:
                imb, iib = inv_mass[b], inv_inertia[b]
                ima, iia = (inv_mass[a], inv_inertia[a]) if a >= 0 else (0.0, 0.0)
                soft = 1 if a < 0 or ima == 0.0 or imb == 0.0 else 0
                sides[slot, 0] = np.uint64(offset + a) if a >= 0 else none
                sides[slot, 1] = np.uint64(offset + b)
                record[at + R_IMA], record[at + R_IIA] = ima, iia
                record[at + R_IMB], record[at + R_IIB] = imb, iib
                record[at + R_MU] = np.sqrt(friction[a] * friction[b]) if a >= 0 else friction[b]
                record[at + R_BIAS] = softness[soft, 0]
                record[at + R_SCALE] = softness[soft, 1]
                record[at + R_LET_GO] = softness[soft, 2]
                record[at + R_MOVES_A] = 1.0 if a >= 0 else 0.0
                record[at + R_TWO] = 1.0 if k1 - k0 > 1 else 0.0
                for q in range(k1 - k0):
                    slots[k0 + q] = np.uint64(2) * slot + np.uint64(q)
            if k1 - k0 == 1:  # no second point: zeros, which the passes compute with and then drop
                for f in range(R_NX, R_NX + SECOND, np.uint64(LANES)):
                    record[at + SECOND + f] = 0.0
            for q in range(k1 - k0):
                k = k0 + q
                nx, ny = table[k, NX], table[k, NY]
                px, py = table[k, PX], table[k, PY]
                rbx, rby = px - x[b], py - y[b]
                rax, ray = (px - x[a], py - y[a]) if a >= 0 else (0.0, 0.0)
                p = at + np.uint64(q) * SECOND
                record[p + R_NX], record[p + R_NY] = nx, ny
                record[p + R_RAX], record[p + R_RAY] = rax, ray
                record[p + R_RBX], record[p + R_RBY] = rbx, rby
                base = -table[k, DEPTH] - ((rbx - rax) * nx + (rby - ray) * ny)
                record[p + R_BASE] = base
                # ``measure`` where no body has moved yet (no shift, no turn): its products by 1 and by 0 and
                # its sums with 0 leave each anchor as it is but for a zero's sign, which ``0.0 + r`` gives
                sx = (0.0 + rbx) - (0.0 + rax)
                sy = (0.0 + rby) - (0.0 + ray)
                record[p + R_S] = base + sx * nx + sy * ny
                record[p + R_PN], record[p + R_PT] = impulses[k, 0], impulses[k, 1]
        begin = tally[v]


@leaf
def empty_lanes(record: np.ndarray, sides: np.ndarray, begin: int, end: int, ground: int) -> None:
    """Lanes ``begin`` to ``end`` hold no manifold: the ground on both sides, no points, zeros, which the passes
    compute with and nothing reads back."""
    for lane in range(np.uint64(begin), np.uint64(end)):
        sides[lane, 0], sides[lane, 1] = np.uint64(ground), np.uint64(ground)
        at = (lane // np.uint64(LANES)) * np.uint64(BLOCK) + lane % np.uint64(LANES)
        for f in range(np.uint64(0), R_VAX, np.uint64(LANES)):
            record[at + f] = 0.0


@leaf
def effective_masses(record: np.ndarray, blocks: np.uint64) -> None:
    """Every point's normal and tangent effective masses (``contacts.effective_mass``) from the masses,
    anchors and normal ``lay_out`` wrote: one loop over the lanes, whose divisions LLVM does four at a time.
    A lane or point without a contact has zeros, and an effective mass of 0."""
    for blk in range(blocks):
        for lane in range(np.uint64(LANES)):
            at = blk * np.uint64(BLOCK) + lane
            ima, iia, imb, iib = record[at + R_IMA], record[at + R_IIA], record[at + R_IMB], record[at + R_IIB]
            for q in range(2):
                p = at + np.uint64(q) * SECOND
                nx, ny = record[p + R_NX], record[p + R_NY]
                rax, ray, rbx, rby = record[p + R_RAX], record[p + R_RAY], record[p + R_RBX], record[p + R_RBY]
                record[p + R_KN] = effective_mass(ima, iia, rax, ray, imb, iib, rbx, rby, nx, ny)
                record[p + R_KT] = effective_mass(ima, iia, rax, ray, imb, iib, rbx, rby, -ny, nx)


@leaf
def remember_laid(ids: np.ndarray, count: int, slots: np.ndarray, record: np.ndarray, keys: np.ndarray,
                  carried: np.ndarray) -> int:
    """``contacts.remember`` for one world laid out with point slots ``slots`` (``lay_out``), the impulses read
    where the passes left them: each of the first ``count`` points' key and accumulated impulses kept for the
    next step (as many as the memory holds); returns how many."""
    held = min(count, keys.shape[0])
    for k in range(held):
        keys[k, 0], keys[k, 1], keys[k, 2] = ids[k, A], ids[k, B], ids[k, FEATURE]
        at = point_at(slots[k])
        carried[k, 0], carried[k, 1] = record[at + R_PN], record[at + R_PT]
    return held


@leaf
def point_at(slot: np.uint64) -> np.uint64:
    """Where point slot ``slot`` (lane ``slot // 2``, its point ``slot % 2``) starts in the records: add a
    point field times ``LANES``."""
    lane = slot // np.uint64(2)
    blk = lane // np.uint64(LANES)
    return blk * np.uint64(BLOCK) + lane % np.uint64(LANES) + (slot % np.uint64(2)) * SECOND


@leaf
def add_applied(slots: np.ndarray, count: int, record: np.ndarray, applied: np.ndarray) -> None:
    """``applied.add_applied`` for one world's ``count`` points laid out with point slots ``slots``: the end of
    a substep adds each point's accumulated impulses, which the substep applied, to ``applied`` at the
    point's table row."""
    for k in range(min(count, applied.shape[0])):
        at = point_at(slots[k])
        applied[k, 0] += record[at + R_PN]
        applied[k, 1] += record[at + R_PT]


@leaf
def warm_start(bodies: np.ndarray, sides: np.ndarray, record: np.ndarray, waves: int, ends: np.ndarray) -> None:
    """``contacts.warm_start`` on the blocks: every point's accumulated impulses applied to its bodies, wave by
    wave as a pass walks them (the wave's bodies gathered, both points of every lane, scattered back). Each
    body meets its points in the order of the points of the table (a wave's manifolds share no body, a
    lane's points in order), so the same sums."""
    begin = np.uint64(0)
    for v in range(waves):
        end = ends[v]
        for blk in range(begin, end):
            gather(bodies, sides, record, blk, False)
        for blk in range(begin, end):
            for lane in range(np.uint64(LANES)):
                at = blk * np.uint64(BLOCK) + lane
                vax, vay, wa, vbx, vby, wb = velocities(record, at)
                for q in range(2):
                    vax, vay, wa, vbx, vby, wb = warm_visit(record, at, q, vax, vay, wa, vbx, vby, wb)
                put_velocities(record, at, vax, vay, wa, vbx, vby, wb)
        for blk in range(begin, end):
            scatter(bodies, sides, record, blk)
        begin = end


@inlined
def warm_visit(record: np.ndarray, at: np.uint64, q: int, vax: float, vay: float, wa: float, vbx: float,
               vby: float, wb: float) -> tuple[float, float, float, float, float, float]:
    """Point ``q``'s accumulated impulses applied in the lane whose fields start at ``at`` to the lane's
    velocities, kept where the lane has the point and it carries an impulse (``contacts.warm_start`` applies
    only those)."""
    p = at + np.uint64(q) * SECOND
    pn, pt = record[p + R_PN], record[p + R_PT]
    nx, ny = record[p + R_NX], record[p + R_NY]
    keep = ((q == 0) | (record[at + R_TWO] != 0.0)) & ((pn != 0.0) | (pt != 0.0))
    return apply(record, at, p, pn * nx - pt * ny, pn * ny + pt * nx, keep, vax, vay, wa, vbx, vby, wb)


@inlined
def velocities(record: np.ndarray, at: np.uint64) -> tuple[float, float, float, float, float, float]:
    """The velocities of both sides of the lane whose fields start at ``at``, as gathered: ``(vax, vay, wa,
    vbx, vby, wb)``."""
    return (record[at + R_VAX], record[at + R_VAY], record[at + R_WA],
            record[at + R_VBX], record[at + R_VBY], record[at + R_WB])


@inlined
def put_velocities(record: np.ndarray, at: np.uint64, vax: float, vay: float, wa: float, vbx: float, vby: float,
                   wb: float) -> None:
    """A lane's velocities back to its record, once its visits are done. Written whole, whatever a visit
    kept: a select stored back where the lane's number already lies is compiled as a masked store (the
    module doc says why that is avoided)."""
    record[at + R_VAX], record[at + R_VAY], record[at + R_WA] = vax, vay, wa
    record[at + R_VBX], record[at + R_VBY], record[at + R_WB] = vbx, vby, wb


@inlined
def gather(bodies: np.ndarray, sides: np.ndarray, record: np.ndarray, blk: np.uint64, moved: bool) -> None:
    """The block's lanes' bodies' velocities into its record, and their motion since the step began when they
    ``moved`` since the last pass."""
    o = blk * np.uint64(BLOCK)
    for lane in range(np.uint64(LANES)):
        a, b = sides[blk * np.uint64(LANES) + lane, 0], sides[blk * np.uint64(LANES) + lane, 1]
        at = o + lane
        record[at + R_VAX], record[at + R_VAY], record[at + R_WA] = bodies[a, V_X], bodies[a, V_Y], bodies[a, V_W]
        record[at + R_VBX], record[at + R_VBY], record[at + R_WB] = bodies[b, V_X], bodies[b, V_Y], bodies[b, V_W]
        if moved:
            record[at + R_DXA], record[at + R_DYA] = bodies[a, D_X], bodies[a, D_Y]
            record[at + R_CA], record[at + R_SA] = bodies[a, COS], bodies[a, SIN]
            record[at + R_DXB], record[at + R_DYB] = bodies[b, D_X], bodies[b, D_Y]
            record[at + R_CB], record[at + R_SB] = bodies[b, COS], bodies[b, SIN]


@inlined
def scatter(bodies: np.ndarray, sides: np.ndarray, record: np.ndarray, blk: np.uint64) -> None:
    """The block's lanes' velocities back to their bodies, without a test for the ground: a lane whose side is
    the ground kept its gathered zeros there (``apply``'s select), and an empty lane's zero masses and
    impulses add zeros to zeros (``0.0 + -0.0`` is ``0.0``), so the ground's row is written the zeros it
    holds."""
    o = blk * np.uint64(BLOCK)
    for lane in range(np.uint64(LANES)):
        a, b = sides[blk * np.uint64(LANES) + lane, 0], sides[blk * np.uint64(LANES) + lane, 1]
        at = o + lane
        bodies[b, V_X] = record[at + R_VBX]
        bodies[b, V_Y] = record[at + R_VBY]
        bodies[b, V_W] = record[at + R_WB]
        bodies[a, V_X] = record[at + R_VAX]
        bodies[a, V_Y] = record[at + R_VAY]
        bodies[a, V_W] = record[at + R_WA]


@inlined
def normals(record: np.ndarray, begin: np.uint64, end: np.uint64, h: float, use_bias: bool, push_out: float,
            moved: bool) -> None:
    """Both points' normal visits in every lane of blocks ``begin`` to ``end``, the first point's then the
    second's, each point's separation measured again (``measure``) before its visit when the bodies ``moved``
    since the last pass. A lane reads and writes its own numbers at fixed offsets from its block's start,
    so LLVM does the lanes at once in vector registers, and the blocks' visits, independent of each other,
    overlap.

    The speculative target ``-s / h`` of a point still apart is a division, which the vector registers do
    for every lane and point whatever the lane's separation. Where the separations were measured by an
    earlier pass or the layout (the relax pass's serve the next substep's solve, the layout's the step's
    first), a block with no point apart (a pile at
    rest: every point sunk in) is visited without it, the same numbers; measuring first, to know, costs
    more than the division in the passes that measure."""
    for blk in range(begin, end):
        if moved:
            normal_lanes(record, blk, h, use_bias, push_out, True, True)
        elif apart(record, blk):
            normal_lanes(record, blk, h, use_bias, push_out, False, True)
        else:
            normal_lanes(record, blk, h, use_bias, push_out, False, False)


@inlined
def normal_lanes(record: np.ndarray, blk: np.uint64, h: float, use_bias: bool, push_out: float, measuring: bool,
                 some_apart: bool) -> None:
    """Both points' normal visits in every lane of block ``blk``, each point's separation measured first when
    ``measuring`` (``normals`` passes both flags as constants, so each build tests neither)."""
    for lane in range(np.uint64(LANES)):
        at = blk * np.uint64(BLOCK) + lane
        vax, vay, wa, vbx, vby, wb = velocities(record, at)
        for q in range(2):
            if measuring:
                measure(record, at, q)
            vax, vay, wa, vbx, vby, wb = normal_visit(record, at, q, h, use_bias, push_out, some_apart,
                                                      vax, vay, wa, vbx, vby, wb)
        put_velocities(record, at, vax, vay, wa, vbx, vby, wb)


@inlined
def measure(record: np.ndarray, at: np.uint64, q: int) -> None:
    """Point ``q``'s separation in the lane whose fields start at ``at`` measured again from the bodies'
    motion since the step began (gathered with the velocities): the normal is held, the anchors move and
    turn with their bodies."""
    p = at + np.uint64(q) * SECOND
    nx, ny = record[p + R_NX], record[p + R_NY]
    rax, ray = record[p + R_RAX], record[p + R_RAY]
    rbx, rby = record[p + R_RBX], record[p + R_RBY]
    ca, sa = record[at + R_CA], record[at + R_SA]
    cb, sb = record[at + R_CB], record[at + R_SB]
    sx = record[at + R_DXB] + (cb * rbx - sb * rby)
    sy = record[at + R_DYB] + (sb * rbx + cb * rby)
    sx -= record[at + R_DXA] + (ca * rax - sa * ray)
    sy -= record[at + R_DYA] + (sa * rax + ca * ray)
    record[p + R_S] = record[p + R_BASE] + sx * nx + sy * ny


@inlined
def apart(record: np.ndarray, blk: np.uint64) -> bool:
    """Whether some point of the block is still apart (its separation positive): only then does a visit
    aim at the speculative target. A lane without the point has a separation of 0."""
    found = False
    for lane in range(np.uint64(LANES)):
        at = blk * np.uint64(BLOCK) + lane
        found |= (record[at + R_S] > 0.0) | (record[at + SECOND + R_S] > 0.0)
    return found


@inlined
def frictions(record: np.ndarray, begin: np.uint64, end: np.uint64) -> None:
    """Both points' friction visits in every lane of blocks ``begin`` to ``end``, as ``normals``."""
    for blk in range(begin, end):
        for lane in range(np.uint64(LANES)):
            at = blk * np.uint64(BLOCK) + lane
            vax, vay, wa, vbx, vby, wb = velocities(record, at)
            for q in range(2):
                vax, vay, wa, vbx, vby, wb = friction_visit(record, at, q, vax, vay, wa, vbx, vby, wb)
            put_velocities(record, at, vax, vay, wa, vbx, vby, wb)


@inlined
def normal_visit(record: np.ndarray, at: np.uint64, q: int, h: float, use_bias: bool, push_out: float,
                 some_apart: bool, vax: float, vay: float, wa: float, vbx: float, vby: float,
                 wb: float) -> tuple[float, float, float, float, float, float]:
    """Point ``q``'s normal visit in the lane whose fields start at ``at`` (the soft step's visit, its
    arithmetic in its order) at its separation as last measured (``measure``): the soft or speculative
    target (none speculative when no lane of the block is ``some_apart``), the accumulated normal impulse
    clamped at 0 and applied to the lane's velocities, which it returns. What a lane without the point
    would change is kept by a select; the point's impulse is written either way (a lane without the point
    holds zeros there that nothing reads back)."""
    p = at + np.uint64(q) * SECOND
    nx, ny = record[p + R_NX], record[p + R_NY]
    rax, ray = record[p + R_RAX], record[p + R_RAY]
    rbx, rby = record[p + R_RBX], record[p + R_RBY]
    s = record[p + R_S]
    # the softness read whatever the separation: a load under a test of each lane's own number is compiled as
    # a masked load
    bias, scale, let_go = (record[at + R_BIAS], record[at + R_SCALE], record[at + R_LET_GO]) if use_bias else (
        0.0, 1.0, 0.0)
    target, mass_scale, impulse_scale = 0.0, 1.0, 0.0
    if s > 0.0:
        target = -s / h if some_apart else 0.0
    elif use_bias:
        target = min(-bias * s, push_out)
        mass_scale = scale
        impulse_scale = let_go
    un = speed_along(vax, vay, wa, vbx, vby, wb, nx, ny, rax, ray, rbx, rby)
    old = record[p + R_PN]
    total = max(old + record[p + R_KN] * mass_scale * (target - un) - impulse_scale * old, 0.0)
    keep = (q == 0) | (record[at + R_TWO] != 0.0)
    record[p + R_PN] = total
    return apply(record, at, p, (total - old) * nx, (total - old) * ny, keep, vax, vay, wa, vbx, vby, wb)


@inlined
def friction_visit(record: np.ndarray, at: np.uint64, q: int, vax: float, vay: float, wa: float, vbx: float,
                   vby: float, wb: float) -> tuple[float, float, float, float, float, float]:
    """Point ``q``'s friction visit in the lane whose fields start at ``at``: the accumulated friction impulse
    within ``mu`` times the point's normal impulse, applied to the lane's velocities, which it returns."""
    p = at + np.uint64(q) * SECOND
    nx, ny = record[p + R_NX], record[p + R_NY]
    limit = record[at + R_MU] * record[p + R_PN]
    old = record[p + R_PT]
    ut = speed_along(vax, vay, wa, vbx, vby, wb, -ny, nx, record[p + R_RAX], record[p + R_RAY], record[p + R_RBX],
                     record[p + R_RBY])
    total = old - record[p + R_KT] * ut
    total = min(max(total, -limit), limit)
    keep = (q == 0) | (record[at + R_TWO] != 0.0)
    record[p + R_PT] = total
    return apply(record, at, p, -(total - old) * ny, (total - old) * nx, keep, vax, vay, wa, vbx, vby, wb)


@inlined
def speed_along(vax: float, vay: float, wa: float, vbx: float, vby: float, wb: float, dx: float, dy: float,
                rax: float, ray: float, rbx: float, rby: float) -> float:
    """``contacts.relative_velocity`` in a lane: ``((v_B + w_B x r_B) - (v_A + w_A x r_A)) . d``, the same
    arithmetic in the same order."""
    ux = vbx - wb * rby
    uy = vby + wb * rbx
    ux -= vax - wa * ray
    uy -= vay + wa * rax
    return ux * dx + uy * dy


@inlined
def apply(record: np.ndarray, at: np.uint64, p: np.uint64, px: float, py: float, keep: bool, vax: float,
          vay: float, wa: float, vbx: float, vby: float, wb: float) -> tuple[float, float, float, float, float, float]:
    """``contacts.apply_impulse`` in a lane: the impulse ``(px, py)`` at the point whose fields start at ``p``
    on side ``B`` and its opposite on side ``A``, kept where the lane has the point (``keep``) and, for
    ``A``, where ``A`` is a body (not the ground's row of zeros); the lane's velocities after it."""
    nvbx = vbx + record[at + R_IMB] * px
    nvby = vby + record[at + R_IMB] * py
    nwb = wb + record[at + R_IIB] * (record[p + R_RBX] * py - record[p + R_RBY] * px)
    nvax = vax - record[at + R_IMA] * px
    nvay = vay - record[at + R_IMA] * py
    nwa = wa - record[at + R_IIA] * (record[p + R_RAX] * py - record[p + R_RAY] * px)
    moves = keep & (record[at + R_MOVES_A] != 0.0)
    return (nvax if moves else vax, nvay if moves else vay, nwa if moves else wa,
            nvbx if keep else vbx, nvby if keep else vby, nwb if keep else wb)


@leaf
def soft_pass(bodies: np.ndarray, sides: np.ndarray, record: np.ndarray, waves: int, ends: np.ndarray, h: float,
              use_bias: bool, push_out: float, moved: bool) -> None:
    """One pass over the blocks wave by wave: the wave's bodies gathered into its blocks, both normals of
    every lane, then both frictions (each a loop over the wave's blocks and lanes, whose visits do not wait
    on each other), and the velocities scattered back. A manifold's visits keep their order and the blocks
    of a wave share no body, so this is the pass over the manifolds in table order to the bit. The
    separations are measured again when the bodies ``moved`` since the last pass (every pass after
    positions were integrated); otherwise the last pass's, or the layout's where the step begins, serve: the
    same numbers, found once."""
    if moved:
        if use_bias:
            sweep(bodies, sides, record, waves, ends, h, True, push_out, True)
        else:
            sweep(bodies, sides, record, waves, ends, h, False, push_out, True)
    elif use_bias:
        sweep(bodies, sides, record, waves, ends, h, True, push_out, False)
    else:
        sweep(bodies, sides, record, waves, ends, h, False, push_out, False)


@leaf
def sweep(bodies: np.ndarray, sides: np.ndarray, record: np.ndarray, waves: int, ends: np.ndarray, h: float,
          use_bias: bool, push_out: float, moved: bool) -> None:
    """``soft_pass``'s walk, built once for each setting of its flags (``soft_pass`` passes them as constants),
    so the compiled loops test neither flag: a relax pass's visits load no softness, and a pass that measures
    nothing no motion. A kernel of its own, called once a pass, not copied into ``soft_pass``: numba copies an
    inlined function's code afresh, with all it inlines in turn, at every call site, and the four copies made
    ``soft_pass`` the longest compile of any solver (a first soft-step run from an empty cache spent about 250 s
    of CPU compiling against about 150 s with the walk its own kernel, the same numbers and the same speed)."""
    begin = np.uint64(0)
    for v in range(waves):
        end = ends[v]
        for blk in range(begin, end):
            gather(bodies, sides, record, blk, moved)
        normals(record, begin, end, h, use_bias, push_out, moved)
        frictions(record, begin, end)
        for blk in range(begin, end):
            scatter(bodies, sides, record, blk)
        begin = end


@leaf
def place_waves(tally: np.ndarray, waves: np.ndarray, most: int, place: np.ndarray, used: np.ndarray,
                ends: np.ndarray) -> int:
    """Where the manifolds of several worlds go in one set of blocks (``tally[r]`` and ``waves[r]`` world
    ``r``'s from ``wavefronts``, ``most`` the largest of ``waves``): wave ``v`` of every world side by side, world
    by world, in the blocks of the layout's wave ``v``. ``place[r, v]``: the lane world ``r``'s wave ``v`` begins
    at (``lay_out``); ``used[v]``: one past the last lane of wave ``v`` with a manifold; ``ends[v]``: where the
    blocks of wave ``v`` end. Returns the blocks. The worlds share no body, so no manifold of a wave shares a
    body with another of it, and each body meets its manifolds in its own world's order."""
    blocks = 0
    for v in range(most):
        lane = blocks * LANES
        for r in range(tally.shape[0]):
            if v < waves[r]:
                place[r, v] = lane
                lane += tally[r, v] - (tally[r, v - 1] if v > 0 else 0)
        used[v] = lane
        blocks = (lane + LANES - 1) // LANES
        ends[v] = np.uint64(blocks)
    return blocks
