"""How a world is drawn: the lab's drawing rules, each a parameter with the lab's value as default.

The column is drawn by the lab's rules exactly (``draw_column``); planar boxes are drawn by
``stackx.render.planar`` with the same style (colours, floor, mapping), rotated and filled. Which mapping a
picture uses, the fixed one below or one fitted to the scene, is ``fit`` (``stackx.render.view``).
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

from stackx.render.gfxlib import Canvas
from stackx.models.column.state import ColumnState

Colour = tuple[Annotated[int, Field(ge=0, le=255)], Annotated[int, Field(ge=0, le=255)],
               Annotated[int, Field(ge=0, le=255)]]


class Style(BaseModel):
    """Screen mapping ``sx = int(x*scale + origin_x)``, ``sy = int(origin_y - y*scale)`` (or fitted to the
    scene), and colours."""

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
    ground: Colour | None = Field((34, 34, 46), description="colour of the ground below the floor row, drawn "
                                                            "under the boxes (none shows with the lab's mapping); "
                                                            "null: the background")
    static: Colour = Field((120, 120, 132), description="colour of static boxes (planar scenes: ramps, ledges), "
                                                        "drawn before the boxes that move")
    fit: bool | None = Field(None, description="fit the view to the scene: scale and origin chosen so that every "
                                               "box of every picture drawn shows, whole, with the ground near the "
                                               "bottom edge (scale, origin_x and origin_y are then not used); "
                                               "null: planar scenes are fitted, the column keeps the lab's fixed "
                                               "mapping")


class Styled(BaseModel):
    """Params of a renderer that draws columns: where to write, and the style (lab defaults)."""

    model_config = ConfigDict(extra="forbid")
    style: Style = Field(default_factory=Style)


def backdrop(style: Style) -> Canvas:
    """An empty picture: the background, and the ground below the floor row (drawn first, so a box that
    sinks into the ground shows)."""
    canvas = Canvas(style.width, style.height, style.background)
    row = int(style.origin_y)
    if style.ground is not None and row + 1 < style.height:
        canvas.fill_rect(0, row + 1, style.width - 1, style.height - 1, style.ground)
    return canvas


def draw_floor(canvas: Canvas, style: Style) -> None:
    """The floor row (world y = 0), drawn last, over whatever touches it."""
    if style.floor is not None:
        row = int(style.origin_y)
        canvas.line(0, row, style.width - 1, row, style.floor)


def draw_column(state: ColumnState, style: Style) -> Canvas:
    """Draw batch row 0 of ``state``: boxes bottom-up as filled rectangles, then the floor row."""
    canvas = backdrop(style)
    x0 = int(-style.half_width * style.scale + style.origin_x)
    x1 = int(style.half_width * style.scale + style.origin_x)
    for i, (y, h) in enumerate(zip(state.y[0].tolist(), state.half[0].tolist())):
        top = int(style.origin_y - (y + h) * style.scale)
        bottom = int(style.origin_y - (y - h) * style.scale)
        canvas.fill_rect(x0, top, x1, bottom, style.colours[i % len(style.colours)])
    draw_floor(canvas, style)
    return canvas
