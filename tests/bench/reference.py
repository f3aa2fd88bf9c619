"""Plain-Python yardsticks for the bench: the lab step with per-box masses and removals, and the exact
velocity solve found by brute force.

Written from the lab contract (notes/lab-contract.md) and the definition of the velocity problem (no active
contact approaches, none pulls, a contact pushes only while it is exactly closing), with the standard
library only and nothing taken from stackx, so that the bench's numbers are checked against a second,
independent derivation.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field


@dataclass
class Column:
    """Heights, velocities, inverse masses and half-heights of one column, bottom box first."""

    y: list[float]
    v: list[float]
    inv: list[float]
    half: list[float]
    history: list[tuple[list[float], list[float]]] = field(default_factory=list)  # (y, v) before each step

    def depths(self) -> list[float]:
        floor = [self.half[0] - self.y[0]]
        return floor + [(self.half[i] + self.half[i + 1]) - (self.y[i + 1] - self.y[i]) for i in range(len(self.y) - 1)]

    def remove(self, box: int) -> None:
        for values in (self.y, self.v, self.inv, self.half):
            del values[box]


def lab_step(c: Column, g: float, dt: float, iterations: int, slop: float, percent: float) -> None:
    """One step of the lab solver: gravity, Gauss-Seidel velocity passes, positions, position correction."""
    c.history.append((list(c.y), list(c.v)))
    n = len(c.y)
    for i in range(n):
        c.v[i] += g * dt
    for _ in range(iterations):
        if c.half[0] - c.y[0] > 0 and c.v[0] < 0 and c.inv[0] > 0:
            c.v[0] = 0.0
        for i in range(n - 1):
            depth = (c.half[i] + c.half[i + 1]) - (c.y[i + 1] - c.y[i])
            rv = c.v[i + 1] - c.v[i]
            total = c.inv[i] + c.inv[i + 1]
            if depth > 0 and rv < 0 and total > 0:
                j = -rv / total
                c.v[i] -= j * c.inv[i]
                c.v[i + 1] += j * c.inv[i + 1]
    for i in range(n):
        c.y[i] += c.v[i] * dt
    total = 0.0 + c.inv[0]
    if total > 0:
        amount = max((c.half[0] - c.y[0]) - slop, 0.0) / total * percent
        c.y[0] += amount * c.inv[0]
    for i in range(n - 1):
        depth = (c.half[i] + c.half[i + 1]) - (c.y[i + 1] - c.y[i])
        total = c.inv[i] + c.inv[i + 1]
        if total > 0:
            amount = max(depth - slop, 0.0) / total * percent
            c.y[i] -= amount * c.inv[i]
            c.y[i + 1] += amount * c.inv[i + 1]


def lab_run(boxes: list[dict[str, float]], steps: int, iterations: int, *, g: float = -9.8, dt: float = 1 / 60,
            slop: float = 0.01, percent: float = 0.2, removals: dict[int, int] | None = None) -> Column:
    """The lab solver over ``steps`` steps; ``removals`` maps a step to the box taken away before it."""
    c = Column([b["y"] for b in boxes], [b.get("v", 0.0) for b in boxes], [1.0 / b.get("mass", 1.0) for b in boxes],
               [b.get("half", 0.5) for b in boxes])
    for k in range(steps):
        if removals and k in removals:
            c.remove(removals[k])
        lab_step(c, g, dt, iterations, slop, percent)
    return c


def _solve(a: list[list[float]], b: list[float]) -> list[float] | None:
    """Gaussian elimination with partial pivoting; None when singular."""
    n = len(b)
    m = [row[:] + [b[i]] for i, row in enumerate(a)]
    for col in range(n):
        pivot = max(range(col, n), key=lambda r: abs(m[r][col]))
        if abs(m[pivot][col]) < 1e-300:
            return None
        m[col], m[pivot] = m[pivot], m[col]
        for r in range(n):
            if r != col:
                f = m[r][col] / m[col][col]
                for k in range(col, n + 1):
                    m[r][k] -= f * m[col][k]
    return [m[i][n] / m[i][i] for i in range(n)]


def exact_velocities(y: list[float], v: list[float], inv: list[float], half: list[float], g: float,
                     dt: float, speculative: float = 0.0) -> list[float]:
    """The step's exact velocities, found by trying every set of tight contacts.

    After gravity ``u = v + g*dt``, contacts with depth above ``-speculative`` (and something movable) take
    part; one with a gap may close it within the step (its relative velocity at least ``depth/dt``), one
    that touches may not approach (at least 0).
    """
    n = len(y)
    u = [v[i] + g * dt for i in range(n)]
    depth = [half[0] - y[0]] + [(half[i] + half[i + 1]) - (y[i + 1] - y[i]) for i in range(n - 1)]
    bounds = {k: min(depth[k], 0.0) / dt for k in range(n) if depth[k] > -speculative}
    return ordered_projection(u, inv, bounds)


def ordered_projection(u: list[float], inv: list[float], bounds: dict[int, float]) -> list[float]:
    """The values closest to ``u`` (weighted by mass) that keep every contact ``k`` of ``bounds`` at a relative
    value of at least ``bounds[k]`` (the floor contact: ``x[0]``; contact ``k``: ``x[k] - x[k-1]``), found by
    trying every set of tight contacts. Each contact has a row of ``J``: the floor ``+1`` on box 0; contact
    ``k`` ``-1`` on box ``k-1`` and ``+1`` on box ``k``. The answer ``x = u + M^-1 J^T lam`` has ``lam >= 0``,
    ``J x >= bound`` and ``lam_k = 0`` wherever ``(J x)_k > bound_k``; with positive masses it is unique, so
    the first set of tight contacts that satisfies everything gives it.
    """
    n = len(u)

    def row(k: int) -> dict[int, float]:
        return {0: 1.0} if k == 0 else {k - 1: -1.0, k: 1.0}

    active = [k for k in sorted(bounds) if sum(inv[i] for i in row(k)) > 0]

    def after(lam: dict[int, float]) -> list[float]:
        out = list(u)
        for k, value in lam.items():
            for i, sign in row(k).items():
                out[i] += inv[i] * sign * value
        return out

    def rel(vel: list[float], k: int) -> float:
        return sum(sign * vel[i] for i, sign in row(k).items())

    for size in range(len(active) + 1):
        for tight in itertools.combinations(active, size):
            a = [[sum(inv[i] * row(p).get(i, 0.0) * row(q).get(i, 0.0) for i in range(n)) for q in tight]
                 for p in tight]
            lam_values = _solve(a, [bounds[p] - rel(u, p) for p in tight]) if tight else []
            if lam_values is None or any(x < -1e-12 for x in lam_values):
                continue
            vel = after(dict(zip(tight, lam_values)))
            if all(rel(vel, k) >= bounds[k] - 1e-12 for k in active):
                return vel
    raise AssertionError("no solution found: an ordered projection always has one")
