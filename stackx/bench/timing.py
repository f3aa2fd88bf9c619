"""Microseconds per step, measured apart from the batched runs that give the measures.

The rows of a batch share one call, so a row's own time cannot be read from it; each knob value is timed
in short runs of its own, from the scene's start. Every repeat is kept; the figure is the **minimum** (as
asv and google-benchmark report: other work on the machine only ever adds time, so the fastest repeat is the
one least disturbed) and beside it the **spread**, how far the median repeat is above the minimum, as a
share of it. A spread above ``UNSTABLE`` says the machine was too busy for the figure to be trusted, and so
does a µs/step above its µs/call (stepping many steps in one call does less than one call per step, so it
can only come out slower by noise): such a figure is flagged ``unstable``, and fronts and winners that rest
on it say so. These are the only numbers of a bench that change from run to run; verdicts never read them.

The clock is the CPU time of the timing thread (``time.thread_time``; compiled kernels run on it, on one
thread, see ``one_thread``), not the wall clock: on a machine shared with other work a timed run of a
millisecond is often taken off the CPU for many milliseconds, which a wall clock adds to its figure (two
benches once read 9 and 480 µs/step for the same run) and a CPU clock does not. What other work still does
to the timed thread (caches, memory bandwidth) shows in the spread.

The two ways of stepping alternate within each repeat, and their order alternates between repeats, so a
burst of other work falls on both alike rather than on one.

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
from stackx.config.spec import RunSpec

CLOCK = time.thread_time  # seconds of CPU this thread has used: time the machine gave to other work is not counted
UNSTABLE = 0.25  # spread (median repeat over the fastest, minus 1) above which a figure is flagged


def spread(repeats: list[float]) -> float:
    """How far the median repeat is above the fastest, as a share of it: 0 when they agree."""
    best = min(repeats)
    return statistics.median(repeats) / best - 1.0 if best > 0 else 0.0


def summary(times: list[float], calls: list[float], per_call_only: bool) -> dict[str, Any]:
    """The timing record of measured repeats (µs per step, one step per call): minimum, spread, every repeat,
    and whether the figures are ``unstable`` (a large spread, or µs/step above µs/call), with why."""
    step = calls if per_call_only else times
    out: dict[str, Any] = {"us_per_step": min(step), "us_per_call": min(calls), "spread": spread(step),
                           "call_spread": spread(calls), "repeats": step, "call_repeats": calls}
    why = []
    if max(out["spread"], out["call_spread"]) > UNSTABLE:
        why.append(f"the median repeat is {100 * max(out['spread'], out['call_spread']):.0f}% above the fastest")
    if out["us_per_step"] > out["us_per_call"]:
        why.append("µs/step came out above µs/call")
    out["unstable"] = "; ".join(why)
    if per_call_only:
        out["one_step_per_call"] = True
    return out


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
    (``us_per_call``): each the fastest of ``timing.repeats`` runs of up to ``timing.steps`` steps from the
    scene's start (stopping before the first scene event), after an untimed warm-up of both ways of stepping,
    compiled (unless ``STACKX_JIT=0``); with every repeat and the spread (``summary``)."""
    events = [e.step for e in run.scene.events()]
    steps = min([timing.steps, run.steps, *events])
    per_call_only = bool(getattr(run.solver_cls, "one_step_per_call", False))

    def fresh() -> tuple[Any, Any]:
        solver = run.solver_cls([run.solver_params], np.array([run.gravity]), np.array([run.dt]))
        state = run.scene.build()
        if per_call_only:
            solver.advance(state, 0)  # an engine builds its world on its first call: not a step, not timed
        return solver, state

    def in_one_call() -> float:
        solver, state = fresh()
        t0 = CLOCK()
        solver.advance(state, steps)
        return 1e6 * (CLOCK() - t0) / steps

    def per_call() -> float:
        solver, state = fresh()
        t0 = CLOCK()
        for _ in range(steps):
            solver.advance(state, 1)
        return 1e6 * (CLOCK() - t0) / steps

    try:
        with kernel.compiled(kernel.enabled()):
            solver, state = fresh()
            solver.advance(state, 1)  # loads the compiled kernels; not timed
            if not per_call_only:
                solver.advance(state, 2)  # and those of many steps in one call, if they differ
            times: list[float] = []
            calls: list[float] = []
            for k in range(timing.repeats):
                if per_call_only:
                    calls.append(per_call())
                elif k % 2 == 0:
                    times.append(in_one_call())
                    calls.append(per_call())
                else:
                    calls.append(per_call())
                    times.append(in_one_call())
    except Exception as exc:  # a solver that fails on its own is reported by the measured run, not here
        return {"us_per_step": None, "us_per_call": None, "steps": steps, "repeats": [], "call_repeats": [],
                "failed": f"{type(exc).__name__}: {exc}"}
    return {**summary(times, calls, per_call_only), "steps": steps}
