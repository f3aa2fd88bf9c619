"""Augmented Vertex Block Descent on the column (Giles, Diaz and Yuksel, "Augmented Vertex Block Descent",
ACM TOG 44(4), SIGGRAPH 2025): positions found by a Newton step per box, contacts as augmented-Lagrangian
springs whose stiffness ramps up until they hold.

The step is posed on positions: the boxes' heights ``y`` minimise the incremental potential
``sum m/(2 h^2) (y - y~)^2`` (``y~ = y0 + v h + g h^2``, where the boxes would be with no contact) plus, for
each contact row, the energy of a force ``f = min(k C + lambda, 0)``. ``C`` is the row's gap, measured from the
step's start: ``C = C0 + (dy_above - dy_below)`` with ``C0`` the gap when the step began and ``dy`` how far a
box has moved since; an overlap (``C0 < 0``) counts only its share ``1 - alpha``, so that near 1 an old
overlap is undone over many steps rather than thrown out in one (or, ``post_stabilize``, after the velocities
are taken). A contact may only push (``f <= 0``).

Each iteration visits the boxes bottom-up: the box's one degree of freedom takes a Newton step of the
potential with the other boxes held (``m/h^2 + sum k`` over its rows: a row within ``CONTACT_GAP`` when the
step began adds its stiffness even while its force is clamped at zero, as the demo's contacts do, which
damps the step instead of letting it flip between two heights; a row further apart, looked at only ahead of
a fast box, carries no force in and adds its stiffness from the first time it pushes), then every row's
``lambda`` takes the dual step ``min(k C + lambda, 0)`` and, while the row pushes, its stiffness grows by
``beta |C|`` (bounded by ``penalty_max``). Rows keep ``lambda`` and ``k`` into the next step, ``k`` times
``gamma`` (at least ``penalty_min``) and ``lambda`` whole (``post_stabilize``) or times ``alpha gamma``, so a
pile at rest starts each step from last step's forces. Velocities come from positions (BDF1):
``v = (y - y0)/h``.

With ``post_stabilize`` (the demo's current default) the iterations leave a starting overlap alone and one
more Newton sweep after the velocities are taken undoes it: the overlap goes in one step as a move, not as
speed. Without it, the paper's ``alpha`` undoes ``1 - alpha`` of it per step, as speed.

The first guess of the positions is the paper's adaptive one: ``y0 + v h + a g h^2`` where ``a`` is how much
of gravity the box actually felt last step (1 falling freely, 0 resting), so a resting box starts at rest and
a falling one starts falling.

One step: rows within ``margin`` of touching (after the step's approach) take part, their lambda and k warm
started; the first guess; ``iterations`` times (Newton step of every box bottom-up, dual step of every row);
velocities from positions; with ``post_stabilize`` one more Newton sweep.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from stackx.kernel import kernel, leaf, prange
from stackx.models.column.monitor import observe
from stackx.models.column.state import ColumnState
from stackx.registry import solvers
from stackx.solvers.avbd_knobs import AVBDKnobs
from stackx.solvers.base import Solver
from stackx.solvers.contacts import depth, relative_velocity

CONTACT_GAP = 0.01  # m: a row this near is a contact from the step's start, keeping its force (the demo's
# collision margin); one further apart takes part only ahead of a fast box


class AVBDParams(AVBDKnobs):
    """``AVBDKnobs`` and the column's contact margin."""

    margin: float = Field(0.02, ge=0, le=1.0, allow_inf_nan=False,
                          description="rows whose gap, less what the current approach speed closes in a step, is "
                                      "below this (m) take part: a row that sits out cannot push this step, one "
                                      "that takes part stiffens its boxes' Newton steps even while apart (the "
                                      "demo keeps a contact while its boxes' bounds overlap; 0.02 m is the "
                                      "planar solvers' speculative margin)")


@leaf
def guess_weight(v: float, previous: float, g: float, h: float) -> float:
    """How much of gravity the box felt last step, in [0, 1]: its acceleration along gravity over ``|g|``
    (the adaptive first guess; 0 without gravity)."""
    if g == 0.0:
        return 0.0
    weight = ((v - previous) / h) * np.sign(g) / abs(g)
    return min(max(weight, 0.0), 1.0)


