"""What pictures and plots read of a planar state at one instant: where the boxes' corners are, how high the
top box is, how deep the deepest contact goes, and how far the boxes placed at rest have drifted.

Each works on every batch row at once (a player's note reads row 0, the bench's plots every row of a batch),
from positions alone. Depths are the model's own measure (``measures.max_depth``, the collision test with no
margin) and drift is measured as ``measures.drift`` measures it at the end of a run, so a plot's last point is
the figure the criteria judge.
"""

from __future__ import annotations

import numpy as np

from stackx.models.planar.measures import max_depth
from stackx.models.planar.state import PlanarState

# a box's corners in its own frame, in order around it (counter-clockwise): (+x, +y), (-x, +y), (-x, -y), (+x, -y)
CORNER_SIGNS = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])


def corners(state: PlanarState) -> np.ndarray:
    """World corners ``(batch, bodies, 4, 2)`` of every box, counter-clockwise from its own (+x, +y) corner."""
    c, s = np.cos(state.angle)[..., None], np.sin(state.angle)[..., None]
    px = CORNER_SIGNS[:, 0] * state.hx[..., None]
    py = CORNER_SIGNS[:, 1] * state.hy[..., None]
    return np.stack([state.x[..., None] + c * px - s * py, state.y[..., None] + s * px + c * py], axis=-1)


def top_height(state: PlanarState, top: np.ndarray) -> np.ndarray:
    """Per row, the height of box ``top[b]`` (the top of a pile, whose rest height the criteria know), or,
    where ``top[b]`` is negative, of the highest centre of a box that can move (the highest static box's when
    none can): a stack that topples shows as this height falling."""
    moving = state.inv_mass > 0.0
    highest = np.where(moving, state.y, -np.inf).max(axis=1)
    highest = np.where(moving.any(axis=1), highest, state.y.max(axis=1))
    rows = np.arange(state.batch)
    return np.where(top >= 0, state.y[rows, np.maximum(top, 0)], highest)


def deepest(state: PlanarState) -> np.ndarray:
    """Per row, the largest contact depth (m, 0 when nothing overlaps)."""
    return np.array([max_depth(state, b) for b in range(state.batch)])


def drift(state: PlanarState, start: PlanarState, rests: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per row, how far the boxes placed at rest (``rests``, ``(batch, bodies)``) have gone from ``start``: the
    largest horizontal distance ``|x - x0|`` (m) and the largest turn ``|angle - angle0|`` (rad); 0 for a row
    with no such box."""
    dx = np.where(rests, np.abs(state.x - start.x), 0.0).max(axis=1, initial=0.0)
    turn = np.where(rests, np.abs(state.angle - start.angle), 0.0).max(axis=1, initial=0.0)
    return dx, turn
