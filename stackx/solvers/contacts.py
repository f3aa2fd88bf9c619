"""Contacts as the solvers with memory see them, and the stages they share.

Contact ``k`` is numbered as in ``ColumnState.depths``: ``k = 0`` is the floor under box 0, ``k >= 1`` the
pair of box ``k - 1`` (below) and box ``k`` (above). A positive impulse ``p`` pushes a contact apart: the box
above gains ``p * inv`` of velocity, the box below loses its share; the floor never moves.

Unlike the lab solver, which clamps each visit and forgets everything at the end of the step, these solvers
keep the impulse each contact has accumulated during the step (``impulse``, clamped as a sum to stay >= 0,
so a later visit may take back what an earlier one gave too much) and may start the next step from it
(warm start). Every contact that takes part in a step has a ``target``: the slowest relative velocity it
accepts (0 for touching contacts without a bias; negative for a speculative contact, which may still close
its gap; positive for a Baumgarte bias that pushes apart). ``mass`` holds ``1 / (inv_below + inv_above)``
and is 0 for a contact that sits the step out.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from stackx.kernel import kernel
from stackx.solvers.base import Solver
from stackx.solvers.column.pgs import gravity
from stackx.models.column.state import ColumnState


SPECULATIVE_DOC = ("contacts whose gap is below this (m) take part too, allowed to close the gap within the "
                   "step but not more; 0 is the lab's rule (only overlapping contacts push), under which a "
                   "falling column is stopped one contact per step and a box lands with the speed it gathered; "
                   "Box2D v3 uses 4 x its linear slop = 0.02 m")


def speculative_field(default: float, note: str = "") -> Any:
    """The ``speculative`` margin knob shared by the solvers with contacts that take part before touching."""
    return Field(default, ge=0, le=1.0, allow_inf_nan=False, description=SPECULATIVE_DOC + note)


class ImpulseParams(BaseModel):
    """Knobs every solver with accumulated impulses has; each solver adds its position handling."""

    model_config = ConfigDict(extra="forbid")
    iterations: int = Field(10, gt=0, le=100_000,
                            description="velocity passes per step: more converge further towards the exact "
                                        "solve and cost linearly more; with warm start they only fix what "
                                        "changed since the last step, but a new load (a landing box) still "
                                        "needs about one pass per box it must reach")
    warm_start: bool = Field(True, description="start each step from the impulses the contacts carried at the "
                                               "end of the last one: what lets few iterations hold a tall or "
                                               "heavy-on-light column; off forgets them, and the iterations "
                                               "rebuild every load from zero each step (the lab's weakness)")
    speculative: float = speculative_field(0.0)


class ImpulseSolver(Solver):
    """Base of the solvers that keep an accumulated impulse per contact between steps.

    Packs the knobs they share into one array per batch row and owns the memory: ``impulse`` is shaped like
    the state, ``(batch, boxes)``, zero until the first step, so a removed box takes its contact's impulse
    with it (``Solver.remove_box``).
    """

    def __init__(self, params: list[Any], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.speculative = self.column("speculative")
        self.impulse: np.ndarray | None = None

    def memory(self, state: ColumnState) -> np.ndarray:
        """The impulses carried into the next step; zeros the first time."""
        if self.impulse is None or self.impulse.shape != state.y.shape:
            self.impulse = np.zeros(state.y.shape)
        return self.impulse


@kernel
def depth(y: np.ndarray, half: np.ndarray, k: int) -> float:
    """Overlap of contact ``k`` (m); negative is a gap."""
    if k == 0:
        return half[0] - y[0]
    return (half[k - 1] + half[k]) - (y[k] - y[k - 1])


@kernel
def inverse_mass_sum(inv: np.ndarray, k: int) -> float:
    """How easily contact ``k`` gives: the inverse masses of its two sides (the floor's is 0)."""
    if k == 0:
        return inv[0]
    return inv[k - 1] + inv[k]


@kernel
def relative_velocity(v: np.ndarray, k: int) -> float:
    """Separating speed of contact ``k`` (m/s); negative is approach."""
    if k == 0:
        return v[0]
    return v[k] - v[k - 1]


@kernel
def push(x: np.ndarray, inv: np.ndarray, k: int, p: float) -> None:
    """Apply ``p`` apart at contact ``k``: an impulse to velocities, or a position impulse to heights."""
    if k > 0:
        x[k - 1] -= p * inv[k - 1]
    x[k] += p * inv[k]


@kernel
def prepare(y: np.ndarray, inv: np.ndarray, half: np.ndarray, dt: float, speculative: float, beta: float,
            slop: float, max_bias: float, impulse: np.ndarray, mass: np.ndarray, target: np.ndarray) -> None:
    """Decide which contacts take part in this step and the slowest relative velocity each accepts.

    A contact takes part when its depth is above ``-speculative`` and something on it can move. An
    overlapping contact accepts no approach, or with ``beta`` > 0 asks for the Baumgarte bias
    ``beta/dt * max(depth - slop, 0)``, at most ``max_bias``; a speculative contact may approach by its gap
    within ``dt``. A contact that sits the step out forgets its impulse.
    """
    for k in range(y.shape[0]):
        d = depth(y, half, k)
        total = inverse_mass_sum(inv, k)
        if d > -speculative and total > 0.0:
            mass[k] = 1.0 / total
            if d > 0.0:
                target[k] = min(beta / dt * max(d - slop, 0.0), max_bias)
            else:
                target[k] = d / dt
        else:
            mass[k] = 0.0
            target[k] = 0.0
            impulse[k] = 0.0


@kernel
def warm_start(v: np.ndarray, inv: np.ndarray, impulse: np.ndarray, carry: bool) -> None:
    """Apply every contact's carried impulse to the velocities before the first iteration, or forget them all."""
    for k in range(v.shape[0]):
        if not carry:
            impulse[k] = 0.0
        elif impulse[k] != 0.0:
            push(v, inv, k, impulse[k])


@kernel
def velocity_iteration(v: np.ndarray, inv: np.ndarray, impulse: np.ndarray, mass: np.ndarray,
                       target: np.ndarray) -> None:
    """One Gauss-Seidel pass, floor first then pairs bottom-up, clamping each accumulated impulse at 0.

    The increment may be negative (an earlier visit pushed too hard); only the contact's total is kept
    non-negative, so a contact never pulls.
    """
    for k in range(v.shape[0]):
        if mass[k] > 0.0:
            total = max(impulse[k] + mass[k] * (target[k] - relative_velocity(v, k)), 0.0)
            push(v, inv, k, total - impulse[k])
            impulse[k] = total


@kernel
def solve_velocities(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, g: float, dt: float,
                     speculative: float, beta: float, slop: float, max_bias: float, carry: bool, iterations: int,
                     impulse: np.ndarray, mass: np.ndarray, target: np.ndarray) -> None:
    """The velocity half of a step with accumulated impulses, in order: gravity, prepare contacts (with the
    Baumgarte bias ``beta``, 0 for none), warm start (or forget, ``carry``), ``iterations`` velocity passes."""
    gravity(v, g, dt)
    prepare(y, inv, half, dt, speculative, beta, slop, max_bias, impulse, mass, target)
    warm_start(v, inv, impulse, carry)
    for _ in range(iterations):
        velocity_iteration(v, inv, impulse, mass, target)
