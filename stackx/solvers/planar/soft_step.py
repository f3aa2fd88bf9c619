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
arrays the substeps walk in order, bodies' velocities in one compact array): once a step, ``wide.lay_out``
writes all a visit reads that does not change within the step, manifold by manifold in the order the
passes visit them, and each body's velocities and motion since the step began sit in one row, the ground
as a last row of zeros. The order is ``wavefront``'s: manifolds in waves that share no body, which gives
the numbers of visiting them in table order to the bit (see that module), and the manifolds of a wave are
solved four at a time in the lanes of vector registers, as Box2D v3 solves a graph colour (``wide``). A
point's separation is measured once per position of the boxes: the layout's serves the first solve, the
relax pass's the next substep's solve. The contacts found where a call's last step ends start the next call
(``kept``).

A batch steps up to ``GROUP`` consecutive rows of the same substep, substeps, relax and push-out together
(``step_rows``): each row finds, recalls and orders its own contacts, and one layout holds every row's
manifolds, wave ``v`` of all of them side by side in the blocks of the layout's wave ``v``, each row's bodies
in rows of their own. No manifold of one row shares a body with another row's, so each body meets its
manifolds in its own row's order and every number is the row's alone; but a pass over one pyramid waits on
its chain of 57 waves, and over four it keeps four chains' visits in flight (on a 20-row pyramid the passes
cost about a quarter less a row). While a row's points are between the same bodies as the last step's (a
pile at rest), its wave order is kept, and while every row of a group keeps its pairs the layout writes
only what the points' positions and impulses give.

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

from stackx.kernel import kernel, leaf, prange, spread
from stackx.models.planar.state import PlanarState
from stackx.registry import solvers
from stackx.solvers.planar.applied import clear_applied
from stackx.solvers.planar.base import PlanarMemorySolver, StepImpulses
from stackx.solvers.planar.kept import Kept, keep, take_back
from stackx.solvers.planar.contacts import find_contacts_near, observe_contacts, recall_impulses, same_pairs
from stackx.solvers.planar.wavefront import manifold_starts, wavefronts
from stackx.solvers.planar.wide import (BLOCK, BODY_COLUMNS, COS, D_X, D_Y, LANES, SIN, V_W, V_X, V_Y,
                                        add_applied, block_workspace, effective_masses, empty_lanes, lay_out,
                                        line_aligned, place_waves, remember_laid, soft_pass, warm_start)
from stackx.solvers.column.soft_step import STATIC_HERTZ, SoftStepParams, soft


SUBSTEP_HERTZ = 0.125  # the contact frequency is at most this share of the substep rate (Box2D v3.1.1 on)
GROUP = 4  # rows whose passes run as one (``step_rows``): a pass over one pyramid waits on its chain of waves


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


