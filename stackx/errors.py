"""The two kinds of failure stackx reports without a traceback.

``ConfigError`` is the user's input being wrong (exit code 2): it names the file, the line:column and the
key. ``RunError`` is a simulation or plugin failing while running (exit code 1): it names where.
"""

from __future__ import annotations

from collections.abc import Callable

Fail = Callable[[tuple[str | int, ...], str], "ConfigError"]
"""``fail(key_path, message)``: the error to raise for a config value, located by whoever knows the file."""


class StackxError(Exception):
    """Base of every error stackx reports as a short message."""

    exit_code = 1


class ConfigError(StackxError):
    """Bad input: a config, a ``--set`` override, a plugin name or a command-line value."""

    exit_code = 2

    def __init__(self, message: str, *, file: str | None = None, line: int | None = None,
                 col: int | None = None, key: str | None = None) -> None:
        self.message, self.file, self.line, self.col, self.key = message, file, line, col, key
        super().__init__(str(self))

    def __str__(self) -> str:
        where = self.file or "<input>"
        if self.line is not None:
            where += f":{self.line}:{self.col or 1}"
        key = f" {self.key}:" if self.key else ""
        return f"{where}:{key} {self.message}"


class RunError(StackxError):
    """A run that failed while stepping or writing (blow-up, a plugin raising)."""

    exit_code = 1


class BlowUp(RunError):
    """A run whose state became NaN or infinite, or moved faster than ``limits.max_speed``.

    ``report`` is what the failed-run file keeps: where it happened (step, run, box, solver) and the measures
    of every run as far as it got, so the partial numbers are not lost with the run.
    """

    def __init__(self, message: str, report: dict[str, object]) -> None:
        super().__init__(message)
        self.report = report


def first_line(exc: BaseException) -> str:
    """``Type: first line of the message``: plugin errors (numba's are pages long) stay one line."""
    lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
    return f"{type(exc).__name__}: {lines[0]}" if lines else type(exc).__name__


def listing(names: list[str]) -> str:
    """The runs a message is about, as it names them: ``'a', 'b'`` (every run of a batch, in its order)."""
    return ", ".join(map(repr, names))
