"""Progress as one line per finished piece of work, for an error stream that is not a terminal.

A progress bar is drawn only on a terminal: written to a file, a pipe or a CI log it shows nothing (rich does
not draw it there), and a first planar bench, which compiles kernels for minutes, would sit silent until its
summary. Where the bar is not drawn, ``Finished`` prints instead one line per finished piece (a solver on a
case, an experiment): what finished, how many of how many, and the seconds since the start, e.g.
``bench: 3/18 done: tall-20 pgs (42 s)``. On a terminal it prints nothing (the bar is there), and with
``quiet`` nothing at all.
"""

from __future__ import annotations

import time

from rich.console import Console


class Finished:
    """Counts finished pieces of ``total`` and says each on ``console`` when that is not a terminal."""

    def __init__(self, console: Console, what: str, total: int, quiet: bool = False) -> None:
        self.console, self.what, self.total = console, what, total
        self.on = not quiet and not console.is_terminal
        self.count = 0
        self.start = time.perf_counter()

    def done(self, name: str) -> None:
        """One more piece, ``name``, finished: its line (when lines are on)."""
        self.count += 1
        if self.on:
            seconds = time.perf_counter() - self.start
            self.console.print(f"{self.what}: {self.count}/{self.total} done: {name} ({seconds:.0f} s)",
                               markup=False, highlight=False, soft_wrap=True)
