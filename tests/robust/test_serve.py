"""``stackx serve`` serves the files under its folder and nothing else; a bad port is one line, exit 2."""

from __future__ import annotations

import functools
import http.client
import os
import threading
from collections.abc import Iterator
from http.server import ThreadingHTTPServer
from pathlib import Path

import pytest

from tests.conftest import Cli


@pytest.fixture
def site(tmp_path: Path) -> Iterator[tuple[Path, int]]:
    """A served folder with a page, a sub-folder without a page, and links in and out; its port."""
    from stackx.output.serve import FolderHandler

    root = tmp_path / "site"
    (root / "sub").mkdir(parents=True)
    (root / "index.html").write_text("<p>player</p>")
    (root / "sub" / "a.txt").write_text("inside")
    secret = tmp_path / "secret.txt"
    secret.write_text("outside the folder")
    os.symlink(secret, root / "lnk")
    os.symlink("/etc", root / "etc")
    os.symlink("sub/a.txt", root / "inner")  # a link that stays inside is fine
    server = ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(FolderHandler, directory=str(root)))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield root, server.server_address[1]
    finally:
        server.shutdown()
        server.server_close()


def _ask(port: int, method: str, path: str) -> tuple[int, bytes, dict[str, str]]:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    try:
        conn.request(method, path)
        response = conn.getresponse()
        return response.status, response.read(), dict(response.getheaders())
    finally:
        conn.close()


def test_files_under_the_folder_are_served(site: tuple[Path, int]) -> None:
    _, port = site
    assert _ask(port, "GET", "/sub/a.txt")[:2] == (200, b"inside")
    assert _ask(port, "GET", "/inner")[:2] == (200, b"inside")
    assert _ask(port, "GET", "/")[:2] == (200, b"<p>player</p>")
    status, body, headers = _ask(port, "HEAD", "/sub/a.txt")
    assert (status, body, headers["Content-Length"]) == (200, b"", "6")


def test_a_link_out_of_the_folder_is_refused(site: tuple[Path, int]) -> None:
    _, port = site
    for path in ("/lnk", "/etc/hostname", "/etc/", "/sub/../lnk", "/%2e%2e/secret.txt"):
        status, body, _ = _ask(port, "GET", path)
        assert status in (403, 404), path
        assert b"outside the folder" not in body and b"hostname" not in body, path


def test_no_directory_listing(site: tuple[Path, int]) -> None:
    _, port = site
    status, body, _ = _ask(port, "GET", "/sub/")
    assert status == 404 and b"a.txt" not in body


def test_only_get_and_head(site: tuple[Path, int]) -> None:
    _, port = site
    for method in ("POST", "PUT", "DELETE", "OPTIONS"):
        status, _, headers = _ask(port, method, "/sub/a.txt")
        assert status == 405, method
        assert headers["Allow"] == "GET, HEAD"


@pytest.mark.parametrize("port", ["99999", "-1", "65536"])
def test_a_port_out_of_range_is_one_line(cli: Cli, tmp_path: Path, port: str) -> None:
    done = cli("serve", tmp_path, "--port", port, timeout=30)
    assert done.returncode == 2
    assert done.stderr.strip() == f"error: <input>: --port: a TCP port is 1 to 65535 (or 0 for any free port), " \
                                  f"not {port}"
