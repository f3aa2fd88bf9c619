"""``stackx serve`` prints the URL of every HTML page it serves, and each answers 200: a bench folder has no
``index.html``, so its address alone is a 404."""

from __future__ import annotations

import contextlib
import http.client
import os
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from urllib.parse import urlsplit

import pytest

from tests.conftest import REPO


def _status(url: str) -> int:
    parts = urlsplit(url)
    conn = http.client.HTTPConnection(parts.hostname, parts.port, timeout=30)
    try:
        conn.request("GET", parts.path)
        response = conn.getresponse()
        response.read()
        return response.status
    finally:
        conn.close()


@contextlib.contextmanager
def _serve(folder: Path) -> Iterator[tuple[str, str]]:
    """``stackx serve FOLDER --port 0``: (its address, all it printed when it started)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p)}
    server = subprocess.Popen([sys.executable, "-m", "stackx", "serve", str(folder), "--port", "0"], cwd=REPO,
                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, bufsize=0, env=env)
    try:
        assert server.stdout is not None
        first = server.stdout.readline().decode()  # unbuffered: reads up to the first line end, no further
        base = re.search(r"http://\S+?/", first)
        assert base, first
        _status(base.group(0))  # answered: it serves, so all it printed before serving is in the pipe
        os.set_blocking(server.stdout.fileno(), False)
        rest = server.stdout.read() or b""
        yield base.group(0), first + rest.decode()
    finally:
        server.terminate()
        server.wait(timeout=30)


@pytest.fixture
def pages(tmp_path: Path) -> Path:
    """A folder like a bench's (a report, no index.html) with a player in a sub-folder and pictures."""
    folder = tmp_path / "out"
    (folder / "runs" / "deep").mkdir(parents=True)
    (folder / "report.html").write_text("<p>report</p>")
    (folder / "card house.html").write_text("<p>player</p>")
    (folder / "runs" / "index.html").write_text("<p>runs</p>")
    (folder / "runs" / "deep" / "stack.html").write_text("<p>stack</p>")
    (folder / "f00.png").write_bytes(b"png")
    return folder


def test_every_page_is_printed_and_answers(pages: Path) -> None:
    with _serve(pages) as (base, printed):
        urls = re.findall(r"^\s+(http://\S+)$", printed, re.M)
        assert sorted(urlsplit(u).path for u in urls) == ["/card%20house.html", "/report.html", "/runs/",
                                                          "/runs/deep/stack.html"], printed
        assert all(url.startswith(base) for url in urls)
        assert {url: _status(url) for url in urls} == {url: 200 for url in urls}
        assert _status(base) == 404 and "no page at /" in printed.splitlines()[0]


def test_a_run_folder_prints_its_player(tmp_path: Path) -> None:
    (tmp_path / "index.html").write_text("<p>player</p>")
    with _serve(tmp_path) as (base, printed):
        urls = re.findall(r"^\s+(http://\S+)$", printed, re.M)
        assert urls == [base] and _status(base) == 200
        assert "no page" not in printed


def test_a_folder_without_pages_says_so(tmp_path: Path) -> None:
    (tmp_path / "a.txt").write_text("x")
    with _serve(tmp_path) as (_, printed):
        assert not re.findall(r"^\s+http://", printed, re.M)
        assert "no HTML page" in printed
