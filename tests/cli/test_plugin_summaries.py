"""``stackx plugins`` shows each plugin's first sentence whole, as plain text: never half a sentence cut at the
docstring's first line break, never reStructuredText's double backticks."""

from __future__ import annotations

import re

import pytest

from stackx.output.summary_text import first_sentence
from tests.conftest import Cli


def _about_cells(table: str) -> dict[str, str]:
    """Each row's name and its "about" cell, the cell's wrapped lines joined."""
    rows: list[list[str]] = []
    for line in table.splitlines():
        if not line.startswith("│"):
            continue
        cells = [c.strip() for c in line.strip("│").split("│")]
        if cells[1]:
            rows.append(cells)
        else:  # a wrapped continuation of the row above
            rows[-1] = [f"{a} {b}".strip() for a, b in zip(rows[-1], cells)]
    return {cells[1]: cells[3] for cells in rows}


def test_every_plugin_summary_is_a_whole_sentence_without_markup(cli: Cli) -> None:
    done = cli("plugins", env={"COLUMNS": "100"})
    assert done.returncode == 0, done.stderr
    about = _about_cells(done.stdout)
    assert {"pgs", "exact", "planar-exact", "planar-xpbd", "sor", "column"} <= about.keys()
    for name, text in about.items():
        if text.startswith("unavailable:"):
            continue
        assert re.search(r"[.!?]$", text), f"{name}: {text!r} stops mid-sentence"
        assert "``" not in text, f"{name}: {text!r}"


def test_a_sentence_over_two_lines_is_joined() -> None:
    doc = """The velocity problem of every step solved to a residual: the limit of the planar
    iterative solvers' iterations. More detail follows here.

    Another paragraph."""
    assert first_sentence(doc) == ("The velocity problem of every step solved to a residual: the limit of the "
                                   "planar iterative solvers' iterations.")


@pytest.mark.parametrize("doc, summary", [
    ("Small steps (Macklin et al. 2019). Then more.", "Small steps (Macklin et al. 2019)."),
    ("Cheap passes, e.g. the lab's. Then more.", "Cheap passes, e.g. the lab's."),
    ("Box2D 2.3 (pybox2d): one call per step.\n\nDetails.", "Box2D 2.3 (pybox2d): one call per step."),
    ("Box ``i`` rests on box ``i - 1``.", "Box i rests on box i - 1."),
    ("Made by :class:`~stackx.solvers.PGS` for ``omega``.", "Made by stackx.solvers.PGS for omega."),
    ("No sentence end at all\n  over two lines", "No sentence end at all over two lines"),
    (None, ""),
])
def test_the_first_sentence_whole_and_plain(doc: str | None, summary: str) -> None:
    assert first_sentence(doc) == summary
