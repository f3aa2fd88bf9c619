"""How a column is drawn: the lab's drawing rules, each a parameter with the lab's value as default."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

from stackx.gfxlib import Canvas
from stackx.models.column.state import ColumnState

Colour = tuple[Annotated[int, Field(ge=0, le=255)], Annotated[int, Field(ge=0, le=255)],
               Annotated[int, Field(ge=0, le=255)]]


class Style(BaseModel):
    """Screen mapping ``sx = int(x*scale + origin_x)``, ``sy = int(origin_y - y*scale)``, and colours."""

    model_config = ConfigDict(extra="forbid")
    width: int = Field(256, gt=0, le=8192, description="canvas width (px)")
    height: int = Field(256, gt=0, le=8192, description="canvas height (px)")
    background: Colour = (20, 20, 28)
    scale: float = Field(25.6, gt=0, allow_inf_nan=False, description="pixels per metre")
    origin_x: float = Field(128.0, allow_inf_nan=False, description="screen x of world x = 0")
    origin_y: float = Field(255.0, allow_inf_nan=False, description="screen y of the floor (world y = 0)")
    half_width: float = Field(1.5, gt=0, allow_inf_nan=False, description="horizontal half-width of a box (m)")
    colours: list[Colour] = Field(
        default_factory=lambda: [(230, 120, 110), (230, 190, 110), (150, 220, 120), (120, 190, 230),
                                 (190, 140, 230)],
        min_length=1, description="box colours bottom-up, repeated when there are more boxes")
    floor: Colour | None = Field((255, 255, 255), description="colour of the floor row, drawn last; null hides it")


class Styled(BaseModel):
    """Params of a renderer that draws columns: where to write, and the style (lab defaults)."""

    model_config = ConfigDict(extra="forbid")
    style: Style = Field(default_factory=Style)


def draw_column(state: ColumnState, style: Style) -> Canvas:
    """Draw batch row 0 of ``state``: boxes bottom-up as filled rectangles, then the floor row."""
    canvas = Canvas(style.width, style.height, style.background)
    x0 = int(-style.half_width * style.scale + style.origin_x)
    x1 = int(style.half_width * style.scale + style.origin_x)
    for i, (y, h) in enumerate(zip(state.y[0].tolist(), state.half[0].tolist())):
        top = int(style.origin_y - (y + h) * style.scale)
        bottom = int(style.origin_y - (y - h) * style.scale)
        canvas.fill_rect(x0, top, x1, bottom, style.colours[i % len(style.colours)])
    if style.floor is not None:
        row = int(style.origin_y)
        canvas.line(0, row, style.width - 1, row, style.floor)
    return canvas
