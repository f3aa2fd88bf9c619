"""The planar model's state: boxes in the x-y plane (y up) over a ground, the half-plane y <= 0.

Arrays are shaped ``(batch, bodies)`` like the column's. A box has its centre ``x, y``, its ``angle``
(radians, counter-clockwise), its velocities ``vx, vy, w``, its inverse mass and inverse moment of inertia
(both 0 for a static box), its half-sizes ``hx, hy`` and its Coulomb coefficient ``friction``; two bodies in
contact use ``sqrt(mu_a * mu_b)``, the mix Box2D uses, so a frictionless body makes every contact frictionless.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class PlanarState:
    x: np.ndarray
    y: np.ndarray
    angle: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    w: np.ndarray
    inv_mass: np.ndarray
    inv_inertia: np.ndarray
    hx: np.ndarray
    hy: np.ndarray
    friction: np.ndarray

    FIELDS = ("x", "y", "angle", "vx", "vy", "w", "inv_mass", "inv_inertia", "hx", "hy", "friction")

    def __post_init__(self) -> None:
        for name in self.FIELDS:
            setattr(self, name, np.ascontiguousarray(getattr(self, name), dtype=np.float64))

    @property
    def batch(self) -> int:
        return self.x.shape[0]

    @property
    def bodies(self) -> int:
        return self.x.shape[1]

    def copy(self) -> PlanarState:
        return PlanarState(*(getattr(self, k).copy() for k in self.FIELDS))

    def row(self, b: int) -> PlanarState:
        """Batch row ``b`` as a batch of one (views)."""
        out = object.__new__(PlanarState)
        out.__dict__.update((k, getattr(self, k)[b:b + 1]) for k in self.FIELDS)
        return out

    @staticmethod
    def concat(states: list[PlanarState]) -> PlanarState:
        return PlanarState(*(np.concatenate([getattr(s, k) for s in states]) for k in PlanarState.FIELDS))


def box_mass(hx: float, hy: float, density: float) -> tuple[float, float]:
    """Mass and moment of inertia about the centre of a uniform box of half-sizes ``hx, hy``."""
    mass = density * 4.0 * hx * hy
    return mass, mass * (hx * hx + hy * hy) / 3.0
