"""Sizing a plan before it steps: refuse one whose recorded states would not fit in memory, whose work would
take hours, or whose boxes start faster than a blow-up (the limits of ``stackx.limits``), at the config key
that sizes it, instead of after an hour or with the machine swapping."""

from __future__ import annotations

import numpy as np

from stackx.errors import Fail
from stackx.spec import Plan, RunSpec, record_steps

def memory_bytes(plan: Plan) -> int:
    """Bytes of the states kept while ``plan`` runs: each run's recorded steps, plus the working state."""
    wanted = plan.frame_steps()
    return sum((len(record_steps(run, wanted)) + 2) * run.scene.size() * run.model.bytes_per_body
               for run in plan.runs)


def work(plan: Plan) -> int:
    """Box-steps times the solver's passes per step, summed over the runs."""
    return sum(run.steps * run.scene.size() * run.solver_cls.passes(run.solver_params) for run in plan.runs)


def check(plan: Plan, fail: Fail) -> None:
    """Refuse, before stepping, a plan over its memory or work limit (at the key that sizes it)."""
    limits = plan.limits
    mib = memory_bytes(plan) / 2**20
    if mib > limits.max_memory_mb:
        raise fail(("scene",), f"the recorded states would take {mib:,.0f} MiB, over "
                                f"limits.max_memory_mb = {limits.max_memory_mb:g}; use fewer boxes, runs or "
                                "frames, or raise the limit")
    total = work(plan)
    if total > limits.max_work:
        raise fail(("steps",), f"steps x boxes x solver passes = {total:.3g}, over "
                                f"limits.max_work = {limits.max_work:g}; use fewer steps, boxes or "
                                "iterations, or raise the limit")
    started: set[int] = set()
    for run in plan.runs:
        if id(run.scene) in started:
            continue  # runs with the same scene section share one scene (see config._resolve_run): built once
        started.add(id(run.scene))
        fastest = _fastest_start(run)
        if fastest is not None and fastest > limits.max_speed:
            raise fail(("scene",), f"run {run.name!r} starts with a box at {fastest:g} m/s, over "
                                    f"limits.max_speed = {limits.max_speed:g}; slow it down or raise the limit")


def _fastest_start(run: RunSpec) -> float | None:
    """The fastest initial speed of a run's boxes (None when the scene cannot be built here: the run says why)."""
    try:
        speed = run.model.speeds(run.scene.build())
    except Exception:
        return None
    return float(np.max(speed)) if np.size(speed) and np.isfinite(speed).all() else None
