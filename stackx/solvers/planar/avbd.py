"""Augmented Vertex Block Descent on planar boxes (Giles, Diaz and Yuksel, "Augmented Vertex Block Descent",
ACM TOG 44(4), SIGGRAPH 2025; numbers from the authors' 2D demo).

The step is posed on poses ``q = (x, y, angle)``: they minimise the incremental potential
``sum (q - q~)^T M (q - q~) / (2 h^2)`` (``q~ = q0 + v h + g h^2``, where the boxes would go with no contact)
plus the energy of every contact row. Each contact point has two rows, normal and friction, each a force
``f = clamp(k C + lambda, fmin, fmax)``: an augmented-Lagrangian spring of stiffness ``k`` on the row's
error ``C`` with the multiplier ``lambda``. ``C`` is linear in how far the two bodies moved since the step
began (``J dq``, the point's anchors held at where the step found it), plus the starting gap for the normal
row. The normal force may only push (``f <= 0`` here: ``C`` is the gap), friction stays within ``mu |lambda_n|``.

Each iteration visits the bodies in order: a body takes one Newton step of the potential with the others
held, its 3 x 3 system ``M/h^2 + sum k J J^T`` against ``M/h^2 (q - q~) + sum J f`` over the rows that touch
it (a point within ``CONTACT_GAP`` when the step began counts its stiffness even while its force is clamped
at zero, as the demo's contacts do: a contact stiffened under load damps a body's step rather than flicker;
a speculative point further apart, which carries no force into the step, counts from the first Newton step
in which it pushes, since its stiffness alone, through the lever arm in ``J``, would turn a falling box that
touches nothing, and from then on, since dropping it again makes the iterations flip between two poses);
then every row's ``lambda`` takes the dual step ``clamp(k C + lambda)`` and, while it is strictly inside its
bounds, its stiffness grows by ``beta |C|`` up to ``penalty_max``. The rows' ``lambda`` and ``k`` are kept
per ``(A, B, FEATURE)`` into the next step, ``k`` times ``gamma`` (at least ``penalty_min``). Velocities come
from poses (BDF1): ``v = (q - q0)/h``.

Overlap a step begins with: by default (``post_stabilize``, the demo's current choice) the iterations leave
it alone and one extra Newton sweep after the velocities are taken undoes it, so it moves boxes without
giving them speed, and ``lambda`` is kept whole; otherwise the paper's ``alpha`` leaves a share ``alpha`` of
it in every row's error and ``lambda`` is carried times ``alpha gamma``.

The first guess is the adaptive one of the paper: ``q0 + v h + a g h^2`` with ``a`` in [0, 1] the share of
gravity the body felt last step, so a resting box starts at rest. Spins are capped at ``max_spin`` first.

One step of one world: contacts within ``speculative`` (grown to what the fastest box closes in the step,
``planar.reach``) where the step starts; rows' ``lambda`` and ``k`` recalled and decayed; first guess;
``iterations`` times (Newton step of every body, dual step of every row); velocities; with
``post_stabilize`` one more Newton sweep; contacts where the step ended, for the monitors and the next step.

Static friction as in the demo: a point that sticks (its friction inside the bound, having slipped less
than ``stick``) carries its slip into the next step, where its friction row starts from it (times
``1 - alpha``, or whole in the post-stabilizing sweep), so what a pile let slip is pulled back rather than
kept. The demo keeps the sticking contact's anchors on both bodies; here the slip is carried along the
point's tangent, the same to first order.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from stackx.kernel import kernel, leaf, prange
from stackx.models.planar.layout import A, B, DEPTH, MU, NX, NY, RAX, RAY, RBX, RBY
from stackx.models.planar.monitor import contact_room
from stackx.models.planar.state import PlanarState
from stackx.registry import solvers
from stackx.solvers.avbd_knobs import AVBDKnobs
from stackx.solvers.contacts import speculative_field
from stackx.solvers.planar.base import PlanarMemorySolver, StepImpulses
from stackx.solvers.planar.contacts import contact_workspace, find_contacts, observed_contacts, prepare, recall_impulses
from stackx.solvers.planar.reach import contact_margin

# a point's two rows: forces (N), stiffnesses (N/m), the slip along the tangent since it began to stick (m)
# with whether it stuck at the end of the last step (1.0) or not (0.0), and whether its rows are springs in
# this step's Newton steps (1.0: touching when the step began, or has pushed since)
LAMBDA_N, LAMBDA_T, K_N, K_T, SLIP, STUCK, ENGAGED = range(7)
ROW_VALUES = 7
CONTACT_GAP = 0.01  # m: a point this near is a contact from the step's start, keeping its force (the demo's
# collision margin); one further apart is only looked at ahead of a fast box


class PlanarAVBDParams(AVBDKnobs):
    """``AVBDKnobs`` and the planar ones: static friction's anchoring, the spin cap, the contact margin."""

    stick: float = Field(0.01, ge=0, le=1.0, allow_inf_nan=False,
                         description="slip (m) up to which a sticking point keeps where it first held and static "
                                     "friction pulls back what slipped (the demo's 0.01); 0: friction only stops "
                                     "the sliding within each step and a pile may creep. Measured: 0 holds "
                                     "stack-10 at 100 iterations where 0.01 leaves it moving")
    max_spin: float = Field(50.0, gt=0, allow_inf_nan=False,
                            description="fastest spin a body keeps into a step (rad/s; the demo's current 50): "
                                        "bounds the first guess of a tumbling box; lower damps real spins")
    speculative: float = speculative_field(0.02, "; grown to what the fastest box closes in the step")


