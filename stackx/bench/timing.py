"""Microseconds per step, measured apart from the batched runs that give the measures.

The rows of a batch share one call, so a row's own time cannot be read from it; each knob value is timed
in short runs of its own, from the scene's start, and the median of a few repeats is kept (a 2-core
machine shared with other work is noisy). These are the only numbers of a bench that change from run to run.

Two times are kept. ``us_per_step`` advances the run's steps in one call, as ``stackx run`` does: the cost
of the stepping itself. ``us_per_call`` advances one step per call, as a game loop or an engine bound to
Python (pymunk, Box2D, MuJoCo are stepped so) does: the same work plus the cost of entering the solver
every step, which on a small column is most of it. Set a solver beside an engine with the second.

An engine (a solver with ``one_step_per_call``) has no faster way: a call into it is one step, and its
``advance(state, n)`` is n such calls. It is timed one step per call only (its world built before the clock
starts), and its ``us_per_step`` is that same figure, marked ``one_step_per_call`` in the timing record so
that tables can say so.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

from stackx import kernel
from stackx.bench.case import Timing
from stackx.spec import RunSpec


@contextmanager
def one_thread() -> Iterator[None]:
    """Run compiled kernels on one thread. A timed run is a single row and cannot use more; the batched runs
    stop at every step (the error against the exact solve is measured on each), and on a busy 2-core machine waking the idle
    pool thread at each such call costs about half a millisecond, more than the steps themselves."""
    if not kernel.enabled():
        yield
        return
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(before)


def time_run(run: RunSpec, timing: Timing) -> dict[str, Any]:
    """Microseconds per step of ``run`` alone, stepped in one call (``us_per_step``) and one step per call
    (``us_per_call``): each the median of ``timing.repeats`` runs of up to ``timing.steps`` steps from the
    scene's start (stopping before the first scene event), after one untimed warm-up step, compiled (unless
    ``STACKX_JIT=0``)."""
    events = [e.step for e in run.scene.events()]
    steps = min([timing.steps, run.steps, *events])
    per_call_only = bool(getattr(run.solver_cls, "one_step_per_call", False))

    def fresh() -> tuple[Any, Any]:
        solver = run.solver_cls([run.solver_params], np.array([run.gravity]), np.array([run.dt]))
        state = run.scene.build()
        if per_call_only:
            solver.advance(state, 0)  # an engine builds its world on its first call: not a step, not timed
        return solver, state

    try:
        with kernel.compiled(kernel.enabled()):
            solver, state = fresh()
            solver.advance(state, 1)  # loads the compiled kernels; not timed
            times, calls = [], []
            for _ in range(timing.repeats):
                if not per_call_only:
                    solver, state = fresh()
                    t0 = time.perf_counter()
                    solver.advance(state, steps)
                    times.append(1e6 * (time.perf_counter() - t0) / steps)
                solver, state = fresh()
                t0 = time.perf_counter()
                for _ in range(steps):
                    solver.advance(state, 1)
                calls.append(1e6 * (time.perf_counter() - t0) / steps)
    except Exception as exc:  # a solver that fails on its own is reported by the measured run, not here
        return {"us_per_step": None, "us_per_call": None, "steps": steps, "repeats": [], "call_repeats": [],
                "failed": f"{type(exc).__name__}: {exc}"}
    if per_call_only:
        return {"us_per_step": statistics.median(calls), "us_per_call": statistics.median(calls), "steps": steps,
                "repeats": calls, "call_repeats": calls, "one_step_per_call": True}
    return {"us_per_step": statistics.median(times), "us_per_call": statistics.median(calls), "steps": steps,
            "repeats": times, "call_repeats": calls}
