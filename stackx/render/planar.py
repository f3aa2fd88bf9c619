"""How a planar world is drawn: every box a filled polygon at its angle, in the lab's colours and on its
canvas, with the ground and its floor row.

World point (x, y) is screen point ``(x*scale + origin_x, origin_y - y*scale)``, the lab's mapping without
its rounding; a pixel is filled when its centre lies in the box (``Canvas.fill_convex``), so a box turned
by any angle covers what it covers on screen. Static boxes (ramps, ledges) are drawn first in the style's
``static`` colour; the boxes that move follow in the scene's order, coloured as the column's are, the k-th
moving box in the k-th colour; the floor row is drawn last.
"""

from __future__ import annotations

from stackx.render.gfxlib import Canvas
from stackx.models.planar.figures import corners
from stackx.models.planar.state import PlanarState
from stackx.render.style import Style, backdrop, draw_floor
from stackx.render.view import Bounds


def planar_bounds(state: PlanarState) -> Bounds:
    """The world rectangle that batch row 0's boxes take up, corners included."""
    pts = corners(state)[0]
    return (float(pts[..., 0].min()), float(pts[..., 1].min()), float(pts[..., 0].max()),
            float(pts[..., 1].max()))


def draw_planar(state: PlanarState, style: Style) -> Canvas:
    """Draw batch row 0 of ``state``: static boxes, then the moving boxes in order, then the floor row."""
    canvas = backdrop(style)
    pts = corners(state)[0].tolist()
    static = (state.inv_mass[0] == 0.0).tolist()
    screen = [[(x * style.scale + style.origin_x, style.origin_y - y * style.scale) for x, y in box] for box in pts]
    for box, fixed in zip(screen, static):
        if fixed:
            canvas.fill_convex(box, style.static)
    moving = [box for box, fixed in zip(screen, static) if not fixed]
    for k, box in enumerate(moving):
        canvas.fill_convex(box, style.colours[k % len(style.colours)])
    draw_floor(canvas, style)
    return canvas