@leaf
def start_rows(count: int, table: np.ndarray, decay: float, gamma: float, penalty_min: float,
               penalty_max: float, rows: np.ndarray) -> None:
    """Warm start of the step's rows (recalled into ``rows``): forces times ``decay`` (a point more than
    ``CONTACT_GAP`` apart when the step begins starts from none and is not yet a spring), stiffnesses times
    ``gamma`` within the penalty bounds (a new point's 0 becomes ``penalty_min``); the slip of a point that
    did not stick is forgotten."""
    for k in range(count):
        if rows[k, STUCK] == 0.0:
            rows[k, SLIP] = 0.0
        if table[k, DEPTH] < -CONTACT_GAP:  # apart: no force carried into the step (it would push from afar)
            rows[k, LAMBDA_N], rows[k, LAMBDA_T], rows[k, ENGAGED] = 0.0, 0.0, 0.0
        else:
            rows[k, LAMBDA_N] *= decay
            rows[k, LAMBDA_T] *= decay
            rows[k, ENGAGED] = 1.0
        rows[k, K_N] = min(max(rows[k, K_N] * gamma, penalty_min), penalty_max)
        rows[k, K_T] = min(max(rows[k, K_T] * gamma, penalty_min), penalty_max)


@kernel
def body_links(ids: np.ndarray, count: int, bodies: int, first: np.ndarray, links: np.ndarray) -> None:
    """For every body the points that touch it: ``links[first[i]:first[i + 1]]`` (a point of two boxes is
    listed under both, a point on the ground under its box only)."""
    first[:] = 0
    for k in range(count):
        first[ids[k, B] + 1] += 1
        if ids[k, A] >= 0:
            first[ids[k, A] + 1] += 1
    for i in range(bodies):
        first[i + 1] += first[i]
    fill = first[:bodies].copy()
    for k in range(count):
        for body in (ids[k, A], ids[k, B]):
            if body >= 0:
                links[fill[body]] = k
                fill[body] += 1


@leaf
def row_errors(x: np.ndarray, y: np.ndarray, angle: np.ndarray, start: np.ndarray, ids: np.ndarray,
               table: np.ndarray, k: int, kept: float, slip: float) -> tuple[float, float]:
    """Point ``k``'s normal and friction errors now: ``J dq`` of both bodies since the step began along the
    normal and the tangent ``t = (-ny, nx)``, plus where each began: the starting gap for the normal (of an
    overlap, the share ``1 - kept``) and the share ``1 - kept`` of the slip ``slip`` for the tangent."""
    a, b = ids[k, A], ids[k, B]
    nx, ny = table[k, NX], table[k, NY]
    turn = angle[b] - start[b, 2]
    ux = x[b] - start[b, 0] - turn * table[k, RBY]
    uy = y[b] - start[b, 1] + turn * table[k, RBX]
    if a >= 0:
        turn = angle[a] - start[a, 2]
        ux -= x[a] - start[a, 0] - turn * table[k, RAY]
        uy -= y[a] - start[a, 1] + turn * table[k, RAX]
    gap = -table[k, DEPTH]
    if gap < 0.0:  # only overlap is left alone; a gap is kept whole
        gap *= 1.0 - kept
    return gap + ux * nx + uy * ny, (1.0 - kept) * slip + (-ux * ny + uy * nx)


