"""Pictures of the column every ``every`` steps, and optionally an HTML page that plays them."""

from __future__ import annotations

from pydantic import Field

from stackx.outputs import Renderer
from stackx.registry import renderers
from stackx.render.pick import run_name
from stackx.render.player import player_html
from stackx.render.style import Styled, draw_column


class FramesParams(Styled):
    path: str = Field("f{index:02d}.png", description="file name template; {index} counts frames from 0")
    start: int = Field(0, ge=0, description="step of the first frame (the state before that step)")
    every: int = Field(gt=0, description="steps between frames")
    count: int = Field(gt=0, le=100_000, description="number of frames")
    run: str | None = Field(None, description="which run to draw (needed when there are several)")
    player: str | None = Field(None, description="HTML page that plays the frames in order (e.g. index.html)")
    interval_ms: int = Field(250, gt=0, le=60_000, description="time each frame is shown in the player")


@renderers.register("frames")
class Frames(Renderer):
    """The column drawn every few steps, with an optional HTML page that plays the pictures."""

    Params = FramesParams
    models = ("column",)

    def steps(self) -> list[int]:
        p = self.params
        return [p.start + k * p.every for k in range(p.count)]

    def names(self) -> list[str]:
        return [self.params.path.format(index=k) for k in range(self.params.count)]

    def files(self) -> list[str]:
        return self.names() + ([self.params.player] if self.params.player else [])

    def check(self, spec, fail) -> None:  # type: ignore[no-untyped-def]
        self.run = run_name(spec, self.params.run, fail)
        try:
            names = self.names()
        except (KeyError, IndexError, ValueError) as exc:
            raise fail(("path",), f"bad template: {exc}; use {{index}}, e.g. f{{index:02d}}.png") from None
        if len(set(names)) != len(names):
            raise fail(("path",), "the template gives every frame the same name; put {index} in it")
        last, steps = self.steps()[-1], spec.run(self.run).steps
        if last > steps:
            raise fail(("count",), f"the last frame would be at step {last}, past the end of the run ({steps})")

    def frame_steps(self, spec) -> set[int]:  # type: ignore[no-untyped-def]
        return set(self.steps())

    def write(self, result, out) -> None:  # type: ignore[no-untyped-def]
        run = result.run(self.run)
        for name, step in zip(self.names(), self.steps()):
            out.write_bytes(name, draw_column(run.frames[step], self.params.style).png_bytes())
        if self.params.player:
            title = result.spec.description or result.spec.name
            out.write_text(self.params.player, player_html(self.names(), self.params.interval_ms, title))
