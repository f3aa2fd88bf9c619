"""Limits of a run: what counts as a blow-up, and how big a run may be before it is refused.

A config may carry a top-level ``limits:`` section; every key has a default, so most configs never write it.
The size limits are checked when the config is loaded, before anything steps, so a run that could not fit
in memory or finish in reasonable time fails at once with the config's ``file:line:col`` instead of after
an hour or with the machine swapping. ``max_speed`` is checked while stepping (see ``stackx.watch``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pydantic import BaseModel, ConfigDict, Field

if TYPE_CHECKING:
    from stackx.config import ExperimentSpec, RunSpec

BYTES_PER_BOX = 40  # one recorded state per box: y, v, inv_mass, half (float64) and touched, rounded up


class Limits(BaseModel):
    """Bounds that stop a run: speed while stepping, memory and work before stepping."""

    model_config = ConfigDict(extra="forbid")
    max_speed: float = Field(
        1000.0, gt=0, allow_inf_nan=False,
        description="fastest a box may move (m/s) before the run is stopped as blown up; a box dropped from "
                    "h metres lands at sqrt(2*9.8*h) m/s, 140 m/s from a kilometre, so the default only "
                    "trips on a solver that has gone unstable. Checked between solver calls (a few hundred "
                    "steps apart at most, and at every recorded step), then narrowed to the first step over it: a "
                    "speed that stays over the limit is caught, a spike that settles within one call is not")
    max_memory_mb: float = Field(
        4096.0, gt=0, allow_inf_nan=False,
        description="most memory (MiB) the recorded states of one experiment may take (states kept for "
                    "frames, events and the final motion window, for every run and box)")
    max_work: float = Field(
        1e12, gt=0, allow_inf_nan=False,
        description="most box-steps times solver passes (iterations x substeps) one experiment may ask for; "
                    "1e12 is hours of compiled stepping")


def memory_bytes(spec: ExperimentSpec) -> int:
    """Bytes of the states kept while ``spec`` runs: each run's recorded steps, plus the working state."""
    from stackx.runner import record_steps

    return sum((len(record_steps(spec, run)) + 2) * run.scene.size() * BYTES_PER_BOX for run in spec.runs)


def work(spec: ExperimentSpec) -> int:
    """Box-steps times the solver's passes per step, summed over the runs."""
    return sum(run.steps * run.scene.size() * run.solver_cls.passes(run.solver_params) for run in spec.runs)


def check(spec: ExperimentSpec, limits: Limits) -> None:
    """Refuse, before stepping, an experiment over its memory or work limit (at the key that sizes it)."""
    mib = memory_bytes(spec) / 2**20
    if mib > limits.max_memory_mb:
        raise spec.source.error(("scene",), f"the recorded states would take {mib:,.0f} MiB, over "
                                f"limits.max_memory_mb = {limits.max_memory_mb:g}; use fewer boxes, runs or "
                                "frames, or raise the limit")
    total = work(spec)
    if total > limits.max_work:
        raise spec.source.error(("steps",), f"steps x boxes x solver passes = {total:.3g}, over "
                                f"limits.max_work = {limits.max_work:g}; use fewer steps, boxes or "
                                "iterations, or raise the limit")
    started: set[int] = set()
    for run in spec.runs:
        if id(run.scene) in started:
            continue  # runs with the same scene section share one scene (see config._resolve_run): built once
        started.add(id(run.scene))
        fastest = _fastest_start(run)
        if fastest is not None and fastest > limits.max_speed:
            raise spec.source.error(("scene",), f"run {run.name!r} starts with a box at {fastest:g} m/s, over "
                                    f"limits.max_speed = {limits.max_speed:g}; slow it down or raise the limit")


def _fastest_start(run: RunSpec) -> float | None:
    """The fastest initial speed of a run's boxes (None when the scene cannot be built here: the run says why)."""
    import numpy as np

    try:
        v = run.scene.build().v
    except Exception:
        return None
    return float(np.abs(v).max()) if np.size(v) and np.isfinite(v).all() else None