@leaf
def solve3(m: np.ndarray, r: np.ndarray) -> tuple[float, float, float]:
    """``m^-1 r`` for a symmetric positive definite 3 x 3 ``m`` (LDL^T, as the demo solves it)."""
    d1 = m[0, 0]
    l21 = m[1, 0] / d1
    l31 = m[2, 0] / d1
    d2 = m[1, 1] - l21 * l21 * d1
    l32 = (m[2, 1] - l31 * l21 * d1) / d2
    d3 = m[2, 2] - l31 * l31 * d1 - l32 * l32 * d2
    z1 = r[0]
    z2 = r[1] - l21 * z1
    z3 = r[2] - l31 * z1 - l32 * z2
    x3 = z3 / d3
    x2 = z2 / d2 - l32 * x3
    x1 = z1 / d1 - l21 * x2 - l31 * x3
    return x1, x2, x3


@leaf
def add_row(lhs: np.ndarray, rhs: np.ndarray, jx: float, jy: float, jw: float, f: float, k: float) -> None:
    """A row's force ``J f`` into the right-hand side and its stiffness ``k J J^T`` into the matrix."""
    rhs[0] += jx * f
    rhs[1] += jy * f
    rhs[2] += jw * f
    lhs[0, 0] += k * jx * jx
    lhs[1, 0] += k * jy * jx
    lhs[1, 1] += k * jy * jy
    lhs[2, 0] += k * jw * jx
    lhs[2, 1] += k * jw * jy
    lhs[2, 2] += k * jw * jw


@leaf
def primal_sweep(x: np.ndarray, y: np.ndarray, angle: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
                 h: float, kept: float, start: np.ndarray, inertial: np.ndarray, ids: np.ndarray,
                 table: np.ndarray, rows: np.ndarray, first: np.ndarray, links: np.ndarray, lhs: np.ndarray,
                 rhs: np.ndarray) -> None:
    """One Newton step of each movable body in turn, the others held."""
    for i in range(x.shape[0]):
        if inv_mass[i] <= 0.0:
            continue
        m, inertia = 1.0 / (inv_mass[i] * h * h), 1.0 / (inv_inertia[i] * h * h)
        lhs[:, :] = 0.0
        lhs[0, 0], lhs[1, 1], lhs[2, 2] = m, m, inertia
        rhs[0] = m * (x[i] - inertial[i, 0])
        rhs[1] = m * (y[i] - inertial[i, 1])
        rhs[2] = inertia * (angle[i] - inertial[i, 2])
        for j in range(first[i], first[i + 1]):
            k = links[j]
            cn, ct = row_errors(x, y, angle, start, ids, table, k, kept, rows[k, SLIP])
            nx, ny = table[k, NX], table[k, NY]
            sign, rx, ry = 1.0, table[k, RBX], table[k, RBY]
            if ids[k, A] == i:
                sign, rx, ry = -1.0, table[k, RAX], table[k, RAY]
            fn = min(rows[k, K_N] * cn + rows[k, LAMBDA_N], 0.0)
            if rows[k, ENGAGED] == 0.0:  # apart when the step began: a spring only once it has pushed
                if fn == 0.0:
                    continue
                rows[k, ENGAGED] = 1.0
            add_row(lhs, rhs, sign * nx, sign * ny, sign * (rx * ny - ry * nx), fn, rows[k, K_N])
            bound = table[k, MU] * abs(rows[k, LAMBDA_N])
            ft = min(max(rows[k, K_T] * ct + rows[k, LAMBDA_T], -bound), bound)
            add_row(lhs, rhs, -sign * ny, sign * nx, sign * (rx * nx + ry * ny), ft, rows[k, K_T])
        dx, dy, da = solve3(lhs, rhs)
        x[i] -= dx
        y[i] -= dy
        angle[i] -= da


