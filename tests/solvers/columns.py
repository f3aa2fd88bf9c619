"""Columns, runs and the hard cases' pass criteria shared by the solver tests.

Local plugins (``plugins/`` at the repository root) are loaded on import, so every test parametrized over
``solver_names()`` also covers them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

from stackx import registry
from stackx.models.column.state import ColumnState
from tests.conftest import REPO

registry.load_local_plugins(REPO / "plugins")

G = -9.8
DT = 1 / 60
SLOP = 0.01  # the lab's slop: the hard cases judge every solver's depth against 2 x this
MOTION_WINDOW = 60


def solver_names() -> list[Any]:
    """Every registered solver that steps the column: built in, installed and local; one that cannot run here
    (an engine whose package is not installed) is skipped, saying how to install it."""
    return [pytest.param(e.name, marks=pytest.mark.skip(reason=why)) if (why := registry.unavailable(e.plugin))
            else e.name for e in registry.solvers.entries() if "column" in getattr(e.plugin, "models", ("column",))]


def column(ys: list[float], masses: list[float] | None = None, vs: list[float] | None = None,
           half: float = 0.5) -> ColumnState:
    """A batch of one: boxes at heights ``ys`` (bottom first)."""
    n = len(ys)
    masses = masses or [1.0] * n
    return ColumnState(np.array([ys], dtype=float), np.array([vs or [0.0] * n], dtype=float),
                       1.0 / np.array([masses], dtype=float), np.full((1, n), half))


def resting(count: int, masses: list[float] | None = None) -> ColumnState:
    """The hard cases' start: boxes 1 mm apart, the bottom one 1 mm above the floor."""
    return column([0.501 + i for i in range(count)], masses)


def solver(name: str, rows: list[dict[str, Any]], dt: float = DT, g: float = G) -> Any:
    """A solver for ``len(rows)`` batch rows, each with its own params."""
    cls = registry.solvers.get(name)
    params = [cls.Params.model_validate(row) for row in rows]
    return cls(params, np.full(len(rows), g), np.full(len(rows), dt))


def run(name: str, state: ColumnState, steps: int, **params: Any) -> ColumnState:
    """Step a batch of one in place and return it."""
    solver(name, [params]).advance(state, steps)
    return state


@dataclass
class Verdict:
    """A run measured as the hard cases measure it."""

    max_depth: float
    top: float
    rms_motion: float
    launch: float
    reach: float

    @property
    def holds(self) -> bool:
        return self.max_depth <= 2 * SLOP and self.reach <= 1.0

    @property
    def settled(self) -> bool:
        return self.rms_motion < 1e-4

    @property
    def launched(self) -> bool:
        return self.launch > 1.0

    @property
    def passes(self) -> bool:
        return self.holds and self.settled and not self.launched


def judge(name: str, state: ColumnState, steps: int, dt: float = DT, **params: Any) -> Verdict:
    """Run ``steps`` steps and measure: final depth, top height, RMS of actual motion over the last 60 steps
    ((y_now - y_prev)/dt, stored velocities do not count), the fastest upward velocity after touching, and
    how far any box ever went into its neighbour (as a share of the half-height)."""
    stepper = solver(name, [params], dt=dt)
    stepper.advance(state, steps - MOTION_WINDOW)
    heights = [state.y[0].copy()]
    for _ in range(MOTION_WINDOW):
        stepper.advance(state, 1)
        heights.append(state.y[0].copy())
    motion = np.diff(np.array(heights), axis=0) / dt
    return Verdict(float(state.penetration().max()), float(state.y[0, -1]), float(np.sqrt(np.mean(motion ** 2))),
                   float(state.launch[0]), float(state.reach[0]))
