"""Watching a batch while it steps: plugin failures, broken state, and blow-ups named to the exact step.

Solvers advance many steps per call (compiled loops do not come back to Python every step), so the state is
checked after each call: every array must keep its shape and type, and the model's health check
(``Model.offender``) must find no box that is not finite or moves faster than ``limits.max_speed``. When a
check fails, the call is replayed one step at a time from a copy taken before it (the state and the solver's array attributes, where memory such as
warm-start impulses lives), and the first step whose state fails is the one reported, with its run, box and
solver. Stepping is deterministic, so the replay meets the same numbers; a solver that is not (or keeps
memory outside numpy arrays) is reported with the range of steps instead. "At step k" means the state after
k steps is the first bad one: the state frames and events call "before step k".

NaN and infinity never heal (every later step carries them), so they are always caught. A box that goes
faster than the limit and slows down again within one call is not: a blow-up is a divergence, which does
not come back, and checking inside the kernels would cost every solver a branch per box and step.
"""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np

from stackx.errors import BlowUp, RunError, first_line, listing


def snapshot(solver: Any) -> Any | None:
    """A copy of ``solver`` whose array memory does not move on with the original (None if it cannot be)."""
    try:
        twin = copy.copy(solver)
        for name, value in vars(solver).items():
            if isinstance(value, np.ndarray):
                setattr(twin, name, value.copy())
        return twin
    except Exception:
        return None


def _json_number(x: float) -> float | str:
    return x if math.isfinite(x) else str(x)


def _plain(values: Any) -> Any:
    """Lists and numbers with NaN and infinity as text, so the failed-run file stays valid JSON."""
    if isinstance(values, dict):
        return {k: _plain(v) for k, v in values.items()}
    if isinstance(values, (list, tuple)):
        return [_plain(v) for v in values]
    return _json_number(values) if isinstance(values, float) else values


class Watch:
    """Checks one batch of runs (``names``, one per row) stepped by ``solver``."""

    def __init__(self, file: str, names: list[str], solver: Any, model: Any, steps: int, max_speed: float) -> None:
        self.file, self.names, self.solver, self.steps, self.max_speed = file, names, solver, steps, max_speed
        self.model = model
        self.origin = getattr(solver, "plugin_origin", "unknown source")
        self.where = f"solver {solver.plugin_name!r} ({self.origin})"
        self._saved: tuple[Any, Any] | None = None

    def start(self, state: Any) -> None:
        """Refuse a batch that is already out of bounds before its first step."""
        hit = self.model.offender(state, self.max_speed)
        if hit:
            self._fail(0, hit, state, state)

    def save(self, state: Any) -> None:
        """Keep a copy of the state and the solver's memory, to replay the next call step by step."""
        self._saved = (state.copy(), snapshot(self.solver))

    def advance(self, state: Any, done: int, n: int) -> None:
        """``solver.advance(state, n)``, turning its failures and broken results into ``RunError``."""
        shapes = {k: (getattr(state, k).shape, getattr(state, k).dtype) for k in type(state).FIELDS}
        try:
            returned = self.solver.advance(state, n)
        except Exception as exc:
            raise RunError(f"{self.file}: {self.where} raised in {self._span(done, n)}: {first_line(exc)}") from exc
        if returned is not None:
            raise RunError(f"{self.file}: {self.where}: advance must change the state in place and return "
                           f"None; it returned {type(returned).__name__}")
        for name, (shape, dtype) in shapes.items():
            got = getattr(state, name)
            if not isinstance(got, np.ndarray) or got.shape != shape or got.dtype != dtype:
                what = f"{got.shape} {got.dtype}" if isinstance(got, np.ndarray) else type(got).__name__
                raise RunError(f"{self.file}: {self.where} left state.{name} as {what} in {self._span(done, n)}; "
                               f"it must stay {shape} {dtype}")

    def _span(self, done: int, n: int) -> str:
        """The steps of a call and its runs, for a message (made only then: a sweep has thousands of runs)."""
        return f"steps {done + 1}..{done + n} of run(s) {listing(self.names)}"

    def check(self, state: Any, done: int, n: int) -> None:
        """After ``advance``: find the first bad step of the call, if the state went bad, and raise."""
        if self.model.offender(state, self.max_speed) is None:
            return
        assert self._saved is not None
        before, twin = self._saved
        if twin is not None:
            replay = before.copy()
            for j in range(n):
                previous = replay.copy()
                try:
                    twin.advance(replay, 1)
                except Exception:
                    break
                hit = self.model.offender(replay, self.max_speed)
                if hit:
                    self._fail(done + j + 1, hit, previous, replay)
        hit = self.model.offender(state, self.max_speed)
        assert hit is not None
        self._fail(None, hit, before, state, (done, done + n))

    def _fail(self, step: int | None, hit: tuple[int, int, str, str], good: Any, bad: Any,
              span: tuple[int, int] | None = None) -> None:
        row, box, cause, detail = hit
        if step is None:
            assert span is not None
            when = (f"between steps {span[0] + 1} and {span[1]} (replaying them one at a time did not repeat "
                    "it: the solver is not deterministic or keeps memory outside numpy array attributes)")
        else:
            when = "before its first step" if step == 0 else f"at step {step} of {self.steps}"
        message = (f"{self.file}: run {self.names[row]!r} blew up {when}: box {box} {detail}; {self.where}")
        last_good = (span[0] if span else step - 1) if step != 0 else 0
        report: dict[str, Any] = {
            "status": "FAILED",
            "error": message,
            "config": self.file,
            "cause": cause,
            "step": step,
            "run": self.names[row],
            "box": box,
            "solver": self.solver.plugin_name,
            "solver_source": self.origin,
            "max_speed": self.max_speed,
            "runs": {name: stopped(self.model, "blew up" if b == row else "stopped with its batch", last_good,
                                   good, bad, b)
                     for b, name in enumerate(self.names)},
        }
        raise BlowUp(message, report)


def stopped(model: Any, status: str, steps_done: int, good: Any, bad: Any, b: int) -> dict[str, Any]:
    """What a failed-run report says of row ``b`` of a batch that stopped: its measures in the last good state
    (``good``, after ``steps_done`` steps) and its motion in the first bad one (``bad``)."""
    return {"status": status, "steps_done": steps_done, "measures": _plain(model.state_measures(good.row(b))),
            "after_failing_step": _plain(model.motion(bad, b))}


def add_finished(report: dict[str, Any], finished: dict[str, Any], all_runs: list[str]) -> None:
    """Complete a failed-run report with the runs that finished before the blow-up and those never run."""
    runs = report["runs"]
    for name in all_runs:
        if name in runs:
            continue
        if name in finished:
            r = finished[name]
            runs[name] = {"status": "finished", "steps_done": r.spec.steps, "measures": _plain(r.measures)}
        else:
            runs[name] = {"status": "not run"}
