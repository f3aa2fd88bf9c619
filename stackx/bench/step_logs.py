"""Which step log watches a bench case's runs: the bench's own for the built-in models, the model's for others.

Measuring every step against a reference needs the reference solver (``stackx.solvers``) and the bench's
criteria, so a model does not carry it: the column's log is ``stackx.bench.error_column``, the planar
model's ``stackx.bench.error_planar``. A model's own ``Model.step_log``, when it gives one, comes first.
"""

from __future__ import annotations

from typing import Any

from stackx.bench.criteria import Criteria
from stackx.models import Model


def step_log(model: type[Model], criteria: Criteria) -> Any:
    """A ``stackx.run.runner.StepObserver`` measuring every step of ``model``'s runs against its ``reference``,
    or None when there is none. Imported when asked for: the planar log loads the reference's kernels."""
    from stackx.models.column.model import Column
    from stackx.models.planar.model import Planar

    own = model.step_log(criteria)
    if own is not None:
        return own
    if issubclass(model, Column):
        from stackx.bench.error_column import StepLog as ColumnLog

        return ColumnLog(criteria)
    if issubclass(model, Planar):
        from stackx.bench.error_planar import StepLog as PlanarLog

        return PlanarLog(criteria)
    return None
