"""TGS sticky on planar boxes (Solver2D's ``TGS_Sticky``): substeps of rigid contacts with Baumgarte bias, and
static friction as a position constraint on anchors held where the contact first touched.

Each contact point has two pairs of anchors. Its **contact anchors** are found with the point every step
(``contacts.prepare``). Its **friction anchors** are two material points, one on each body, that were one point
when the contact began: the first step a point touches, they are the contact point itself, fixed in both
bodies' frames; while the point keeps sticking they are kept from step to step (by ``(A, B, FEATURE)``, with
the point's normal in A's frame and the bodies' turn against each other), so a slow creep of the contact
point within each step does not move them. A manifold's friction anchors are let go, and taken afresh at the
contact points, when any point of it slid (its friction reached its bound) in the last step, when a point is
new, when the bodies turned more than about 11 degrees against each other (the kept normals' cosine below
0.98), or when a friction anchor pair has come more than ``2 slop`` apart along the normal.

Per step, with no warm start (impulses start from 0), ``substeps`` times with ``h = dt / substeps``:

1. gravity;
2. one pass, manifold by manifold: normals at the contact anchors as they are now, the separation measured
   from how far the bodies moved and turned (``substep.separation``), a rigid target: a point apart may
   close its gap within the substep, an overlapping one is pushed out at ``contact_baumgarte`` times its
   depth per substep, at most ``push_out``; then friction at the friction anchors as they are now: the
   tangential distance between the two anchored points, times ``friction_baumgarte`` per substep, is asked
   back as a sliding speed, and the accumulated friction impulse is held within ``mu`` times the manifold's
   normal impulse shared evenly over its points (Solver2D: half of the sum of two points', since friction
   anchors need not sit where the normal impulses act); reaching that bound marks the manifold as sliding;
3. positions and angles move with the velocities.

Then ``relax_iterations`` passes of the same without bias, on velocities only (the positions stay). Solver2D
measures their separations after dropping the step's translation but keeping its turn; here they are measured
where the boxes are. Solver2D's defaults, the defaults here: 4 substeps, 2 relax passes, Baumgarte 0.8 for
contacts and 0.5 for friction, 4 m/s push-out (its largest Baumgarte speed), slop 0.005 m.

Not a knob of another solver: no other holds friction anchors between steps. What it trades: a box below its
friction angle is held to its anchors and does not creep (a velocity-level friction lets a little slip through
every step, which adds up), at the cost of rigid contacts with no memory of their load: each step rebuilds it
from zero within its substeps, so tall stacks sag and bounce more than under warm-started solvers.

``step_impulses`` is None: friction acts at anchors that are not the contact points, and all impulses at
anchors that turn within the step.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from stackx.kernel import kernel, leaf, prange
from stackx.models.planar.state import PlanarState
from stackx.registry import solvers
from stackx.solvers.contacts import speculative_field
from stackx.solvers.planar.base import PlanarMemorySolver, StepImpulses
from stackx.solvers.planar.contacts import (A, B, FEATURE, KN, KT, MU, NX, NY, PN, PT, PX, PY, RAX, RAY, RBX, RBY,
                                            apply_impulse, contact_workspace, effective_mass, find_contacts,
                                            gravity, observed_contacts, recall_impulses, relative_velocity)
from stackx.solvers.planar.substep import separation
from stackx.solvers.planar.tgs_soft import begin_step, move_bodies
from stackx.solvers.planar.wavefront import manifold_end

# what a point's friction anchors keep between steps: the anchors in A's and B's frames, the normal in A's
# frame, B's angle less A's when they were taken, and whether the point still sticks (1) or not (0)
LAX, LAY, LBX, LBY, LNAX, LNAY, TURN, STICKS = range(8)
KEPT = 8
ALIGNED = 0.98  # kept anchors are let go when the bodies' kept normals' cosine falls below this (Solver2D)


class PlanarTGSStickyParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    substeps: int = Field(4, gt=0, le=10_000,
                          description="substeps per step, each one pass with bias (Solver2D: 4): more make "
                                      "contacts firmer and friction anchors hold closer, at linear cost")
    relax_iterations: int = Field(2, ge=0, le=10_000,
                                  description="passes without bias after the substeps, on velocities only "
                                              "(Solver2D: 2): take back the push-out speed the bias gave; 0 "
                                              "keeps it (boxes pop off overlaps)")
    contact_baumgarte: float = Field(0.8, gt=0, le=1, allow_inf_nan=False,
                                     description="share of an overlap a substep asks to push out: high recovers "
                                                 "fast, near 1 overshoots and jitters")
    friction_baumgarte: float = Field(0.5, ge=0, le=1, allow_inf_nan=False,
                                      description="share of the friction anchors' tangential distance a substep "
                                                  "asks back: 0 makes friction a velocity constraint again "
                                                  "(creeps), high snaps back and jitters")
    push_out: float = Field(4.0, gt=0, allow_inf_nan=False,
                            description="largest separating speed the bias may ask for (m/s): keeps a deep "
                                        "overlap from launching boxes, at the cost of a slower recovery")
    slop: float = Field(0.005, ge=0, allow_inf_nan=False,
                        description="kept friction anchors are let go when they have come more than twice this "
                                    "apart along the normal (m): small re-anchors often, large keeps anchors "
                                    "across small bounces")
    speculative: float = speculative_field(0.02)


@leaf
def rotate(c: float, s: float, x: float, y: float) -> tuple[float, float]:
    """``(x, y)`` turned by the angle whose cosine and sine are ``c``, ``s``."""
    return c * x - s * y, s * x + c * y


@leaf
def kept_still(x: np.ndarray, y: np.ndarray, angle: np.ndarray, a: int, b: int, kept: np.ndarray, k: int,
               slop: float) -> bool:
    """Whether point ``k``'s kept friction anchors (``kept[k]``, recalled) still hold: it stuck, the bodies
    turned little against each other since, and the anchored points are within ``2 slop`` along the normal
    turned with A."""
    if kept[k, STICKS] != 1.0:
        return False
    ta = angle[a] if a >= 0 else 0.0
    if np.cos(angle[b] - ta - kept[k, TURN]) < ALIGNED:
        return False
    ca, sa = np.cos(ta), np.sin(ta)
    cb, sb = np.cos(angle[b]), np.sin(angle[b])
    ax, ay = rotate(ca, sa, kept[k, LAX], kept[k, LAY])
    bx, by = rotate(cb, sb, kept[k, LBX], kept[k, LBY])
    nx, ny = rotate(ca, sa, kept[k, LNAX], kept[k, LNAY])
    ox, oy = x[b] + bx - ax, y[b] + by - ay
    if a >= 0:
        ox, oy = ox - x[a], oy - y[a]
    return abs(ox * nx + oy * ny) <= 2.0 * slop


@leaf
def fresh_anchors(x: np.ndarray, y: np.ndarray, angle: np.ndarray, ids: np.ndarray, table: np.ndarray, k: int,
                  kept: np.ndarray) -> None:
    """Point ``k``'s friction anchors taken at its contact point, in both bodies' frames (the ground's is the
    world's), with its normal in A's frame and the bodies' turn, sticking."""
    a, b = ids[k, A], ids[k, B]
    px, py, nx, ny = table[k, PX], table[k, PY], table[k, NX], table[k, NY]
    ta, xa, ya = (angle[a], x[a], y[a]) if a >= 0 else (0.0, 0.0, 0.0)
    ca, sa = np.cos(ta), np.sin(ta)
    cb, sb = np.cos(angle[b]), np.sin(angle[b])
    kept[k, LAX], kept[k, LAY] = rotate(ca, -sa, px - xa, py - ya)
    kept[k, LBX], kept[k, LBY] = rotate(cb, -sb, px - x[b], py - y[b])
    kept[k, LNAX], kept[k, LNAY] = rotate(ca, -sa, nx, ny)
    kept[k, TURN] = angle[b] - ta
    kept[k, STICKS] = 1.0


@leaf
def take_anchors(x: np.ndarray, y: np.ndarray, angle: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
                 ids: np.ndarray, table: np.ndarray, count: int, kept: np.ndarray, slop: float,
                 grip: np.ndarray) -> None:
    """Each manifold's friction anchors for the step: the kept ones (``kept``, recalled) when every point of
    it still holds (``kept_still``), else fresh ones at the contact points; into ``grip``, a copy of the
    step's table whose anchor columns are the friction anchors relative to the centres (so the shared
    velocity and impulse stages act there) and whose ``KT`` is the tangent mass at them."""
    first = 0
    while first < count:
        end = manifold_end(ids, first, count)
        a, b = ids[first, A], ids[first, B]
        holds = True
        for k in range(first, end):
            holds = holds and kept_still(x, y, angle, a, b, kept, k, slop)
        ta = angle[a] if a >= 0 else 0.0
        ca, sa = np.cos(ta), np.sin(ta)
        cb, sb = np.cos(angle[b]), np.sin(angle[b])
        ima, iia = (inv_mass[a], inv_inertia[a]) if a >= 0 else (0.0, 0.0)
        for k in range(first, end):
            if not holds:
                fresh_anchors(x, y, angle, ids, table, k, kept)
            for c in range(table.shape[1]):
                grip[k, c] = table[k, c]
            grip[k, RAX], grip[k, RAY] = rotate(ca, sa, kept[k, LAX], kept[k, LAY])
            grip[k, RBX], grip[k, RBY] = rotate(cb, sb, kept[k, LBX], kept[k, LBY])
            grip[k, KT] = effective_mass(ima, iia, grip[k, RAX], grip[k, RAY], inv_mass[b], inv_inertia[b],
                                         grip[k, RBX], grip[k, RBY], -table[k, NY], table[k, NX])
        first = end


@leaf
def sticky_normal(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
                  ids: np.ndarray, now: np.ndarray, k: int, s: float, h: float, use_bias: bool, baumgarte: float,
                  push_out: float) -> None:
    """Point ``k``'s rigid normal visit at separation ``s``: apart, it may close its gap within ``h``;
    overlapping and ``use_bias``, pushed out at ``baumgarte * depth / h``, at most ``push_out``; otherwise no
    approach. The accumulated total is kept >= 0."""
    nx, ny = now[k, NX], now[k, NY]
    target = 0.0
    if s > 0.0:
        target = -s / h
    elif use_bias:
        target = min(-baumgarte * s / h, push_out)
    old = now[k, PN]
    total = max(old + now[k, KN] * (target - relative_velocity(vx, vy, w, ids, now, k, nx, ny)), 0.0)
    now[k, PN] = total
    apply_impulse(vx, vy, w, inv_mass, inv_inertia, ids, now, k, (total - old) * nx, (total - old) * ny)


@leaf
def drift(x: np.ndarray, y: np.ndarray, ids: np.ndarray, grip: np.ndarray, k: int) -> float:
    """How far point ``k``'s friction anchor on B is from the one on A along the tangent ``(-ny, nx)`` (m),
    the anchors as they are now."""
    a, b = ids[k, A], ids[k, B]
    ox, oy = x[b] + grip[k, RBX], y[b] + grip[k, RBY]
    if a >= 0:
        ox, oy = ox - x[a] - grip[k, RAX], oy - y[a] - grip[k, RAY]
    else:
        ox, oy = ox - grip[k, RAX], oy - grip[k, RAY]
    return -ox * grip[k, NY] + oy * grip[k, NX]


@leaf
def sticky_friction(x: np.ndarray, y: np.ndarray, vx: np.ndarray, vy: np.ndarray, w: np.ndarray,
                    inv_mass: np.ndarray, inv_inertia: np.ndarray, ids: np.ndarray, grip: np.ndarray, k: int,
                    limit: float, h: float, use_bias: bool, baumgarte: float) -> bool:
    """Point ``k``'s friction visit at its friction anchors (``grip``): the tangential speed that stops the
    anchors and, with ``use_bias``, brings back ``baumgarte`` of their distance in ``h``; the accumulated
    total (``grip``'s ``PT``) held within ``limit``. Returns whether it reached the limit (the point slides)."""
    nx, ny = grip[k, NX], grip[k, NY]
    bias = baumgarte * drift(x, y, ids, grip, k) / h if use_bias else 0.0
    old = grip[k, PT]
    total = old - grip[k, KT] * (relative_velocity(vx, vy, w, ids, grip, k, -ny, nx) + bias)
    slides = total < -limit or total > limit
    total = min(max(total, -limit), limit)
    grip[k, PT] = total
    apply_impulse(vx, vy, w, inv_mass, inv_inertia, ids, grip, k, -(total - old) * ny, (total - old) * nx)
    return slides


@leaf
def sticky_pass(x: np.ndarray, y: np.ndarray, vx: np.ndarray, vy: np.ndarray, w: np.ndarray,
                inv_mass: np.ndarray, inv_inertia: np.ndarray, ids: np.ndarray, table: np.ndarray,
                now: np.ndarray, grip: np.ndarray, count: int, base: np.ndarray, since: np.ndarray, h: float,
                use_bias: bool, contact_baumgarte: float, friction_baumgarte: float, push_out: float,
                kept: np.ndarray) -> None:
    """One pass over the manifolds in table order: each manifold's normals (``sticky_normal``), then its
    frictions (``sticky_friction``) within ``mu`` times its points' mean normal impulse; a manifold whose
    friction reached that bound is marked in ``kept`` as no longer sticking."""
    first = 0
    while first < count:
        end = manifold_end(ids, first, count)
        pressed = 0.0
        for k in range(first, end):
            s = separation(ids, table, base, since, k)
            sticky_normal(vx, vy, w, inv_mass, inv_inertia, ids, now, k, s, h, use_bias, contact_baumgarte,
                          push_out)
            pressed += now[k, PN]
        limit = now[first, MU] * pressed / (end - first)
        for k in range(first, end):
            if sticky_friction(x, y, vx, vy, w, inv_mass, inv_inertia, ids, grip, k, limit, h, use_bias,
                               friction_baumgarte):
                for j in range(first, end):
                    kept[j, STICKS] = 0.0
        first = end


@leaf
def turn_grip(ids: np.ndarray, held: np.ndarray, since: np.ndarray, count: int, grip: np.ndarray) -> None:
    """Every point's friction anchors in ``grip`` turned as its bodies have turned since the step began
    (``held``: the anchors where the step began)."""
    for k in range(count):
        a, b = ids[k, A], ids[k, B]
        grip[k, RBX], grip[k, RBY] = rotate(since[b, 2], since[b, 3], held[k, RBX], held[k, RBY])
        if a >= 0:
            grip[k, RAX], grip[k, RAY] = rotate(since[a, 2], since[a, 3], held[k, RAX], held[k, RAY])


@leaf
def recall_anchors(ids: np.ndarray, count: int, keys: np.ndarray, carried: np.ndarray, held: int,
                   kept: np.ndarray) -> None:
    """Each point's kept friction anchors from the last step's point with the same ``(A, B, FEATURE)``
    (``contacts.recall_impulses``, two columns at a time), zeros (not sticking) for a new point."""
    for c in range(0, KEPT, 2):
        recall_impulses(ids, count, keys, carried[:, c:c + 2], held, kept[:, c:c + 2])


@leaf
def remember_anchors(ids: np.ndarray, count: int, kept: np.ndarray, keys: np.ndarray, carried: np.ndarray) -> int:
    """This step's points and friction anchors kept for the next (as many as the memory holds)."""
    held = min(count, keys.shape[0])
    for k in range(held):
        keys[k, 0], keys[k, 1], keys[k, 2] = ids[k, A], ids[k, B], ids[k, FEATURE]
        for c in range(KEPT):
            carried[k, c] = kept[k, c]
    return held


@kernel
def tgs_sticky_advance(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                       w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray,
                       hy: np.ndarray, friction: np.ndarray, g: np.ndarray, dt: np.ndarray, substeps: np.ndarray,
                       relax_iterations: np.ndarray, contact_baumgarte: np.ndarray,
                       friction_baumgarte: np.ndarray, push_out: np.ndarray, slop: np.ndarray,
                       speculative: np.ndarray, keys: np.ndarray, carried: np.ndarray, held: np.ndarray,
                       last: np.ndarray, peak: np.ndarray, reach: np.ndarray, touched: np.ndarray,
                       launch: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row, in place; ``keys``, ``carried`` (the friction anchors) and ``held``
    carry over."""
    for b in prange(x.shape[0]):
        xb, yb, ab, vxb, vyb, wb = x[b], y[b], angle[b], vx[b], vy[b], w[b]  # the row's views, made once
        im, ii, hxb, hyb, mub = inv_mass[b], inv_inertia[b], hx[b], hy[b], friction[b]
        n = x.shape[1]
        h = dt[b] / substeps[b]
        ids, table = contact_workspace(keys.shape[1])
        ids, table, count = find_contacts(xb, yb, ab, hxb, hyb, im, speculative[b], ids, table)
        now, grip, held_grip = table.copy(), table.copy(), table.copy()
        base, kept = np.empty(table.shape[0]), np.empty((table.shape[0], KEPT))
        start, since = np.empty((n, 3)), np.empty((n, 4))
        for _ in range(steps):
            if now.shape[0] < table.shape[0]:  # the table grew
                now, grip, held_grip = table.copy(), table.copy(), table.copy()
                base, kept = np.empty(table.shape[0]), np.empty((table.shape[0], KEPT))
            begin_step(xb, yb, ab, im, ii, mub, ids, table, count, False, keys[b], carried[b], held[b], base,
                       start, since, now)
            recall_anchors(ids, count, keys[b], carried[b], held[b], kept)
            take_anchors(xb, yb, ab, im, ii, ids, table, count, kept, slop[b], held_grip)
            grip[:count] = held_grip[:count]
            for _ in range(substeps[b]):
                gravity(vyb, im, g[b], h)
                sticky_pass(xb, yb, vxb, vyb, wb, im, ii, ids, table, now, grip, count, base, since, h, True,
                            contact_baumgarte[b], friction_baumgarte[b], push_out[b], kept)
                move_bodies(xb, yb, ab, vxb, vyb, wb, h, ids, table, count, start, since, now)
                turn_grip(ids, held_grip, since, count, grip)
            for _ in range(relax_iterations[b]):
                sticky_pass(xb, yb, vxb, vyb, wb, im, ii, ids, table, now, grip, count, base, since, h, False,
                            contact_baumgarte[b], friction_baumgarte[b], push_out[b], kept)
            held[b] = remember_anchors(ids, count, kept, keys[b], carried[b])
            ids, table, count = observed_contacts(xb, yb, ab, hxb, hyb, im, speculative[b], ids, table, dt[b],
                                                  last, peak, reach, touched, launch, b)


@solvers.register("planar-tgs-sticky")
class PlanarTGSSticky(PlanarMemorySolver):
    """Substepped rigid contacts whose static friction holds anchors where the contact first touched
    (Solver2D's TGS sticky)."""

    Params = PlanarTGSStickyParams
    carried_values = KEPT  # each point's friction anchors instead of impulses

    def __init__(self, params: list[PlanarTGSStickyParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.substeps = self.counts("substeps")
        self.relax_iterations = self.counts("relax_iterations")
        self.contact_baumgarte = self.column("contact_baumgarte")
        self.friction_baumgarte = self.column("friction_baumgarte")
        self.push_out = self.column("push_out")
        self.slop = self.column("slop")
        self.speculative = self.column("speculative")

    @classmethod
    def passes(cls, params: PlanarTGSStickyParams) -> int:
        return params.substeps + params.relax_iterations

    def step_impulses(self, b: int) -> StepImpulses | None:
        """None: friction acts at anchors that are not the contact points (see the module text)."""
        return None

    def advance(self, state: PlanarState, steps: int) -> None:
        s = state
        tgs_sticky_advance(s.x, s.y, s.angle, s.vx, s.vy, s.w, s.inv_mass, s.inv_inertia, s.hx, s.hy,
                           s.friction, self.gravity, self.dt, self.substeps, self.relax_iterations,
                           self.contact_baumgarte, self.friction_baumgarte, self.push_out, self.slop,
                           self.speculative, *self.memory(state), *s.monitors(), steps)
