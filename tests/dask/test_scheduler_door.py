"""``--scheduler`` at something that is not a Dask scheduler: one line, exit 2, nothing written, in bounded time.

Fake servers listen on 127.0.0.1 in this process, for the length of one test: one answers like an HTTP server
(nothing until it has a request, then ``400 Bad Request``), one speaks first the way SSH or SMTP servers do,
one accepts and never says a word, one accepts and hangs up. The connect and greeting time limit is set to
1 s through Dask's own variable, so each refusal takes about a second.
"""

from __future__ import annotations

import socket
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from tests.conftest import CONFIGS, Cli

pytest.importorskip("distributed")

Answer = Callable[[socket.socket], None]


def _http(conn: socket.socket) -> None:
    conn.recv(65536)
    conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")


def _banner(conn: socket.socket) -> None:
    conn.sendall(b"SSH-2.0-OpenSSH_9.2\r\n")
    conn.recv(65536)


def _silent(conn: socket.socket) -> None:
    conn.recv(65536)


def _hang_up(conn: socket.socket) -> None:
    conn.close()


@contextmanager
def fake_server(answer: Answer) -> Iterator[int]:
    """A server on 127.0.0.1 that treats each connection with ``answer``; its port. Stopped on leaving."""
    listener = socket.create_server(("127.0.0.1", 0))
    listener.settimeout(0.2)
    stop = threading.Event()
    taken: list[socket.socket] = []

    def serve() -> None:
        while not stop.is_set():
            try:
                conn, _ = listener.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            conn.settimeout(30)
            taken.append(conn)
            threading.Thread(target=_quietly, args=(answer, conn), daemon=True).start()

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield listener.getsockname()[1]
    finally:
        stop.set()
        thread.join(timeout=5)
        listener.close()
        for conn in taken:
            conn.close()


def _quietly(answer: Answer, conn: socket.socket) -> None:
    try:
        answer(conn)
    except OSError:
        pass


@pytest.mark.parametrize("answer, says", [
    (_http, "the server accepted the connection but sent nothing in 1 s, where a Dask scheduler greets at once: "
            "not a Dask scheduler (or a very slow one)"),
    (_silent, "the server accepted the connection but sent nothing in 1 s, where a Dask scheduler greets at once: "
              "not a Dask scheduler (or a very slow one)"),
    (_banner, "the server there does not speak Dask's protocol (it sent 'SSH-2.0-OpenSSH_9.2\\r\\n'...): not a "
              "Dask scheduler"),
    (_hang_up, "the server closed the connection without a greeting: not a Dask scheduler"),
])
def test_a_stranger_on_the_scheduler_port_is_one_line(cli: Cli, tmp_path: Path, answer: Answer, says: str) -> None:
    out = tmp_path / "out"
    with fake_server(answer) as port:
        address = f"tcp://127.0.0.1:{port}"
        done = cli("run", CONFIGS / "03-sink.yaml", "--out", out, "--executor", "dask", "--scheduler", address,
                   env={"DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT": "1s"}, timeout=60)
    assert (done.returncode, done.stderr) == (2, f"error: <input>: --scheduler {address}: {says}\n")
    assert not out.exists()


def test_nothing_listening_is_one_line(cli: Cli, tmp_path: Path) -> None:
    with socket.create_server(("127.0.0.1", 0)) as taken:
        port = taken.getsockname()[1]
    done = cli("run", CONFIGS / "03-sink.yaml", "--out", tmp_path / "out", "--executor", "dask",
               "--scheduler", f"tcp://127.0.0.1:{port}", env={"DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT": "1s"},
               timeout=60)
    assert done.returncode == 2
    assert done.stderr == f"error: <input>: --scheduler tcp://127.0.0.1:{port}: no Dask scheduler answered: " \
                          f"Connection refused\n"
