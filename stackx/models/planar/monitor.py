"""Measures taken inside the planar stepping loop, after every step, from positions alone.

Solvers call ``observe`` for each batch row after every step, as column solvers call theirs: what it records
comes from where the boxes are, found by the model's own collision test (``collide``, with points up to the
touching gap apart, ``stackx.models.touch``), never from what a solver reports about its contacts, so a solver
cannot hide an overlap it did not see. A solver
that finds its next step's contacts where this step ended passes them to ``observe_points`` instead: the
same collision test at the same positions, run once for both (``contacts.observed_contacts``).
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import kernel, leaf
from stackx.models.planar.collide import GROUND, collide
from stackx.models.touch import TOUCH_GAP, touching


@kernel
def contact_room(bodies: int) -> int:
    """Contact points a world of ``bodies`` boxes is first given room for (grown when it needs more)."""
    return 8 * bodies + 8


@kernel
def observe(x: np.ndarray, y: np.ndarray, angle: np.ndarray, hx: np.ndarray, hy: np.ndarray,
            inv_mass: np.ndarray, dt: float, last_y: np.ndarray, peak: np.ndarray, reach: np.ndarray,
            touched: np.ndarray, launch: np.ndarray, b: int) -> None:
    """Update the monitors of batch row ``b`` (its arrays ``x .. inv_mass``) after a step of ``dt``.

    - ``peak[b]``: the largest contact depth so far (m);
    - ``reach[b]``: the largest depth as a share of the thinner body's smaller half-size (the ground's
      contacts: the box's own); above 1 a box has passed half-way into its neighbour or the ground;
    - ``touched[b, i]``: body ``i`` has touched something at some step (a contact point overlapping, at
      zero depth or a hair apart: ``stackx.models.touch``);
    - ``launch[b]``: the fastest upward motion ``(y - last_y)/dt`` of a movable body that had touched
      something (m/s), whatever moved it;
    - ``last_y[b, i]``: the height of body ``i`` after this step, for the next one.
    """
    static = inv_mass == 0.0
    room = contact_room(x.shape[0])
    while True:
        body_a = np.empty(room, np.int64)
        body_b = np.empty(room, np.int64)
        normal = np.empty((room, 2))
        point = np.empty((room, 2))
        depth = np.empty(room)
        feature = np.empty(room, np.int64)
        count = collide(x, y, angle, hx, hy, static, TOUCH_GAP, body_a, body_b, normal, point, depth, feature)
        if count <= room:
            break
        room = count
    observe_points(body_a, body_b, depth, count, y, hx, hy, inv_mass, dt, last_y, peak, reach, touched, launch, b)


@leaf
def observe_points(body_a: np.ndarray, body_b: np.ndarray, depth: np.ndarray, count: int, y: np.ndarray,
                   hx: np.ndarray, hy: np.ndarray, inv_mass: np.ndarray, dt: float, last_y: np.ndarray,
                   peak: np.ndarray, reach: np.ndarray, touched: np.ndarray, launch: np.ndarray, b: int) -> None:
    """``observe`` from contact points ``collide`` has just found at the row's current positions (its first
    ``count`` bodies and depths), with any margin: a point still apart (negative depth) changes no monitor,
    so a solver that finds its next step's points (within its speculative margin) where the step ended
    serves the monitors with the same list instead of colliding once more."""
    deepest, farthest = peak[b], reach[b]  # in registers: a store to ``touched`` might otherwise be to them
    for k in range(count):
        d = depth[k]
        i, j = body_a[k], body_b[k]
        size = min(hx[j], hy[j])
        if i != GROUND:
            size = min(size, min(hx[i], hy[i]))
        if d > deepest:  # peak and reach start at 0: a gap never raises them
            deepest = d
        if d / size > farthest:
            farthest = d / size
        if touching(d):
            touched[b, j] = True
            if i != GROUND:
                touched[b, i] = True
    peak[b], reach[b] = deepest, farthest
    fastest = launch[b]
    for i in range(y.shape[0]):
        if touched[b, i] and inv_mass[i] != 0.0:
            rise = (y[i] - last_y[b, i]) / dt
            if rise > fastest:
                fastest = rise
        last_y[b, i] = y[i]
    launch[b] = fastest
