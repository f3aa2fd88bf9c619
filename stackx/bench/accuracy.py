"""Error against the exact solver: how far a solver's step is from the exactly solved step, on its own path.

Definition. At sampled steps ``k`` of a solver's own run, take the state before step ``k`` (heights and
velocities, as the solver left them) and let the exact solver's velocity stage compute the velocities that
step should end with: gravity, then the step's velocity problem (no contact approaches, no contact pulls)
solved to machine precision. The solver's answer is the velocity it stored after step ``k``. The error is
the RMS over sampled steps and boxes of the difference (m/s); the largest difference is kept beside it.

Why along the solver's own path and not by running both side by side: two runs part ways within a few
steps on any stack that is not held, after which a per-step comparison measures the distance between two
different piles, not how well each step was solved. From the same state, the difference is the error of
this step's solve alone: iteration error for an iterative solver, plus whatever the solver does on purpose
that a rigid contact does not (a bias that pushes apart, a soft contact, substeps).

Which contacts take part is part of the problem, not of its solution, so the exact step uses the solver's
own ``speculative`` margin (0, the lab's rule, for a solver without one): a solver is compared with the
exact solve of the problem it set itself.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

import numpy as np

from stackx import registry
from stackx.config import RunSpec
from stackx.errors import ConfigError
from stackx.results import RunResult

Reference = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float, float, float], np.ndarray]
"""``(y, v, inv_mass, half, g, dt, speculative) -> v_after`` for one column (1-D arrays): the exact step's
velocities."""

REFERENCE_SOLVER = "exact"


def find_reference() -> Reference | None:
    """The exact step's velocities, from the ``exact`` solver's ``exact_velocities`` kernel; None when no
    such solver is registered."""
    try:
        cls = registry.solvers.get(REFERENCE_SOLVER)
    except ConfigError:
        return None
    solve = getattr(importlib.import_module(cls.__module__), "exact_velocities", None)
    if solve is None:
        return None
    def reference(y: np.ndarray, v: np.ndarray, inv: np.ndarray, half: np.ndarray, g: float,
                  dt: float, speculative: float) -> np.ndarray:
        after_gravity = v + g * dt  # the same rounding as every solver's gravity stage, v[i] += g*dt
        return np.asarray(solve(y, after_gravity, inv, half, dt, speculative)[0])

    return reference


def sample_steps(run: RunSpec, count: int) -> list[int]:
    """Up to ``count`` steps spread evenly over the run, leaving out a step that ends at a scene event (its
    state before and after differ in boxes)."""
    events = {e.step for e in run.scene.events()}
    picked = np.unique(np.round(np.linspace(0, run.steps - 1, min(count, run.steps))).astype(np.int64))
    return [int(k) for k in picked if k + 1 not in events]


def velocity_error(result: RunResult, samples: list[int], reference: Reference) -> dict[str, Any]:
    """``rms`` and ``max`` velocity difference from the exact step over the sampled ``steps`` (see the module
    text)."""
    spec = result.spec
    speculative = float(getattr(spec.solver_params, "speculative", 0.0))
    diffs = []
    for k in samples:
        before, after = result.frames[k], result.frames[k + 1]
        exact = reference(before.y[0].copy(), before.v[0].copy(), before.inv_mass[0].copy(), before.half[0].copy(),
                          spec.gravity, spec.dt, speculative)
        diffs.append(after.v[0] - np.asarray(exact))
    if not diffs:
        return {"rms": None, "max": None, "steps": []}
    d = np.concatenate(diffs)
    return {"rms": float(np.sqrt(np.mean(d * d))), "max": float(np.abs(d).max()), "steps": samples}
