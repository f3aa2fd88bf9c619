"""The contact problem a step of a planar world sets itself, and its reference solve with memory across steps.

From the state before the step: gravity first (the free velocity), then every contact point closer than
``speculative`` to touching (with ``speculative`` 0, the points that overlap: the lab's rule), with anchors, effective masses, friction and targets made by the stages every
planar solver uses (``stackx.solvers.planar.contacts``): a touching point must not approach (target 0), a
point still ``gap`` apart may approach by at most what closes the gap within the step (target ``-gap/dt``).
So the reference solves the very problem the solvers set themselves.

``ReferenceStep`` keeps, per batch row, the impulses of the last solve by ``(body_a, body_b, feature)``, and
starts the next solve from them (``recall``/``remember``): from one step to the next most points carry
nearly the same load, and the solve then needs few or no Newton rounds.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import kernel
from stackx.models.planar.monitor import contact_room
from stackx.models.planar.problem import ContactProblem
from stackx.models.planar.reference import Solution, solve
from stackx.models.planar.state import PlanarState
from stackx.solvers.planar.contacts import (A, B, DEPTH, MU, NX, NY, PN, PT, RAX, RAY, RBX, RBY, TARGET,
                                            contact_workspace, find_contacts, gravity, prepare, recall, remember,
                                            set_targets)


@kernel
def gather(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vy: np.ndarray, inv_mass: np.ndarray,
           inv_inertia: np.ndarray, hx: np.ndarray, hy: np.ndarray, friction: np.ndarray, g: float, dt: float,
           margin: float, ids: np.ndarray, table: np.ndarray, keys: np.ndarray, carried: np.ndarray,
           held: int) -> tuple[np.ndarray, np.ndarray, int]:
    """One world's step problem into a contact table: gravity on ``vy`` (in place), the points within
    ``margin``, their anchors, masses, friction and targets, and the remembered impulses of the points seen
    last step in ``PN``, ``PT``. Returns the (maybe grown) table and the count."""
    gravity(vy, inv_mass, g, dt)
    ids, table, found = find_contacts(x, y, angle, hx, hy, inv_mass, margin, ids, table)
    count = 0
    for k in range(found):  # keep the points closer than ``margin``: at 0, those overlapping (the lab's rule)
        if table[k, DEPTH] > -margin:
            ids[count, :] = ids[k, :]
            table[count, :] = table[k, :]
            count += 1
    prepare(x, y, inv_mass, inv_inertia, friction, ids, table, count)
    set_targets(table, count, dt)
    recall(ids, table, count, keys, carried, held)
    return ids, table, count


def as_problem(ids: np.ndarray, table: np.ndarray, count: int, inv_mass: np.ndarray, inv_inertia: np.ndarray,
               vx: np.ndarray, vy: np.ndarray, w: np.ndarray) -> ContactProblem:
    """The ``ContactProblem`` of the first ``count`` points of a contact table, for free velocities
    ``vx, vy, w`` (after gravity)."""
    t = table[:count]
    return ContactProblem(inv_mass.copy(), inv_inertia.copy(), np.stack([vx, vy, w], axis=1), ids[:count, A].copy(),
                          ids[:count, B].copy(), t[:, NX:NY + 1].copy(), t[:, [RAX, RAY]].copy(),
                          t[:, [RBX, RBY]].copy(), t[:, MU].copy(), t[:, TARGET].copy())


def step_problem(state: PlanarState, b: int, g: float, dt: float, speculative: float) -> ContactProblem:
    """Row ``b``'s problem for a step of ``dt`` under gravity ``g`` with contacts within ``speculative``."""
    ids, table = contact_workspace(contact_room(state.bodies))
    vy = state.vy[b].copy()
    ids, table, count = gather(state.x[b], state.y[b], state.angle[b], vy, state.inv_mass[b], state.inv_inertia[b],
                               state.hx[b], state.hy[b], state.friction[b], g, dt, speculative, ids, table,
                               np.zeros((0, 3), np.int64), np.zeros((0, 2)), 0)
    return as_problem(ids, table, count, state.inv_mass[b], state.inv_inertia[b], state.vx[b], vy, state.w[b])


class ReferenceStep:
    """The reference solve of every step of a batch's rows, each row remembering its last impulses.

    ``rows`` worlds of ``bodies`` bodies; the memory holds the points of the last solve of each row."""

    def __init__(self, rows: int, bodies: int) -> None:
        room = contact_room(bodies)
        self.keys = [np.zeros((room, 3), np.int64) for _ in range(rows)]
        self.carried = [np.zeros((room, 2)) for _ in range(rows)]
        self.held = np.zeros(rows, np.int64)
        self.ids, self.table = contact_workspace(room)
        self.problem: ContactProblem | None = None  # the last problem solved

    def forget(self) -> None:
        """Start every row from zero impulses (after the bodies were renumbered)."""
        self.held[:] = 0

    def solve(self, b: int, x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
              w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray, hy: np.ndarray,
              friction: np.ndarray, g: float, dt: float, speculative: float) -> Solution:
        """Row ``b``'s step from its state before the step (arrays of the row, left untouched) solved to the
        reference's tolerance: the velocities after it and the impulses (``ReferenceFailure`` if not)."""
        vy = vy.copy()
        self.ids, self.table, count = gather(x, y, angle, vy, inv_mass, inv_inertia, hx, hy, friction, g, dt,
                                             speculative, self.ids, self.table, self.keys[b], self.carried[b],
                                             int(self.held[b]))
        self.problem = problem = as_problem(self.ids, self.table, count, inv_mass, inv_inertia, vx, vy, w)
        found = solve(problem, self.table[:count, PN], self.table[:count, PT])
        self.table[:count, PN], self.table[:count, PT] = found.pn, found.pt
        if count > self.keys[b].shape[0]:
            self.keys[b] = np.zeros((count, 3), np.int64)
            self.carried[b] = np.zeros((count, 2))
        self.held[b] = remember(self.ids, self.table, count, self.keys[b], self.carried[b])
        return found
