"""Tables laid out within the screen's width, every name readable and no number cut.

rich shrinks a table that is too wide by folding its wrapping columns, and when that is not enough, by
taking the excess from every column alike, down to nothing: at 80 columns the run table's run and solver
columns vanished, and names folded at any letter (``ramp-slid`` / ``e/main``). Here a table is laid out
before rich sees it:

- a table that fits is left as it is;
- else every column gets its **floor**: a number column (one that does not wrap) its widest cell, so no
  number is ever cut, and its header's longest word (a header wraps at spaces); a text column its longest
  piece, names breaking after ``/``, ``-``, ``_`` and at spaces (``planar-`` / ``warm-start``), and at least
  ``FLOOR`` characters where its text is that long;
- the width left over goes to the text columns where it saves the most lines per character (a name on two
  lines rather than three), then to the headers of number columns; each text cell is broken at those
  points to its column's width, so rich never folds a name mid-word;
- when even the floors do not fit (``--wide`` at 80 columns), the columns are split into tables shown one
  after the other, each repeating the first column (the row's name): every figure is still there, whole.

The knob is the screen's width; the trade is a second line for a long name, or a second table for a wide
one, against a line cut at the terminal's edge or a column shrunk to nothing.
"""

from __future__ import annotations

import copy
import re
from collections.abc import Iterable
from dataclasses import dataclass

from rich.cells import cell_len
from rich.console import Console, ConsoleRenderable, RenderableType, RenderHook
from rich.padding import Padding
from rich.table import Column, Table
from rich.text import Text

KEYS = 2  # leading text columns repeated in each part of a table split in parts
FLOOR = 6  # characters below which a text column is not squeezed (unless its text is shorter)
PIECES = re.compile(r"(?:[^ /_-]|(?<![A-Za-z])-|-(?![A-Za-z]))*(?:[/_]+ *|-(?=[A-Za-z]) *| +|$)")
"""The pieces a name breaks into: after ``/``, ``_``, a space, and a ``-`` between letters (``planar-`` /
``warm-start``), never inside a number (``-0.03``, ``1e-05``)."""
WORDS = re.compile(r"[^ ]*(?: +|$)")  # a header breaks at spaces only


class FitTables(RenderHook):
    """A render hook that lays out every table printed on a console within the console's width (``fit``),
    and a table that a ``Padding`` indents within what the padding leaves."""

    def __init__(self, console: Console) -> None:
        self.console = console

    def process_renderables(self, renderables: list[ConsoleRenderable]) -> list[ConsoleRenderable]:
        out: list[ConsoleRenderable] = []
        for item in renderables:
            out.extend(fitted(item, self.console, self.console.width))
        return out


def fitted(item: ConsoleRenderable, console: Console, width: int) -> list[ConsoleRenderable]:
    """``item`` as it prints within ``width``: a table laid out (``fit``), a padded table laid out within what
    the padding leaves; anything else as it is."""
    if isinstance(item, Table):
        return list(fit(item, console, width))
    if isinstance(item, Padding) and isinstance(item.renderable, Table):
        inner = width - item.left - item.right
        if inner <= 0:
            return [item]
        pads = (item.top, item.right, item.bottom, item.left)
        return [Padding(t, pads, style=item.style, expand=item.expand) for t in fit(item.renderable, console, inner)]
    return [item]


@dataclass
class _Col:
    """One column as the layout sees it: its header and cells as text, whether it wraps, and its widths."""

    column: Column
    header: Text
    cells: list[Text | RenderableType]
    texts: list[Text]       # the text cells, each text once (a solver's name repeats down a sweep)
    wraps: bool
    natural: int
    floor: int


def fit(table: Table, console: Console, width: int) -> list[ConsoleRenderable]:
    """``table`` laid out within ``width`` columns (see the module doc): itself when it fits, else one table
    with its widths set and its text broken, else several, each with the first column and a share of the
    rest, the caption after the last as a paragraph of the screen's width."""
    if table.width is not None or not table.columns:
        return [table]
    cols = [_col(console, c) for c in table.columns]
    if sum(c.natural for c in cols) + _overhead(console, table, len(cols)) <= width:
        return [table]
    table = _tight(table)
    groups = _groups(console, table, cols, width)
    if len(groups) == 1:
        return [_laid_out(console, table, cols, width)]
    out: list[ConsoleRenderable] = []
    for k, group in enumerate(groups):
        part = _laid_out(console, table, [cols[i] for i in group], width)
        part.title = table.title if k == 0 else f"{_plain(table.title)} (continued)" if table.title else None
        part.caption = None
        out.append(part)
    if table.caption:
        caption = _text(console, table.caption).copy()
        caption.stylize(table.caption_style or "table.caption")
        caption.justify = table.caption_justify
        out.append(caption)
    return out


