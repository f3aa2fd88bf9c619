"""The view a picture is drawn in: the lab's fixed mapping, or one fitted to the scene.

A fitted view maps the world rectangle the boxes take up (every box of every picture of a player, so the
view does not jump from frame to frame, and always the ground line y = 0) onto the canvas with a margin
around it: one scale for both axes (boxes keep their shape), centred across, the lowest point near the
bottom edge, so the ground sits where the lab's floor does and the empty sky is above. A tall stack and a
wide pyramid both fill the picture; the price is that two scenes fitted apart are drawn at different scales.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from stackx.render.style import Style

Bounds = tuple[float, float, float, float]  # world x0, y0, x1, y1 (m)

MARGIN = 0.05  # share of the canvas's smaller side left empty around a fitted scene
SMALLEST = 1e-6  # m: the narrowest span fitted, so that a scene of one point does not divide by zero


def union(boxes: Iterable[Bounds]) -> Bounds:
    """The smallest rectangle holding every one of ``boxes`` (at least one)."""
    x0s, y0s, x1s, y1s = zip(*boxes)
    return min(x0s), min(y0s), max(x1s), max(y1s)


def fitted(style: Style, bounds: Bounds) -> Style:
    """``style`` with ``scale``, ``origin_x`` and ``origin_y`` chosen to show ``bounds`` and the ground whole."""
    x0, y0, x1, y1 = bounds
    if not all(math.isfinite(v) for v in bounds):
        raise ValueError(f"cannot fit a view to a scene that reaches {bounds}")
    y0 = min(y0, 0.0)
    w, h = style.width, style.height
    pad = max(1, round(MARGIN * min(w, h)))
    scale = min(max(w - 2 * pad, 1) / max(x1 - x0, SMALLEST), max(h - 2 * pad, 1) / max(y1 - y0, SMALLEST))
    return style.model_copy(update={"scale": scale, "origin_x": w / 2 - (x0 + x1) / 2 * scale,
                                    "origin_y": h - 1 - pad + y0 * scale})
