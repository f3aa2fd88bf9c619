"""Small pieces of the report's HTML: escaped text, table cells and tables, numbers, solver swatches, and
pictures embedded as ``data:`` URIs so that ``report.html`` is one file that needs nothing beside it."""

from __future__ import annotations

import base64
import html

from stackx.bench.palette import colour


def esc(text: object) -> str:
    return html.escape(str(text))


def number(value: float | None, fmt: str = ".3g") -> str:
    """A measure for a table; ``-`` where there is none."""
    return "-" if value is None else format(value, fmt)


def table(head: list[str], rows: list[list[str]], cls: str = "", markup: bool = False) -> str:
    """A table of ``head`` (plain text, escaped here; HTML as given with ``markup``) over rows of ready cells
    (``td``)."""
    th = "".join(f"<th>{h if markup else esc(h)}</th>" for h in head)
    body = "".join("<tr>" + "".join(cells) + "</tr>" for cells in rows)
    return f'<table class="{cls}"><tr>{th}</tr>{body}</table>'


def td(text: object, cls: str = "", title: str | None = None) -> str:
    """A cell of escaped text; ``title`` shows on hover (the full text of a shortened cell)."""
    tip = f' title="{esc(title)}"' if title else ""
    return f'<td class="{cls}"{tip}>{esc(text)}</td>'


def swatch(solver: str) -> str:
    """The solver's name behind a square of its colour, as in every plot."""
    return f'<span class="sw" style="background:{colour(solver)}"></span>{esc(solver)}'


def png_uri(png: bytes) -> str:
    """A PNG as a ``data:`` URI, for an ``<img src>`` that needs no file beside the page."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")
