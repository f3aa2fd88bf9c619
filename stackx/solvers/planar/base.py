"""What the planar solvers share beyond their stages: the model they step, the lab's correction knob, the
impulses carried between steps for warm starting, and the impulses a step applied, shown to the bench.

**A step's own answer.** ``PlanarSolver.step_impulses(b)`` gives the impulses row ``b``'s last step applied
at each contact point (``StepImpulses``), keyed by ``(A, B, FEATURE)`` as the contact table keys them, so
the bench can check them against the step's contact conditions (``stackx.solvers.planar.conditions``)
without a reference. What "applied" means is each solver's to say: for a solver with one velocity solve a
step, that solve's accumulated impulses; for one that takes substeps at fixed anchors, their sum over the
substeps. None (the default) says the solver has no impulses that give its velocities (XPBD, engines): the
bench then checks what velocities alone show.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from stackx.models.planar.monitor import contact_room
from stackx.models.planar.state import PlanarState
from stackx.solvers.base import Correction, Solver


def sequential_only(correction: Correction | None) -> Correction | None:
    """Refuse the column's ``global`` stage and ``max_push``: only the lab's sequential stage is carried over
    to planar boxes, and a knob that would be ignored is an error rather than a silent no-op."""
    if correction is not None and (correction.stage != "sequential" or correction.max_push is not None):
        raise ValueError("the planar model has only the sequential stage: leave 'stage' at 'sequential' and "
                         "'max_push' unset")
    return correction


@dataclass(frozen=True)
class StepImpulses:
    """The impulses one step of one world applied per contact point: ``keys`` ``(m, 3)`` the points'
    ``(A, B, FEATURE)`` (``contacts``' ids columns), ``pn``, ``pt`` ``(m,)`` the normal and tangent impulses
    (N s) along the point's normal and tangent ``t = (-ny, nx)``."""

    keys: np.ndarray
    pn: np.ndarray
    pt: np.ndarray


class PlanarSolver(Solver):
    """Base of the planar solvers: they step ``PlanarState``s."""

    watched = False  # whether a caller reads ``step_impulses`` after every step (``watch_impulses``)

    models = ("planar",)
    speculative_reach: ClassVar[bool] = False  # True: the contact margin grows with speed (planar.reach)

    def lab_correction(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per batch row: whether the lab's correction runs, its slop and percent."""
        on, slop, percent, _, _ = self.corrections()
        return on, slop, percent

    def remove_box(self, state: PlanarState, box: int) -> None:
        """Nothing to forget: a solver without memory between steps."""

    def step_impulses(self, b: int) -> StepImpulses | None:
        """The impulses row ``b``'s last step applied (see the module text); None: not exposed."""
        return None

    def watch_impulses(self) -> None:
        """The caller reads ``step_impulses`` after every step: a solver that spends work only to keep them
        (the soft step sums them over its substeps, pgs records what its passes gave) keeps them from now on
        (``watched``); stepping alone does not pay for it."""
        self.watched = True


class PlanarMemorySolver(PlanarSolver):
    """A planar solver that keeps each contact point's impulses at the end of its last step: what a warm
    started solver starts the next step from, and (``step_impulses``) the step's own answer.

    Per batch row: ``keys`` ``(room, 3)``, the ``(A, B, FEATURE)`` of the points of the last step in
    ``collide``'s order, ``carried`` ``(room, 2)`` their normal and tangent impulses, and ``held`` how many
    there are. ``room`` is the room the monitors first give a world (8 points a box): a world with more
    points keeps the first ``room`` of them, and the rest start their next step from zero. A solver that carries
    more per point (forces and stiffnesses, friction anchors) sets ``carried_values``.
    """

    carried_values: ClassVar[int] = 2  # what ``carried`` holds per point: here its normal and tangent impulses

    def __init__(self, params: list[Any], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.keys: np.ndarray | None = None
        self.carried: np.ndarray | None = None
        self.held: np.ndarray | None = None

    def memory(self, state: PlanarState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(keys, carried, held)``, empty the first time (or when the state's shape changed). A row's
        points are read only up to its ``held``, so the room is made empty, not cleared: clearing it (4 MB
        for 64 rows of 210 boxes) took up to a millisecond and a half of a fresh solver's first call."""
        room = contact_room(state.bodies)
        if self.keys is None or self.keys.shape[:2] != (state.batch, room):
            self.keys = np.empty((state.batch, room, 3), np.int64)
            self.carried = np.empty((state.batch, room, self.carried_values))
            self.held = np.zeros(state.batch, np.int64)
        assert self.carried is not None and self.held is not None
        return self.keys, self.carried, self.held

    def step_impulses(self, b: int) -> StepImpulses | None:
        """The impulses the memory holds for row ``b``: the last velocity solve's accumulated totals. None
        before the first step, and when the memory is full (points past its room were applied but not kept,
        so the answer would be incomplete)."""
        if self.keys is None or self.held is None or self.held[b] >= self.keys.shape[1]:
            return None
        assert self.carried is not None
        n = int(self.held[b])
        return StepImpulses(self.keys[b, :n].copy(), self.carried[b, :n, 0].copy(), self.carried[b, :n, 1].copy())

    def remove_box(self, state: PlanarState, box: int) -> None:
        """Forget the points of box ``box`` and renumber the boxes after it, keeping every other point's
        impulses (the order by bodies is kept, so the next step still finds them), in a memory sized for one
        box fewer."""
        if self.keys is None:
            return
        assert self.carried is not None and self.held is not None
        room = contact_room(state.bodies - 1)
        keys = np.zeros((state.batch, room, 3), np.int64)
        carried = np.zeros((state.batch, room, self.carried_values))
        held = np.zeros(state.batch, np.int64)
        for b in range(state.batch):
            k, c = self.keys[b, :self.held[b]], self.carried[b, :self.held[b]]
            keep = (k[:, 0] != box) & (k[:, 1] != box)
            k, c = k[keep].copy(), c[keep]
            k[:, :2] -= k[:, :2] > box
            held[b] = n = min(len(k), room)
            keys[b, :n], carried[b, :n] = k[:n], c[:n]
        self.keys, self.carried, self.held = keys, carried, held
