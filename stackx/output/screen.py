"""Where the tables of ``stackx run``, ``stackx bench`` and ``stackx plugins`` print: standard output, as wide as
the terminal (or ``COLUMNS``), else ``WIDE`` columns when the output goes to a file or a pipe: a log then keeps
every row on one line instead of folding names like ``planar-warm-start`` at rich's 80-column default."""

from __future__ import annotations

import os

from rich.console import Console

WIDE = 160  # columns of the tables when the output is not a terminal


def screen() -> Console:
    """A console on standard output: the terminal's width or ``COLUMNS``, else ``WIDE`` columns."""
    console = Console()
    if console.is_terminal or "COLUMNS" in os.environ:
        return console
    return Console(width=WIDE)