class Workspace:
    """What ``soft_step_advance``'s threads step their rows in, kept by the solver from one call to the next
    (made again when the threads, the room or the boxes change): per thread, ``GROUP`` rows' recalled
    impulses of ``room`` points (``impulses``; the points are in each row's own table, ``kept.Kept``),
    their lanes (``wave`` to ``used``, as ``lane_workspace`` makes them), the rows of ``GROUP`` worlds of
    ``bodies`` boxes and the ground (``start``, ``body_rows``), and blocks for ``blocks`` blocks
    (``record``, ``sides``, ``wide.block_workspace``), which grow to what the last call needed. Everything
    a call reads there it has written first, so a call steps as in fresh memory; made afresh by every call,
    the megabytes of a large batch's tables and blocks were faulted in page by page each time (on 64 rows
    of a 20-row pyramid stepped a step a call, 3 to 4% of the step), and the quarter megabyte of lanes
    and body rows made afresh by every group of rows was handed back to the system and faulted in again
    by the next (on 64 rows of a 20-row pyramid, about 2% of the step). Unfilled: zeroing a pile's room
    costs more than its bookkeeping."""

    def __init__(self, threads: int, room: int, bodies: int, blocks: int = 1) -> None:
        self.impulses = np.empty((threads, GROUP, room, 2))
        self.wave = np.empty((threads, GROUP, room), np.int64)
        self.place = np.empty((threads, GROUP, room + 1), np.int64)
        self.slots = np.empty((threads, GROUP, room), np.uint64)
        self.ends = np.empty((threads, room + 1), np.uint64)
        self.used = np.empty((threads, room + 1), np.int64)
        self.start = np.empty((threads, GROUP * bodies, 3))
        self.body_rows = per_thread(threads, GROUP * bodies + 1, BODY_COLUMNS)
        self.record = per_thread(threads, blocks * BLOCK)
        self.sides = np.empty((threads, blocks * LANES, 2), np.uint64)
        self.blocks = np.zeros(threads, np.int64)  # the blocks each thread stepped in, by the last call

    def fits(self, threads: int, room: int, bodies: int) -> bool:
        """Whether this has room for ``threads`` threads of ``room`` points and ``bodies`` boxes a row."""
        return self.impulses.shape[:3] == (threads, GROUP, room) and self.start.shape[1] == GROUP * bodies

    def arrays(self) -> tuple[np.ndarray, ...]:
        """``(impulses, wave, place, slots, ends, used, start, body_rows, record, sides, blocks)``, as
        ``soft_step_advance`` takes them."""
        return (self.impulses, self.wave, self.place, self.slots, self.ends, self.used, self.start,
                self.body_rows, self.record, self.sides, self.blocks)

    def grow(self) -> None:
        """Blocks for as many as the last call grew to, where a thread needed more than there were."""
        most = int(self.blocks.max())
        if most * LANES > self.sides.shape[1]:
            threads = self.impulses.shape[0]
            self.record = per_thread(threads, most * BLOCK)
            self.sides = np.empty((threads, most * LANES, 2), np.uint64)


def per_thread(threads: int, *shape: int) -> np.ndarray:
    """An unfilled array of ``shape`` for each of ``threads`` threads, one after the other, each beginning a
    cache line (``wide.line_aligned``): a thread's part is whole blocks (``BLOCK`` numbers, 1,536 bytes) or
    whole body rows (64 bytes), so where the first begins a line, every one does."""
    return line_aligned(threads * int(np.prod(shape))).reshape(threads, *shape)


class WaveOrders:
    """Per batch row, the wave order of its last step's manifolds (``wavefront``), kept by the solver from
    one call to the next (made again with the memory): ``first``, ``order``, ``tally`` and ``waves`` as
    ``wavefronts`` leaves them, and ``ordered``, the points they are for (-1: none). A step whose points are
    between the same bodies as the memory's (``contacts.same_pairs``) takes the order as it is: it was found
    for those pairs, whichever call found it. A pile at rest stepped a step a call thus orders its
    manifolds once, not once a call (on 64 rows of a 20-row pyramid, 2% of the step)."""

    def __init__(self, batch: int, room: int) -> None:
        self.first = np.empty((batch, room + 1), np.int64)
        self.order = np.empty((batch, room), np.int64)
        self.tally = np.empty((batch, room + 1), np.int64)
        self.waves = np.zeros(batch, np.int64)
        self.ordered = np.full(batch, -1, np.int64)

    def fits(self, batch: int, room: int) -> bool:
        """Whether this holds the orders of ``batch`` rows of ``room`` points."""
        return self.order.shape == (batch, room)

    def arrays(self) -> tuple[np.ndarray, ...]:
        """``(first, order, tally, waves, ordered)``, as ``soft_step_advance`` takes them."""
        return self.first, self.order, self.tally, self.waves, self.ordered


