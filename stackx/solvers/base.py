"""What every solver plugin has: a params model, the models it steps, and ``advance``.

A solver is built once per batch: it receives one validated params object per batch row (the variants of a
sweep may differ in any parameter) and packs them into arrays for its stepping loop. ``advance`` moves the
state of one of its ``models`` forward by a number of steps in place and updates the state's monitors after
every step (on the column: ``stackx.models.column.monitor.observe``).
"""

from __future__ import annotations

from typing import Annotated, Any, ClassVar, Literal

import numpy as np
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field

from stackx.solvers.column.position import STAGES


class Correction(BaseModel):
    """Position correction after the velocity solve: the lab's ``correct()``, contact by contact or for the
    whole column at once (``stackx.solvers.column.position`` says what each stage trades)."""

    model_config = ConfigDict(extra="forbid")
    slop: float = Field(0.01, ge=0, allow_inf_nan=False,
                        description="overlap left alone (m): 0 makes a tiny correction every step and jitters")
    percent: float = Field(0.2, gt=0, le=1, allow_inf_nan=False,
                           description="share of the overlap beyond slop undone per step: small values settle "
                                       "slowly; the lab warns that 1.0 throws boxes out (configs/hard/percent-1 "
                                       "measures it)")
    stage: Literal["sequential", "global"] = Field(
        "sequential", description="'sequential': the lab's, contact by contact bottom-up (a column overlapping "
                                  "everywhere recovers in steps growing with the square of its height); "
                                  "'global': every contact at once, an O(n) projection (a tall column recovers "
                                  "in one step, so use it with max_push)")
    max_push: float | None = Field(None, gt=0, allow_inf_nan=False,
                                   description="fastest the stage may move a box (m/s), by scaling its whole move "
                                               "down; null: no limit (the lab). Below 1 m/s it never launches a "
                                               "box; smaller values recover more slowly")


def _off(value: Any) -> Any:
    """``correction: off`` (or false) switches the lab's position correction off."""
    return None if value is False or value == "off" else value


LabCorrection = Annotated[Correction | None, BeforeValidator(
    _off, json_schema_input_type=Correction | Literal["off", False] | None)]
"""The lab's position correction as a params field: ``{slop, percent}``, or ``off``/null for none."""