@leaf
def dual_sweep(x: np.ndarray, y: np.ndarray, angle: np.ndarray, beta: float, kept: float, penalty_max: float,
               start: np.ndarray, ids: np.ndarray, table: np.ndarray, count: int, rows: np.ndarray) -> None:
    """Every row's force takes its augmented-Lagrangian step; a row strictly inside its bounds stiffens by
    ``beta |C|``. Friction's bound is ``mu`` times the normal force before this update (the demo's order)."""
    for k in range(count):
        cn, ct = row_errors(x, y, angle, start, ids, table, k, kept, rows[k, SLIP])
        bound = table[k, MU] * abs(rows[k, LAMBDA_N])
        rows[k, LAMBDA_N] = min(rows[k, K_N] * cn + rows[k, LAMBDA_N], 0.0)
        if rows[k, LAMBDA_N] < 0.0:
            rows[k, K_N] = min(rows[k, K_N] + beta * abs(cn), penalty_max)
        rows[k, LAMBDA_T] = min(max(rows[k, K_T] * ct + rows[k, LAMBDA_T], -bound), bound)
        if -bound < rows[k, LAMBDA_T] < bound:
            rows[k, K_T] = min(rows[k, K_T] + beta * abs(ct), penalty_max)


@leaf
def stick(x: np.ndarray, y: np.ndarray, angle: np.ndarray, start: np.ndarray, ids: np.ndarray, table: np.ndarray,
          count: int, rows: np.ndarray, stick_slip: float) -> None:
    """Whether each point stuck this step (its friction force inside its bound and its slip so far within
    ``stick_slip``), and if so its slip at the step's end, from which its friction row starts next step: the
    demo keeps a sticking contact's anchors on both bodies, so static friction pulls back what it let slip."""
    for k in range(count):
        _, slipped = row_errors(x, y, angle, start, ids, table, k, 0.0, rows[k, SLIP])
        bound = table[k, MU] * abs(rows[k, LAMBDA_N])
        held = abs(rows[k, LAMBDA_T]) < bound and abs(rows[k, SLIP]) < stick_slip
        rows[k, STUCK] = 1.0 if held else 0.0
        rows[k, SLIP] = slipped if held else 0.0


@leaf
def first_guess(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray, w: np.ndarray,
                previous: np.ndarray, inv_mass: np.ndarray, g: float, h: float, max_spin: float,
                start: np.ndarray, inertial: np.ndarray) -> None:
    """Spins capped; where each body starts (``start``) and would go free (``inertial``); movable bodies moved
    to the adaptive first guess (gravity times the share of it the body felt last step)."""
    for i in range(x.shape[0]):
        start[i, 0], start[i, 1], start[i, 2] = x[i], y[i], angle[i]
        inertial[i, 0], inertial[i, 1], inertial[i, 2] = x[i], y[i], angle[i]
        if inv_mass[i] <= 0.0:
            continue
        w[i] = min(max(w[i], -max_spin), max_spin)
        felt = 0.0
        if g != 0.0:
            felt = min(max(((vy[i] - previous[i]) / h) * np.sign(g) / abs(g), 0.0), 1.0)
        inertial[i, 0] = x[i] + vx[i] * h
        inertial[i, 1] = y[i] + vy[i] * h + g * h * h
        inertial[i, 2] = angle[i] + w[i] * h
        x[i] = inertial[i, 0]
        y[i] = y[i] + vy[i] * h + g * felt * h * h
        angle[i] = inertial[i, 2]


@leaf
def velocities_from_poses(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                          w: np.ndarray, previous: np.ndarray, inv_mass: np.ndarray, start: np.ndarray,
                          h: float) -> None:
    """``v = (q - q0)/h`` for movable bodies (BDF1), keeping the old vertical speed for the next first guess."""
    for i in range(x.shape[0]):
        previous[i] = vy[i]
        if inv_mass[i] > 0.0:
            vx[i] = (x[i] - start[i, 0]) / h
            vy[i] = (y[i] - start[i, 1]) / h
            w[i] = (angle[i] - start[i, 2]) / h


