"""``stackx serve`` serves the files under its folder and nothing else; a bad port is one line, exit 2."""

from __future__ import annotations

import http.client
import os
import socket
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.conftest import Cli


Serving = Callable[..., int]


@pytest.fixture
def serving() -> Iterator[Serving]:
    """``serving(folder, **knobs)``: serve ``folder`` in a thread with ``FolderServer``'s knobs; its port."""
    from stackx.output.serve import FolderServer

    servers = []

    def start(folder: Path, **knobs: Any) -> int:
        server = FolderServer(folder, "127.0.0.1", 0, **knobs)
        threading.Thread(target=server.serve_forever, daemon=True).start()
        servers.append(server)
        return server.server_address[1]

    yield start
    for server in servers:
        server.shutdown()
        server.server_close()


@pytest.fixture
def site(tmp_path: Path, serving: Serving) -> tuple[Path, int]:
    """A served folder with a page, a sub-folder without a page, and links in and out; its port."""
    root = tmp_path / "site"
    (root / "sub").mkdir(parents=True)
    (root / "index.html").write_text("<p>player</p>")
    (root / "sub" / "a.txt").write_text("inside")
    secret = tmp_path / "secret.txt"
    secret.write_text("outside the folder")
    os.symlink(secret, root / "lnk")
    os.symlink("/etc", root / "etc")
    os.symlink("../secret.txt", root / "up")  # a relative link climbing out
    os.symlink("sub/a.txt", root / "inner")  # a link that stays inside is fine
    return root, serving(root)


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
    for path in ("/lnk", "/etc/hostname", "/etc/", "/sub/../lnk", "/%2e%2e/secret.txt", "/up"):
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


def test_a_folder_without_its_slash_is_redirected(site: tuple[Path, int]) -> None:
    _, port = site
    status, _, headers = _ask(port, "GET", "/sub?x=1")
    assert (status, headers["Location"]) == (301, "/sub/?x=1")
    status, _, headers = _ask(port, "GET", "//sub")
    assert (status, headers["Location"]) == (301, "/sub/")  # "//sub/" would name another host


@pytest.mark.parametrize("path", ["/%00", "/sub/a.txt%00.html", "/%0a", "/sub/%1b%5b31m", "/%c3", "/" + "a" * 1000,
                                  "/sub/" + "b" * 256, "/" + "a/" * 2100])
def test_a_bad_path_is_400_without_a_traceback(site: tuple[Path, int], capsys: pytest.CaptureFixture[str],
                                               path: str) -> None:
    _, port = site
    assert _ask(port, "GET", path)[0] == 400
    assert _ask(port, "GET", "/sub/a.txt")[:2] == (200, b"inside")  # and the server goes on
    assert "Traceback" not in capsys.readouterr().err


def test_a_long_name_within_the_limit_is_404(site: tuple[Path, int]) -> None:
    _, port = site
    assert _ask(port, "GET", "/" + "a" * 255)[0] == 404


def test_the_folder_replaced_by_a_link_to_the_root_changes_nothing(site: tuple[Path, int]) -> None:
    root, port = site
    root.rename(root.with_name("moved"))
    os.symlink("/", root)
    passwd = Path("/etc/passwd").read_bytes()
    for path in ("/etc/passwd", "/etc/hostname", "/etc/", "/root/", "/passwd"):
        status, body, _ = _ask(port, "GET", path)
        assert status in (403, 404), path
        assert passwd[:20] not in body, path
    assert _ask(port, "GET", "/")[:2] == (200, b"<p>player</p>")  # still the folder it opened at start
    assert _ask(port, "GET", "/sub/a.txt")[:2] == (200, b"inside")


def test_a_link_swapped_in_under_the_folder_is_not_followed(site: tuple[Path, int], tmp_path: Path) -> None:
    root, port = site
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "a.txt").write_text("outside the folder")
    (root / "sub").rename(root / "real")
    os.symlink(outside, root / "sub")  # a folder on the way replaced
    os.symlink(tmp_path / "secret.txt", root / "real" / "b.txt")
    (root / "index.html").unlink()
    os.symlink(tmp_path / "secret.txt", root / "index.html")  # the file itself replaced
    for path in ("/sub/a.txt", "/real/b.txt", "/", "/index.html"):
        status, body, _ = _ask(port, "GET", path)
        assert status in (403, 404) and b"outside the folder" not in body, path
    assert _ask(port, "GET", "/real/a.txt")[:2] == (200, b"inside")