class Solver:
    """Base of solver plugins."""

    Params: ClassVar[type[BaseModel]]
    models: ClassVar[tuple[str, ...]] = ("column",)
    plugin_name: ClassVar[str]

    def __init__(self, params: list[Any], gravity: np.ndarray, dt: np.ndarray) -> None:
        self.params = params
        self.gravity = np.ascontiguousarray(gravity, dtype=np.float64)
        self.dt = np.ascontiguousarray(dt, dtype=np.float64)

    def column(self, name: str, default: float = 0.0) -> np.ndarray:
        """One float per batch row from the params (``a.b`` reaches into sub-models; None gives default)."""
        out = []
        for p in self.params:
            for part in name.split("."):
                p = getattr(p, part) if p is not None else None
            out.append(default if p is None else float(p))
        return np.array(out, dtype=np.float64)

    def counts(self, name: str) -> np.ndarray:
        """An integer knob (iterations, substeps) per batch row."""
        return np.array([getattr(p, name) for p in self.params], dtype=np.int64)

    def flags(self, name: str) -> np.ndarray:
        """A yes/no knob per batch row."""
        return np.array([bool(getattr(p, name)) for p in self.params], dtype=np.bool_)

    def corrections(self) -> tuple[np.ndarray, ...]:
        """Per batch row of a solver with a ``correction`` knob, the arguments of its position stage: whether
        it runs, slop, percent, stage (``stackx.solvers.column.position.STAGES``) and max_push (m/s, inf for none)."""
        on = np.array([p.correction is not None for p in self.params], dtype=np.bool_)
        stage = np.array([STAGES[p.correction.stage] if p.correction is not None else 0 for p in self.params],
                         dtype=np.int64)
        return (on, self.column("correction.slop"), self.column("correction.percent"), stage,
                self.column("correction.max_push", np.inf))

    def advance(self, state: Any, steps: int) -> None:
        raise NotImplementedError

    @classmethod
    def passes(cls, params: Any) -> int:
        """Sweeps over the column per step, for the work estimate checked against ``limits.max_work``
        before a run: ``iterations`` times ``substeps`` where the params have them; override when not."""
        count = 1
        for name in ("iterations", "substeps"):
            value = getattr(params, name, None)
            if isinstance(value, int) and value > 0:
                count *= value
        return count

    @classmethod
    def default_passes(cls) -> int:
        """``passes`` at the solver's default params (1 when its params have no defaults): the yardstick its
        rows' passes are weighed against when the runner decides whether compiling pays. One solver's pass is
        not another's (``exact``'s is a whole direct solve, ``pgs``'s one sweep), but a box-step at each
        solver's defaults costs about the same in plain Python (20 to 30 µs on the column)."""
        try:
            return max(1, int(cls.passes(cls.Params())))
        except Exception:
            return 1

    def step_work(self, state: Any, bodies: int) -> np.ndarray:
        """Contact visits one step makes, per batch row (float64, ``(batch,)``): ``passes + 1`` times
        ``bodies`` (a column has one contact per box; a pile about one a body), the one being the step's
        integration, correction and monitors. The runner reads it after every stretch of steps: to share a
        batch's time among its rows, and to decide whether compiling the batch pays
        (``stackx.kernel.worth_compiling``, weighed against the solver's defaults: ``default_passes``). The
        passes are ``passes`` of each row's params with the ``iterations`` and ``substeps`` this solver holds,
        which a solver may change as it steps (the README's ``pgs-tall`` raises its iterations in
        ``advance``). Override to count what a step really did (a solver that stops at a tolerance) from
        ``state`` or from the solver's own memory."""
        return (self.held_passes(state.batch) + 1.0) * float(bodies)

    def held_passes(self, rows: int) -> np.ndarray:
        """``passes`` of each row's params, scaled where the solver now holds other ``iterations`` or
        ``substeps`` (integer arrays of one value per row) than its params gave: numpy over the rows, as the
        runner asks after every stretch of steps and a sweep has thousands of rows."""
        given, counts = self._given_passes(rows)
        passes = given
        for name, count in counts.items():
            held = getattr(self, name, None)
            if (isinstance(held, np.ndarray) and held.shape == count.shape and held.dtype.kind in "iu"
                    and not np.array_equal(held, count)):
                passes = passes * np.where(count > 0, held / np.maximum(count, 1), 1.0)
        return passes

    def _given_passes(self, rows: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Each row's ``passes`` and its ``iterations`` and ``substeps`` as its params give them (made once);
        one pass a row for a solver that keeps no params per row."""
        made = self.__dict__.get("_passes_given")
        if made is None or len(made[0]) != rows:
            params = getattr(self, "params", None)
            if not isinstance(params, list) or len(params) != rows:
                return np.ones(rows), {}
            counts = {}
            for name in ("iterations", "substeps"):
                values = [getattr(p, name, None) for p in params]
                if values and all(isinstance(v, int) for v in values):
                    counts[name] = np.array(values, dtype=np.int64)
            made = (np.array([self.passes(p) for p in params], dtype=np.float64), counts)
            self.__dict__["_passes_given"] = made
        return made  # type: ignore[no-any-return]

    def remove_box(self, state: Any, box: int) -> None:
        """Forget box ``box``, which a scene event is about to take out of ``state`` (still holding it).

        Memory kept per box or per contact (contact k is the one under box k, as in ``state.depths()``) in
        array attributes shaped ``(batch, boxes)`` loses column ``box``: the contact under the box goes, and
        the one above it becomes the contact between the two neighbours, keeping its value (it carried the
        same load). A solver keeping such memory in another shape overrides this.
        """
        for name, value in vars(self).items():
            if isinstance(value, np.ndarray) and value.shape[:2] == (state.batch, state.boxes):
                setattr(self, name, np.ascontiguousarray(np.delete(value, box, axis=1)))
