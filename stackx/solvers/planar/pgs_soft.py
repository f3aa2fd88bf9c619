"""Soft PGS on planar boxes (Solver2D's soft PGS): one full step, soft contacts, warm start, then relax.

Box2D v3's soft contact without its substeps. One step of one world:

1. gravity over the whole step;
2. the contacts where the step begins (within ``speculative`` of touching): per point the anchors, normal and
   tangent effective masses and friction (``contacts.prepare``), and the impulses the same ``(A, B,
   feature)`` carried at the end of the last step (``warm_start``), applied to the velocities;
3. ``iterations`` Gauss-Seidel passes over the manifolds in table order, with bias: an overlapping point is a
   stiff, heavily damped spring of ``contact_hertz`` (twice that where a side is static: the ground, a static
   box) and damping ratio ``damping_ratio``, asking a separating speed of ``bias_rate x depth``, at most
   ``push_out``; each visit applies ``mass_scale`` of the full impulse and lets go ``impulse_scale`` of the
   point's accumulated total (Box2D v3's soft step coefficients, ``stackx.solvers.column.soft_step.soft``,
   here over the whole step ``dt``); a point still apart may close its gap within the step and no more; then
   each point's friction, its accumulated total within ``mu`` times its normal total;
4. positions and angles move with the velocities;
5. ``relax_iterations`` passes of the same visits without bias (a rigid contact that only stops approach), so
   the push-out speed the bias gave does not stay in the boxes;
6. the impulses kept for the next step; the contacts found where the step ended (monitors, next step).

Anchors, normals and depths are those found when the step began, for every pass (Solver2D's "fixed
anchors"): the relax passes do not measure the separation again after the positions moved.

Solver2D's numbers are the defaults: 4 velocity and 2 relax iterations at 60 Hz, contact hertz 30 capped at a
third of the step rate (20 Hz at 60 Hz; 40 Hz against the ground), damping ratio 10, push-out half of its
4 m/s Baumgarte speed cap (2 m/s), speculative distance 4 x its 0.005 m linear slop. Solver2D's soft PGS
visits a manifold's points one after the other (no block solve) and so does this.

This is not ``planar-soft-step`` at one substep: that solver takes one biased and one relax pass per substep
(here ``iterations`` and ``relax_iterations`` per step), measures each point's separation again at every
visit, and caps the contact frequency at an eighth of the substep rate (7.5 Hz at one substep of 1/60 s).

A soft contact carries its load by sinking: at rest a point under load ``F`` (N) with effective mass ``k`` sits
``F / (k (2 pi hertz)^2)`` deep (the biased passes' fixed point with no approach). A step's velocities are
its start velocities plus gravity plus what the accumulated totals give at the fixed anchors, so the totals the
memory keeps are the step's own answer (``step_impulses``); the positions moved with the velocities of the
biased passes, before relax.

Measured at the defaults (60 Hz): the 10-row pyramid, the card house, the ramps and the skid hold; no pass count
holds the 10-box stack (the soft stack sways, its boxes drifting 7.5 to 9 cm; at 120 Hz, 40 Hz contacts, it
stands) or the 100 kg box on a 1 kg one (8 cm sink): what holds those is a stiffer contact, i.e. a shorter step.

``planar-jacobi`` steps with the same stages, its passes Jacobi's (``soft_jacobi_pass``).
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from stackx.kernel import inlined, kernel, leaf, prange
from stackx.models.planar.state import PlanarState
from stackx.registry import solvers
from stackx.solvers.column.soft_step import STATIC_HERTZ, soft
from stackx.solvers.contacts import speculative_field
from stackx.solvers.planar.base import PlanarMemorySolver
from stackx.solvers.planar.contacts import (A, B, DEPTH, KN, KT, MU, NX, NY, PN, PT, contact_workspace,
                                            find_contacts_near, gravity, integrate_positions, manifold_impulse,
                                            manifold_velocity, near_workspace, observe_contacts, prepare, recall,
                                            remember, warm_start)
from stackx.solvers.planar.wavefront import manifold_end

STEP_HERTZ = 0.333  # the contact frequency is at most this share of the step rate (Solver2D's soft PGS and Jacobi)
STATIC_SIDE, MOVABLE = 0, 1  # rows of a step's softness: contacts with a static side, contacts between movable boxes


class PlanarPGSSoftParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    iterations: int = Field(4, gt=0, le=100_000,
                            description="biased velocity passes per step (Solver2D: 4): more converge further "
                                        "towards the soft contacts' answer and cost linearly more; warm start "
                                        "carries the rest into the next step")
    relax_iterations: int = Field(2, ge=0, le=100_000,
                                  description="passes without bias after positions move (Solver2D: 2): they take "
                                              "the push-out speed back out of the boxes; 0 keeps it (boxes "
                                              "bounce off overlap), more cost linearly")
    contact_hertz: float = Field(30.0, gt=0, allow_inf_nan=False,
                                 description="stiffness of a contact as a spring frequency (Hz), capped at a third "
                                             "of the step rate (20 Hz at 60 Hz); contacts with a static side use "
                                             "twice it: higher sinks less under load, the cap keeps one step "
                                             "of the spring stable")
    damping_ratio: float = Field(10.0, ge=0, allow_inf_nan=False,
                                 description="damping of the contact spring: high values (10) push out without "
                                             "bouncing, low ones spring back")
    push_out: float = Field(2.0, gt=0, allow_inf_nan=False,
                            description="largest separating speed the bias may ask for (m/s; Solver2D's soft PGS: "
                                        "2): keeps a deep overlap from launching boxes, at the cost of a slower "
                                        "recovery")
    warm_start: bool = Field(True, description="start each step from the impulses each point carried at the end "
                                               "of the last one; off rebuilds every load from zero each step")
    speculative: float = speculative_field(0.02)


@kernel
def step_softness(hertz: float, damping_ratio: float, dt: float) -> np.ndarray:
    """``(bias_rate, mass_scale, impulse_scale)`` over a whole step ``dt`` for contacts with a static side
    (row ``STATIC_SIDE``, twice the hertz) and between movable boxes (row ``MOVABLE``); the hertz is capped at
    ``STEP_HERTZ`` of the step rate before doubling (Solver2D's order)."""
    capped = min(hertz, STEP_HERTZ / dt)
    out = np.empty((2, 3))
    out[STATIC_SIDE, 0], out[STATIC_SIDE, 1], out[STATIC_SIDE, 2] = soft(STATIC_HERTZ * capped, damping_ratio, dt)
    out[MOVABLE, 0], out[MOVABLE, 1], out[MOVABLE, 2] = soft(capped, damping_ratio, dt)
    return out


@leaf
def soft_normal(vax: float, vay: float, wa: float, vbx: float, vby: float, wb: float, grounded: bool, ima: float,
                iia: float, imb: float, iib: float, table: np.ndarray, k: int, dt: float, springs: np.ndarray,
                side: int, biased: bool, push_out: float,
                relaxation: float) -> tuple[float, float, float, float, float, float]:
    """Point ``k``'s normal total after one soft visit: apart (depth < 0), the gap may close within the step;
    overlapping and ``biased``, the spring's separating speed (at most ``push_out``) with its mass and impulse
    scales (``springs[side]``); overlapping and not biased, no approach. The change is scaled by
    ``relaxation`` and the total kept >= 0. Returns the manifold's velocities after it."""
    nx, ny = table[k, NX], table[k, NY]
    depth = table[k, DEPTH]
    target, mass_scale, impulse_scale = 0.0, 1.0, 0.0
    if depth < 0.0:
        target = depth / dt
    elif biased:
        target = min(springs[side, 0] * depth, push_out)
        mass_scale, impulse_scale = springs[side, 1], springs[side, 2]
    old = table[k, PN]
    approach = manifold_velocity(vax, vay, wa, vbx, vby, wb, grounded, table, k, nx, ny)
    change = table[k, KN] * mass_scale * (target - approach) - impulse_scale * old
    total = max(old + relaxation * change, 0.0)
    if total == old:
        return vax, vay, wa, vbx, vby, wb
    step = total - old
    table[k, PN] = total
    return manifold_impulse(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb, iib, table, k, step * nx,
                            step * ny)


@leaf
def soft_friction(vax: float, vay: float, wa: float, vbx: float, vby: float, wb: float, grounded: bool,
                  ima: float, iia: float, imb: float, iib: float, table: np.ndarray, k: int,
                  relaxation: float) -> tuple[float, float, float, float, float, float]:
    """Point ``k``'s tangent total moved towards stopping its sliding (the change scaled by ``relaxation``),
    kept within ``mu`` times its normal total. Returns the manifold's velocities after it."""
    nx, ny = table[k, NX], table[k, NY]
    limit = table[k, MU] * table[k, PN]
    old = table[k, PT]
    slide = manifold_velocity(vax, vay, wa, vbx, vby, wb, grounded, table, k, -ny, nx)
    total = min(max(old - relaxation * table[k, KT] * slide, -limit), limit)
    if total == old:
        return vax, vay, wa, vbx, vby, wb
    step = total - old
    table[k, PT] = total
    return manifold_impulse(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb, iib, table, k, -step * ny,
                            step * nx)


@inlined
def soft_manifold(vax: float, vay: float, wa: float, vbx: float, vby: float, wb: float, grounded: bool,
                  ima: float, iia: float, imb: float, iib: float, table: np.ndarray, k: int, end: int, dt: float,
                  springs: np.ndarray, biased: bool, push_out: float,
                  relaxation: float) -> tuple[float, float, float, float, float, float]:
    """One visit of the manifold of points ``k`` to ``end``: every normal, then every friction, one point
    after the other (Solver2D's order), on the two bodies' velocities held in locals."""
    side = STATIC_SIDE if ima == 0.0 or imb == 0.0 else MOVABLE
    for i in range(k, end):
        vax, vay, wa, vbx, vby, wb = soft_normal(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb, iib, table, i,
                                                 dt, springs, side, biased, push_out, relaxation)
    for i in range(k, end):
        vax, vay, wa, vbx, vby, wb = soft_friction(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb, iib, table,
                                                   i, relaxation)
    return vax, vay, wa, vbx, vby, wb


@leaf
def soft_pgs_pass(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
                  ids: np.ndarray, table: np.ndarray, count: int, dt: float, springs: np.ndarray, biased: bool,
                  push_out: float) -> None:
    """One Gauss-Seidel pass: the manifolds in table order, each seeing what the ones before it did."""
    k = 0
    while k < count:
        end = manifold_end(ids, k, count)
        a, b = ids[k, A], ids[k, B]
        grounded = a < 0
        vax, vay, wa, ima, iia = 0.0, 0.0, 0.0, 0.0, 0.0
        if not grounded:
            vax, vay, wa, ima, iia = vx[a], vy[a], w[a], inv_mass[a], inv_inertia[a]
        vax, vay, wa, vx[b], vy[b], w[b] = soft_manifold(vax, vay, wa, vx[b], vy[b], w[b], grounded, ima, iia,
                                                         inv_mass[b], inv_inertia[b], table, k, end, dt, springs,
                                                         biased, push_out, 1.0)
        if not grounded:
            vx[a], vy[a], w[a] = vax, vay, wa
        k = end


@leaf
def soft_jacobi_pass(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
                     ids: np.ndarray, table: np.ndarray, count: int, dt: float, springs: np.ndarray, biased: bool,
                     push_out: float, relaxation: float, change: np.ndarray) -> None:
    """One Jacobi pass: every manifold visited from the velocities the pass began with, its bodies' changes
    summed per body in ``change`` (``(bodies, 3)`` scratch), and the sums applied at the end. A body shared by
    several manifolds gets every one's full change (Solver2D's sum); ``relaxation`` scales each visit's
    changes."""
    change[:, :] = 0.0
    k = 0
    while k < count:
        end = manifold_end(ids, k, count)
        a, b = ids[k, A], ids[k, B]
        grounded = a < 0
        vax, vay, wa, ima, iia = 0.0, 0.0, 0.0, 0.0, 0.0
        if not grounded:
            vax, vay, wa, ima, iia = vx[a], vy[a], w[a], inv_mass[a], inv_inertia[a]
        ax, ay, aw, bx, by, bw = soft_manifold(vax, vay, wa, vx[b], vy[b], w[b], grounded, ima, iia, inv_mass[b],
                                               inv_inertia[b], table, k, end, dt, springs, biased, push_out,
                                               relaxation)
        change[b, 0] += bx - vx[b]
        change[b, 1] += by - vy[b]
        change[b, 2] += bw - w[b]
        if not grounded:
            change[a, 0] += ax - vax
            change[a, 1] += ay - vay
            change[a, 2] += aw - wa
        k = end
    for i in range(vx.shape[0]):
        vx[i] += change[i, 0]
        vy[i] += change[i, 1]
        w[i] += change[i, 2]


@leaf
def soft_passes(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
                ids: np.ndarray, table: np.ndarray, count: int, dt: float, springs: np.ndarray, biased: bool,
                push_out: float, passes: int, jacobi: bool, relaxation: float, change: np.ndarray) -> None:
    """``passes`` passes, Jacobi's (``jacobi``) or Gauss-Seidel's."""
    for _ in range(passes):
        if jacobi:
            soft_jacobi_pass(vx, vy, w, inv_mass, inv_inertia, ids, table, count, dt, springs, biased, push_out,
                             relaxation, change)
        else:
            soft_pgs_pass(vx, vy, w, inv_mass, inv_inertia, ids, table, count, dt, springs, biased, push_out)


@kernel
def soft_pgs_advance(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                     w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray, hy: np.ndarray,
                     friction: np.ndarray, g: np.ndarray, dt: np.ndarray, iterations: np.ndarray,
                     relax_iterations: np.ndarray, hertz: np.ndarray, damping_ratio: np.ndarray,
                     push_out: np.ndarray, carry: np.ndarray, speculative: np.ndarray, jacobi: np.ndarray,
                     relaxation: np.ndarray, keys: np.ndarray, carried: np.ndarray, held: np.ndarray,
                     last: np.ndarray, peak: np.ndarray, reach: np.ndarray, touched: np.ndarray,
                     launch: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row (the module's steps 1-6), in place; ``keys``, ``carried`` and
    ``held`` carry over. ``jacobi`` and ``relaxation`` per row: which passes (``soft_passes``)."""
    for b in prange(x.shape[0]):
        xb, yb, ab, vxb, vyb, wb = x[b], y[b], angle[b], vx[b], vy[b], w[b]  # the row's views, made once
        im, ii, hxb, hyb, mub = inv_mass[b], inv_inertia[b], hx[b], hy[b], friction[b]
        springs = step_softness(hertz[b], damping_ratio[b], dt[b])
        change = np.zeros((x.shape[1], 3))
        ids, table = contact_workspace(keys.shape[1])
        near, wide = near_workspace(x.shape[1])  # the candidate pairs, kept while the boxes stay near
        ids, table, count, near = find_contacts_near(xb, yb, ab, hxb, hyb, im, speculative[b], near, wide, ids,
                                                     table)
        for _ in range(steps):
            gravity(vyb, im, g[b], dt[b])
            prepare(xb, yb, im, ii, mub, ids, table, count)
            if carry[b]:
                recall(ids, table, count, keys[b], carried[b], held[b])
                warm_start(vxb, vyb, wb, im, ii, ids, table, count)
            soft_passes(vxb, vyb, wb, im, ii, ids, table, count, dt[b], springs, True, push_out[b], iterations[b],
                        jacobi[b], relaxation[b], change)
            integrate_positions(xb, yb, ab, vxb, vyb, wb, dt[b])
            soft_passes(vxb, vyb, wb, im, ii, ids, table, count, dt[b], springs, False, push_out[b],
                        relax_iterations[b], jacobi[b], relaxation[b], change)
            held[b] = remember(ids, table, count, keys[b], carried[b])
            ids, table, count, near = find_contacts_near(xb, yb, ab, hxb, hyb, im, speculative[b], near, wide, ids,
                                                         table)
            observe_contacts(xb, yb, ab, hxb, hyb, im, speculative[b], ids, table, count, dt[b], last, peak, reach,
                             touched, launch, b)


class SoftPassesSolver(PlanarMemorySolver):
    """What the soft PGS and soft Jacobi solvers share: the knobs read per row and the step
    (``soft_pgs_advance``); a subclass says which passes (``jacobi``) and reads its ``relaxation``."""

    jacobi = False

    def __init__(self, params: list[PlanarPGSSoftParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.iterations = self.counts("iterations")
        self.relax_iterations = self.counts("relax_iterations")
        self.hertz = self.column("contact_hertz")
        self.damping_ratio = self.column("damping_ratio")
        self.push_out = self.column("push_out")
        self.carry = self.flags("warm_start")
        self.speculative = self.column("speculative")
        self.use_jacobi = np.full(len(params), self.jacobi, np.bool_)
        self.relaxation = self.column("relaxation", 1.0) if self.jacobi else np.ones(len(params))

    @classmethod
    def passes(cls, params: PlanarPGSSoftParams) -> int:
        return params.iterations + params.relax_iterations

    def advance(self, state: PlanarState, steps: int) -> None:
        s = state
        soft_pgs_advance(s.x, s.y, s.angle, s.vx, s.vy, s.w, s.inv_mass, s.inv_inertia, s.hx, s.hy, s.friction,
                         self.gravity, self.dt, self.iterations, self.relax_iterations, self.hertz,
                         self.damping_ratio, self.push_out, self.carry, self.speculative, self.use_jacobi,
                         self.relaxation, *self.memory(state), *s.monitors(), steps)


@solvers.register("planar-pgs-soft")
class PlanarPGSSoft(SoftPassesSolver):
    """Soft contacts solved by Gauss-Seidel in one full step, then relaxed without bias (Solver2D's soft PGS)."""

    Params = PlanarPGSSoftParams