def _tight(table: Table) -> Table:
    """A table that does not fit, its columns one space apart where nothing but space parts them (no box, or
    a box without vertical lines): a space more between columns is worth less than a line more in a name."""
    if table.box is not None and table.box.mid_vertical.strip():
        return table
    top, right, bottom, left = table.padding
    if right + left <= 1:
        return table
    tight = copy.copy(table)
    tight.padding = (top, 1, bottom, 0)
    tight.pad_edge = False
    return tight


def _plain(title: object) -> str:
    return title.plain if isinstance(title, Text) else str(title)


def _col(console: Console, column: Column) -> _Col:
    """Measure one column: its natural width (nothing wrapped) and its floor (see the module doc)."""
    header = _text(console, column.header, column.highlight)
    cells = [_text(console, c, column.highlight) if isinstance(c, (str, Text)) else c for c in column.cells]
    wraps = not column.no_wrap
    widths = [_width(console, c) for c in cells]
    natural = max([_width(console, header), *widths, 1])
    head_floor = _longest(header, WORDS)
    if wraps:
        pieces = max([_longest(c, PIECES) if isinstance(c, Text) else w for c, w in zip(cells, widths)] or [1])
        floor = max(head_floor, pieces, min(natural, FLOOR))
    else:
        floor = max([head_floor, *widths, 1])
    return _Col(column, header, cells, _distinct(cells), wraps, natural, min(floor, natural))


def _text(console: Console, value: RenderableType, highlight: bool = False) -> Text:
    """A cell's text, markup read (and highlighted, where its column is) as the table would read it."""
    if isinstance(value, Text):
        return value
    return console.render_str(str(value), highlight=highlight) if value is not None else Text("")


def _width(console: Console, cell: RenderableType) -> int:
    if isinstance(cell, Text):
        return max((cell_len(line) for line in cell.plain.split("\n")), default=0)
    return console.measure(cell).maximum


def _longest(text: Text | RenderableType, pattern: re.Pattern[str]) -> int:
    """The widest piece that ``text`` cannot be broken inside (``pattern`` says where it breaks)."""
    if not isinstance(text, Text):
        return 1
    return max((cell_len(m.group().rstrip(" ")) for line in text.plain.split("\n")
                for m in pattern.finditer(line)), default=0)


def _overhead(console: Console, table: Table, count: int) -> int:
    """The columns a table of ``count`` columns spends beyond their content: padding, borders, edges."""
    probe = copy.copy(table)
    probe.columns, probe.rows = [], []
    probe.title = probe.caption = None
    for _ in range(count):
        probe.add_column(width=1)
    return console.measure(probe, options=console.options.update_width(10_000)).maximum - count


def _groups(console: Console, table: Table, cols: list[_Col], width: int) -> list[list[int]]:
    """The columns of each table to print: all in one when their floors fit, else the row's name (``_keys``)
    with as many of the next columns as fit, again and again."""
    if sum(c.floor for c in cols) + _overhead(console, table, len(cols)) <= width:
        return [list(range(len(cols)))]
    keys = _keys(cols)
    groups: list[list[int]] = []
    group = list(keys)
    for i in range(len(keys), len(cols)):
        trial = [*group, i]
        if len(group) > len(keys) and sum(cols[j].floor for j in trial) + _overhead(console, table, len(trial)) > width:
            groups.append(group)
            trial = [*keys, i]
        group = trial
    groups.append(group)
    return groups


def _keys(cols: list[_Col]) -> list[int]:
    """The leading columns that name a row and are repeated in every part of a split table: the first column,
    and the second too when it is text as well (a solver and its knob value), at most ``KEYS``."""
    keys = [0]
    while len(keys) < min(KEYS, len(cols) - 1) and cols[len(keys)].wraps and cols[0].wraps:
        keys.append(len(keys))
    return keys


def _laid_out(console: Console, table: Table, cols: list[_Col], width: int) -> Table:
    """A copy of ``table`` with ``cols`` at widths that fit ``width``, text broken to them."""
    room = width - _overhead(console, table, len(cols))
    widths = _share([c for c in cols], room)
    out = copy.copy(table)
    out.columns, out.rows = [], []
    for c, w in zip(cols, widths):
        c_ = c.column
        out.add_column(_broken(c.header, w, WORDS), footer=c_.footer, header_style=c_.header_style,
                       footer_style=c_.footer_style, style=c_.style, justify=c_.justify, vertical=c_.vertical,
                       overflow=c_.overflow, width=w, no_wrap=c_.no_wrap, highlight=c_.highlight)
    for r, row in enumerate(table.rows):
        cells = [_broken(c.cells[r], w, PIECES) if c.wraps and isinstance(c.cells[r], Text) else c.cells[r]
                 for c, w in zip(cols, widths)]
        out.add_row(*cells, style=row.style, end_section=row.end_section)
    return out


