"""How a run's time and error read in the bench's tables, terminal and report alike.

A time carries how it was stepped (``stackx.bench.stepping``): compiled figures bare, an engine's marked
``*`` (``result.step_time``: timed one step per call) and a plain-Python solver's marked ``py``, so that a
plugin written without kernels is not read as a slow method. An error carries its uncertainty where the
record has one (``error["spread"]``, m/s, the same units as the error; ``stackx.bench.uncertainty``):
``0.0123 ± 0.0004`` above it, ``<= 0.0024`` at or below it (the error cannot be told from zero), and the steps
the reference left unsolved with the largest residual left on them: ``0.0124 (3 steps unsolved, residual <=
2.4e-6 m/s)``; a record without an uncertainty shows the error alone, and the reference shows ``reference``
(its error is zero by definition, not by merit).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from stackx.bench.result import step_time
from stackx.bench.stepping import PLAIN, stepping
from stackx.bench.sweep import Record
from stackx.bench.uncertainty import SPREAD, error_text as _error_text

if TYPE_CHECKING:
    from stackx.bench.result import CaseResult

PLAIN_MARK = "py"  # after the time of a solver stepped as plain Python
UNCERTAINTY = SPREAD  # the key of a record's error that holds the RMS error's uncertainty (m/s)


def steppings(res: CaseResult) -> dict[str, str]:
    """How each solver of a case was stepped (``stepping``), by solver name."""
    from stackx import kernel

    on = kernel.enabled()
    return {p.solver: stepping(p.solver_cls, on) for p in res.case.plans}


def timed(rec: Record, how: str) -> str:
    """A record's µs/step as tables show it (``step_time``: spread, ``!``, ``*``), and ``py`` when the solver
    stepped as plain Python (``how``, from ``steppings``)."""
    text = step_time(rec)
    return f"{text} {PLAIN_MARK}" if how == PLAIN and rec.us_per_step is not None else text


def error_text(rec: Record, unit: str = "") -> str:
    """A record's RMS error against the reference for a table: ``0.0123``, ``0.0123 ± 0.0004`` or ``<= 0.0024``
    where the record carries its uncertainty, with the steps the reference left unsolved and their largest
    residual (``stackx.bench.uncertainty.error_text``, ``unit`` after the figure); ``reference`` for the
    reference, ``-`` where there is none (a run that broke)."""
    if rec.reference:
        return "reference"
    return "-" if rec.broke else _error_text(rec.error, unit)


def plain_note(how: dict[str, str]) -> str:
    """The line under a case's table when a solver in it stepped as plain Python; empty otherwise."""
    plain = [solver for solver, way in how.items() if way == PLAIN]
    if not plain:
        return ""
    if all(way == PLAIN for way in how.values()):
        return (f"{PLAIN_MARK}: stepped as plain Python (compiled kernels are off: STACKX_JIT=0, or numba is "
                "missing): every time is the language's as much as the method's")
    return (f"{PLAIN_MARK}: stepped as plain Python, no compiled kernels ({', '.join(plain)}): its time is the "
            "language's as much as the method's, not comparable with the compiled times beside it")
