"""Base of the two output plugin kinds: sinks (numbers to files) and renderers (pictures and pages).

An output is configured once per experiment. Before anything runs, ``check`` validates what it refers to
(run names, measures, box indices) and ``frame_steps`` says which intermediate states it needs recorded;
afterwards ``write`` turns the finished results into files through the staged output folder. Outputs never
step physics.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, ClassVar

from pydantic import BaseModel

from stackx.yamlsrc import Path

if TYPE_CHECKING:
    from stackx.config import ExperimentSpec
    from stackx.errors import ConfigError
    from stackx.outdir import OutputDir
    from stackx.results import ExperimentResult

Fail = Callable[[Path, str], "ConfigError"]


class Output:
    """Common shape of sinks and renderers."""

    Params: ClassVar[type[BaseModel]]
    plugin_name: ClassVar[str]
    needs_runs: ClassVar[bool] = True

    def __init__(self, params: BaseModel) -> None:
        self.params = params

    def files(self) -> list[str]:
        """Paths, relative to the output folder, that ``write`` creates."""
        return [self.params.path]  # type: ignore[attr-defined]

    def check(self, spec: ExperimentSpec, fail: Fail) -> None:
        """Refuse, before any stepping, what cannot be produced (``raise fail(key_path, message)``)."""

    def frame_steps(self, spec: ExperimentSpec) -> set[int]:
        """Steps whose state (before that step) must be recorded for ``write``."""
        return set()

    def write(self, result: ExperimentResult, out: OutputDir) -> None:
        raise NotImplementedError


class Sink(Output):
    """Writes measured numbers."""


class Renderer(Output):
    """Draws states or pages."""
