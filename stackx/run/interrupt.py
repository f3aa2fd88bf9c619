"""Ctrl-C (SIGINT) and SIGTERM, at any moment of any command: one line on stderr, never a traceback.

SIGTERM is what ``timeout``, systemd and ``docker stop`` send; it is answered exactly like Ctrl-C (the same
line, the same cleanup) with exit code 143 instead of 130 (128 + the signal's number, as a shell reports it).

The ``stackx`` entry point (``stackx.__main__``) imports this module first and installs the handlers before
any other import, so a signal while Python imports typer, rich or numpy is answered like one while a run steps.
That is why this module imports only ``os``, ``signal`` and ``sys``: everything it imports is time in which a
Ctrl-C would still print Python's traceback (``tests/robust/test_interrupt.py`` pins the list).

The first signal raises ``Interrupted``: a ``BaseException`` that is not ``KeyboardInterrupt``, so no library
mistakes it for its own (typer turns a ``KeyboardInterrupt`` into a silent exit 130), and every ``finally`` on
the way out runs (a run's staged files are thrown away and its folder lock let go). A second signal while that
cleanup runs ends the process at once. ``held`` defers a signal over a few lines that must not be cut (the
switch of an output folder), so what the line says stays true. Once the command is over, or its line printed,
a signal ends the process at once (it may be stuck joining threads at exit), printing the line if not yet done.
Before the command runs, and when a signal lands in a finalizer (``__del__``, where Python could only print
the exception and go on), there is nothing to unwind: the line is printed and the process ends there.
"""

import os
import signal
import sys

SIGNALS = (signal.SIGINT, signal.SIGTERM)
WRITERS = {"run": "out", "bench": "out/bench"}  # commands whose output folder (option --out) is switched whole
FOLDER_ARGUMENT = {"init": "."}  # commands whose folder is their first argument, switched whole


class Interrupted(BaseException):
    """Ctrl-C or SIGTERM: unwinds the command (running every ``finally``) up to the entry point."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum

    @property
    def exit_code(self) -> int:
        """128 + the signal's number: 130 for Ctrl-C, 143 for SIGTERM."""
        return 128 + self.signum


class _State:
    """Where the command stands, as the handlers see it."""

    installed: tuple[int, ...] = ()  # the signals this process answers (not those it was started ignoring)
    held = 0  # depth of ``held`` blocks
    pending = 0  # a signal that came during a ``held`` block
    switched = False  # the output folder holds this run's files
    running = False  # the command runs (``run``): a signal unwinds it
    first = 0  # the signal being answered (0 while the command runs)
    said = False  # the one line is printed
    late = "interrupted"  # the line for a signal once the command is over
    over = False  # the command is over (done, failed or interrupted)
    unraisable = sys.__unraisablehook__  # the hook for every other error in a finalizer


_state = _State()


def install() -> None:
    """Answer SIGINT and SIGTERM as this module says, unless the caller chose to ignore them (``nohup``, a
    background job started from a script: ignored signals stay ignored). Calling it again changes nothing."""
    if not _state.installed:
        _state.installed = tuple(s for s in SIGNALS if signal.getsignal(s) is not signal.SIG_IGN)
    _answer_with(on_signal)
    if sys.unraisablehook is not _unraisable:
        _state.unraisable, sys.unraisablehook = sys.unraisablehook, _unraisable


def _answer_with(handler: object) -> None:
    for signum in _state.installed:
        signal.signal(signum, handler)  # type: ignore[arg-type]


def on_signal(signum: int, frame: object) -> None:
    """The first signal: raise ``Interrupted`` here (or at the end of a ``held`` block); before the command
    runs (stackx still starting), there is nothing to clean up: print the line and exit."""
    if _state.held:
        _state.pending = _state.pending or signum
        return
    if not _state.running:
        _state.said = True
        _write(message(sys.argv[1:]))
        os._exit(128 + signum)
    _state.first = signum
    _answer_with(_again)
    raise Interrupted(signum)


def _again(signum: int, frame: object) -> None:
    """A second signal while the first one's cleanup runs: stop now."""
    _write("interrupted")
    os._exit(128 + (_state.first or signum))


def _late(signum: int, frame: object) -> None:
    """A signal once the command is over (it may be joining threads at exit): stop now, in one line."""
    if not _state.said:
        _state.said = True
        _flush(sys.stdout)
        _write(str(_state.late))
    os._exit(128 + (_state.first or signum))


