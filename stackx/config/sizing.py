"""Sizing a plan before it steps: refuse one whose recorded states would not fit in memory, whose work would
take hours, or whose boxes start faster than a blow-up (the limits of ``stackx.config.limits``), at the config key
that sizes it, instead of after an hour or with the machine swapping."""

from __future__ import annotations

from stackx.errors import Fail
from stackx.config.spec import Plan, RunSpec, record_steps


def memory_bytes(plan: Plan) -> int:
    """Bytes of the states kept while ``plan`` runs: each run's recorded steps, plus the working state."""
    wanted = plan.frame_steps()
    return sum(run_bytes(run, wanted) for run in plan.runs)


def run_bytes(run: RunSpec, wanted: set[int]) -> int:
    """Bytes of one run's recorded states (``wanted`` the steps its readers ask for) and its working state."""
    return (len(record_steps(run, wanted)) + 2) * run.scene.size() * run.model.bytes_per_body


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
        fast = _fast_start(run, limits.max_speed)
        if fast is not None:
            raise fail(("scene",), f"run {run.name!r} starts with box {fast[0]} that {fast[1]}; slow it down or "
                                    "raise the limit")


def _fast_start(run: RunSpec, max_speed: float) -> tuple[int, str] | None:
    """The first body a run's scene starts too fast, by its model's health check, with what is wrong (None when
    every body is within the limit, or when the scene cannot be built here: the run says why)."""
    try:
        state = run.scene.build()
    except Exception:
        return None
    found = run.model.offender(state, max_speed)
    return (found[1], found[3]) if found is not None and found[2] == "speed" else None
