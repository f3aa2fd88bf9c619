"""What pictures and plots read of a planar state at one instant: where the boxes' corners are, how high the
highest box is, how deep the deepest contact goes, and how far the boxes have drifted from where they began.

Each works on every batch row at once (a player's note reads row 0, the bench's plots every row of a batch),
from positions alone. Depths come from the model's own collision test (``collide`` with no margin), as the
monitors' do, so a picture's "deepest contact" is the figure the criteria judge.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import kernel, prange
from stackx.models.planar.collide import collide
from stackx.models.planar.monitor import contact_room
from stackx.models.planar.state import PlanarState

# a box's corners in its own frame, in order around it (counter-clockwise): (+x, +y), (-x, +y), (-x, -y), (+x, -y)
CORNER_SIGNS = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])


def corners(state: PlanarState) -> np.ndarray:
    """World corners ``(batch, bodies, 4, 2)`` of every box, counter-clockwise from its own (+x, +y) corner."""
    c, s = np.cos(state.angle)[..., None], np.sin(state.angle)[..., None]
    px = CORNER_SIGNS[:, 0] * state.hx[..., None]
    py = CORNER_SIGNS[:, 1] * state.hy[..., None]
    return np.stack([state.x[..., None] + c * px - s * py, state.y[..., None] + s * px + c * py], axis=-1)


def movable(state: PlanarState) -> np.ndarray:
    """``(batch, bodies)``: the boxes that can move (static ones have inverse mass 0)."""
    return state.inv_mass > 0.0


def highest(state: PlanarState) -> np.ndarray:
    """Per row, the height of the highest centre of a box that can move (m); the highest static box's when
    none can. A stack that topples shows as this height falling."""
    moving = movable(state)
    y = np.where(moving, state.y, -np.inf).max(axis=1)
    return np.where(moving.any(axis=1), y, state.y.max(axis=1))


@kernel
def deepest_rows(x: np.ndarray, y: np.ndarray, angle: np.ndarray, hx: np.ndarray, hy: np.ndarray,
                 inv_mass: np.ndarray, out: np.ndarray) -> None:
    """``out[b]``: the largest contact depth of row ``b`` (0 when nothing overlaps), every pair tested."""
    for b in prange(x.shape[0]):
        static = inv_mass[b] == 0.0
        room = contact_room(x.shape[1])
        while True:
            body_a = np.empty(room, np.int64)
            body_b = np.empty(room, np.int64)
            normal = np.empty((room, 2))
            point = np.empty((room, 2))
            depth = np.empty(room)
            feature = np.empty(room, np.int64)
            count = collide(x[b], y[b], angle[b], hx[b], hy[b], static, 0.0, body_a, body_b, normal, point,
                            depth, feature)
            if count <= room:
                break
            room = count
        deepest = 0.0
        for k in range(count):
            if depth[k] > deepest:
                deepest = depth[k]
        out[b] = deepest


def deepest(state: PlanarState) -> np.ndarray:
    """Per row, the largest contact depth (m, 0 when nothing overlaps)."""
    out = np.zeros(state.batch)
    deepest_rows(state.x, state.y, state.angle, state.hx, state.hy, state.inv_mass, out)
    return out


def drift(state: PlanarState, start: PlanarState) -> tuple[np.ndarray, np.ndarray]:
    """Per row, how far the boxes that can move have gone from ``start`` (the same rows and boxes): the
    largest horizontal distance ``|x - x0|`` (m) and the largest turn ``|angle - angle0|`` (radians). Boxes
    that should rest show theirs creeping up; 0 for a row with nothing movable."""
    moving = movable(start)
    dx = np.where(moving, np.abs(state.x - start.x), 0.0).max(axis=1, initial=0.0)
    turn = np.where(moving, np.abs(state.angle - start.angle), 0.0).max(axis=1, initial=0.0)
    return dx, turn
