"""Planar states built by hand for the reference's and the exact solver's tests: a pyramid of unit boxes
and a box on a ramp, one batch row each."""

from __future__ import annotations

import math

import numpy as np

from stackx.models.planar.state import PlanarState, box_mass


def _row(values: list[float]) -> np.ndarray:
    return np.array([values], dtype=np.float64)


def boxes(x: list[float], y: list[float], angle: list[float], half: list[tuple[float, float]],
          density: list[float], mu: list[float]) -> PlanarState:
    """Boxes at rest; a density of 0 makes a static box."""
    n = len(x)
    mass = [box_mass(hx, hy, d) if d > 0 else (math.inf, math.inf) for (hx, hy), d in zip(half, density)]
    zero = _row([0.0] * n)
    return PlanarState(_row(x), _row(y), _row(angle), zero.copy(), zero.copy(), zero.copy(),
                       _row([1.0 / m for m, _ in mass]), _row([1.0 / i for _, i in mass]),
                       _row([h[0] for h in half]), _row([h[1] for h in half]), _row(mu))


def pyramid(rows: int, mu: float = 0.6, jitter: float = 0.0, seed: int = 0) -> PlanarState:
    """Unit boxes in ``rows`` rows, each row centred on the one below, exactly touching; ``jitter`` moves each
    box sideways by up to that much (a seeded generator) so that rows overlap unevenly."""
    rng = np.random.default_rng(seed)
    x, y = [], []
    for i in range(rows):
        for j in range(rows - i):
            x.append(j - (rows - i - 1) / 2 + jitter * rng.uniform(-1.0, 1.0))
            y.append(0.5 + i)
    n = len(x)
    return boxes(x, y, [0.0] * n, [(0.5, 0.5)] * n, [1.0] * n, [mu] * n)


def ramp(slope: float, mu: float) -> PlanarState:
    """A static plank at ``slope`` (radians) and a unit box resting on it half-way up, both of friction
    ``mu`` (mixed: ``mu``)."""
    length, thick = 10.0, 0.25
    c, s = math.cos(slope), math.sin(slope)
    px, py = 0.0, 3.0
    up = 0.25  # the box's centre sits this far along the plank from its middle
    bx = px + c * up - s * (thick + 0.5)
    by = py + s * up + c * (thick + 0.5)
    return boxes([px, bx], [py, by], [slope, slope], [(length, thick), (0.5, 0.5)], [0.0, 1.0], [mu, mu])