@leaf
def keep_rows(ids: np.ndarray, count: int, rows: np.ndarray, keys: np.ndarray, carried: np.ndarray) -> int:
    """This step's points and their rows' forces and stiffnesses, for the next step (as many as fit)."""
    held = min(count, keys.shape[0])
    for k in range(held):
        keys[k, 0], keys[k, 1], keys[k, 2] = ids[k, 0], ids[k, 1], ids[k, 2]
        for c in range(ROW_VALUES):
            carried[k, c] = rows[k, c]
    return held


@kernel
def avbd_step(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray, w: np.ndarray,
              inv_mass: np.ndarray, inv_inertia: np.ndarray, friction: np.ndarray, g: float, h: float,
              iterations: int, beta: float, post: bool, alpha: float, gamma: float, penalty_min: float,
              penalty_max: float, max_spin: float, stick_slip: float, ids: np.ndarray, table: np.ndarray,
              count: int,
              keys: np.ndarray, carried: np.ndarray, held: int, previous: np.ndarray, rows: np.ndarray,
              start: np.ndarray, inertial: np.ndarray, first: np.ndarray, links: np.ndarray) -> int:
    """One step of one world on the ``count`` points found where it starts; returns how many the memory holds."""
    n = x.shape[0]
    prepare(x, y, inv_mass, inv_inertia, friction, ids, table, count)
    recall_impulses(ids, count, keys, carried[:, LAMBDA_N:LAMBDA_T + 1], held, rows[:, LAMBDA_N:LAMBDA_T + 1])
    recall_impulses(ids, count, keys, carried[:, K_N:K_T + 1], held, rows[:, K_N:K_T + 1])
    recall_impulses(ids, count, keys, carried[:, SLIP:STUCK + 1], held, rows[:, SLIP:STUCK + 1])
    kept = 1.0 if post else alpha  # the share of the starting gap the iterations leave alone
    start_rows(count, table, 1.0 if post else alpha * gamma, gamma, penalty_min, penalty_max, rows)
    body_links(ids, count, n, first, links)
    first_guess(x, y, angle, vx, vy, w, previous, inv_mass, g, h, max_spin, start, inertial)
    lhs, rhs = np.zeros((3, 3)), np.zeros(3)
    for _ in range(iterations):
        primal_sweep(x, y, angle, inv_mass, inv_inertia, h, kept, start, inertial, ids, table, rows, first, links,
                     lhs, rhs)
        dual_sweep(x, y, angle, beta, kept, penalty_max, start, ids, table, count, rows)
    velocities_from_poses(x, y, angle, vx, vy, w, previous, inv_mass, start, h)
    if post:  # one more sweep undoing the whole starting overlap, after the velocities are taken
        primal_sweep(x, y, angle, inv_mass, inv_inertia, h, 0.0, start, inertial, ids, table, rows, first, links,
                     lhs, rhs)
    stick(x, y, angle, start, ids, table, count, rows, stick_slip)
    return keep_rows(ids, count, rows, keys, carried)


