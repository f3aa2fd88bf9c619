"""Every step's contact problem solved exactly on planar boxes: the ground truth the planar solvers tend to.

One step of one world:
1. gravity on every movable box;
2. the contact points within ``speculative`` of touching, with targets (0 for a touching point, ``-gap/dt``
   for one still apart), anchors, effective masses and friction (``stackx.solvers.planar.contacts``);
3. the velocity problem solved to a residual below 1e-10 m/s by the reference solve
   (``stackx.solvers.planar.reference``: Gauss-Seidel for the active set, then Newton on it), starting from
   the impulses the same points carried in the last step. A step it does not solve to that tolerance keeps
   the closest answer the solve found and goes on: the run is the user's, and one hard step must not end
   it. Such steps are counted in the state (``unsolved``, with the first of them and the largest residual
   kept), so the run's measures (``unsolved_steps``, ``first_unsolved``, ``worst_unsolved``) and its table
   say so;
4. positions and angles move with the velocities;
5. the lab's position correction (slop, percent) on the points that overlap after the move.

Steps 1, 2, 4 and 5 are compiled kernels; the solve's linear algebra (the central path's iterations, each
mode system's band LU and its proximal steps: ``stackx.solvers.planar.banded``) is compiled too, the choice of
its stages numpy. The solver's only knobs say which problem it sets itself (``speculative``) and how overlap is
undone (``correction``); the solve has no knob: it is exact or it fails.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from stackx.kernel import kernel
from stackx.models.planar.monitor import contact_room, observe
from stackx.solvers.planar.reference import ReferenceFailure
from stackx.models.planar.state import PlanarState
from stackx.solvers.planar.step_problem import ReferenceStep
from stackx.registry import solvers
from stackx.solvers.base import Correction, LabCorrection
from stackx.solvers.contacts import speculative_field
from stackx.solvers.planar.contacts import contact_workspace, correct_positions, find_contacts, integrate_positions
from stackx.solvers.planar.base import PlanarSolver, StepImpulses, sequential_only


class PlanarExactParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    speculative: float = speculative_field(
        0.02, "; at 0 only overlapping points take part, as in the lab solver")
    correction: LabCorrection = Field(
        default_factory=Correction,
        description="the lab's position correction after the exact velocity solve (slop, percent; translation "
                    "along each point's normal), or 'off': the same stage as planar-pgs's, so the two differ "
                    "only in how well the velocities are solved")

    _sequential = field_validator("correction")(sequential_only)


@kernel
def finish_step(x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray, w: np.ndarray,
                inv_mass: np.ndarray, hx: np.ndarray, hy: np.ndarray, dt: float, corrects: bool, slop: float,
                percent: float, ids: np.ndarray, table: np.ndarray, shift: np.ndarray, last: np.ndarray,
                peak: np.ndarray, reach: np.ndarray, touched: np.ndarray, launch: np.ndarray,
                b: int) -> tuple[np.ndarray, np.ndarray]:
    """After the velocity solve of row ``b``: positions, the lab's correction, the monitors. Returns the
    (maybe grown) contact table."""
    integrate_positions(x, y, angle, vx, vy, w, dt)
    if corrects:
        ids, table, count = find_contacts(x, y, angle, hx, hy, inv_mass, 0.0, ids, table)
        correct_positions(x, y, inv_mass, ids, table, count, slop, percent, shift)
    observe(x, y, angle, hx, hy, inv_mass, dt, last, peak, reach, touched, launch, b)
    return ids, table


@solvers.register("planar-exact")
class PlanarExact(PlanarSolver):
    """The velocity problem of every step solved to a residual below 1e-10 m/s: the limit of the planar
    iterative solvers' iterations, and the bench's reference on the planar model."""

    Params = PlanarExactParams

    def __init__(self, params: list[PlanarExactParams], gravity: np.ndarray, dt: np.ndarray) -> None:
        super().__init__(params, gravity, dt)
        self.corrects, self.slop, self.percent = self.lab_correction()
        self.speculative = self.column("speculative")
        self.reference: ReferenceStep | None = None
        self.steps = 0  # steps taken, to name the one that fails

    def advance(self, state: PlanarState, steps: int) -> None:
        s = state
        if self.reference is None:
            self.reference = ReferenceStep(s.batch, s.bodies)
        ids, table = contact_workspace(contact_room(s.bodies))
        shift = np.zeros((s.bodies, 2))
        for _ in range(steps):
            for b in range(s.batch):
                try:
                    found = self.reference.solve(b, s.x[b], s.y[b], s.angle[b], s.vx[b], s.vy[b], s.w[b],
                                                 s.inv_mass[b], s.inv_inertia[b], s.hx[b], s.hy[b], s.friction[b],
                                                 self.gravity[b], self.dt[b], self.speculative[b])
                except ReferenceFailure as failure:
                    found = self.reference.closest(b, failure)
                    s.unsolved[b] += 1
                    if s.first_unsolved[b] < 0:
                        s.first_unsolved[b] = self.steps
                    s.worst_unsolved[b] = max(s.worst_unsolved[b], found.residual)
                s.vx[b], s.vy[b], s.w[b] = found.velocity[:, 0], found.velocity[:, 1], found.velocity[:, 2]
                ids, table = finish_step(s.x[b], s.y[b], s.angle[b], s.vx[b], s.vy[b], s.w[b], s.inv_mass[b],
                                         s.hx[b], s.hy[b], self.dt[b], self.corrects[b], self.slop[b],
                                         self.percent[b], ids, table, shift, *s.monitors(), b)
            self.steps += 1

    def step_impulses(self, b: int) -> StepImpulses | None:
        """The impulses of row ``b``'s last solve (on a step it could not solve, the closest it found); None
        before the first step."""
        ref = self.reference
        if ref is None:
            return None
        n = int(ref.held[b])
        return StepImpulses(ref.keys[b][:n].copy(), ref.carried[b][:n, 0].copy(), ref.carried[b][:n, 1].copy())

    def remove_box(self, state: PlanarState, box: int) -> None:
        """The remembered points name bodies by index, which the removal shifts: start again from zero."""
        if self.reference is not None:
            self.reference = ReferenceStep(state.batch, state.bodies - 1)
