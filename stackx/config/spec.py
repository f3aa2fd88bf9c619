"""What a validated config asks to simulate: its runs, and which of their states must be kept.

This is the hinge of a run's one-way flow, config -> scene -> solver -> recorder -> outputs -> files:
``stackx.config.experiment`` builds these from YAML, the runner steps them, outputs read them. Nothing here knows YAML,
files or outputs, so every stage can depend on it without depending on the others.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from pydantic import BaseModel

from stackx.config.limits import Limits
from stackx.scenes import Scene


@dataclass
class RunSpec:
    """One fully validated simulation: what to step (``scene``, a world of ``model``), with what, for how long."""

    name: str
    scene: Scene
    solver_cls: type
    solver_params: BaseModel
    gravity: float
    dt: float
    steps: int
    overrides: dict[str, Any] = field(default_factory=dict)
    model: Any = None  # the model plugin the scene builds (``stackx.models.Model`` subclass)


@dataclass
class Plan:
    """The runs of one experiment and what bounds them; ``frame_steps`` says which states its readers need."""

    file: str
    name: str
    description: str
    runs: list[RunSpec]
    limits: Limits = field(default_factory=Limits)

    def run(self, name: str) -> RunSpec:
        return next(r for r in self.runs if r.name == name)

    def frame_steps(self) -> set[int]:
        """Steps whose state (before that step) something reading the results needs: none for a bare plan."""
        return set()


def record_steps(run: RunSpec, wanted: set[int]) -> list[int]:
    """Steps before which a run's state is kept: ``wanted``, the scene's events, and the final steps the model's
    measures need (its ``window``) with the end."""
    window = getattr(run.model, "window", 0)
    kept = set(range(max(0, run.steps - window), run.steps + 1)) | {e.step for e in run.scene.events()} | wanted
    return sorted(k for k in kept if 0 <= k <= run.steps)
