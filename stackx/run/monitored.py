"""Monitors no solver can forget: a solver that never calls its model's ``observe`` is refused before it runs.

A model's monitors (peak depth, reach, launch, which boxes touched) live in the state and are updated by the
solver, after every step, with the model's ``observe`` (``stackx.models.column.monitor``,
``stackx.models.planar.monitor``): a compiled loop cannot come back to Python each step, so the runner cannot
do it for the solver. A solver plugin that leaves the call out would otherwise be trusted: peak depth, reach
and launch stay at their start (0 and none), and a run whose boxes sink into each other passes.

The check rests on one monitor that changes whatever happens: the first of ``state.monitors()`` holds the
heights ``y`` after the previous step, and ``observe`` rewrites it for every body of the row at every step.
Before a batch steps, a copy of the solver steps a copy of the batch once with that monitor set to NaN; a row
left NaN where its heights are finite was not observed, and the solver is refused with one line naming its file
and the call it must make. The same untimed step compiles the kernels (or loads them from the cache), so the
time charged to the runs is stepping alone. A model whose state has no monitors (``monitors()``) is not
checked. A solver that cannot be copied is checked on its first real call instead, by the same monitor: its
heights moved and the monitor did not.
"""

from __future__ import annotations

import importlib.util
from typing import Any

import numpy as np

from stackx.errors import RunError, listing
from stackx.run.watch import snapshot


def seen_heights(state: Any) -> np.ndarray | None:
    """The monitor ``observe`` rewrites at every step (the heights after the previous step, shaped like
    ``state.y``); None for a state without monitors, which has nothing to check."""
    monitors = getattr(state, "monitors", None)
    heights = getattr(state, "y", None)
    if not callable(monitors) or not isinstance(heights, np.ndarray):
        return None
    kept = monitors()
    seen = kept[0] if kept else None
    if not isinstance(seen, np.ndarray) or seen.shape != heights.shape or seen.dtype.kind != "f":
        return None
    return seen


def first_step(file: str, names: list[str], state: Any, solver: Any) -> bool:
    """Step a copy of the batch ``state`` once with a copy of ``solver``, untimed, and refuse the solver when it
    did not update the monitors of every row (``names``: the rows' runs). Returns whether the check was made:
    False for a solver that cannot be copied (check its first real call with ``observed``). A solver that fails
    on the copy (raises, returns something, reshapes the state) is left for the real run to report, as
    ``stackx.run.watch`` words it."""
    twin = snapshot(solver)
    if twin is None:
        return False
    probe = state.copy()
    seen = seen_heights(probe)
    if seen is not None:
        seen[...] = np.nan
    try:
        returned = twin.advance(probe, 1)
    except Exception:
        return True
    if seen is not None and returned is None:  # a solver that returns something is named by the real run
        seen = seen_heights(probe)  # the solver may have put new arrays in the copy: read them again
        if seen is not None:
            _refuse(file, names, solver, probe, np.isnan(seen) & np.isfinite(probe.y))
    return True


def observed(file: str, names: list[str], solver: Any, before: Any, after: Any) -> None:
    """Refuse ``solver`` when its call took the batch from ``before`` to ``after`` moving some row's heights
    while that row's monitor stayed as it was: the check of a solver ``first_step`` could not copy."""
    was, now = seen_heights(before), seen_heights(after)
    if was is None or now is None or was.shape != now.shape:
        return
    moved = np.any(after.y != before.y, axis=1, keepdims=True)
    _refuse(file, names, solver, after, moved & np.all(now == was, axis=1, keepdims=True))


def _refuse(file: str, names: list[str], solver: Any, state: Any, missed: np.ndarray) -> None:
    """Raise for the rows with a body in ``missed`` (shaped like ``state.y``), if any."""
    rows = [names[b] for b in np.flatnonzero(np.any(missed, axis=1))]
    if not rows:
        return
    where = f"solver {solver.plugin_name!r} ({getattr(solver, 'plugin_origin', '?')})"
    raise RunError(f"{file}: {where} did not call {observe_of(state)}(...) in its first step (run(s) "
                   f"{listing(rows)}): advance must call it for every row after every step, or depths and "
                   "launches go unmeasured")


def observe_of(state: Any) -> str:
    """Where the ``observe`` of ``state``'s model is: ``stackx.models.column.monitor.observe`` beside the
    model's ``state`` module, or the model's own words when it keeps it elsewhere."""
    package = type(state).__module__.rpartition(".")[0]
    try:
        found = importlib.util.find_spec(f"{package}.monitor") is not None
    except (ImportError, ValueError):
        found = False
    return f"{package}.monitor.observe" if found else "the model's observe"