@leaf
def row_gap(y: np.ndarray, start: np.ndarray, gap0: np.ndarray, alpha: float, k: int) -> float:
    """Row ``k``'s gap now, linear in the moves since the step began: its starting gap (of an overlap, the
    share ``1 - alpha``) plus how far its two sides have come apart."""
    opened = y[k] - start[k]
    if k > 0:
        opened -= y[k - 1] - start[k - 1]
    if gap0[k] > 0.0:  # a gap is kept whole: only overlap is left alone
        return gap0[k] + opened
    return (1.0 - alpha) * gap0[k] + opened


@leaf
def start_rows(y: np.ndarray, v: np.ndarray, half: np.ndarray, inv: np.ndarray, h: float, margin: float,
               decay: float, gamma: float,
               penalty_min: float, penalty_max: float, gap0: np.ndarray, active: np.ndarray,
               spring: np.ndarray, lam: np.ndarray, pen: np.ndarray) -> None:
    """Which rows take part this step (those within ``margin`` of touching once the step's approach at the
    current speeds has closed their gap), their starting gaps, and their warm-started force (times ``decay``)
    and stiffness (times ``gamma``), a row more than ``CONTACT_GAP`` apart starting from no force and not yet a
    spring (``spring``);
    a row that sits out forgets both (it starts again from ``penalty_min`` when it comes back)."""
    for k in range(y.shape[0]):
        gap0[k] = -depth(y, half, k)
        movable = inv[k] > 0.0 or (k > 0 and inv[k - 1] > 0.0)
        closing = min(relative_velocity(v, k), 0.0) * h  # how much of the gap this step's speed would close
        active[k] = gap0[k] + closing < margin and movable
        spring[k] = active[k] and gap0[k] <= CONTACT_GAP
        if active[k]:
            lam[k] = lam[k] * decay if spring[k] else 0.0  # far apart: no force carried in (it would push from afar)
            pen[k] = min(max(pen[k] * gamma, penalty_min), penalty_max)
        else:
            lam[k] = 0.0
            pen[k] = 0.0


@leaf
def first_guess(y: np.ndarray, v: np.ndarray, previous: np.ndarray, inv: np.ndarray, g: float, h: float,
                start: np.ndarray, inertial: np.ndarray) -> None:
    """Remember where each box starts and where it would go free (``inertial``), and move it to the adaptive
    first guess."""
    for i in range(y.shape[0]):
        start[i] = y[i]
        if inv[i] > 0.0:
            inertial[i] = y[i] + v[i] * h + g * h * h
            y[i] = y[i] + v[i] * h + g * guess_weight(v[i], previous[i], g, h) * h * h
        else:
            inertial[i] = y[i]


@leaf
def primal_sweep(y: np.ndarray, inv: np.ndarray, h: float, alpha: float, start: np.ndarray,
                 inertial: np.ndarray, gap0: np.ndarray, active: np.ndarray, spring: np.ndarray, lam: np.ndarray,
                 pen: np.ndarray) -> None:
    """One Newton step of each movable box, bottom-up, the others held: its row below pushes it up
    (``J = 1``), its row above down (``J = -1``). A row that is a spring adds its stiffness even while its force
    is clamped at zero (as the demo's contacts do: the step is damped rather than flipping between two
    poses); one apart when the step began becomes a spring once it pushes."""
    n = y.shape[0]
    for i in range(n):
        if inv[i] <= 0.0:
            continue
        inertia = 1.0 / (inv[i] * h * h)
        lhs = inertia
        rhs = inertia * (y[i] - inertial[i])
        for k in range(i, min(i + 2, n)):
            if not active[k]:
                continue
            f = min(pen[k] * row_gap(y, start, gap0, alpha, k) + lam[k], 0.0)
            if not spring[k]:  # apart when the step began: a spring from the first time it pushes
                if f == 0.0:
                    continue
                spring[k] = True
            rhs += f if k == i else -f
            lhs += pen[k]
        y[i] -= rhs / lhs


@leaf
def dual_sweep(y: np.ndarray, beta: float, alpha: float, penalty_max: float, start: np.ndarray,
               gap0: np.ndarray, active: np.ndarray, lam: np.ndarray, pen: np.ndarray) -> None:
    """Every row's force takes its augmented-Lagrangian step; a row that pushes stiffens by ``beta |C|``."""
    for k in range(y.shape[0]):
        if active[k]:
            c = row_gap(y, start, gap0, alpha, k)
            lam[k] = min(pen[k] * c + lam[k], 0.0)
            if lam[k] < 0.0:
                pen[k] = min(pen[k] + beta * abs(c), penalty_max)


