"""The contact problem a step of a planar world sets itself, and its reference solve with memory across steps.

From the state before the step: gravity first (the free velocity), then every contact point closer than
``speculative`` to touching (with ``speculative`` 0, the points that overlap: the lab's rule), with anchors, effective masses, friction and targets made by the stages every
planar solver uses (``stackx.solvers.planar.contacts``): a touching point must not approach (target 0), a
point still ``gap`` apart may approach by at most what closes the gap within the step (target ``-gap/dt``).
So the reference solves the very problem the solvers set themselves.

``ReferenceStep`` keeps, per batch row, the impulses of the last solve by ``(body_a, body_b, feature)``, and
starts the next solve from them (``recall``/``remember``): from one step to the next most points carry
nearly the same load, and the solve then needs few or no Newton rounds.

**The try that landed the last step comes first.** A row also keeps which of the solve's tries landed its last
step (``Solution.attempt``), and its next solve begins with that try, the earlier ones coming last
(``reference.solve``'s ``begin``). A pile that needs the proximal point method at nearly every step
(``pyramid-10`` under ``planar-xpbd``) so skips the three cheap tries, 0.45 s a step that never landed: its first
150 steps at 16 substeps cost the reference 191 s against 336 s, one run of each version side by side
(``python3 -m benchmarks.planar_reference --steps 150 --run configs/planar/pyramid-10.yaml planar-xpbd 16``,
the ``total s`` column). The count of unsolved steps moved (27 then, 33 after; 1 since stalls are probed, see
``reference``): the impulses that hold a pile are not unique, and which answer a try lands on is the next
step's start. A solve begun elsewhere that misses is made again in the default order before it counts as
missed: the tries leave each other different starts (the stall is probed once), and on step 345 of a
leaning row of dominoes the order begun at the fifth try missed what the default order lands.

**What a hopeless run costs.** A pile the reference cannot follow sets steps that every try fails, each
costing all the tries (a 20-row pyramid under ``planar-xpbd`` at 16 substeps: 9 of its first 40 steps, up to
81 s a solve, on 2 shared cores: ``python3 -m benchmarks.planar_reference --steps 40 --run
configs/planar/pyramid-20.yaml planar-xpbd 16``). After ``MISSES`` such steps in a row, a row's solves are quick: the first ``reference.QUICK``
tries of their order, the walk of the proximal point method cut to ``reference.SETTLE_QUICK`` rounds, until one
lands again. That may leave more steps unsolved, never a wrong answer: every unsolved step is counted and
shown beside the error, and a run with any is kept out of speed-against-error plots, fronts and winners. The
rule depends only on the run's own steps, so the same run gives the same counts. Why two tries: a trembling
``stack-40`` (``planar-warm-start`` at 16 iterations, relaxation 1.9) whose solves made the first try alone
after three early misses left 597 of its 600 steps unsolved; with the second try (full rounds), 2
(``python3 -m benchmarks.planar_reference --steps 600 --run configs/planar/stack-40.yaml planar-warm-start 16``).
Why in the run's order: when the quick tries were always the two cheap ones, a run that needs the walk landed
nothing once quick, and ``pyramid-10`` under ``planar-xpbd`` at 4 substeps left 126 of its first 150 steps
unsolved (its RMS error, 0.0592 m/s, then came from 24 steps); now 39 (0.0464 m/s), at 301 s against 240 s.

**A near miss is not counted.** A failed solve whose best residual is below ``NEAR_MISS`` (1e-8 m/s, against
the tolerance of 1e-10) shows the full tries working on this run, so it does not count toward ``MISSES``.
``pyramid-10`` under ``planar-xpbd`` at 16 substeps needs the proximal point method (the fourth try) at
nearly every step; six steps in a row ended at 2.3e-10 m/s, and the quick tries that followed (then the two
cheap ones) could land none of the rest: 46 of its first 150 steps unsolved, 27 with near misses not counted.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import compiled, enabled, kernel
from stackx.models.planar.monitor import contact_room
from stackx.models.planar.problem import ContactProblem, residual, velocities_after
from stackx.models.planar.reference import ReferenceFailure, Solution, solve
from stackx.models.planar.state import PlanarState
from stackx.solvers.planar.contacts import (A, B, DEPTH, MU, NX, NY, PN, PT, RAX, RAY, RBX, RBY, TARGET,
                                            contact_workspace, find_contacts, gravity, prepare, recall, remember,
                                            set_targets)

MISSES = 3  # failed solves in a row after which a row's solves make only their quick tries
NEAR_MISS = 1e-8  # m/s: a failed solve whose best residual is below this does not count toward MISSES


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
        self.missed = np.zeros(rows, np.int64)  # steps in a row the solve failed, per row
        self.landed = np.ones(rows, np.int64)  # the try that landed the row's last solved step: the next begins there
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
        with compiled(enabled()):  # compiled unless STACKX_JIT=0, however small the run it measures
            return self._solve(b, x, y, angle, vx, vy, w, inv_mass, inv_inertia, hx, hy, friction, g, dt,
                               speculative)

    def _solve(self, b: int, x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
               w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray, hy: np.ndarray,
               friction: np.ndarray, g: float, dt: float, speculative: float) -> Solution:
        vy = vy.copy()
        self.ids, self.table, count = gather(x, y, angle, vy, inv_mass, inv_inertia, hx, hy, friction, g, dt,
                                             speculative, self.ids, self.table, self.keys[b], self.carried[b],
                                             int(self.held[b]))
        self.problem = problem = as_problem(self.ids, self.table, count, inv_mass, inv_inertia, vx, vy, w)
        try:
            found = solve(problem, self.table[:count, PN], self.table[:count, PT], quick=self.missed[b] >= MISSES,
                          begin=int(self.landed[b]))
        except ReferenceFailure as failure:
            if failure.best > NEAR_MISS:  # a near miss says the full tries work on this run: it is not counted
                self.missed[b] += 1
            raise
        self.missed[b] = 0
        if found.attempt:  # the interior point stage (0) comes first anyway: the memory is of the tries after it
            self.landed[b] = found.attempt
        self.keep(b, count, found)
        return found

    def closest(self, b: int, failure: ReferenceFailure) -> Solution:
        """Row ``b``'s last solve, which raised ``failure``, answered by the closest impulses it found (zero
        impulses when it found none), remembered as a solved step's are: for a solver that must go on."""
        problem = self.problem
        assert problem is not None
        count = problem.points
        pn = np.zeros(count) if failure.pn is None else failure.pn
        pt = np.zeros(count) if failure.pt is None else failure.pt
        found = Solution(pn, pt, velocities_after(problem, pn, pt), residual(problem, pn, pt), 0, 0, 0)
        self.keep(b, count, found)
        return found

    def keep(self, b: int, count: int, found: Solution) -> None:
        """Remember the impulses of ``found`` by feature, for row ``b``'s next solve."""
        self.table[:count, PN], self.table[:count, PT] = found.pn, found.pt
        if count > self.keys[b].shape[0]:
            self.keys[b] = np.zeros((count, 3), np.int64)
            self.carried[b] = np.zeros((count, 2))
        self.held[b] = remember(self.ids, self.table, count, self.keys[b], self.carried[b])
