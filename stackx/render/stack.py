"""A picture of the world at one step (the final state unless ``step`` says otherwise): the column by the lab's
rules, a planar world with its boxes turned and the view fitted to them (``stackx.render.draw``)."""

from __future__ import annotations

from pydantic import Field

from stackx.outputs import Renderer
from stackx.registry import renderers
from stackx.render.pick import run_name
from stackx.render.draw import DRAWN, framed, picture
from stackx.render.style import Styled


class StackParams(Styled):
    path: str = Field("stack.png", description="PNG file to write")
    run: str | None = Field(None, description="which run to draw (needed when there are several)")
    step: int | None = Field(None, ge=0, description="draw the state before this step; default: the final state")


@renderers.register("stack")
class StackPicture(Renderer):
    """The world drawn at one step, by default the final state."""

    Params = StackParams
    models = DRAWN

    def check(self, spec, fail) -> None:  # type: ignore[no-untyped-def]
        self.run = run_name(spec, self.params.run, fail)
        steps = spec.run(self.run).steps
        if self.params.step is not None and self.params.step > steps:
            raise fail(("step",), f"step {self.params.step} is past the end of the run ({steps} steps)")
        self.at = steps if self.params.step is None else self.params.step

    def frame_steps(self, spec) -> set[int]:  # type: ignore[no-untyped-def]
        return {self.at}

    def write(self, result, out) -> None:  # type: ignore[no-untyped-def]
        state = result.run(self.run).frames[self.at]
        out.write_bytes(self.params.path, picture(state, framed([state], self.params.style)).png_bytes())
