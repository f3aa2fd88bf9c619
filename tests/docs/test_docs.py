"""The documentation as a reader meets it: every relative link resolves, and every block marked runnable runs.

The convention (written down in docs/architecture.md, "Examples that run"): a fenced block whose info string is
``bash run`` or ``python run`` is run; ``python file=PATH`` (or any language with ``file=PATH``) is written to
``PATH`` before the blocks after it run. Blocks of one page run in order, in one scratch folder holding copies of
``configs/`` and ``plugins/``, with ``stackx`` and ``python3`` on the PATH running this checkout. Other blocks
(``yaml``, plain ``bash``: long benchmarks, servers, installs) are shown, not run.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.conftest import REPO
from tests.limits import hang_limit

PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
FENCE = re.compile(r"^```([^\n]*)\n(.*?)^```[ \t]*$", re.S | re.M)
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")


@dataclass(frozen=True)
class Block:
    """A fenced code block: its language, the words after it, its text and the line it starts on."""
    language: str
    words: tuple[str, ...]
    text: str
    line: int

    @property
    def runs(self) -> bool:
        return "run" in self.words

    @property
    def file(self) -> str | None:
        return next((w.removeprefix("file=") for w in self.words if w.startswith("file=")), None)


def blocks(text: str) -> list[Block]:
    found = []
    for m in FENCE.finditer(text):
        language, *words = m.group(1).split() or [""]
        found.append(Block(language, tuple(words), m.group(2), text.count("\n", 0, m.start()) + 1))
    return found


def prose(text: str) -> str:
    """The text without fenced blocks and inline code, where links are not links."""
    return re.sub(r"`[^`\n]*`", "", FENCE.sub("", text))


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors(page: Path) -> set[str]:
    seen: dict[str, int] = {}
    out = set()
    for line in FENCE.sub("", page.read_text()).splitlines():
        if m := re.match(r"#{1,6} (.+)", line):
            base = slug(m.group(1))
            n = seen.get(base, 0)
            seen[base] = n + 1
            out.add(base if n == 0 else f"{base}-{n}")
    return out


def _name(page: Path) -> str:
    return page.relative_to(REPO).as_posix()


def test_the_slug_is_githubs() -> None:
    assert slug("Past one machine: `--executor dask`") == "past-one-machine---executor-dask"
    assert slug("The `bench:` section") == "the-bench-section"
    assert slug("A million variants of scene 06") == "a-million-variants-of-scene-06"


@pytest.mark.parametrize("page", PAGES, ids=_name)
def test_every_relative_link_resolves(page: Path) -> None:
    broken = []
    for target in LINK.findall(prose(page.read_text())):
        if re.match(r"[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
            continue
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.exists():
            broken.append(f"{target}: no such file")
        elif anchor and (dest.suffix != ".md" or anchor not in anchors(dest)):
            broken.append(f"{target}: no heading with anchor #{anchor}")
    assert not broken, f"{_name(page)}: " + "; ".join(broken)


def test_the_link_check_sees_a_broken_link(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    page.write_text("# Title\n\n[ok](#title) [gone](missing.md) [bad](#nowhere)\n\n```\n[not a link](x.md)\n```\n")
    targets = LINK.findall(prose(page.read_text()))
    assert targets == ["#title", "missing.md", "#nowhere"]
    assert anchors(page) == {"title"}


@pytest.mark.parametrize("page", sorted((REPO / "docs").glob("*.md")), ids=_name)
def test_every_page_opens_with_what_it_teaches_and_is_linked_from_the_readme(page: Path) -> None:
    paragraphs = [p for p in page.read_text().split("\n\n") if p.strip()]
    assert paragraphs[0].startswith("# ") and paragraphs[1].startswith("What you learn here:"), _name(page)
    assert f"({_name(page)})" in (REPO / "README.md").read_text()


def test_the_readme_starts_with_the_two_commands_and_the_test_command_is_cis() -> None:
    first = blocks((REPO / "README.md").read_text())[0]
    lines = [line.split("#")[0].strip() for line in first.text.splitlines()]
    assert len(lines) == 2 and lines[0].endswith("&& stackx run configs/")
    assert lines[1].endswith("&& python3 -m pytest")
    assert lines[0].split("&&")[0] == lines[1].split("&&")[0]  # one install, the same extras
    ci = [line.strip() for line in (REPO / ".ci/run").read_text().splitlines()]
    assert lines[1] in ci, ".ci/run must run the README's test command as written"


def _scratch(folder: Path) -> dict[str, str]:
    """A folder like a checkout's root for the blocks to run in, and the environment they run with."""
    for name in ("configs", "plugins"):
        shutil.copytree(REPO / name, folder / name, ignore=shutil.ignore_patterns("__pycache__"))
    bin_dir = folder / ".bin"
    bin_dir.mkdir()
    for name, args in (("stackx", "-m stackx"), ("python3", "")):
        shim = bin_dir / name
        shim.write_text(f'#!/bin/sh\nexec "{sys.executable}" {args} "$@"\n')
        shim.chmod(0o755)
    path = os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p)
    return {**os.environ, "PYTHONPATH": path, "PATH": f"{bin_dir}{os.pathsep}{os.environ['PATH']}"}


RUNNABLE = [p for p in PAGES if any(b.runs or b.file for b in blocks(p.read_text()))]


@pytest.mark.parametrize("page", RUNNABLE, ids=_name)
def test_runnable_blocks_run(page: Path, tmp_path: Path) -> None:
    env = _scratch(tmp_path)
    for block in blocks(page.read_text()):
        where = f"{_name(page)}:{block.line}"
        if block.file:
            target = tmp_path / block.file
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(block.text)
        elif block.runs:
            if block.language == "bash":
                command = ["bash", "-euo", "pipefail", "-c", block.text]
            elif block.language == "python":
                command = [sys.executable, "-c", block.text]
            else:
                pytest.fail(f"{where}: cannot run a {block.language!r} block")
            done = subprocess.run(command, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=hang_limit(600))
            assert done.returncode == 0, f"{where} failed:\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}"