@leaf
def velocities_from_positions(y: np.ndarray, v: np.ndarray, previous: np.ndarray, inv: np.ndarray,
                              start: np.ndarray, h: float) -> None:
    """``v = (y - y0)/h`` for movable boxes (BDF1), keeping the old velocity for the next first guess."""
    for i in range(y.shape[0]):
        previous[i] = v[i]
        if inv[i] > 0.0:
            v[i] = (y[i] - start[i]) / h


@kernel
def avbd_advance(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, g: np.ndarray,
                 dt: np.ndarray, iterations: np.ndarray, beta: np.ndarray, alpha: np.ndarray, gamma: np.ndarray,
                 penalty_min: np.ndarray, penalty_max: np.ndarray, margin: np.ndarray,
                 post_stabilize: np.ndarray, lam: np.ndarray,
                 pen: np.ndarray, previous: np.ndarray, last: np.ndarray, peak: np.ndarray, reach: np.ndarray,
                 touched: np.ndarray, launch: np.ndarray, steps: int) -> None:
    """``steps`` steps of every batch row, in place; ``lam``, ``pen`` and ``previous`` carry over."""
    for b in prange(y.shape[0]):
        yb, vb, ib, hb = y[b], v[b], inv[b], half[b]  # the row's views, made once
        n = y.shape[1]
        start, inertial, gap0 = np.zeros(n), np.zeros(n), np.zeros(n)
        active, spring = np.zeros(n, np.bool_), np.zeros(n, np.bool_)
        for _ in range(steps):
            post = post_stabilize[b]
            kept = 1.0 if post else alpha[b]  # the share of the starting gap the iterations leave alone
            start_rows(yb, vb, hb, ib, dt[b], margin[b], 1.0 if post else alpha[b] * gamma[b], gamma[b], penalty_min[b],
                       penalty_max[b], gap0, active, spring, lam[b], pen[b])
            first_guess(yb, vb, previous[b], ib, g[b], dt[b], start, inertial)
            for _ in range(iterations[b]):
                primal_sweep(yb, ib, dt[b], kept, start, inertial, gap0, active, spring, lam[b], pen[b])
                dual_sweep(yb, beta[b], kept, penalty_max[b], start, gap0, active, lam[b], pen[b])
            velocities_from_positions(yb, vb, previous[b], ib, start, dt[b])
            if post:  # one more sweep that undoes the whole starting overlap, after the velocities are taken
                primal_sweep(yb, ib, dt[b], 0.0, start, inertial, gap0, active, spring, lam[b], pen[b])
            observe(yb, hb, dt[b], last, peak, reach, touched, launch, b)


@solvers.register("avbd")
class AVBD(Solver):
    """Augmented Vertex Block Descent: a Newton step per box, contacts as stiffening springs (Giles et al. 2025)."""

    Params = AVBDParams

    def __init__(self, params: list[AVBDParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.iterations = self.counts("iterations")
        self.beta, self.alpha, self.gamma = self.column("beta"), self.column("alpha"), self.column("gamma")
        self.penalty_min, self.penalty_max = self.column("penalty_min"), self.column("penalty_max")
        self.margin = self.column("margin")
        self.post_stabilize = self.flags("post_stabilize")
        self.lam: np.ndarray | None = None
        self.pen: np.ndarray | None = None
        self.previous: np.ndarray | None = None

    def memory(self, state: ColumnState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each contact's force and stiffness and each box's last velocity, carried between calls (shaped
        like the state, so ``Solver.remove_box`` keeps them right); a fresh start takes the boxes' own
        velocities as the last ones (no felt acceleration)."""
        if self.lam is None or self.lam.shape != state.y.shape:
            self.lam, self.pen = np.zeros(state.y.shape), np.zeros(state.y.shape)
            self.previous = state.v.copy()
        assert self.pen is not None and self.previous is not None
        return self.lam, self.pen, self.previous

    def advance(self, state: ColumnState, steps: int) -> None:
        avbd_advance(state.y, state.v, state.inv_mass, state.half, self.gravity, self.dt, self.iterations,
                     self.beta, self.alpha, self.gamma, self.penalty_min, self.penalty_max, self.margin,
                     self.post_stabilize,
                     *self.memory(state), *state.monitors(), steps)
