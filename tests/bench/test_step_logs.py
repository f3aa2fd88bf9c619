"""The bench picks the step log that watches a case's runs: its own for the column and the planar model (a model
imports nothing of the bench), the model's own when a model gives one, none for a model without a reference."""

from __future__ import annotations

from typing import Any

from stackx.bench import error_column, error_planar
from stackx.bench.criteria import Criteria
from stackx.bench.step_logs import step_log
from stackx.models import Model
from stackx.models.column.model import Column
from stackx.models.planar.model import Planar


class Unmeasured(Model):
    """A model with no reference solver."""


class OwnLog(Model):
    """A model that measures its steps itself."""

    @classmethod
    def step_log(cls, criteria: Any) -> Any:
        return ("own", criteria)


def test_the_column_and_the_planar_model_are_watched_by_the_bench_logs() -> None:
    criteria = Criteria(reach=0.25)
    column, planar = step_log(Column, criteria), step_log(Planar, criteria)
    assert type(column) is error_column.StepLog and column.criteria is criteria
    assert type(planar) is error_planar.StepLog and planar.criteria is criteria


def test_another_model_keeps_its_own_log_or_none() -> None:
    criteria = Criteria()
    assert step_log(OwnLog, criteria) == ("own", criteria)
    assert step_log(Unmeasured, criteria) is None
