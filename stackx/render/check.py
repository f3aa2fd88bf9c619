"""A picture drawn from primitives in the config: the drawing toolbox's test pattern, for one."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from stackx.render.gfxlib import Canvas
from stackx.outputs import Renderer
from stackx.registry import renderers
from stackx.render.style import Colour

Point = tuple[int, int]


class Line(BaseModel):
    model_config = ConfigDict(extra="forbid", populate_by_name=True)
    start: Point = Field(alias="from", description="first end point (x, y), included")
    end: Point = Field(alias="to", description="second end point (x, y), included")
    rgb: Colour


class Rect(Line):
    """A filled rectangle between two corners, both included."""


class Shape(BaseModel):
    model_config = ConfigDict(extra="forbid")
    line: Line | None = None
    rect: Rect | None = None


class DrawingParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    path: str = Field(description="PNG file to write, inside the output folder")
    width: int = Field(gt=0, le=8192)
    height: int = Field(gt=0, le=8192)
    background: Colour = (0, 0, 0)
    shapes: list[Shape] = Field(default_factory=list, description="each {line: {from, to, rgb}} or "
                                "{rect: {from, to, rgb}}; drawn in order, later over earlier")


@renderers.register("drawing")
class Drawing(Renderer):
    """Lines and filled rectangles on a canvas; needs no simulation."""

    Params = DrawingParams
    needs_runs = False

    def check(self, spec, fail) -> None:  # type: ignore[no-untyped-def]
        for i, shape in enumerate(self.params.shapes):
            if (shape.line is None) == (shape.rect is None):
                raise fail(("shapes", i), "each shape is exactly one of 'line' or 'rect'")

    def write(self, result, out) -> None:  # type: ignore[no-untyped-def]
        p = self.params
        canvas = Canvas(p.width, p.height, p.background)
        for shape in p.shapes:
            if shape.line is not None:
                canvas.line(*shape.line.start, *shape.line.end, shape.line.rgb)
            else:
                canvas.fill_rect(*shape.rect.start, *shape.rect.end, shape.rect.rgb)
        out.write_bytes(p.path, canvas.png_bytes())
