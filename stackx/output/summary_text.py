"""A plugin's one-line summary for ``stackx plugins``: the first sentence of its docstring, whole, as plain text.

A docstring's first line is often half a sentence (the sentence goes on over the next line), and its names are
marked up for the reference docs (double backticks, roles such as ``:class:``). The summary joins the first
paragraph's lines, keeps it up to the first sentence end, and drops the markup; the table then wraps it at
spaces, so no word is cut.
"""

from __future__ import annotations

import re

# A sentence ends at ".", "!" or "?" followed by the end of the paragraph or by a space and a capital letter:
# "et al. 2019", "e.g. the" and "2.3" do not end one.
_SENTENCE_END = re.compile(r"[.!?](?=\s+[A-Z]|\s*$)")
_ROLE = re.compile(r":[a-z]+(?::[a-z]+)?:`~?([^`]+)`")  # :class:`~stackx.Foo` -> stackx.Foo
_LITERAL = re.compile(r"``([^`]+)``")  # ``iterations`` -> iterations


def plain(text: str) -> str:
    """The text without reStructuredText's inline markup: literals and roles as the names they mark."""
    return _LITERAL.sub(r"\1", _ROLE.sub(r"\1", text))


def first_sentence(doc: str | None) -> str:
    """The first sentence of a docstring's first paragraph, its lines joined, as plain text ('' for none).

    A paragraph without a sentence end is returned whole, so nothing is cut mid-way."""
    paragraph = re.split(r"\n\s*\n", (doc or "").strip(), maxsplit=1)[0]
    joined = " ".join(line.strip() for line in paragraph.splitlines() if line.strip())
    end = _SENTENCE_END.search(joined)
    return plain(joined[: end.end()] if end else joined)
