"""Model plugins: the kinds of world a scene can build and a solver can step.

A model owns everything that depends on what a world is made of, so that the rest of stackx (config, runner,
watch, sinks, bench) works on any model, and a new one adds files without touching another's:

- its **state**: a class of numpy arrays with the batch axis first (runs of a sweep step together), which can
  be copied, stacked along the batch axis and looked at row by row;
- its **measures**: the numbers a finished run is summarised by (``SCALARS``, one per run, and ``VECTORS``,
  one per body), computed from the states the runner recorded, plus those the bench judges by;
- its **health check**: which body of which row has left the bounds of a sane simulation (non-finite, faster
  than ``limits.max_speed``), so a blow-up is named to its body;
- the bench's **reference**: the solver whose every step the others are measured against, and the observer
  that measures them.

Scenes say which model they build (``Scene.model``), solvers which models they step (``Solver.models``),
renderers which models they draw (``Output.models``); a config pairing them wrongly is refused at load.
Models register like every other plugin kind (``@registry.models.register("name")``, the entry-point group
``stackx.models``, or a local plugin file). A model has no config section of its own: its ``Params`` is
empty, and what varies between worlds is the scene's business.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

from pydantic import BaseModel, ConfigDict

if TYPE_CHECKING:
    from stackx.run.results import RunResult
    from stackx.config.spec import RunSpec

Measures = dict[str, float | list[float]]
Offender = tuple[int, int, str, str]  # (row, body, cause, detail) of the first bad body, bodies bottom-up


class State(Protocol):
    """What the runner, the watch and the outputs ask of a model's state (a batch of worlds)."""

    FIELDS: ClassVar[tuple[str, ...]]  # the array attributes, each with the batch axis first

    @property
    def batch(self) -> int: ...

    def copy(self) -> Any: ...

    def row(self, b: int) -> Any: ...


class NoParams(BaseModel):
    """A model has no section of its own in a config."""

    model_config = ConfigDict(extra="forbid")


class Model:
    """Base of model plugins; every method is a class method (a model is a kind, not an instance)."""

    Params: ClassVar[type[BaseModel]] = NoParams
    plugin_name: ClassVar[str]
    State: ClassVar[type]
    SCALARS: ClassVar[dict[str, str]] = {}  # measure -> what it means (one number per run)
    VECTORS: ClassVar[dict[str, str]] = {}  # measure -> what it means (one number per body)
    window: ClassVar[int] = 0  # final steps whose states ``measure`` needs beside the last one
    step_cost: ClassVar[float] = 1.0  # plain-Python time of one body-step, in column box-steps: whether
    # compiling a batch pays is decided on box-steps times this (``stackx.kernel.worth_compiling``)
    reference: ClassVar[str | None] = None  # the bench's reference solver on this model, if it has one
    bytes_per_body: ClassVar[int] = 40  # memory of one recorded state per body, for limits.max_memory_mb

    @classmethod
    def concat(cls, states: list[Any]) -> Any:
        """Same-shaped states of one batch's runs, stacked along the batch axis."""
        return cls.State.concat(states)  # type: ignore[attr-defined]

    @classmethod
    def measure(cls, frames: Mapping[int, Any], steps: int, dt: Any) -> list[Measures]:
        """Every measure of every row of a batch from its recorded states (``frames[steps]`` the final one)."""
        raise NotImplementedError

    @classmethod
    def state_measures(cls, state: Any) -> Measures:
        """The measures one state (a batch of one) gives alone: a run that blew up is reported with these."""
        raise NotImplementedError

    @classmethod
    def offender(cls, state: Any, max_speed: float) -> Offender | None:
        """The first body of the first row that is not finite or moves faster than ``max_speed``, or None."""
        raise NotImplementedError

    @classmethod
    def motion(cls, state: Any, b: int) -> dict[str, list[float]]:
        """Positions and velocities of row ``b`` as lists, for the report of a failed step."""
        raise NotImplementedError

    @classmethod
    def bench_measures(cls, result: RunResult, every_step: bool) -> dict[str, float]:
        """Measures the bench's criteria need beyond the run's own (none unless the model says); with
        ``every_step`` the state before every step was recorded, and measures of the whole path may be added."""
        return {}

    @classmethod
    def unjudged(cls, run: RunSpec) -> tuple[str, ...]:
        """Measures whose check cannot pass or fail on this run's scene (a box sliding down a ramp never
        settles): the bench leaves them out of its verdicts. None by default."""
        return ()

    @classmethod
    def step_log(cls, criteria: Any) -> Any:
        """A ``stackx.run.runner.StepObserver`` measuring every step against ``reference``, or None when the model
        has no reference: its runs then carry no error figures. The bench measures the built-in models itself
        (``stackx.bench.step_logs``); a model plugin gives its own here."""
        return None
