"""Where the tables of ``stackx run``, ``stackx bench`` and ``stackx plugins`` print: standard output, as wide as
the terminal (or ``COLUMNS``), else ``WIDE`` columns when the output goes to a file or a pipe: a log then keeps
every row on one line instead of folding names like ``planar-warm-start`` at rich's 80-column default. Every table
printed there is laid out within that width by ``stackx.output.layout``: names wrap at their ``/`` and ``-`` (never
to nothing), numbers are never cut, and a table too wide even so is shown in parts that each repeat its first
column."""

from __future__ import annotations

import functools
import os
from typing import Any

from rich.console import Console

from stackx.bench.stepping import COMPILED, ENGINE, PLAIN, stepping
from stackx.output.layout import FitTables

WIDE = 160  # columns of the tables when the output is not a terminal


def screen() -> Console:
    """A console on standard output: the terminal's width or ``COLUMNS``, else ``WIDE`` columns; its tables
    laid out within that width (``stackx.output.layout``)."""
    console = Console()
    if not (console.is_terminal or "COLUMNS" in os.environ):
        console = Console(width=WIDE)
    console.push_render_hook(FitTables(console))
    return console


# The µs/step column of the run table: how each run stepped and how its time was obtained. The marks say what
# the bench's tables say (``stackx.bench.stepping``), where a compiled time is unmarked, ``py`` plain Python and
# ``*`` an engine; a run table marks every row, so its compiled rows say ``jit``.
SHARED = "≈"  # before a time that is the run's share of its batch's time, not its own
MARKS = {COMPILED: "jit", PLAIN: "py", ENGINE: "engine"}  # after a time: how the run stepped
ENGINE_MARK = MARKS[ENGINE]
TIMING_CAPTION = (f"µs/step: jit = compiled kernels (compile not counted), py = plain Python (kernels off, or a "
                  f"plugin of Python loops), {ENGINE_MARK} = an engine's own code (pymunk, Box2D, MuJoCo); "
                  f"{SHARED} = the run's share of its batch's time by the work each run "
                  "did (passes x contacts), else timed on its own")


def timing_cell(run: Any, form: str) -> str:
    """A run's µs/step as the run table shows it: ``54.6 jit`` timed on its own, ``≈54.6 jit`` a share of its
    batch's time (``stackx.run.results.RunResult.timed``). The mark is how its solver stepped in that batch
    (``stackx.bench.stepping``): ``jit`` a solver reaching compiled kernels in a compiled batch, ``py`` plain
    Python (a plain batch, or a plugin of Python loops in a compiled one), ``engine`` an engine whatever the
    batch."""
    shared = SHARED if getattr(run, "timed", "own") == "share" else ""
    return f"{shared}{run.us_per_step:{form}} {MARKS[_stepped(run.spec.solver_cls, bool(run.compiled))]}"


@functools.lru_cache(maxsize=None)
def _stepped(solver_cls: type, compiled: bool) -> str:
    """``stepping`` of a solver class in a batch compiled or not, read from its code once per class."""
    return stepping(solver_cls, compiled)
