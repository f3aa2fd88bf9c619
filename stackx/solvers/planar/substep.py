"""Where a contact point is while its bodies move within a step, for solvers that find contacts once per
step and take several substeps (the soft step, XPBD).

A point keeps the normal it was found with and its anchors ``r_A``, ``r_B`` (the table's, from
``contacts.prepare``), which move and turn with their bodies. Each body's motion since the step began is
kept in ``since`` ``(bodies, 4)``: ``dx, dy`` and the cosine and sine of its turn, so a point's separation
is its separation when found plus how far its two anchors have come apart along the normal (Box2D v3
measures a substep's separation this way). Holding the normal is exact for the ground and for boxes that
turn little within a step; a box that turns far within one step would need its contacts found again.
Both solvers visit a face's points together, so ``wavefront.manifold_end`` says where each manifold's points end.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import kernel, leaf
from stackx.solvers.planar.contacts import A, B, DEPTH, NX, NY, RAX, RAY, RBX, RBY


@leaf
def step_start(x: np.ndarray, y: np.ndarray, angle: np.ndarray, start: np.ndarray, since: np.ndarray) -> None:
    """Remember where every body is as the step begins (``start``: x, y, angle) and that none has moved."""
    for i in range(x.shape[0]):
        start[i, 0], start[i, 1], start[i, 2] = x[i], y[i], angle[i]
        since[i, 0], since[i, 1], since[i, 2], since[i, 3] = 0.0, 0.0, 1.0, 0.0


@leaf
def moved_body(x: np.ndarray, y: np.ndarray, angle: np.ndarray, start: np.ndarray, since: np.ndarray,
               i: int) -> None:
    """How far body ``i`` has moved since the step began: ``since[i] = (dx, dy, cos turn, sin turn)``."""
    since[i, 0], since[i, 1] = x[i] - start[i, 0], y[i] - start[i, 1]
    turn = angle[i] - start[i, 2]
    since[i, 2], since[i, 3] = np.cos(turn), np.sin(turn)


@leaf
def moved(x: np.ndarray, y: np.ndarray, angle: np.ndarray, start: np.ndarray, since: np.ndarray) -> None:
    """``moved_body`` for every body."""
    for i in range(x.shape[0]):
        moved_body(x, y, angle, start, since, i)


@leaf
def base_separations(ids: np.ndarray, table: np.ndarray, count: int, base: np.ndarray) -> None:
    """Each point's separation when found (``-depth``) less what its anchors give along the normal, so that
    ``separation`` adds back the anchors as they move: ``base = -depth - (r_B - r_A) . n``."""
    for k in range(count):
        lever_x, lever_y = table[k, RBX] - table[k, RAX], table[k, RBY] - table[k, RAY]
        base[k] = -table[k, DEPTH] - (lever_x * table[k, NX] + lever_y * table[k, NY])


@leaf
def anchor(table: np.ndarray, since: np.ndarray, body: int, k: int, rx: int) -> tuple[float, float]:
    """Anchor ``r`` of point ``k`` (table columns ``rx``, ``rx + 1``) turned as ``body`` has turned since
    the step began: the anchored material point relative to the body's centre now."""
    r0x, r0y = table[k, rx], table[k, rx + 1]
    return since[body, 2] * r0x - since[body, 3] * r0y, since[body, 3] * r0x + since[body, 2] * r0y


@leaf
def separation(ids: np.ndarray, table: np.ndarray, base: np.ndarray, since: np.ndarray, k: int) -> float:
    """Separation of point ``k`` now (m, negative: overlap)."""
    a, b = ids[k, A], ids[k, B]
    rx, ry = anchor(table, since, b, k, RBX)
    px, py = since[b, 0] + rx, since[b, 1] + ry
    if a >= 0:
        rx, ry = anchor(table, since, a, k, RAX)
        px -= since[a, 0] + rx
        py -= since[a, 1] + ry
    return base[k] + px * table[k, NX] + py * table[k, NY]
