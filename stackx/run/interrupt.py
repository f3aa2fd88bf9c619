"""Ctrl-C (SIGINT), at any moment of any command: one line on stderr and exit code 130, never a traceback.

The ``stackx`` entry point (``stackx.__main__``) installs ``on_sigint`` before it imports anything heavy, so
an interrupt while Python imports typer, rich or numpy is answered like one while a run steps. The first
SIGINT raises ``Interrupted``: a ``BaseException`` that is not ``KeyboardInterrupt``, so no library mistakes
it for its own (typer turns a ``KeyboardInterrupt`` into a silent exit 130), and every ``finally`` on the way
out runs (a run's staged files are thrown away and its folder lock let go). A second SIGINT while that
cleanup runs ends the process at once. ``held`` defers an interrupt over a few lines that must not be cut
(the switch of an output folder), so what the line says stays true.
"""

from __future__ import annotations

import os
import signal
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

EXIT_CODE = 130  # 128 + SIGINT, what a shell reports for a command stopped by Ctrl-C
WRITERS = {"run": "out"}  # commands whose output folder an interrupt leaves as it was, with its default


class Interrupted(BaseException):
    """Ctrl-C: unwinds the command (running every ``finally``) up to the entry point."""


_state = {"held": 0, "pending": False, "switched": False}


def on_sigint(signum: int, frame: FrameType | None) -> None:
    if _state["held"]:
        _state["pending"] = True
        return
    signal.signal(signal.SIGINT, _again)
    raise Interrupted


def _again(signum: int, frame: FrameType | None) -> None:
    """A second Ctrl-C while the first one's cleanup runs: stop now."""
    os.write(2, b"interrupted\n")
    os._exit(EXIT_CODE)


def install() -> None:
    """Answer Ctrl-C as this module says, unless the caller chose to ignore it (``nohup``, a background job)."""
    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        signal.signal(signal.SIGINT, on_sigint)


@contextmanager
def held() -> Iterator[None]:
    """Defer a Ctrl-C until the block ends (keep the block short); it is raised then."""
    _state["held"] += 1
    try:
        yield
    finally:
        _state["held"] -= 1
        if not _state["held"] and _state["pending"] and signal.getsignal(signal.SIGINT) is on_sigint:
            _state["pending"] = False
            on_sigint(signal.SIGINT, None)


def switched() -> None:
    """Note that an output folder now holds this run's files (an interrupt after it changes nothing)."""
    _state["switched"] = True


def message(argv: list[str]) -> str:
    """The line an interrupt prints: for a command writing an output folder, what became of the folder."""
    words = [a for a in argv if not a.startswith("-")]
    command = words[0] if words else ""
    if command not in WRITERS:
        return "interrupted"
    out = WRITERS[command]
    for i, arg in enumerate(argv):
        if arg in ("--out", "-o") and i + 1 < len(argv):
            out = argv[i + 1]
        elif arg.startswith("--out="):
            out = arg[len("--out="):]
        elif arg.startswith("-o") and len(arg) > 2 and not arg.startswith("--"):
            out = arg[2:]
    if _state["switched"]:
        return f"interrupted; {out} already holds the run's files"
    return f"interrupted; {out} left as it was"


def run(main: object) -> None:
    """Call ``main()`` (the command line), answering an interrupt in one line and exit code 130."""
    try:
        main()  # type: ignore[operator]
    except Interrupted:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        sys.stderr.write(message(sys.argv[1:]) + "\n")
        sys.stderr.flush()
        sys.exit(EXIT_CODE)
