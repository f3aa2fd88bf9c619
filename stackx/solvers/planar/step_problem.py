"""The contact problem a step of a planar world sets itself, and its reference solve with memory across steps.

From the state before the step: gravity first (the free velocity), then every contact point closer than
``speculative`` to touching (with ``speculative`` 0, the points that overlap: the lab's rule), with anchors, effective masses, friction and targets made by the stages every
planar solver uses (``stackx.solvers.planar.contacts``): a touching point must not approach (target 0), a
point still ``gap`` apart may approach by at most what closes the gap within the step (target ``-gap/dt``).
So the reference solves the very problem the solvers set themselves.

``ReferenceStep`` keeps, per batch row, the impulses of the last solve by ``(body_a, body_b, feature)``, and
starts the next solve from them (``recall``/``remember``): from one step to the next most points carry
nearly the same load, and the solve then needs few or no Newton rounds.

**What a hopeless run costs.** A pile the reference cannot follow sets steps that nothing lands, each costing
the whole fallback (the proximal point method's walk and Lemke's pivoting: up to tens of seconds on a 20-row
pyramid). After ``MISSES`` such steps in a row, a row's solves are quick (``reference.solve``'s ``quick``):
without Lemke's walks on the whole problem (the proximal point method, and on a large problem the walk on its
points in doubt: 2 to 8 s a failing step of a toppling 20-row pyramid, against about 25 s), until a step lands
again. That may leave more steps unsolved, never a wrong answer: every unsolved step is counted and shown beside
the error, and a run with any is kept out of speed-against-error plots, fronts and winners. The rule depends
only on the run's own steps, so the same run gives the same counts. A failed solve whose best residual is below
``NEAR_MISS`` (1e-8 m/s, against the tolerance of 1e-10) shows the fallback working on this run, so it does not
count toward ``MISSES``. That is ``planar-exact``'s solve (``solve``).

**A step solved to be measured** (``measure``, the bench's step log): to the tolerance the measurement asks
(``stackx.bench.error_planar.stop_rule``), and where that misses once more from zero impulses (a cold restart:
the paths' Newton rounds then reach other closest answers; on recorded pyramid-20 steps three of eleven missed
steps landed so). On a problem over ``pivoting.EXACT_POINTS`` points Lemke's walk on the whole problem is left
out of both (where it ran in every fallback it landed 2 of 18 steps at 13 to 19 s each) and comes last, alone,
on a step that both starts missed (``WHOLE_WALK``): on the one step of ``pyramid-20``'s whole bench that they
missed (``planar-avbd`` at 4 iterations, closest answers at 4.8e-4 and 6.0e-4 m/s against a stop of 3.4e-4) it
lands in 3.4 s. After one that missed it is not tried again until a step of the row lands, so a pile the
reference cannot follow pays for it once a stretch. The proximal point method comes right
after the first central path (``reference.solve``'s ``early_walk``): on a toppling pile every path misses, and
the walk then costs less than the two more paths and five stages of friction before it (on 161 recorded
fallback steps of ``pyramid-20`` under ``planar-warm-start`` at 1 iteration, 23 s against 41; on ``pyramid-10``'s
steps that the later paths landed it lands too, for less). A step that still misses keeps the closest answer
either solve reached, which the bench measures and counts.

**A second solve** (``nearest``) looks for the exact answer nearest a solver's own, from its impulses, with a
short walk (``NEAREST_WALK``): see ``stackx.bench.error_planar`` for when the bench asks for one.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import compiled, enabled, kernel
from stackx.models.planar.monitor import contact_room
from stackx.solvers.planar import pivoting
from stackx.solvers.planar.problem import ContactProblem, residual, velocities_after
from stackx.solvers.planar.reference import PATH, WARM, ReferenceFailure, Solution, Tolerance, solve
from stackx.models.planar.state import PlanarState
from stackx.solvers.planar.contacts import (A, B, DEPTH, MU, NX, NY, PN, PT, RAX, RAY, RBX, RBY, TARGET,
                                            contact_workspace, find_contacts, gravity, prepare, recall, remember,
                                            set_targets)

MISSES = 3  # failed solves in a row after which a row's solves are quick
NEAR_MISS = 1e-8  # m/s: a failed solve whose best residual is below this does not count toward MISSES
# how a measured step's answer came (``ReferenceStep.measure``): the paths or a warm start's Newton rounds, the
# fallback (the proximal point method, Lemke's walk on the points in doubt), the cold restart, none
LANDED, FALLBACK, COLD, WHOLE, UNSOLVED = "path", "fallback", "cold restart", "whole walk", "unsolved"
WHOLE_WALK = True  # a measured step of a large problem that both starts missed ends with Lemke's walk on the whole
NEAREST_WALK = 20  # most rounds of the proximal point method in a second solve for the nearest answer


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
        self.whole_missed = np.zeros(rows, bool)  # the row's last whole walk missed, and no step landed since
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

    def _gather(self, b: int, x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray, hy: np.ndarray,
                friction: np.ndarray, g: float, dt: float, speculative: float) -> ContactProblem:
        """Row ``b``'s step problem into ``self.problem``, its remembered impulses in the table's ``PN``, ``PT``."""
        vy = vy.copy()
        self.ids, self.table, count = gather(x, y, angle, vy, inv_mass, inv_inertia, hx, hy, friction, g, dt,
                                             speculative, self.ids, self.table, self.keys[b], self.carried[b],
                                             int(self.held[b]))
        self.problem = as_problem(self.ids, self.table, count, inv_mass, inv_inertia, vx, vy, w)
        return self.problem

    def _solve(self, b: int, x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
               w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, hx: np.ndarray, hy: np.ndarray,
               friction: np.ndarray, g: float, dt: float, speculative: float) -> Solution:
        problem = self._gather(b, x, y, angle, vx, vy, w, inv_mass, inv_inertia, hx, hy, friction, g, dt,
                               speculative)
        count = problem.points
        try:
            found = solve(problem, self.table[:count, PN], self.table[:count, PT], quick=self.missed[b] >= MISSES)
        except ReferenceFailure as failure:
            if failure.best > NEAR_MISS:  # a near miss says the fallback works on this run: it is not counted
                self.missed[b] += 1
            raise
        self.missed[b] = 0
        self.keep(b, count, found)
        return found

    def measure(self, b: int, tolerance: Tolerance, *state: object) -> tuple[Solution, str]:
        """Row ``b``'s step (``state``: the arguments of ``solve`` after ``b``) solved for a measurement: to
        ``tolerance`` (the bench's stop tied to the error it measures), by the paths and the fallback (on a
        problem over ``pivoting.EXACT_POINTS`` points without Lemke's walk on the whole, which costs seconds
        there; below, it costs milliseconds and stays), then where that misses from zero impulses (a cold restart), and
        where that misses too, on such a problem, Lemke's walk on the whole alone (``WHOLE_WALK``; not again
        after one that missed until a step of the row lands), and where that misses the closest answer any
        reached (``closest``). Returns the answer and how it came (``LANDED``, ``FALLBACK``, ``COLD``, ``WHOLE``,
        ``UNSOLVED``); the answer is remembered for the row's next step either way. Depends only on the row's
        own steps."""
        with compiled(enabled()):  # compiled unless STACKX_JIT=0, however small the run it measures
            problem = self._gather(b, *state)  # type: ignore[arg-type]
            count = problem.points
            warm = self.table[:count, PN].copy(), self.table[:count, PT].copy()
            starts = [(warm, LANDED)] + ([((None, None), COLD)] if warm[0].any() or warm[1].any() else [])
            large = count > pivoting.EXACT_POINTS  # where the walk on the whole is regularized, and costs seconds
            failures = []
            for (pn, pt), how in starts:
                try:
                    found = solve(problem, pn, pt, tolerance=tolerance, quick=large, early_walk=True)
                except ReferenceFailure as failure:
                    failures.append(failure)
                    continue
                if how == LANDED and found.attempt not in (PATH, WARM):
                    how = FALLBACK
                self.whole_missed[b] = False
                self.keep(b, count, found)
                return found, how
            if WHOLE_WALK and large and not self.whole_missed[b]:
                try:  # Lemke's walk alone: the paths and the proximal point method have just missed twice
                    found = solve(problem, *warm, tolerance=tolerance, interior=False, walk=0)
                    self.keep(b, count, found)
                    return found, WHOLE
                except ReferenceFailure as failure:
                    self.whole_missed[b] = True
                    failures.append(failure)
            return self.closest(b, min(failures, key=lambda f: f.best)), UNSOLVED

    def nearest(self, pn: np.ndarray, pt: np.ndarray, tolerance: Tolerance) -> Solution | None:
        """An exact answer of the last problem near impulses ``pn``, ``pt`` (a solver's own): the proximal point
        method from them, which walks to an answer near its start (no central path, whose end does not depend on
        where it starts; no Lemke's walk, whose ends do not either); None where it misses. At most
        ``NEAREST_WALK`` of its rounds: a walk that has not landed by then is a long one from impulses far from
        consistent (``planar-avbd``'s), and on the recorded benches the rest of it bought nothing (docs/bench.md).
        Nothing is remembered."""
        problem = self.problem
        assert problem is not None
        with compiled(enabled()):
            try:
                return solve(problem, pn, pt, tolerance=tolerance, interior=False, walk=NEAREST_WALK, lemke=False)
            except ReferenceFailure:
                return None

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