def _share(cols: list[_Col], room: int) -> list[int]:
    """Each column's width: its floor, then what is left where it saves the most lines per character (text
    columns first, down to their natural width), then to number columns' headers; text columns are then
    narrowed to the lines they were broken into, and what that frees goes to the headers too."""
    widths = [c.floor for c in cols]
    left = room - sum(widths)
    while left > 0:
        best: tuple[float, int, int] | None = None
        for i, c in enumerate(cols):
            if not c.wraps or widths[i] >= c.natural:
                continue
            now = _lines(c, widths[i])
            for w in range(widths[i] + 1, min(c.natural, widths[i] + left) + 1):
                fewer = now - _lines(c, w)
                if fewer > 0:
                    gain = fewer / (w - widths[i])
                    if best is None or gain > best[0]:
                        best = (gain, i, w)
                    break
        if best is None:
            break
        _, i, w = best
        left -= w - widths[i]
        widths[i] = w
    for i, c in enumerate(cols):  # a text column as wide as its broken lines, no wider
        if c.wraps:
            used = max([_width_broken(c.header, widths[i], WORDS),
                        *(_width_broken(cell, widths[i], PIECES) for cell in c.texts)])
            left += widths[i] - max(used, 1)
            widths[i] = max(used, 1)
    for i in sorted(range(len(cols)), key=lambda i: cols[i].natural - widths[i]):  # headers, least first
        more = min(left, cols[i].natural - widths[i])
        if more > 0 and not cols[i].wraps:
            widths[i] += more
            left -= more
    return widths


def _distinct(cells: Iterable[Text | RenderableType]) -> list[Text]:
    """The text cells of a column, each text once (a solver's name repeats down a sweep)."""
    seen: dict[str, Text] = {}
    for cell in cells:
        if isinstance(cell, Text):
            seen.setdefault(cell.plain, cell)
    return list(seen.values())


def _lines(col: _Col, width: int) -> int:
    """How many lines the tallest cell of a text column takes at ``width`` (its header's lines counted too)."""
    return max([len(_spans(col.header.plain, width, WORDS)),
                *(len(_spans(cell.plain, width, PIECES)) for cell in col.texts)])


def _width_broken(text: Text, width: int, pattern: re.Pattern[str]) -> int:
    return max((cell_len(text.plain[a:b]) for a, b in _spans(text.plain, width, pattern)), default=0)


def _spans(plain: str, width: int, pattern: re.Pattern[str]) -> list[tuple[int, int]]:
    """Where ``plain`` is broken into lines of at most ``width`` cells: (start, end) of each, trailing spaces
    left out. Pieces (``pattern``) are filled greedily; a piece wider than a line is folded at ``width``."""
    spans: list[tuple[int, int]] = []
    base = 0
    for line in plain.split("\n"):
        start = end = base
        for m in pattern.finditer(line):
            piece = m.group()
            if not piece:
                continue
            a, b = base + m.start(), base + m.end()
            bare = b - (len(piece) - len(piece.rstrip(" ")))
            if cell_len(plain[start:bare]) <= width or start == bare:
                end = bare
                continue
            if end > start:
                spans.append((start, end))
            start = a
            while cell_len(plain[start:bare]) > width:  # a piece longer than a line: folded
                cut = _cut(plain, start, bare, width)
                spans.append((start, cut))
                start = cut
            end = bare
        spans.append((start, end))
        base += len(line) + 1
    return spans


def _cut(plain: str, start: int, stop: int, width: int) -> int:
    """The end of the longest stretch from ``start`` that is at most ``width`` cells wide (one at least)."""
    end = start + 1
    while end < stop and cell_len(plain[start:end + 1]) <= width:
        end += 1
    return end


def _broken(text: Text | RenderableType, width: int, pattern: re.Pattern[str]) -> Text | RenderableType:
    """``text`` with line breaks where it must wrap to ``width`` (styles kept); anything else as it is."""
    if not isinstance(text, Text):
        return text
    spans = _spans(text.plain, width, pattern)
    if len(spans) <= 1 and "\n" not in text.plain:
        return text
    return Text("\n").join(text[a:b] for a, b in spans)
