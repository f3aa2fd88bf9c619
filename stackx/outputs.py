"""Base of the two output plugin kinds: sinks (numbers to files) and renderers (pictures and pages).

An output is configured once per experiment. Before anything runs, ``check`` validates what it refers to
(run names, measures, box indices) and ``frame_steps`` says which intermediate states it needs recorded;
afterwards ``write`` turns the finished results into files through the staged output folder. Outputs never
step physics. A renderer draws the worlds of the models it names in ``models``; a sink writes measures of any
model.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

from pydantic import BaseModel

from stackx.errors import Fail
from stackx.outdir import check_place, safe_relative

if TYPE_CHECKING:
    from stackx.outdir import OutputDir
    from stackx.results import ExperimentResult
    from stackx.spec import Plan


class Output:
    """Common shape of sinks and renderers."""

    Params: ClassVar[type[BaseModel]]
    plugin_name: ClassVar[str]
    needs_runs: ClassVar[bool] = True
    models: ClassVar[tuple[str, ...] | None] = None  # the models whose states it reads; None: any model

    def __init__(self, params: BaseModel) -> None:
        self.params = params

    def files(self) -> list[str]:
        """Paths, relative to the output folder, that ``write`` creates."""
        return [self.params.path]  # type: ignore[attr-defined]

    def check(self, spec: Plan, fail: Fail) -> None:
        """Refuse, before any stepping, what cannot be produced (``raise fail(key_path, message)``)."""

    def frame_steps(self, spec: Plan) -> set[int]:
        """Steps whose state (before that step) must be recorded for ``write``."""
        return set()

    def write(self, result: ExperimentResult, out: OutputDir) -> None:
        raise NotImplementedError


class Sink(Output):
    """Writes measured numbers."""


class Renderer(Output):
    """Draws states or pages."""


def _key(output: Output, name: str) -> str:
    """The params key that names file ``name`` (e.g. ``player``), for the error position; else ``path``."""
    return next((key for key, value in output.params if value == name), "path")


def confine(output: Output, fail: Fail, root: Path | None = None) -> None:
    """Refuse every path of ``output`` that leaves the folder (and, given ``root``, that meets a link there)."""
    for name in output.files():
        try:
            safe_relative(name)
            if root is not None:
                check_place(root, name)
        except ValueError as exc:
            raise fail((_key(output, name),), str(exc)) from None

