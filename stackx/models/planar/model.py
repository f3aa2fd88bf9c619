"""The planar model as a plugin: its state, measures, health check and the bench's reference solver (the
bench's every-step log against it is ``stackx.bench.error_planar``)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from stackx.models import Measures, Model, Offender
from stackx.models.planar import measures
from stackx.models.planar.state import PlanarState
from stackx.registry import models

if TYPE_CHECKING:
    from stackx.run.results import RunResult
    from stackx.config.spec import RunSpec


@models.register("planar")
class Planar(Model):
    """Rigid boxes in a vertical plane over a ground: they slide, rotate and rest on corners."""

    State = PlanarState
    SCALARS = measures.SCALARS
    VECTORS = measures.VECTORS
    window = measures.MOTION_WINDOW
    reference = "planar-exact"
    bytes_per_body = 112  # a recorded state per body: 12 float64 arrays and touched, rounded up
    step_cost = 100.0  # a planar body-step in plain Python (collision, two-point manifolds, friction) costs about
    # a hundred column box-steps: a 55-box pyramid steps at some 0.12 s per step uncompiled

    @classmethod
    def speeds(cls, state: Any) -> np.ndarray:
        """Each body's fastest point, ``(batch, bodies)``: the centre's speed plus |w| times the half-diagonal
        (m/s), what ``limits.max_speed`` bounds."""
        return np.hypot(state.vx, state.vy) + np.abs(state.w) * measures.half_diagonal(state)  # type: ignore[no-any-return]

    @classmethod
    def measure(cls, frames: Mapping[int, Any], steps: int, dt: Any) -> list[Measures]:
        return measures.measure(frames, steps, dt)

    @classmethod
    def state_measures(cls, state: Any) -> Measures:
        return measures.state_measures(state)

    @classmethod
    def offender(cls, state: Any, max_speed: float) -> Offender | None:
        """Rows first, then bodies in order: a non-finite pose or velocity, or a body whose fastest point
        (centre speed plus |w| times its half-diagonal) goes faster than ``max_speed``."""
        pose = np.isfinite(state.x) & np.isfinite(state.y) & np.isfinite(state.angle)
        velocity = np.isfinite(state.vx) & np.isfinite(state.vy) & np.isfinite(state.w)
        finite = pose & velocity
        with np.errstate(invalid="ignore", over="ignore"):
            speed = cls.speeds(state)
        fast = np.where(finite, speed, 0.0) > max_speed
        bad = ~finite | fast
        if not bad.any():
            return None
        row, body = (int(i) for i in np.argwhere(bad)[0])
        at = {k: float(getattr(state, k)[row, body]) for k in ("x", "y", "angle", "vx", "vy", "w")}
        if not finite[row, body]:
            return row, body, "non-finite", "is not finite (" + ", ".join(f"{k} = {v}" for k, v in at.items()) + ")"
        return (row, body, "speed", f"moves at {speed[row, body]:.4g} m/s (centre and rotation), over "
                                    f"limits.max_speed = {max_speed:g} m/s")

    @classmethod
    def motion(cls, state: Any, b: int) -> dict[str, list[float]]:
        return {k: getattr(state, k)[b].tolist() for k in ("x", "y", "angle", "vx", "vy", "w")}

    @classmethod
    def bench_measures(cls, result: RunResult, every_step: bool) -> dict[str, float]:
        return measures.bench_measures(result)

    @classmethod
    def unjudged(cls, run: RunSpec) -> tuple[str, ...]:
        return measures.unjudged(run.scene)
