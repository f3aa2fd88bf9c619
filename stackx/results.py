"""What a finished run hands to sinks and renderers."""

from __future__ import annotations

from dataclasses import dataclass, field

from stackx.config import ExperimentSpec, RunSpec
from stackx.state import ColumnState


@dataclass
class RunResult:
    """One run's final state, the states recorded on the way, and its measures.

    ``frames[k]`` is the state before step ``k`` (``frames[0]`` the initial state, ``frames[steps]`` the
    final one). ``wall_seconds`` is the stepping time charged to this run (its batch's time divided evenly).
    """

    spec: RunSpec
    final: ColumnState
    frames: dict[int, ColumnState]
    measures: dict[str, float | list[float]]
    wall_seconds: float = 0.0

    @property
    def name(self) -> str:
        return self.spec.name


@dataclass
class ExperimentResult:
    spec: ExperimentSpec
    runs: list[RunResult] = field(default_factory=list)

    def run(self, name: str) -> RunResult:
        return next(r for r in self.runs if r.name == name)
