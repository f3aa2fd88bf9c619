"""The two kinds of failure stackx reports without a traceback.

``ConfigError`` is the user's input being wrong (exit code 2): it names the file, the line:column and the
key. ``RunError`` is a simulation or plugin failing while running (exit code 1): it names where. ``readable``
is how either is printed: one line, its long values cut.
"""

from __future__ import annotations

import re
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


VALUE_CHARS = 200
"""A value in a printed error line too long to print whole (a file name, a key, a list of names) longer than this
is cut: long enough for any path or key a person types, short enough that a list of 10,000 run names does not
bury the rest of the line."""
LINE_CHARS = 300
"""A printed error line aims at this length: about four terminal lines. When cutting values at ``VALUE_CHARS``
is not enough, the longest values (not the labels saying where) are cut again, each only as much as the line
needs and to no less than ``SHORT_VALUE_CHARS``."""
SHORT_VALUE_CHARS = 120
"""The least a value is cut to to bring a line near ``LINE_CHARS``: a path a person must copy (the failed run's
measures, the folder to look in) is rarely longer, so it stays whole, at the price of a longer line."""
MAX_LINE_CHARS = 600
"""A line still longer than this once its values are cut (long prose, many long values) is cut in its middle to
this length: the last resort, as it may cut what the line is about."""

# a quoted value (a repr) or a bare word, and what a listing says of it in brackets: "pgs (built-in)"
_ITEM = r"""(?:'(?:[^'\\]|\\.)*'|"(?:[^"\\]|\\.)*"|[^\s,]+)(?: \([^()]{1,40}\))?"""
_VALUES = re.compile(rf"(?:{_ITEM})(?:, ?(?:{_ITEM}))*")  # one value, or a list of them separated by commas
_ITEMS = re.compile(_ITEM)
_PUNCTUATED = re.compile(r"(.*?)([:;.,)]*)", re.DOTALL)  # a word and the punctuation the sentence put after it


def readable(message: str) -> str:
    """``message`` as one printed line: whitespace runs become one space; a line longer than ``LINE_CHARS`` has
    each value (a quoted or bare word, or a comma-separated list of them) longer than ``VALUE_CHARS`` cut, then,
    while it is too long, the longest values again down to ``SHORT_VALUE_CHARS`` (not the labels saying where,
    such as ``FILE:LINE:COL:`` and ``KEY:``), and at last, over ``MAX_LINE_CHARS``, the line in its middle.

    Every cut is marked with an ellipsis and says how long the value was, so a cut line is never mistaken for
    the whole. The error itself keeps its full text (``--debug`` shows it).
    """
    whole = " ".join(message.split())
    if len(whole) <= LINE_CHARS:  # a list of what is allowed, however long, stays whole while the line fits
        return whole
    pieces, values = _split_values(whole)
    original = list(pieces)
    for i in values:
        pieces[i] = _cut_values(original[i], VALUE_CHARS)
    over = sum(map(len, pieces)) - LINE_CHARS
    for i in sorted(values, key=lambda i: len(pieces[i]), reverse=True):
        if over <= 0 or len(pieces[i]) <= SHORT_VALUE_CHARS:
            break
        if original[i].endswith(":"):  # a label (``FILE:LINE:COL:``, ``KEY:``) says where: it stays whole
            continue
        shorter = _cut_values(original[i], max(SHORT_VALUE_CHARS, len(pieces[i]) - over))
        if len(shorter) < len(pieces[i]):
            over -= len(pieces[i]) - len(shorter)
            pieces[i] = shorter
    line = "".join(pieces)
    if len(line) <= MAX_LINE_CHARS:
        return line
    head = MAX_LINE_CHARS * 2 // 3
    mark = f" … ({len(line):,} characters in all) … "
    return line[:head].rstrip() + mark + line[len(line) - (MAX_LINE_CHARS - head - len(mark)):].lstrip()


def _split_values(line: str) -> tuple[list[str], list[int]]:
    """``line`` as pieces (prose between values, and values) and the indices of the values among them."""
    pieces: list[str] = []
    values: list[int] = []
    at = 0
    for match in _VALUES.finditer(line):
        pieces.append(line[at:match.start()])
        values.append(len(pieces))
        pieces.append(match.group())
        at = match.end()
    pieces.append(line[at:])
    return pieces, values


def shorten(value: str, limit: int = VALUE_CHARS) -> str:
    """``value`` if it is at most ``limit`` long, else at most ``limit`` characters: its beginning and end around
    an ellipsis, and its length (trailing punctuation kept after the length, where the sentence put it)."""
    if len(value) <= limit:
        return value
    word, end = _PUNCTUATED.fullmatch(value).groups()  # type: ignore[union-attr]
    mark = f" ({len(word):,} characters){end}"
    room = max(limit - len(mark) - 1, 12)  # what is kept of the value: never so little that it says nothing
    head = room * 2 // 3
    return f"{word[:head]}…{word[len(word) - (room - head):]}{mark}"


def _cut_values(text: str, limit: int) -> str:
    """A value too long to read cut by ``shorten``; a list: its first items, an ellipsis, its last item and how
    many there were, in at most ``limit`` characters (the first item and the last are kept, cut if need be)."""
    if len(text) <= limit:
        return text
    items = _ITEMS.findall(text)
    if len(items) == 1:
        return shorten(text, limit)
    tail = f", …, {shorten(items[-1], max(limit // 3, 24))} ({len(items):,} items)"
    kept = [shorten(items[0], max(limit - len(tail), 24))]
    for item in items[1:-1]:
        if len(", ".join(kept)) + 2 + len(item) + len(tail) > limit:
            break
        kept.append(item)
    return ", ".join(kept) + tail