@kernel
def planar_avbd_advance(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                        w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray,
                        hy: np.ndarray, friction: np.ndarray, g: np.ndarray, dt: np.ndarray, iterations: np.ndarray,
                        beta: np.ndarray, post: np.ndarray, alpha: np.ndarray, gamma: np.ndarray,
                        penalty_min: np.ndarray, penalty_max: np.ndarray, max_spin: np.ndarray,
                        stick: np.ndarray, speculative: np.ndarray, keys: np.ndarray, carried: np.ndarray,
                        held: np.ndarray,
                        previous: np.ndarray, last: np.ndarray, peak: np.ndarray, reach: np.ndarray,
                        touched: np.ndarray, launch: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row, in place; ``keys``, ``carried``, ``held`` and ``previous`` carry over."""
    for b in prange(x.shape[0]):
        xb, yb, ab, vxb, vyb, wb = x[b], y[b], angle[b], vx[b], vy[b], w[b]  # the row's views, made once
        im, ii, hxb, hyb, mub = inv_mass[b], inv_inertia[b], hx[b], hy[b], friction[b]
        n = x.shape[1]
        ids, table = contact_workspace(keys.shape[1])
        rows = np.zeros((ids.shape[0], ROW_VALUES))
        links = np.zeros(2 * ids.shape[0], np.int64)
        first = np.zeros(n + 1, np.int64)
        start, inertial = np.zeros((n, 3)), np.zeros((n, 3))
        margin = contact_margin(speculative[b], vxb, vyb, wb, im, hxb, hyb, g[b], dt[b])
        ids, table, count = find_contacts(xb, yb, ab, hxb, hyb, im, margin, ids, table)
        for _ in range(steps):
            if rows.shape[0] < ids.shape[0]:  # the table grew
                rows = np.zeros((ids.shape[0], ROW_VALUES))
                links = np.zeros(2 * ids.shape[0], np.int64)
            held[b] = avbd_step(xb, yb, ab, vxb, vyb, wb, im, ii, mub, g[b], dt[b], iterations[b], beta[b], post[b],
                                alpha[b], gamma[b], penalty_min[b], penalty_max[b], max_spin[b], stick[b], ids,
                                table, count, keys[b], carried[b], held[b], previous[b], rows, start, inertial, first,
                                links)
            margin = contact_margin(speculative[b], vxb, vyb, wb, im, hxb, hyb, g[b], dt[b])
            ids, table, count = observed_contacts(xb, yb, ab, hxb, hyb, im, margin, ids, table, dt[b], last, peak,
                                                  reach, touched, launch, b)


@solvers.register("planar-avbd")
class PlanarAVBD(PlanarMemorySolver):
    """Augmented Vertex Block Descent: a Newton step per body, contacts as stiffening springs (Giles et al. 2025)."""

    Params = PlanarAVBDParams
    carried_values = ROW_VALUES
    speculative_reach = True  # contacts looked for as far as the fastest box closes (stackx.solvers.planar.reach)

    def __init__(self, params: list[PlanarAVBDParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.iterations = self.counts("iterations")
        self.beta, self.alpha, self.gamma = self.column("beta"), self.column("alpha"), self.column("gamma")
        self.post = self.flags("post_stabilize")
        self.penalty_min, self.penalty_max = self.column("penalty_min"), self.column("penalty_max")
        self.max_spin = self.column("max_spin")
        self.stick = self.column("stick")
        self.speculative = self.column("speculative")
        self.previous: np.ndarray | None = None

    def memory(self, state: PlanarState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(keys, carried, held)`` as ``PlanarMemorySolver`` keeps them, with ``ROW_VALUES`` a point in
        ``carried``: its rows' forces (N) and stiffnesses (N/m), its slip and whether it stuck; plus each
        body's last vertical speed (``previous``, the boxes' own the first time: no felt acceleration)."""
        fresh = self.keys is None or self.keys.shape[:2] != (state.batch, contact_room(state.bodies))
        kept = super().memory(state)
        if fresh:
            self.previous = state.vy.copy()
        return kept

    def step_impulses(self, b: int) -> StepImpulses | None:
        """The rows' last forces times the step: the impulses on body B along the normal and the tangent (a
        row's force acts against its error, so the impulse is ``-lambda h``)."""
        kept = super().step_impulses(b)
        if kept is None:
            return None
        assert self.carried is not None
        n, h = len(kept.pn), float(self.dt[b])
        return StepImpulses(kept.keys, -h * self.carried[b, :n, LAMBDA_N], -h * self.carried[b, :n, LAMBDA_T])

    def remove_box(self, state: PlanarState, box: int) -> None:
        """Forget the points of box ``box`` and renumber the boxes after it, keeping the others' rows, in a
        memory sized for one box fewer; the box's last speed goes with it."""
        if self.keys is None:
            return
        super().remove_box(state, box)
        assert self.previous is not None
        self.previous = np.ascontiguousarray(np.delete(self.previous, box, axis=1))

    def advance(self, state: PlanarState, steps: int) -> None:
        s = state
        keys, carried, held = self.memory(state)
        assert self.previous is not None
        planar_avbd_advance(s.x, s.y, s.angle, s.vx, s.vy, s.w, s.inv_mass, s.inv_inertia, s.hx, s.hy, s.friction,
                            self.gravity, self.dt, self.iterations, self.beta, self.post, self.alpha, self.gamma,
                            self.penalty_min, self.penalty_max, self.max_spin, self.stick, self.speculative, keys,
                            carried, held, self.previous, *s.monitors(), steps)
