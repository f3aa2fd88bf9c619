"""A worked example of a local solver plugin: projected successive over-relaxation (SOR).

Dropped into a ``plugins/`` folder, this file is imported before configs are resolved, so a config can
say ``solver: {name: sor, omega: 1.3}`` without installing anything. It reuses the lab solver's stages and
changes one thing: each contact's impulse is scaled by ``omega`` before the clamp. ``omega`` > 1
over-relaxes (fewer passes for the same error on a stiff column, until it overshoots), ``omega`` < 1
damps; ``omega`` = 1 is exactly the lab solver.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from stackx.monitor import observe
from stackx.registry import solvers
from stackx.solvers.base import Solver
from stackx.solvers.pgs import PGSParams, correct_positions, gravity, integrate_positions


class SORParams(PGSParams):
    omega: float = Field(1.3, gt=0, lt=2, allow_inf_nan=False,
                         description="relaxation factor: >1 speeds convergence until it overshoots, <1 damps")


def relaxed_pass(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, omega: float) -> None:
    """One Gauss-Seidel pass; each contact's impulse is ``omega`` times the exact one, then clamped >= 0."""
    if half[0] - y[0] > 0.0 and v[0] < 0.0 and inv[0] > 0.0:
        v[0] -= omega * v[0] if omega * v[0] < 0.0 else 0.0
    for i in range(y.shape[0] - 1):
        depth = (half[i] + half[i + 1]) - (y[i + 1] - y[i])
        rv = v[i + 1] - v[i]
        total = inv[i] + inv[i + 1]
        if depth > 0.0 and rv < 0.0 and total > 0.0:
            j = -omega * rv / total
            v[i] -= j * inv[i]
            v[i + 1] += j * inv[i + 1]


@solvers.register("sor")
class SOR(Solver):
    """The lab solver with over-relaxed impulses (``omega``): fewer passes for the same depth, up to a point."""

    Params = SORParams

    def advance(self, state, steps: int) -> None:  # type: ignore[no-untyped-def]
        for b, p in enumerate(self.params):
            y, v, inv, half = state.y[b], state.v[b], state.inv_mass[b], state.half[b]
            for _ in range(steps):
                gravity(v, self.gravity[b], self.dt[b])
                for _ in range(p.iterations):
                    relaxed_pass(y, v, inv, half, p.omega)
                integrate_positions(y, v, self.dt[b])
                if p.correction is not None:
                    correct_positions(y, inv, half, p.correction.slop, p.correction.percent)
                observe(y, v, half, *state.monitors(), b)
