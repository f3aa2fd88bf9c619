"""Pictures of the world every ``every`` steps, and optionally an HTML page that plays them.

The column is drawn by the lab's rules; a planar world with its boxes turned, every frame in one view fitted
to all of them (``stackx.render.draw``), so the picture does not jump while the boxes move.

By default the page is the lab's (``player_html``: the pictures in a loop). With ``controls: true`` it is a
player with pause, step, a frame slider, speed and keys, showing each frame's step and time and the top box's
height (a planar world's highest box) and the deepest contact under the picture; with ``count: all`` the
frames run to the end of the run, the whole settling. Both are asked for, so the lab's ``index.html`` and
pictures stay as they are.
"""

from __future__ import annotations

from pydantic import Field

from stackx.outputs import Renderer, template_problem
from stackx.registry import renderers
from stackx.render.pick import run_name
from stackx.render.player import Panel, controlled_player_html, player_html
from stackx.render.draw import DRAWN, describe, framed, picture
from stackx.render.timeline import TimelineParams, frame_count, frame_steps, labels


class FramesParams(TimelineParams):
    path: str = Field("f{index:02d}.png", description="file name template; {index} counts frames from 0")
    run: str | None = Field(None, description="which run to draw (needed when there are several)")
    player: str | None = Field(None, description="HTML page that plays the frames in order (e.g. index.html)")
    controls: bool = Field(False, description="the player page gets pause, step, a frame slider, speed and keys, "
                                              "with each frame's step, time, top height and deepest contact; "
                                              "false: the lab's page, the pictures in a loop")


@renderers.register("frames")
class Frames(Renderer):
    """The world drawn every few steps, with an optional HTML page that plays the pictures."""

    Params = FramesParams
    models = DRAWN
    count: int

    def steps(self) -> list[int]:
        return frame_steps(self.params, self.count)

    def names(self) -> list[str]:
        return [self.params.path.format(index=k) for k in range(self.count)]

    def files(self) -> list[str]:
        return self.names() + ([self.params.player] if self.params.player else [])

    def pictures(self) -> int:
        return self.count

    def check(self, spec, fail) -> None:  # type: ignore[no-untyped-def]
        self.run = run_name(spec, self.params.run, fail)
        self.count = frame_count(self.params, spec.run(self.run).steps, fail, spec.limits.max_frames)
        problem = template_problem(self.params.path, {"index"})
        if problem:
            raise fail(("path",), problem)
        try:
            names = self.names()
        except (KeyError, IndexError, ValueError) as exc:
            raise fail(("path",), f"bad template: {exc}; use {{index}}, e.g. f{{index:02d}}.png") from None
        if len(set(names)) != len(names):
            raise fail(("path",), "the template gives every frame the same name; put {index} in it")

    def frame_steps(self, spec) -> set[int]:  # type: ignore[no-untyped-def]
        return set(self.steps())

    def write(self, result, out) -> None:  # type: ignore[no-untyped-def]
        run = result.run(self.run)
        style = framed([run.frames[k] for k in self.steps()], self.params.style)
        for name, step in zip(self.names(), self.steps()):
            out.write_bytes(name, picture(run.frames[step], style).png_bytes())
        if not self.params.player:
            return
        title = result.spec.description or result.spec.name
        if not self.params.controls:
            out.write_text(self.params.player, player_html(self.names(), self.params.interval_ms, title))
            return
        panel = Panel(run.name, run.spec.solver_cls.plugin_name, self.names(),
                      [describe(run.frames[k]) for k in self.steps()])
        page = controlled_player_html(title, [panel], labels(self.steps(), run.spec.dt), self.params.interval_ms,
                                      (style.width, style.height))
        out.write_text(self.params.player, page)
