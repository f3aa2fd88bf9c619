"""Scene plugins: each turns its config section into an initial state of one model."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

from pydantic import BaseModel


@dataclass(frozen=True)
class Event:
    """Something done to a run between two steps: ``apply`` runs before step ``step`` (after ``step`` steps).

    The runner stops stepping at each event's step and calls ``apply(state, solver)``; the state recorded
    before that step is the one after the event. An event changes the state in place and tells the solver,
    whose per-box memory must follow. ``origin`` is where the event is written in the scene section, for
    error messages.
    """

    step: int
    origin: tuple[str | int, ...] = field(default=(), kw_only=True, repr=False, compare=False)

    def apply(self, state: Any, solver: Any) -> None:
        raise NotImplementedError


class Scene:
    """Base of scene plugins.

    ``Params`` validates the ``scene:`` section; ``model`` names the state model the scene builds (solvers
    declare which models they step); ``build`` returns the initial state as a batch of one.
    """

    Params: ClassVar[type[BaseModel]]
    model: ClassVar[str]
    plugin_name: ClassVar[str]

    def __init__(self, params: BaseModel) -> None:
        self.params = params

    def build(self) -> Any:
        raise NotImplementedError

    def size(self) -> int:
        """Number of boxes at the start, known without building arrays (for checks before stepping)."""
        raise NotImplementedError

    def final_size(self) -> int:
        """Number of boxes at the end of a run, which is what measures of the final state index."""
        return self.size()

    def events(self) -> tuple[Event, ...]:
        """What happens to the state during a run, in step order (nothing, unless the scene says so)."""
        return ()

    def outlasts(self, steps: int, dt: float, gravity: float) -> tuple[tuple[str, ...], str] | None:
        """Where (a key path) and why a run of ``steps`` of ``dt`` outlasts what the scene states of it (an
        outcome that stops holding before the run ends, so that every solver would be judged wrong); None when
        it does not, as for a scene that states nothing."""
        return None