@kernel
def order_workspace(room: int, worlds: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Room for the wave orders of ``worlds`` worlds of at most ``room`` points each: ``(first, order,
    tally)``, one row a world (``WaveOrders``')."""
    return (np.empty((worlds, room + 1), np.int64), np.empty((worlds, room), np.int64),
            np.empty((worlds, room + 1), np.int64))


@kernel
def lane_workspace(room: int, worlds: int) -> tuple[np.ndarray, ...]:
    """Room for the layout of ``worlds`` worlds of at most ``room`` points each: ``(wave, place, slots)``, one
    row a world (``wavefront``'s scratch, ``wide.place_waves``' lanes and ``wide.lay_out``'s point slots), and
    ``(ends, used)``, the layout's (``wide.place_waves``)."""
    return (np.empty((worlds, room), np.int64), np.empty((worlds, room + 1), np.int64),
            np.empty((worlds, room), np.uint64), np.empty(room + 1, np.uint64), np.empty(room + 1, np.int64))


@leaf
def load_bodies(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray, w: np.ndarray,
                lo: int, hi: int, start: np.ndarray, bodies: np.ndarray) -> None:
    """The body rows of batch rows ``lo`` to ``hi`` as a step begins (row ``r``'s boxes from ``r`` times the
    boxes on): where each box starts (``start``), its velocities, not moved yet. The rows are read by index,
    not sliced: a slice in a compiled loop counts a reference to its array on the way in and out."""
    n = x.shape[1]
    for r in range(hi - lo):
        b = lo + r
        for i in range(n):
            k = r * n + i
            start[k, 0], start[k, 1], start[k, 2] = x[b, i], y[b, i], angle[b, i]
            bodies[k, V_X], bodies[k, V_Y], bodies[k, V_W] = vx[b, i], vy[b, i], w[b, i]
            bodies[k, D_X], bodies[k, D_Y], bodies[k, COS], bodies[k, SIN] = 0.0, 0.0, 1.0, 0.0


@leaf
def still_ground(bodies: np.ndarray) -> None:
    """The ground's row (the last): all zeros and no turn. The ground's zeros enter a visit's sums as
    ``x - 0.0``, which is ``x``, so a visit reads the ground as a body without a test and gets the numbers of
    skipping it; a pass writes it back only the zeros it holds (``wide.scatter``)."""
    g = bodies.shape[0] - 1
    bodies[g, V_X], bodies[g, V_Y], bodies[g, V_W] = 0.0, 0.0, 0.0
    bodies[g, D_X], bodies[g, D_Y], bodies[g, COS], bodies[g, SIN] = 0.0, 0.0, 1.0, 0.0


@leaf
def store_velocities(bodies: np.ndarray, lo: int, hi: int, vx: np.ndarray, vy: np.ndarray, w: np.ndarray) -> None:
    """The velocities the step of batch rows ``lo`` to ``hi`` ends with, back to the state."""
    n = vx.shape[1]
    for r in range(hi - lo):
        b = lo + r
        for i in range(n):
            k = r * n + i
            vx[b, i], vy[b, i], w[b, i] = bodies[k, V_X], bodies[k, V_Y], bodies[k, V_W]


@leaf
def body_gravity(bodies: np.ndarray, inv_mass: np.ndarray, g: np.ndarray, lo: int, hi: int, h: float) -> None:
    """``contacts.gravity`` on the body rows of batch rows ``lo`` to ``hi``: ``vy += g h`` for every movable
    body."""
    n = inv_mass.shape[1]
    for r in range(hi - lo):
        b = lo + r
        for i in range(n):
            if inv_mass[b, i] > 0.0:
                bodies[r * n + i, V_Y] += g[b] * h


@leaf
def integrate_moved(x: np.ndarray, y: np.ndarray, angle: np.ndarray, lo: int, hi: int, bodies: np.ndarray,
                    start: np.ndarray, h: float) -> None:
    """``contacts.integrate_positions`` then ``substep.moved_body`` for every body of batch rows ``lo`` to
    ``hi``, in one walk: positions and angles move with the velocities over ``h``, and each body's row learns
    how far it has come since the step began (``start``)."""
    n = x.shape[1]
    for r in range(hi - lo):
        b = lo + r
        for i in range(n):
            k = r * n + i
            x[b, i] += bodies[k, V_X] * h
            y[b, i] += bodies[k, V_Y] * h
            angle[b, i] += bodies[k, V_W] * h
            bodies[k, D_X], bodies[k, D_Y] = x[b, i] - start[k, 0], y[b, i] - start[k, 1]
            turn = angle[b, i] - start[k, 2]
            bodies[k, COS], bodies[k, SIN] = np.cos(turn), np.sin(turn)


@kernel
def soft_step_advance(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                      w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray, hy: np.ndarray,
                      friction: np.ndarray, g: np.ndarray, dt: np.ndarray, substeps: np.ndarray,
                      hertz: np.ndarray, damping_ratio: np.ndarray, push_out: np.ndarray, relax: np.ndarray,
                      warm: np.ndarray, speculative: np.ndarray, keys: np.ndarray, carried: np.ndarray,
                      held: np.ndarray, applied: np.ndarray, kept_ids: np.ndarray, kept_points: np.ndarray,
                      kept_count: np.ndarray, kept_at: np.ndarray, kept_near: np.ndarray, kept_fat: np.ndarray,
                      last: np.ndarray, peak: np.ndarray, reach: np.ndarray, touched: np.ndarray,
                      launch: np.ndarray, groups: np.ndarray, chunks: np.ndarray, impulses_room: np.ndarray,
                      wave_room: np.ndarray, place_room: np.ndarray, slots_room: np.ndarray,
                      ends_room: np.ndarray, used_room: np.ndarray, start_room: np.ndarray,
                      body_room: np.ndarray, records: np.ndarray, sides_room: np.ndarray, blocks: np.ndarray,
                      first: np.ndarray, order: np.ndarray, tally: np.ndarray, waves: np.ndarray,
                      ordered: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row, in place, the rows ``groups[i]`` to ``groups[i + 1]`` stepped
    together (``step_rows``), the groups ``chunks[t]`` to ``chunks[t + 1]`` one after the other on one thread;
    ``keys``, ``carried`` and ``held`` carry each row's points and impulses from one step (and one call) to
    the next; ``applied`` gets what each step applied (``stackx.solvers.planar.applied``) when it has room
    for them (``watch_impulses``), else nothing; the ``kept_`` arrays (``kept.Kept``) carry the contacts
    found where a call ends to the next call, and are the tables each row's steps find their contacts in.

    Thread ``t`` steps its chunk with its own impulses ``impulses_room[t, r]``, lanes ``wave_room[t]`` to
    ``used_room[t]``, body rows ``start_room[t]``, ``body_room[t]`` and blocks ``records[t]``,
    ``sides_room[t]`` (``Workspace``), grown for the call when they are too small;
    ``blocks[t]`` gets the blocks it stepped in. ``first`` to ``ordered`` hold each row's wave order
    (``WaveOrders``).

    A chunk's groups share one set of impulses, lanes, body rows and blocks: memory taken afresh for every
    group would be handed back to the system and faulted in again page by page, which on 64 rows of a
    20-row pyramid cost about a tenth of a step."""
    for t in prange(chunks.shape[0] - 1):
        most = 1
        for i in range(chunks[t], chunks[t + 1]):
            most = max(most, groups[i + 1] - groups[i])
        impulses_of = [impulses_room[t, r] for r in range(most)]
        record, sides = records[t], sides_room[t]
        for i in range(chunks[t], chunks[t + 1]):
            lo, hi = groups[i], groups[i + 1]
            record, sides = step_rows(lo, hi, x, y, angle, vx, vy, w, inv_mass, inv_inertia, hx, hy, friction, g,
                                      dt, substeps, hertz, damping_ratio, push_out, relax, warm, speculative, keys,
                                      carried, held, applied, kept_ids, kept_points, kept_count, kept_at, kept_near,
                                      kept_fat, last, peak, reach, touched, launch, impulses_of,
                                      wave_room[t], place_room[t], slots_room[t], ends_room[t], used_room[t],
                                      start_room[t], body_room[t], record, sides, first[lo:hi], order[lo:hi],
                                      tally[lo:hi], waves[lo:hi], ordered[lo:hi], steps)
        blocks[t] = sides.shape[0] // LANES


@kernel
def step_rows(lo: int, hi: int, x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
              w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray, hy: np.ndarray,
              friction: np.ndarray, g: np.ndarray, dt: np.ndarray, substeps: np.ndarray, hertz: np.ndarray,
              damping_ratio: np.ndarray, push_out: np.ndarray, relax: np.ndarray, warm: np.ndarray,
              speculative: np.ndarray, keys: np.ndarray, carried: np.ndarray, held: np.ndarray,
              applied: np.ndarray, kept_ids: np.ndarray, kept_points: np.ndarray, kept_count: np.ndarray,
              kept_at: np.ndarray, kept_near: np.ndarray, kept_fat: np.ndarray, last: np.ndarray, peak: np.ndarray,
              reach: np.ndarray, touched: np.ndarray, launch: np.ndarray, impulses_of: list[np.ndarray],
              wave: np.ndarray, place: np.ndarray, slots: np.ndarray, ends: np.ndarray, used: np.ndarray,
              start: np.ndarray, bodies: np.ndarray, record: np.ndarray, sides: np.ndarray, first: np.ndarray,
              order: np.ndarray, tally: np.ndarray, waves: np.ndarray, ordered: np.ndarray,
              steps: int) -> tuple[np.ndarray, np.ndarray]:
    """``steps`` steps of rows ``lo`` to ``hi``, which share their substep, number of substeps, relax and
    push-out (``row_groups``): each row finds, recalls and orders its contacts alone, and the passes run over
    one layout of all the rows' manifolds, the rows' bodies one after the other in the bodies' rows
    (``wide.place_waves``). A row's manifolds and bodies meet no other row's, so every number is the one
    stepping the row alone gives; a pass over several worlds keeps more independent visits in flight (a
    pass over one pyramid waits on its chain of waves). Row ``b`` finds its contacts in its own table
    ``kept_ids[b]``, ``kept_points[b]`` (``kept.Kept``; replaced for the call by a larger one when its points
    outgrow it) and recalls their impulses into ``impulses_of[r]`` (the same); its lanes are row ``r`` of
    ``wave``, ``place``, ``slots`` (``lane_workspace``'s, for ``GROUP`` rows: the same again), its bodies'
    rows ``start`` (where each was when the step began) and ``bodies`` from ``r`` times the boxes on, the
    ground's the last row of ``bodies``; the blocks are ``record`` and ``sides`` (``wide.block_workspace``),
    grown when too small; returns the blocks. The rows'
    wave orders are ``first`` to ``ordered`` (``WaveOrders``), replaced for the call by room for more when
    a row's points outgrow them (and then marked as none when it ends)."""
    worlds = hi - lo
    n = x.shape[1]
    h = dt[lo] / substeps[lo]
    softness = np.empty((worlds, 2, 3))
    for r in range(worlds):
        b = lo + r
        contact_hertz = min(hertz[b], SUBSTEP_HERTZ / h)
        softness[r, 0, 0], softness[r, 0, 1], softness[r, 0, 2] = soft(contact_hertz, damping_ratio[b], h)
        softness[r, 1, 0], softness[r, 1, 1], softness[r, 1, 2] = soft(STATIC_HERTZ * contact_hertz,
                                                                       damping_ratio[b], h)
    ids_of = [kept_ids[lo + r] for r in range(worlds)]  # each row's own table (``kept``)
    table_of = [kept_points[lo + r] for r in range(worlds)]
    near_of = [kept_near[lo + r] for r in range(worlds)]  # the broad phase's candidates, kept while the
    fat_of = [kept_fat[lo + r] for r in range(worlds)]  # boxes stay near (``find_contacts_near``)
    count = np.empty(worlds, np.int64)
    # the counts the workspaces and passes are sized by start as int64, not as the literal 0: numba types a loop in
    # rounds and asks for each kernel called with such a count at every round, so a literal 0 built every pass and
    # workspace kernel a second time, for a value no call passes (two fifths of the soft step's first compile)
    room = np.int64(0)
    for r in range(worlds):
        room = max(room, ids_of[r].shape[0])
    kept_orders = True  # whether the orders are the ones kept for the next call
    latest = np.empty(n, np.int64)
    ground = bodies.shape[0] - 1
    for r in range(worlds):
        b = lo + r
        count[r] = take_back(x[b], y[b], angle[b], hx[b], hy[b], inv_mass[b], kept_count[b], kept_at[b],
                             near_of[r])
        kept_count[b] = -1  # the table is this call's until it ends (``keep``)
        if count[r] < 0:
            ids_of[r], table_of[r], count[r], near_of[r] = find_contacts_near(
                x[b], y[b], angle[b], hx[b], hy[b], inv_mass[b], speculative[b], near_of[r], fat_of[r], ids_of[r],
                table_of[r])
    watched = applied.shape[1] > 0  # the step's impulses are summed only for a caller that reads them
    laid = False  # whether the blocks hold the last step's layout
    for _ in range(steps):
        most = np.int64(0)
        kept_pairs = True  # whether every row's manifolds are the last step's, in the same order
        for r in range(worlds):
            room = max(room, ids_of[r].shape[0])
        if order.shape[1] < room or wave.shape[1] < room:
            ordered[:] = -1
            first, order, tally = order_workspace(room, worlds)
            wave, place, slots, ends, used = lane_workspace(room, worlds)
            kept_orders = False
        for r in range(worlds):
            b, ids = lo + r, ids_of[r]
            if impulses_of[r].shape[0] < count[r]:  # the points outgrew the room: as large as their table
                impulses_of[r] = np.empty((ids.shape[0], 2))
            if warm[b]:  # the impulses recalled, and whether the points' pairs are the last step's
                same = recall_impulses(ids, count[r], keys[b], carried[b], held[b], impulses_of[r])
            else:
                same = same_pairs(ids, count[r], keys[b], held[b])
                impulses_of[r][:count[r]] = 0.0
            # the last step's pairs again (a pile at rest): the same manifolds, so the wave order found for them
            same = same and ordered[r] == count[r]
            kept_pairs = kept_pairs and same
            if not same:
                m = manifold_starts(ids, count[r], first[r])
                waves[r] = wavefronts(ids, first[r], m, latest, wave[r], tally[r], order[r])
                ordered[r] = count[r]
            most = max(most, waves[r])
        blocks = place_waves(tally, waves, most, place, used, ends)
        if sides.shape[0] < blocks * LANES:
            record, sides = block_workspace(blocks + blocks // 2)
            laid = False
        for r in range(worlds):  # the same manifolds in the same lanes: what depends on the pairs alone is there
            b = lo + r
            lay_out(x[b], y[b], inv_mass[b], inv_inertia[b], friction[b], ids_of[r], table_of[r], impulses_of[r],
                    first[r], order[r], waves[r], tally[r], softness[r], place[r], r * n, ground,
                    not (laid and kept_pairs), sides, slots[r], record)
        laid = True
        for v in range(most):
            empty_lanes(record, sides, used[v], ends[v] * LANES, ground)
        effective_masses(record, np.uint64(blocks))
        load_bodies(x, y, angle, vx, vy, w, lo, hi, start, bodies)
        if watched:
            for r in range(worlds):
                clear_applied(applied[lo + r], count[r])
        still_ground(bodies)
        for i in range(substeps[lo]):
            body_gravity(bodies, inv_mass, g, lo, hi, h)
            warm_start(bodies, sides, record, most, ends)
            # the layout measured the separations where the step begins, and the relax pass where the boxes
            # still are
            soft_pass(bodies, sides, record, most, ends, h, True, push_out[lo], i > 0 and not relax[lo])
            integrate_moved(x, y, angle, lo, hi, bodies, start, h)
            if relax[lo]:
                soft_pass(bodies, sides, record, most, ends, h, False, push_out[lo], True)
            if watched:
                for r in range(worlds):
                    add_applied(slots[r], count[r], record, applied[lo + r])
        store_velocities(bodies, lo, hi, vx, vy, w)
        for r in range(worlds):
            b = lo + r
            held[b] = remember_laid(ids_of[r], count[r], slots[r], record, keys[b], carried[b])
            # where the step ended: the contacts of its monitors and of the next step (``observed_contacts``)
            ids_of[r], table_of[r], count[r], near_of[r] = find_contacts_near(
                x[b], y[b], angle[b], hx[b], hy[b], inv_mass[b], speculative[b], near_of[r], fat_of[r], ids_of[r],
                table_of[r])
            observe_contacts(x[b], y[b], angle[b], hx[b], hy[b], inv_mass[b], speculative[b], ids_of[r],
                             table_of[r], count[r], dt[b], last, peak, reach, touched, launch, b)
    for r in range(worlds):
        b = lo + r
        kept_count[b] = keep(x[b], y[b], angle[b], hx[b], hy[b], inv_mass[b], ids_of[r], table_of[r], count[r],
                             near_of[r], fat_of[r], kept_ids[b], kept_points[b], kept_at[b], kept_near[b],
                             kept_fat[b])
    if not kept_orders:  # found in room made for this call: none kept for the next
        ordered[:] = -1
    return record, sides


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
        self.kept: Kept | None = None  # per row, the contacts found where the last call ended (kept.py)
        self.work: Workspace | None = None  # per thread, the impulses, lanes and blocks the calls step in
        self.orders: WaveOrders | None = None  # per row, the wave order of its last step

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

    def remove_box(self, state: PlanarState, box: int) -> None:
        """``PlanarMemorySolver``'s, and the kept contacts and wave orders forgotten: the boxes after ``box``
        are renumbered."""
        super().remove_box(state, box)
        self.kept = None
        self.orders = None

    def advance(self, state: PlanarState, steps: int) -> None:
        s = state
        keys, carried, held = self.memory(state)
        room = keys.shape[1] if self.watched else 0
        if self.applied is None or self.applied.shape[:2] != (keys.shape[0], room):
            self.applied = np.zeros((keys.shape[0], room, 2))
        if self.kept is None or not self.kept.fits(s.batch, s.bodies, keys.shape[1]):
            self.kept = Kept(s.batch, s.bodies, keys.shape[1])
        groups = self.row_groups(s.x)
        threads = spread(s.x)  # the groups split evenly over the threads, as numba splits a prange
        chunks = (np.arange(threads + 1) * (len(groups) - 1)) // threads
        if self.work is None or not self.work.fits(threads, keys.shape[1], s.bodies):
            self.work = Workspace(threads, keys.shape[1], s.bodies)
        if self.orders is None or not self.orders.fits(s.batch, keys.shape[1]):
            self.orders = WaveOrders(s.batch, keys.shape[1])
        soft_step_advance(s.x, s.y, s.angle, s.vx, s.vy, s.w, s.inv_mass, s.inv_inertia, s.hx, s.hy, s.friction,
                          self.gravity, self.dt, self.substeps, self.hertz, self.damping_ratio, self.push_out,
                          self.relax, self.warm, self.speculative, keys, carried, held, self.applied,
                          *self.kept.arrays(), *s.monitors(), groups, chunks, *self.work.arrays(),
                          *self.orders.arrays(), steps)
        self.work.grow()

    def row_groups(self, x: np.ndarray) -> np.ndarray:
        """Which rows ``soft_step_advance`` steps together: runs of consecutive rows, at most ``GROUP`` and no
        more than leaves every thread a group (``kernel.spread``), that share the substep, number of
        substeps, relax and push-out, so their passes can run as one; the boundaries, from 0 to the batch.
        Each row's knobs are compared as one tuple of Python numbers: numpy's scalars made this walk cost a
        call of one step of 64 rows about a percent."""
        batch = x.shape[0]
        size = max(1, min(GROUP, batch // spread(x)))
        knobs = list(zip((self.dt / self.substeps).tolist(), self.substeps.tolist(), self.relax.tolist(),
                         self.push_out.tolist()))
        bounds = [0]
        for b in range(1, batch):
            lead = bounds[-1]
            if b - lead >= size or knobs[b] != knobs[lead]:
                bounds.append(b)
        bounds.append(batch)
        return np.array(bounds, np.int64)
