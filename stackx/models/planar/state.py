"""The planar model's state: boxes in the x-y plane (y up) over a ground, the half-plane y <= 0.

Arrays are shaped ``(batch, bodies)`` like the column's. A box has its centre ``x, y``, its ``angle``
(radians, counter-clockwise), its velocities ``vx, vy, w``, its inverse mass and inverse moment of inertia
(both 0 for a static box), its half-sizes ``hx, hy`` and its Coulomb coefficient ``friction``; two bodies in
contact use ``sqrt(mu_a * mu_b)``, the mix Box2D uses, so a frictionless body makes every contact frictionless.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class PlanarState:
    """The bodies' arrays ``(batch, bodies)``, and the monitors solvers update after every step
    (``stackx.models.planar.monitor.observe``): ``last_y`` and ``touched`` ``(batch, bodies)``,
    ``peak_depth``, ``reach`` and ``launch`` ``(batch,)``. A state built without monitors starts them from its
    own positions. ``unsolved``, ``first_unsolved`` and ``worst_unsolved`` ``(batch,)``: the steps whose
    velocity problem a solver that solves it to a tolerance (``planar-exact``) missed, the first of them
    (-1: none) and the largest residual kept (m/s); 0 for the others."""

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
    last_y: np.ndarray = field(default=None)  # type: ignore[assignment]
    peak_depth: np.ndarray = field(default=None)  # type: ignore[assignment]
    reach: np.ndarray = field(default=None)  # type: ignore[assignment]
    touched: np.ndarray = field(default=None)  # type: ignore[assignment]
    launch: np.ndarray = field(default=None)  # type: ignore[assignment]
    unsolved: np.ndarray = field(default=None)  # type: ignore[assignment]
    first_unsolved: np.ndarray = field(default=None)  # type: ignore[assignment]
    worst_unsolved: np.ndarray = field(default=None)  # type: ignore[assignment]

    BODY = ("x", "y", "angle", "vx", "vy", "w", "inv_mass", "inv_inertia", "hx", "hy", "friction")
    MONITORS = ("last_y", "peak_depth", "reach", "touched", "launch")
    MISSES = ("unsolved", "first_unsolved", "worst_unsolved")
    FIELDS = (*BODY, *MONITORS, *MISSES)

    def __post_init__(self) -> None:
        for name in self.BODY:
            setattr(self, name, np.ascontiguousarray(getattr(self, name), dtype=np.float64))
        if self.unsolved is None:
            self.unsolved = np.zeros(self.batch, dtype=np.int64)
            self.first_unsolved = np.full(self.batch, -1, dtype=np.int64)
            self.worst_unsolved = np.zeros(self.batch)
        if all(getattr(self, k) is not None for k in self.MONITORS):
            return  # a copy: nothing to derive
        from stackx.models.planar.monitor import observe

        self.last_y = self.y.copy()
        self.peak_depth = np.zeros(self.batch)
        self.reach = np.zeros(self.batch)
        self.touched = np.zeros(self.x.shape, dtype=np.bool_)
        self.launch = np.full(self.batch, -np.inf)
        for b in range(self.batch):  # the start's overlaps count; nothing has moved yet, so no launch
            observe(self.x[b], self.y[b], self.angle[b], self.hx[b], self.hy[b], self.inv_mass[b], 1.0,
                    self.last_y, self.peak_depth, self.reach, self.touched, self.launch, b)
        self.launch[:] = -np.inf

    def monitors(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The arguments ``observe`` takes after a row's arrays and ``dt``."""
        return self.last_y, self.peak_depth, self.reach, self.touched, self.launch

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