def test_a_folder_swapped_for_a_link_while_serving_never_leads_out(site: tuple[Path, int], tmp_path: Path) -> None:
    """A folder on the way is swapped for a link out and back again as fast as it goes while files are asked
    for: every answer is the inside file or an error, never the outside one."""
    root, port = site
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "a.txt").write_text("outside the folder")
    done = threading.Event()

    def swap() -> None:
        while not done.is_set():
            (root / "sub").rename(root / "held")
            os.symlink(outside, root / "sub")
            (root / "sub").unlink()
            (root / "held").rename(root / "sub")

    swapper = threading.Thread(target=swap)
    swapper.start()
    try:
        answers = [_ask(port, "GET", "/sub/a.txt")[:2] for _ in range(400)]
    finally:
        done.set()
        swapper.join()
    assert {body for status, body in answers if status == 200} <= {b"inside"}
    assert all(status in (200, 403, 404) for status, _ in answers)


def _closed_by_server(sock: socket.socket) -> bool:
    """Whether the server closed ``sock`` without an answer (waiting at most the socket's timeout)."""
    try:
        return sock.recv(1024) == b""
    except ConnectionResetError:  # closed before it read what was sent
        return True
    except TimeoutError:
        return False


def _half_sent(port: int) -> socket.socket:
    """A connection that sends the start of a request and then nothing."""
    sock = socket.create_connection(("127.0.0.1", port), timeout=30)
    sock.sendall(b"GET /sub/a.txt HTTP/1.1\r\nHost: 127.0.0.1\r\n")
    return sock


def test_an_idle_connection_is_closed_after_the_timeout(tmp_path: Path, serving: Serving) -> None:
    (tmp_path / "index.html").write_text("<p>player</p>")
    port = serving(tmp_path, timeout=0.5)
    with _half_sent(port) as sock:
        assert _closed_by_server(sock), "a half-sent request kept open for 30 s (the server's timeout: 0.5 s)"


def test_idle_connections_hold_no_threads_and_a_request_is_still_answered(site: tuple[Path, int],
                                                                        serving: Serving) -> None:
    root, _ = site
    port = serving(root, timeout=60, workers=4)
    threads = threading.active_count()
    idle = [_half_sent(port) for _ in range(100)]
    try:
        assert _ask(port, "GET", "/sub/a.txt")[:2] == (200, b"inside")
        assert threading.active_count() <= threads + 4  # the workers at most, not a thread per connection
    finally:
        for sock in idle:
            sock.close()


def test_more_idle_connections_than_may_wait_push_out_the_oldest(site: tuple[Path, int], serving: Serving) -> None:
    root, _ = site
    port = serving(root, timeout=60, workers=2, waiting=8)
    idle = [_half_sent(port) for _ in range(50)]
    try:
        assert _ask(port, "GET", "/sub/a.txt")[:2] == (200, b"inside")
        assert _closed_by_server(idle[0])  # the oldest was dropped to let the others in
    finally:
        for sock in idle:
            sock.close()


def test_an_event_of_a_connection_pushed_out_in_the_same_round_is_passed_over(tmp_path: Path) -> None:
    # one round of events can hold a new connection and more bytes from the oldest waiting one: accepting the
    # new one drops the oldest, whose read event then finds it gone (the serving thread died of it once)
    from stackx.output.serve import FolderServer

    with FolderServer(tmp_path, "127.0.0.1", 0, timeout=60, waiting=1) as server:
        port = server.server_address[1]
        first = _half_sent(port)  # connected: in the listener's queue
        server._accept(server.socket)
        (oldest,) = server._waiting
        first.sendall(b"Accept: */*\r\n")  # its next bytes: a read event in the round below
        second = _half_sent(port)
        server._accept(server.socket)  # the round: the new connection first ...
        assert oldest not in server._waiting and len(server._waiting) == 1
        server._receive(oldest)  # ... then the dropped one's event: passed over
        assert len(server._waiting) == 1
        assert _closed_by_server(first)
        first.close()
        second.close()
