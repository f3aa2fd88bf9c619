"""What every engine shares on the planar model: the scene's boxes as the engines build them, the ground's
friction, reading poses back, and the planar monitors after every step.

A planar world in an engine holds one body per box of a batch row, in state order: a movable box is a dynamic
body with the box's mass and moment of inertia about its centre, its pose (centre, angle) and velocities; a
static box (a ramp, a shelf) is a static body at its pose. Every body's origin is the box's centre, so the
engine's position is the state's ``x, y``. Restitution is 0 everywhere. The ground, the half-plane y <= 0, is
a static box whose top face is y = 0, ``GROUND_WIDTH`` wide (MuJoCo: its infinite plane).

Friction is stackx's: a contact between two boxes uses sqrt(mu_a mu_b), a contact with the ground the box's
own coefficient. The 2D engines mix two shapes' coefficients themselves (Box2D: sqrt(f_a f_b), the same;
pymunk: f_a f_b, so a shape carries sqrt(mu)), and a ground of one coefficient would mix it into every box's
contact with it. So the ground is made of one shape per distinct coefficient of the movable boxes
(``ground_groups``), all the same box, each colliding only with the boxes of its coefficient (collision
categories), and carrying that coefficient so that the mix gives it back. Scenes have one or two
coefficients; an engine's category bits bound how many (``MAX_GROUNDS``). How MuJoCo, which takes the larger
of two coefficients, is brought to the same mix is said in its module.

After every step of every row, the movable bodies' poses and velocities are copied into the state (an engine
that returns angles wrapped to (-pi, pi] has them unwrapped against the last step's, so a box that turns
over keeps counting) and ``stackx.models.planar.monitor.observe`` runs on the row: every planar measure and
criterion is stackx's, from the engine's poses, as for stackx's own solvers.
"""

from __future__ import annotations

import math
from typing import NamedTuple, Protocol

import numpy as np

from stackx.kernel import kernel
from stackx.models.planar.monitor import observe
from stackx.models.planar.state import PlanarState

GROUND_WIDTH = 1000.0  # horizontal size of the ground box (m): boxes thrown or toppled stay over it
GROUND_DEPTH = 10.0  # thickness of the ground box under y = 0 (m): no fast box passes through it in a step
MAX_GROUNDS = 14  # distinct friction coefficients of movable boxes (Box2D 2.3 has 16 category bits; 2 kept)

BOX_BIT = 1  # category of the movable boxes
STATIC_BIT = 2  # category of the static boxes; ground shape k is category 4 << k


class Boxes(NamedTuple):
    """One batch row of the planar state as an engine builds it, in state order (float64 arrays)."""

    x: np.ndarray
    y: np.ndarray
    angle: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    w: np.ndarray
    mass: np.ndarray       # kg; 0 for a static box
    inertia: np.ndarray    # kg m^2 about the centre; 0 for a static box
    hx: np.ndarray
    hy: np.ndarray
    friction: np.ndarray
    static: np.ndarray     # bool

    @classmethod
    def of(cls, state: PlanarState, b: int) -> Boxes:
        """Row ``b`` of ``state`` (copies), masses and inertias from their inverses."""
        static = state.inv_mass[b] == 0.0
        with np.errstate(divide="ignore"):
            mass = np.where(static, 0.0, 1.0 / state.inv_mass[b])
            inertia = np.where(static, 0.0, 1.0 / state.inv_inertia[b])
        return cls(*(getattr(state, k)[b].copy() for k in ("x", "y", "angle", "vx", "vy", "w")), mass, inertia,
                   state.hx[b].copy(), state.hy[b].copy(), state.friction[b].copy(), static)

    @property
    def movable(self) -> np.ndarray:
        """Indices of the movable boxes, in state order."""
        return np.flatnonzero(~self.static)


def ground_groups(boxes: Boxes) -> tuple[list[float], np.ndarray]:
    """The distinct friction coefficients of the movable boxes, in the order first met, and per box the index
    of its coefficient (-1 for a static box): the ground shape each box collides with."""
    values: list[float] = []
    group = np.full(boxes.x.shape[0], -1, dtype=np.int64)
    for i in boxes.movable:
        mu = float(boxes.friction[i])
        if mu not in values:
            values.append(mu)
        group[i] = values.index(mu)
    if len(values) > MAX_GROUNDS:
        raise ValueError(f"the movable boxes have {len(values)} different friction coefficients; the engines "
                         f"give the ground each box's own for at most {MAX_GROUNDS}")
    return values, group


def ground_bit(k: int) -> int:
    """Collision category of ground shape ``k``."""
    return 4 << k


def mask(boxes: Boxes, group: np.ndarray, i: int) -> tuple[int, int]:
    """``(category, mask)`` of box ``i``'s shape: a movable box meets every box and its own ground shape, a
    static box only movable boxes."""
    if boxes.static[i]:
        return STATIC_BIT, BOX_BIT
    return BOX_BIT, BOX_BIT | STATIC_BIT | ground_bit(int(group[i]))


def unwrap(angle: np.ndarray, raw: np.ndarray) -> np.ndarray:
    """Angles read as ``raw`` in (-pi, pi], each made the one nearest ``angle`` (the last step's)."""
    return angle + np.remainder(raw - angle + math.pi, 2.0 * math.pi) - math.pi  # type: ignore[no-any-return]


class PlanarWorld(Protocol):
    """One batch row in an engine, made with ``(engine, params, g, dt, boxes)``."""

    def step(self) -> None:
        """Advance the engine by one step (one call into the engine)."""

    def read(self, x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
             w: np.ndarray) -> None:
        """Copy the movable bodies' poses and velocities into the row's arrays (static boxes stay)."""


@kernel
def observe_planar_rows(x: np.ndarray, y: np.ndarray, angle: np.ndarray, hx: np.ndarray, hy: np.ndarray,
                        inv_mass: np.ndarray, dt: np.ndarray, last: np.ndarray, peak: np.ndarray, reach: np.ndarray,
                        touched: np.ndarray, launch: np.ndarray) -> None:
    """The planar monitors of every batch row after a step, from the poses the engines left (serially, as
    ``observe_rows`` on the column)."""
    for b in range(x.shape[0]):
        observe(x[b], y[b], angle[b], hx[b], hy[b], inv_mass[b], dt[b], last, peak, reach, touched, launch, b)


def advance_planar(worlds: list[PlanarWorld], state: PlanarState, dt: np.ndarray, steps: int) -> None:
    """``steps`` steps of every row: one engine call per row and step, the poses and velocities read back into
    the state, then the planar monitors of every row."""
    s = state
    rows = [(w.step, w.read, (s.x[b], s.y[b], s.angle[b], s.vx[b], s.vy[b], s.w[b])) for b, w in enumerate(worlds)]
    monitors = s.monitors()
    for _ in range(steps):
        for step, read, arrays in rows:
            step()
            read(*arrays)
        observe_planar_rows(s.x, s.y, s.angle, s.hx, s.hy, s.inv_mass, dt, *monitors)
