"""What a finished run hands to sinks and renderers."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

from stackx.config.spec import Plan, RunSpec


class RunFrames(Mapping[int, Any]):
    """One run's recorded states: row ``b`` of each recorded state of its batch, made when looked up (a sweep
    records some 60 states of thousands of rows, and outputs look at a few of them, of one run)."""

    def __init__(self, batch: Mapping[int, Any], b: int) -> None:
        self.batch, self.b = batch, b

    def __getitem__(self, step: int) -> Any:
        return self.batch[step].row(self.b)

    def __iter__(self) -> Iterator[int]:
        return iter(self.batch)

    def __len__(self) -> int:
        return len(self.batch)


OWN, SHARE = "own", "share"  # how a run's time was obtained: stepped alone, or its part of its batch's time


@dataclass
class RunResult:
    """One run's final state, the states recorded on the way (states of the run's model, each a batch of
    one), and its measures.

    ``frames[k]`` is the state before step ``k`` (``frames[0]`` the initial state, ``frames[steps]`` the
    final one). ``wall_seconds`` is the stepping time charged to this run, a compile not counted: its own when
    it stepped alone (``timed`` is ``"own"``), else its batch's time shared out by the work each row did
    (``timed`` is ``"share"``; ``work``, the contact visits counted for it, ``Solver.step_work`` over its
    steps), so that a row making four times the passes is charged four times the time. ``compiled`` says
    whether it ran compiled by numba or as plain Python.
    """

    spec: RunSpec
    final: Any
    frames: Mapping[int, Any]
    measures: dict[str, float | list[float]]
    wall_seconds: float = 0.0
    compiled: bool = False
    timed: str = OWN
    work: float = 0.0

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def us_per_step(self) -> float:
        """Wall-clock microseconds per step charged to this run."""
        return 1e6 * self.wall_seconds / self.spec.steps

    def timing_record(self) -> dict[str, Any]:
        """What ``timing.json`` says of this run: µs/step, seconds, how it stepped and how it was timed."""
        return {"us_per_step": self.us_per_step, "wall_seconds": self.wall_seconds, "compiled": self.compiled,
                "timed": self.timed, "contact_visits": self.work}


@dataclass
class ExperimentResult:
    """The runs of one plan, finished, in the plan's order; ``notes``: lines for the user about how they
    stepped (a batch left plain that compiled would have stepped far faster)."""

    spec: Plan
    runs: list[RunResult] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def run(self, name: str) -> RunResult:
        return next(r for r in self.runs if r.name == name)
