"""The figures a bench step log gives per run, whatever the model: one place for reading a batch's arrays.

Each model's step log (``stackx.bench.error_column``, ``stackx.bench.error_planar``) keeps, per batch, arrays
with one element per row: ``sumsq``, ``values`` (differences compared), ``measured`` (steps compared),
``worst``, ``worst_step``, ``crushed_at``, ``last_overlap``, ``last_unheld``, ``last_moving`` and ``steps``.
``RowLog`` reads row ``b`` of them as the bench's error, crushed step and timeline; ``StepLog`` is what both
logs' observers share: a row log per run name, and the per-row numbers every step needs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from stackx.bench.criteria import Criteria
from stackx.config.spec import RunSpec


@dataclass
class RowLog:
    """What one run's steps came to: row ``b`` of a model's batch log."""

    log: Any
    b: int

    def error(self) -> dict[str, Any]:
        """``rms`` and ``max`` (m/s) over every step measured, the ``worst_step`` (0-based; None where no step
        differs), and how many ``steps`` were measured (all, or those before the run was crushed)."""
        log, b = self.log, self.b
        if log.values[b] == 0:
            return {"rms": None, "max": None, "worst_step": None, "steps": 0}
        worst = float(log.worst[b])
        return {"rms": float(np.sqrt(log.sumsq[b] / log.values[b])), "max": worst,
                "worst_step": int(log.worst_step[b]) if worst != 0.0 else None, "steps": int(log.measured[b])}

    @property
    def crushed_at(self) -> int | None:
        return int(self.log.crushed_at[self.b]) if self.log.crushed_at[self.b] >= 0 else None

    def timeline(self) -> dict[str, int | None]:
        """``steps_to_recover`` and ``steps_to_settle``: None when the last step did not get there."""
        log, b = self.log, self.b
        last = log.steps - 1
        overlap, settle_at = int(log.last_overlap[b]), int(max(log.last_unheld[b], log.last_moving[b]))
        return {"steps_to_recover": None if overlap == last else overlap + 1,
                "steps_to_settle": None if settle_at == last else settle_at + 1}


class StepLog:
    """A ``stackx.run.runner.StepObserver`` keeping a ``RowLog`` per run name; each model's log says how a batch's
    steps are measured (``batch``)."""

    row_log: type[RowLog] = RowLog

    def __init__(self, criteria: Criteria) -> None:
        self.criteria = criteria
        self.rows: dict[str, RowLog] = {}

    def start(self, log: Any, runs: list[RunSpec]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Row logs for the batch's runs (row ``b`` of ``log``), and per row its gravity, time step and the
        solver's own speculative margin (0 for a solver without one)."""
        self.rows.update((r.name, self.row_log(log, b)) for b, r in enumerate(runs))
        g = np.array([r.gravity for r in runs], dtype=np.float64)
        dt = np.array([r.dt for r in runs], dtype=np.float64)
        speculative = np.array([float(getattr(r.solver_params, "speculative", 0.0)) for r in runs])
        return g, dt, speculative
