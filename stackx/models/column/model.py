"""The column as a model plugin: its state, measures, health check and the bench's reference solver (the
bench's every-step log against it is ``stackx.bench.error_column``)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from stackx.models import Measures, Model, Offender
from stackx.models.column import measures
from stackx.models.column.state import ColumnState
from stackx.registry import models

if TYPE_CHECKING:
    from stackx.run.results import RunResult


@models.register("column")
class Column(Model):
    """Boxes stacked on a floor, moving only vertically; box ``i`` rests on box ``i - 1``."""

    State = ColumnState
    SCALARS = measures.SCALARS
    VECTORS = measures.VECTORS
    window = measures.MOTION_WINDOW
    reference = "exact"
    bytes_per_body = 40  # a recorded state per box: y, v, inv_mass, half (float64) and touched, rounded up

    @classmethod
    def measure(cls, frames: Mapping[int, Any], steps: int, dt: Any) -> list[Measures]:
        return measures.measure(frames, steps, dt)

    @classmethod
    def state_measures(cls, state: Any) -> Measures:
        return measures.state_measures(state)

    @classmethod
    def offender(cls, state: Any, max_speed: float) -> Offender | None:
        """Rows first, then boxes bottom-up: a non-finite height or velocity, or a speed over the limit."""
        finite = np.isfinite(state.y) & np.isfinite(state.v)
        fast = np.abs(np.where(finite, state.v, 0.0)) > max_speed
        bad = ~finite | fast
        if not bad.any():
            return None
        row, box = (int(i) for i in np.argwhere(bad)[0])
        y, v = float(state.y[row, box]), float(state.v[row, box])
        if not finite[row, box]:
            return row, box, "non-finite", f"is not finite (y = {y}, v = {v})"
        return row, box, "speed", f"moves at {abs(v):.4g} m/s, over limits.max_speed = {max_speed:g} m/s"

    @classmethod
    def motion(cls, state: Any, b: int) -> dict[str, list[float]]:
        return {"y": state.y[b].tolist(), "v": state.v[b].tolist()}

    @classmethod
    def bench_measures(cls, result: RunResult, every_step: bool) -> dict[str, float]:
        extra = measures.extra_measures(result)
        if every_step:
            extra.update(measures.top_motion(result))
        return extra
