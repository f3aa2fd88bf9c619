"""How a run's time and error read in the bench's tables, terminal and report alike.

A time carries how it was stepped (``stackx.bench.stepping``): compiled figures bare, an engine's marked
``*`` (``result.step_time``: timed one step per call) and a plain-Python solver's marked ``py``, so that a
plugin written without kernels is not read as a slow method. An error carries its uncertainty where the
record has one (``error[UNCERTAINTY]``, m/s, the same units as the error): ``0.0123 ± 0.0004``; a record
without one shows the error alone, and the reference shows ``reference`` (its error is zero by
definition, not by merit).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from stackx.bench.markup import number
from stackx.bench.result import step_time
from stackx.bench.stepping import PLAIN, stepping
from stackx.bench.sweep import Record

if TYPE_CHECKING:
    from stackx.bench.result import CaseResult

PLAIN_MARK = "py"  # after the time of a solver stepped as plain Python
UNCERTAINTY = "rms_uncertainty"  # the key of a record's error that holds the RMS error's uncertainty (m/s)


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


def error_text(rec: Record) -> str:
    """A record's RMS error against the reference for a table: ``0.0123``, ``0.0123 ± 0.0004`` where the record
    carries its uncertainty, ``reference`` for the reference, ``-`` where there is none (a run that broke),
    and how many steps the reference could not solve (the error leaves them out)."""
    if rec.reference:
        return "reference"
    rms = None if rec.broke else rec.error.get("rms")
    if rms is None:
        return "-"
    text = number(rms)
    spread = rec.error.get(UNCERTAINTY)
    if spread is not None:
        text += f" ± {number(spread, '.2g')}"
    unsolved = rec.error.get("unsolved")
    if unsolved:
        text += f" ({unsolved} step{'s' if unsolved > 1 else ''} unsolved)"
    return text


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
