"""TGS soft on planar boxes (Solver2D's ``TGS_Soft``): the soft step with anchors that turn with their bodies.

Contacts are found once per step, within ``speculative`` of touching, each point with its anchors, its normal
and tangent effective masses (``contacts.prepare``) and its separation when found; impulses carried over by
``(A, B, FEATURE)`` when ``warm_start``. Then ``substeps`` times with ``h = dt / substeps``:

1. gravity: every movable box gains ``g h``;
2. warm start: every point's accumulated impulses applied at its anchors **as they are now**;
3. solve, manifold by manifold, normals then friction: each point's separation measured from how far its
   bodies moved and turned since the step began (``substep.separation``, the normal held); an overlapping
   point is a soft spring of ``contact_hertz`` (twice it with a static side) and ``damping_ratio``, its
   push-out speed capped at ``push_out``; a point still apart may close its gap within the substep; friction
   within ``mu`` times the point's normal impulse. Velocities are read and impulses applied at the anchors
   turned with the bodies;
4. positions and angles move with the velocities; the anchors turn with them;
5. relax (``relax``): the same pass without the spring's bias, so the push-out speed leaves the boxes.

**How it differs from ``planar-soft-step``.** The stages, their order and where relax, restitution (0) and
warm start happen are the same: warm start at the start of every substep, relax after every position update,
impulses kept for the next step at its end. The one difference is the lever arms of the velocity solve and of
the warm start: the soft step (Solver2D's ``SoftStep``, Box2D v3) applies impulses and reads velocities at the
anchors of the step's start, fixed for the step, and turns them only to measure separations; TGS soft turns
them with the bodies at every visit (Solver2D: "uses updated anchors"). A box that turns little within a step
sees no difference; one spinning fast (a tumbling box, a rolling wheel) does: the fixed arms keep a rolling
contact's direction steady, the turned ones follow the material point. No knob of the soft step gives this,
so it is a solver of its own; its knobs are the soft step's, with its defaults (4 substeps, 30 Hz capped at an
eighth of the substep rate as there, damping ratio 10, push-out 3 m/s, relax on). Solver2D's TGS_Soft caps the
frequency at a quarter of the substep rate (at 4 substeps of 1/240 s neither cap is reached) and the push-out
at 4 m/s. Each point is visited one at a time in table order, without the soft step's lanes or kept contacts:
on a 10-row pyramid a step costs about four times the soft step's.

``step_impulses`` is None: the impulses act at arms that turn within the step, so no one impulse on the
step's contact problem gives the velocities; the bench checks what the velocities alone show.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import kernel, leaf, prange
from stackx.models.planar.state import PlanarState
from stackx.registry import solvers
from stackx.solvers.planar.base import PlanarMemorySolver, StepImpulses
from stackx.solvers.planar.contacts import (A, B, KN, NX, NY, PN, apply_impulse, contact_workspace,
                                            find_contacts, friction_visit, gravity, integrate_positions,
                                            observed_contacts, prepare, recall, relative_velocity, remember,
                                            warm_start)
from stackx.solvers.planar.soft_step import SUBSTEP_HERTZ, PlanarSoftStepParams
from stackx.solvers.planar.substep import base_separations, moved, separation, step_start
from stackx.solvers.planar.wavefront import manifold_end
from stackx.solvers.planar.xpbd import current_anchors
from stackx.solvers.column.soft_step import STATIC_HERTZ, soft


class PlanarTGSSoftParams(PlanarSoftStepParams):
    """The soft step's knobs and defaults (substeps, contact hertz, damping ratio, push-out, relax, warm
    start, speculative): the two solvers differ in where impulses act, not in their knobs."""


@leaf
def begin_step(x: np.ndarray, y: np.ndarray, angle: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
               friction: np.ndarray, ids: np.ndarray, table: np.ndarray, count: int, warm: bool, keys: np.ndarray,
               carried: np.ndarray, held: int, base: np.ndarray, start: np.ndarray, since: np.ndarray,
               now: np.ndarray) -> None:
    """What a substepped step finds once: anchors, masses and friction (``prepare``), the impulses carried
    over (``recall``, when ``warm``), each point's separation less its anchors (``base_separations``), where
    every body starts, and ``now``: the table the substeps work in, its anchors turned as the bodies turn."""
    prepare(x, y, inv_mass, inv_inertia, friction, ids, table, count)
    if warm:
        recall(ids, table, count, keys, carried, held)
    base_separations(ids, table, count, base)
    step_start(x, y, angle, start, since)
    for k in range(count):
        for c in range(table.shape[1]):
            now[k, c] = table[k, c]


@leaf
def move_bodies(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray, w: np.ndarray,
                h: float, ids: np.ndarray, table: np.ndarray, count: int, start: np.ndarray, since: np.ndarray,
                now: np.ndarray) -> None:
    """Positions and angles moved with the velocities over ``h``, and every point's anchors in ``now`` turned
    as its bodies have turned since the step began."""
    integrate_positions(x, y, angle, vx, vy, w, h)
    turn_anchors(x, y, angle, ids, table, count, start, since, now)


@leaf
def turn_anchors(x: np.ndarray, y: np.ndarray, angle: np.ndarray, ids: np.ndarray, table: np.ndarray, count: int,
                 start: np.ndarray, since: np.ndarray, now: np.ndarray) -> None:
    """Every body's motion since the step began (``substep.moved``) and every point's anchors in ``now``
    turned with it (``xpbd.current_anchors``), after something moved the bodies."""
    moved(x, y, angle, start, since)
    for k in range(count):
        current_anchors(ids, table, since, k, now)


@leaf
def soft_normal(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
                ids: np.ndarray, now: np.ndarray, k: int, s: float, h: float, use_bias: bool, push_out: float,
                softness: np.ndarray) -> None:
    """Point ``k``'s normal visit at separation ``s`` (m) and its current anchors (``now``): apart, it may
    close its gap within ``h``; overlapping and ``use_bias``, a soft spring (``softness`` row 1 when a side
    is static: ``(bias_rate, mass_scale, impulse_scale)``) asks for at most ``push_out``; otherwise no
    approach. The accumulated total is kept >= 0 and the change applied."""
    nx, ny = now[k, NX], now[k, NY]
    target, mass_scale, impulse_scale = 0.0, 1.0, 0.0
    if s > 0.0:
        target = -s / h
    elif use_bias:
        a, b = ids[k, A], ids[k, B]
        row = 1 if a < 0 or inv_mass[a] == 0.0 or inv_mass[b] == 0.0 else 0
        target = min(-softness[row, 0] * s, push_out)
        mass_scale, impulse_scale = softness[row, 1], softness[row, 2]
    un = relative_velocity(vx, vy, w, ids, now, k, nx, ny)
    old = now[k, PN]
    total = max(old + now[k, KN] * mass_scale * (target - un) - impulse_scale * old, 0.0)
    now[k, PN] = total
    apply_impulse(vx, vy, w, inv_mass, inv_inertia, ids, now, k, (total - old) * nx, (total - old) * ny)


@leaf
def tgs_pass(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
             ids: np.ndarray, table: np.ndarray, now: np.ndarray, count: int, base: np.ndarray, since: np.ndarray,
             h: float, use_bias: bool, push_out: float, softness: np.ndarray) -> None:
    """One pass over the manifolds in table order, each manifold's normals (``soft_normal`` at the separation
    measured now) then its frictions (``contacts.friction_visit`` at the current anchors)."""
    first = 0
    while first < count:
        end = manifold_end(ids, first, count)
        for k in range(first, end):
            s = separation(ids, table, base, since, k)
            soft_normal(vx, vy, w, inv_mass, inv_inertia, ids, now, k, s, h, use_bias, push_out, softness)
        for k in range(first, end):
            friction_visit(vx, vy, w, inv_mass, inv_inertia, ids, now, k)
        first = end


@kernel
def softness_of(hertz: float, damping_ratio: float, h: float) -> np.ndarray:
    """The soft coefficients of a substep ``h`` (``column.soft_step.soft``): row 0 between two movable boxes
    at ``hertz`` capped at ``SUBSTEP_HERTZ / h`` (the soft step's cap), row 1 with a static side at
    ``STATIC_HERTZ`` times that."""
    out = np.empty((2, 3))
    contact_hertz = min(hertz, SUBSTEP_HERTZ / h)
    out[0, 0], out[0, 1], out[0, 2] = soft(contact_hertz, damping_ratio, h)
    out[1, 0], out[1, 1], out[1, 2] = soft(STATIC_HERTZ * contact_hertz, damping_ratio, h)
    return out


@kernel
def tgs_soft_advance(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                     w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray, hy: np.ndarray,
                     friction: np.ndarray, g: np.ndarray, dt: np.ndarray, substeps: np.ndarray, hertz: np.ndarray,
                     damping_ratio: np.ndarray, push_out: np.ndarray, relax: np.ndarray, warm: np.ndarray,
                     speculative: np.ndarray, keys: np.ndarray, carried: np.ndarray, held: np.ndarray,
                     last: np.ndarray, peak: np.ndarray, reach: np.ndarray, touched: np.ndarray, launch: np.ndarray,
                     steps: int) -> None:
    """``steps`` steps of every batch row, in place; ``keys``, ``carried`` and ``held`` carry over."""
    for b in prange(x.shape[0]):
        xb, yb, ab, vxb, vyb, wb = x[b], y[b], angle[b], vx[b], vy[b], w[b]  # the row's views, made once
        im, ii, hxb, hyb, mub = inv_mass[b], inv_inertia[b], hx[b], hy[b], friction[b]
        n = x.shape[1]
        h = dt[b] / substeps[b]
        softness = softness_of(hertz[b], damping_ratio[b], h)
        ids, table = contact_workspace(keys.shape[1])
        ids, table, count = find_contacts(xb, yb, ab, hxb, hyb, im, speculative[b], ids, table)
        now, base = table.copy(), np.empty(table.shape[0])
        start, since = np.empty((n, 3)), np.empty((n, 4))
        for _ in range(steps):
            if now.shape[0] < table.shape[0]:  # the table grew
                now, base = table.copy(), np.empty(table.shape[0])
            begin_step(xb, yb, ab, im, ii, mub, ids, table, count, warm[b], keys[b], carried[b], held[b], base,
                       start, since, now)
            for _ in range(substeps[b]):
                gravity(vyb, im, g[b], h)
                warm_start(vxb, vyb, wb, im, ii, ids, now, count)
                tgs_pass(vxb, vyb, wb, im, ii, ids, table, now, count, base, since, h, True, push_out[b], softness)
                move_bodies(xb, yb, ab, vxb, vyb, wb, h, ids, table, count, start, since, now)
                if relax[b]:
                    tgs_pass(vxb, vyb, wb, im, ii, ids, table, now, count, base, since, h, False, push_out[b],
                             softness)
            held[b] = remember(ids, now, count, keys[b], carried[b])
            ids, table, count = observed_contacts(xb, yb, ab, hxb, hyb, im, speculative[b], ids, table, dt[b],
                                                  last, peak, reach, touched, launch, b)


@solvers.register("planar-tgs-soft")
class PlanarTGSSoft(PlanarMemorySolver):
    """Substepped soft contacts with relax, impulses at anchors that turn with the bodies (Solver2D's TGS
    soft)."""

    Params = PlanarTGSSoftParams

    def __init__(self, params: list[PlanarTGSSoftParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.substeps = self.counts("substeps")
        self.hertz = self.column("contact_hertz", np.inf)
        self.damping_ratio = self.column("damping_ratio")
        self.push_out = self.column("push_out")
        self.relax = self.flags("relax")
        self.warm = self.flags("warm_start")
        self.speculative = self.column("speculative")

    @classmethod
    def passes(cls, params: PlanarTGSSoftParams) -> int:
        return params.substeps * (2 if params.relax else 1)

    def step_impulses(self, b: int) -> StepImpulses | None:
        """None: the impulses act at anchors that turn within the step (see the module text)."""
        return None

    def advance(self, state: PlanarState, steps: int) -> None:
        s = state
        tgs_soft_advance(s.x, s.y, s.angle, s.vx, s.vy, s.w, s.inv_mass, s.inv_inertia, s.hx, s.hy, s.friction,
                         self.gravity, self.dt, self.substeps, self.hertz, self.damping_ratio, self.push_out,
                         self.relax, self.warm, self.speculative, *self.memory(state), *s.monitors(), steps)
