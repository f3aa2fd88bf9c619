"""Scene plugins: each turns its config section into an initial state of one model."""

from __future__ import annotations

from typing import Any, ClassVar

from pydantic import BaseModel


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
