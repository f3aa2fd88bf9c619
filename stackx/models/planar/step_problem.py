"""The contact problem a step of a planar world sets itself, built from the state before the step.

Gravity first (the free velocity), then every contact point within ``speculative`` of touching, found by the
model's own collision (``collide``): a touching point must not approach (target 0), a point still ``gap``
apart may approach by at most what closes the gap within the step (target ``-gap/dt``), which stops a fast
box at the surface instead of inside it. Friction mixes as ``sqrt(mu_a mu_b)``; the ground is as rough as
what touches it.

Points are named across steps by ``(body_a, body_b, feature)`` (``key``), so a solve can start from the
impulses the same points carried in the step before (``carry``).
"""

from __future__ import annotations

import numpy as np

from stackx.models.planar.collide import GROUND, collide
from stackx.models.planar.monitor import contact_room
from stackx.models.planar.problem import ContactProblem
from stackx.models.planar.state import PlanarState

FEATURES = 256  # feature ids from collide are below this


def contacts(x: np.ndarray, y: np.ndarray, angle: np.ndarray, hx: np.ndarray, hy: np.ndarray,
             static: np.ndarray, margin: float) -> tuple[np.ndarray, ...]:
    """Every point of one world within ``margin``: ``body_a, body_b, normal, point, depth, feature``."""
    room = contact_room(x.shape[0])
    while True:
        out = (np.empty(room, np.int64), np.empty(room, np.int64), np.empty((room, 2)), np.empty((room, 2)),
               np.empty(room), np.empty(room, np.int64))
        count = collide(x, y, angle, hx, hy, static, margin, *out)
        if count <= room:
            return tuple(a[:count] for a in out)
        room = count


def step_problem(state: PlanarState, b: int, gravity: float, dt: float,
                 speculative: float) -> tuple[ContactProblem, np.ndarray]:
    """Row ``b``'s problem for a step of ``dt`` under ``gravity`` (m/s^2 along y) with contacts within
    ``speculative`` (m), and each point's ``key`` for ``carry``."""
    x, y, angle = state.x[b], state.y[b], state.angle[b]
    inv_mass, inv_inertia = state.inv_mass[b], state.inv_inertia[b]
    static = inv_mass == 0.0
    body_a, body_b, normal, point, depth, feature = contacts(x, y, angle, state.hx[b], state.hy[b], static,
                                                             speculative)
    velocity = np.stack([state.vx[b], state.vy[b] + np.where(static, 0.0, gravity * dt), state.w[b]], axis=1)
    centre = np.stack([x, y], axis=1)
    ground = body_a == GROUND
    ra = np.where(ground[:, None], 0.0, point - centre[np.where(ground, 0, body_a)])
    rb = point - centre[body_b]
    mu = state.friction[b]
    mu_a = np.where(ground, mu[body_b], mu[np.where(ground, 0, body_a)])
    problem = ContactProblem(inv_mass.copy(), inv_inertia.copy(), velocity, body_a, body_b, normal, ra, rb,
                             np.sqrt(mu_a * mu[body_b]), np.where(depth >= 0.0, 0.0, depth / dt))
    return problem, key(body_a, body_b, feature, x.shape[0])


def key(body_a: np.ndarray, body_b: np.ndarray, feature: np.ndarray, bodies: int) -> np.ndarray:
    """One integer per point naming it by its bodies and feature."""
    return ((body_a + 1) * (bodies + 1) + body_b) * FEATURES + feature


def carry(old_key: np.ndarray, old_pn: np.ndarray, old_pt: np.ndarray,
          new_key: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The impulses of the points named ``new_key`` that were already there (``old_key``), 0 for new ones."""
    pn, pt = np.zeros(new_key.shape[0]), np.zeros(new_key.shape[0])
    if old_key.shape[0] == 0 or new_key.shape[0] == 0:
        return pn, pt
    order = np.argsort(old_key, kind="stable")
    at = np.clip(np.searchsorted(old_key[order], new_key), 0, order.shape[0] - 1)
    found = old_key[order[at]] == new_key
    pn[found] = old_pn[order[at[found]]]
    pt[found] = old_pt[order[at[found]]]
    return pn, pt