def _unraisable(report: object) -> None:
    """``sys.unraisablehook``: a signal that landed in a finalizer (``__del__``, a weakref callback) cannot
    propagate from there, so it is answered at once, in one line, rather than printed and forgotten."""
    if isinstance(getattr(report, "exc_value", None), Interrupted):
        _state.said = True
        _flush(sys.stdout)
        _write(message(sys.argv[1:]))
        os._exit(report.exc_value.exit_code)  # type: ignore[attr-defined]
    _state.unraisable(report)


class _Held:
    """The context manager ``held`` returns (no ``contextlib`` here: see the module's docstring)."""

    def __enter__(self) -> None:
        _state.held += 1

    def __exit__(self, *exc: object) -> None:
        _state.held -= 1
        pending = _state.pending
        if not _state.held and pending and not _state.first:
            _state.pending = 0
            on_signal(pending, None)


def held() -> _Held:
    """Defer a signal until the block ends (keep the block short); it is raised then."""
    return _Held()


def switched() -> None:
    """Note that an output folder now holds this run's files (an interrupt after it changes nothing)."""
    _state.switched = True


def _folder(argv: list[str], command: str, words: list[str]) -> str | None:
    """The folder ``command`` switches, as the command line names it (its default when it does not)."""
    if command in FOLDER_ARGUMENT:
        return words[1] if len(words) > 1 else FOLDER_ARGUMENT[command]
    if command not in WRITERS:
        return None
    out = WRITERS[command]
    for i, arg in enumerate(argv):
        if arg in ("--out", "-o") and i + 1 < len(argv):
            out = argv[i + 1]
        elif arg.startswith("--out="):
            out = arg[len("--out="):]
        elif arg.startswith("-o") and len(arg) > 2 and not arg.startswith("--"):
            out = arg[2:]
    return out


def message(argv: list[str]) -> str:
    """The line an interrupt prints: for a command switching a folder, what became of the folder."""
    words = [a for a in argv if not a.startswith("-")]
    folder = _folder(argv, words[0] if words else "", words)
    if folder is None:
        return "interrupted"
    from stackx.errors import readable  # a 5,000-character --out is cut like any value in an error line

    if _state.switched:
        return readable(f"interrupted; {folder} already holds the run's files")
    return readable(f"interrupted; {folder} left as it was")


def _write(line: str) -> None:
    """``line`` on stderr, unbuffered; a closed stderr is no reason for a traceback."""
    try:
        os.write(2, (line + "\n").encode(errors="replace"))
    except OSError:
        pass


def _flush(stream: object) -> None:
    """Flush what the command printed before the process ends without Python's own exit."""
    try:
        stream.flush()  # type: ignore[attr-defined]
    except BaseException:  # a closed pipe, or a write this signal interrupted (a reentrant call)
        pass


def run(main: object) -> None:
    """Call ``main()`` (the command line), answering a signal in one line and exit code 128 + its number."""
    try:
        try:
            _state.running = True
            main()  # type: ignore[operator]
        finally:
            _over()
            _wait_for_threads()
    except Interrupted as stop:
        _leave(stop)


def _wait_for_threads() -> None:
    """Wait here, in short joins, for the threads Python would wait for at exit (a pool's, a cluster's). The
    system hands a signal to any thread of the process; Python's own wait at exit is woken only by one handed to
    the main thread, so a SIGTERM landing on another thread would go unanswered. Joined a tenth of a second at a
    time, the main thread answers a signal whichever thread took it."""
    import threading

    for thread in threading.enumerate():
        if thread is not threading.main_thread() and not thread.daemon:
            while thread.is_alive():
                thread.join(0.1)


def _over() -> None:
    """The command is over (done, failed or interrupted): a signal from now on ends the process at once."""
    _state.over = True
    if not _state.first:
        _state.late = message(sys.argv[1:])
        _answer_with(_late)


def _leave(stop: Interrupted) -> None:
    """Print the one line and exit with the signal's code (a further signal: exit at once, silently)."""
    _answer_with(signal.SIG_IGN)  # the line is a moment's work: nothing may cut it in two
    _state.first = stop.signum
    line = message(sys.argv[1:])
    _flush(sys.stdout)
    _write(line)
    _state.said = True
    _answer_with(_late)
    sys.exit(stop.exit_code)
