"""Which drawing a state gets: the renderers draw every model they name through these three functions.

- ``picture``: the column by the lab's rules (``style.draw_column``), a planar world by
  ``stackx.render.planar``;
- ``framed``: the style a set of pictures is drawn in, the same for all of them (a player's frames, the runs
  side by side): fitted to what they show (``stackx.render.view``) when ``style.fit`` says so, by default
  for planar worlds only, so the lab's pictures keep the lab's mapping;
- ``describe``: the figures a player shows under a picture.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from stackx.render.gfxlib import Canvas
from stackx.models.column.state import ColumnState
from stackx.models.planar.figures import top_height
from stackx.models.planar.measures import max_depth
from stackx.models.planar.state import PlanarState
from stackx.render.planar import draw_planar, planar_bounds
from stackx.render.style import Style, draw_column
from stackx.render.view import Bounds, fitted, union

DRAWN = ("column", "planar")  # the models these functions draw: the renderers' ``models``


def picture(state: Any, style: Style) -> Canvas:
    """Batch row 0 of ``state`` drawn in ``style``."""
    if isinstance(state, PlanarState):
        return draw_planar(state, style)
    return draw_column(state, style)


def bounds(state: Any, style: Style) -> Bounds:
    """The world rectangle row 0's boxes take up (a column's boxes are ``style.half_width`` either side)."""
    if isinstance(state, PlanarState):
        return planar_bounds(state)
    y, h = state.y[0], state.half[0]
    return -style.half_width, float((y - h).min()), style.half_width, float((y + h).max())


def framed(states: Sequence[Any], style: Style) -> Style:
    """The style every one of ``states`` is drawn in: ``style`` as given, or with its view fitted to all of
    them at once when ``style.fit`` is true (null: true for planar worlds)."""
    fit = style.fit if style.fit is not None else isinstance(states[0], PlanarState)
    if not fit:
        return style
    return fitted(style, union(bounds(s, style) for s in states))


def describe(state: Any) -> str:
    """Where the top of the pile is and the deepest contact, for a player's note under a picture."""
    if isinstance(state, ColumnState):
        return f"top box {state.y[0, -1]:.3f} m · deepest contact {state.penetration()[0].max():.4f} m"
    highest = top_height(state, np.full(state.batch, -1))[0]
    return f"highest box {highest:.3f} m · deepest contact {max_depth(state):.4f} m"
