"""Attacks on ``stackx serve X``: odd paths, idle connections, and X or a folder under it swapped for a link.

The contract (docs/outputs.md): ``serve`` resolves its folder once and opens files relative to it without
following links; bad paths get 400 or 404, never a traceback in its log; idle connections time out and its
threads are bounded.
"""

from __future__ import annotations

import ctypes
import os
import re
import resource
import signal
import socket
import subprocess
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from benchmarks.attacks.kit import Outcome, environ, stackx_argv

SECRET = Path("/etc/passwd")
IDLE = 800
THREADS_BOUND = 128
"""The most threads the server may hold while ``IDLE`` half-sent requests wait (it held one per connection)."""
IDLE_WAIT_S = 120.0
"""How long the idle connections may stay open before the server closes them."""
RACE_S = 5.0
RACE_REQUESTS = 3000


@dataclass
class Server:
    """A running ``stackx serve``: its process, port and log (stderr, where tracebacks would show)."""

    proc: subprocess.Popen[bytes]
    port: int
    log: Path

    def threads(self) -> int:
        try:
            text = Path(f"/proc/{self.proc.pid}/status").read_text()
        except OSError:
            return 0
        found = re.search(r"^Threads:\s+(\d+)", text, re.M)
        return int(found.group(1)) if found else 0

    def traceback(self) -> bool:
        return "Traceback" in self.log.read_text(errors="replace")


@contextmanager
def serving(folder: Path, root: Path) -> Iterator[Server]:
    """``stackx serve folder --port 0`` until the block ends (then stopped, whatever happened)."""
    log = root / "serve.log"
    out = root / "serve.out"
    with open(log, "wb") as err, open(out, "wb") as said:
        proc = subprocess.Popen(stackx_argv("serve", folder, "--port", 0), cwd=root, env=environ(),
                                stdin=subprocess.DEVNULL, stdout=said, stderr=err, start_new_session=True)
    try:
        port = 0
        deadline = time.monotonic() + 60
        while not port and time.monotonic() < deadline and proc.poll() is None:
            found = re.search(r"http://[^:]+:(\d+)/", out.read_text(errors="replace"))
            port = int(found.group(1)) if found else 0
            time.sleep(0.05)
        if not port:
            raise RuntimeError(f"stackx serve did not start: {log.read_text(errors='replace')[-300:]}")
        yield Server(proc, port, log)
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.wait(30)


def ask(port: int, target: str, timeout: float = 10.0) -> tuple[int, bytes]:
    """One raw GET of ``target`` (sent as is, not quoted): the status (0: no answer) and the whole reply."""
    with socket.create_connection(("127.0.0.1", port), timeout=timeout) as sock:
        sock.sendall(f"GET {target} HTTP/1.0\r\nHost: x\r\n\r\n".encode("latin-1"))
        reply = b""
        try:
            while chunk := sock.recv(65536):
                reply += chunk
        except OSError:
            pass
    found = re.match(rb"HTTP/\d\.\d (\d{3})", reply)
    return (int(found.group(1)) if found else 0), reply


def _site(root: Path) -> Path:
    x = root / "X"
    (x / "sub").mkdir(parents=True)
    (x / "index.html").write_text("<p>player</p>")
    (x / "sub" / "a.txt").write_text("inside")
    (x / "sub" / "passwd").write_text("inside, not the system's")
    return x


def bad_paths(root: Path) -> Outcome:
    """``/%00``, a NUL byte, a 1,000-character path part, a 5,000-character path: 400 or 404, never a traceback
    in the server's log, and the server still answers."""
    x = _site(root)
    targets = {"/%00": "/%00", "/a%00b": "/a%00b", "1,000-char part": "/" + "p" * 1000,
               "5,000-char path": "/" + "/".join(["q" * 200] * 25), "/..%2f..%2fetc/passwd": "/..%2f..%2fetc/passwd"}
    with serving(x, root) as server:
        statuses = {label: ask(server.port, target)[0] for label, target in targets.items()}
        alive = ask(server.port, "/sub/a.txt")[0]
        traced = server.traceback()
    bad = [f"{label} -> {code}" for label, code in statuses.items() if code not in (400, 403, 404)]
    figure = ", ".join(f"{label} {code}" for label, code in statuses.items()) + f"; then /sub/a.txt {alive}"
    wrong = bad + (["a traceback in the log"] if traced else []) + ([] if alive == 200 else ["server stopped"])
    return Outcome(not wrong, figure + "".join(f"; {w}" for w in wrong))


def _half_sent(port: int, n: int) -> list[socket.socket]:
    """Up to ``n`` connections each holding a request cut before its blank line (the server waits for it)."""
    held: list[socket.socket] = []
    refused = 0
    for _ in range(n):
        try:
            sock = socket.create_connection(("127.0.0.1", port), timeout=1.0)
            sock.sendall(b"GET /index.html HTTP/1.1\r\nHost: x\r\n")
            held.append(sock)
            refused = 0
        except OSError:
            refused += 1
            if refused >= 5:  # the server is not taking more: that bounds it too
                break
    return held


def _closed_by_server(socks: list[socket.socket], within: float) -> int:
    """How many of ``socks`` the server closes (or answers) within ``within`` seconds."""
    deadline = time.monotonic() + within
    open_ = list(socks)
    while open_ and time.monotonic() < deadline:
        still = []
        for sock in open_:
            sock.setblocking(False)
            try:
                sock.recv(1024)  # b'' (closed) or an answer such as 408: the server let go either way
            except BlockingIOError:
                still.append(sock)
            except OSError:
                pass
        open_ = still
        time.sleep(0.5)
    return len(socks) - len(open_)


def idle_connections(root: Path) -> Outcome:
    """800 half-sent requests left idle: the server's threads stay bounded, a fresh request is still answered,
    and the idle connections are closed by the server."""
    x = _site(root)
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (max(soft, min(hard, 4 * IDLE)), hard))
    held: list[socket.socket] = []
    try:
        with serving(x, root) as server:
            base = server.threads()
            held = _half_sent(server.port, IDLE)
            time.sleep(1.0)
            peak = server.threads()
            start = time.monotonic()
            try:
                fresh = ask(server.port, "/sub/a.txt", timeout=IDLE_WAIT_S)[0]
            except OSError:
                fresh = 0
            fresh_s = time.monotonic() - start
            closed = _closed_by_server(held, IDLE_WAIT_S)
            traced = server.traceback()
    finally:
        for sock in held:
            sock.close()
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))
    figure = (f"{len(held)} idle held, threads {base} -> {peak}, a fresh request {fresh} in {fresh_s:.1f} s, "
              f"{closed} of {len(held)} closed by the server within {IDLE_WAIT_S:g} s")
    wrong = ([f"over {THREADS_BOUND} threads"] if peak > THREADS_BOUND else []) + \
            ([] if fresh == 200 else ["the fresh request was not answered"]) + \
            ([] if closed == len(held) else ["idle connections never time out"]) + \
            (["a traceback in the log"] if traced else [])
    return Outcome(not wrong, figure + "".join(f"; {w}" for w in wrong))


def root_swap(root: Path) -> Outcome:
    """X renamed away and replaced by a link to ``/`` while it is served: ``/etc/passwd`` is not served."""
    x = _site(root)
    secret = SECRET.read_bytes()
    with serving(x, root) as server:
        before = ask(server.port, "/sub/a.txt")[0]
        os.rename(x, root / "X.away")
        os.symlink("/", x)
        code, reply = ask(server.port, str(SECRET))
        traced = server.traceback()
    leaked = secret in reply
    figure = f"before the swap /sub/a.txt {before}; after it {SECRET} {code}" + (", served" if leaked else "")
    return Outcome(not leaked and not traced and before == 200, figure + ("; a traceback" if traced else ""))


_libc = ctypes.CDLL(None, use_errno=True)


def _exchange(a: Path, b: Path) -> None:
    """Swap two names atomically (``renameat2`` with ``RENAME_EXCHANGE``)."""
    if _libc.renameat2(-100, os.fsencode(a), -100, os.fsencode(b), 2) != 0:
        raise OSError(ctypes.get_errno(), os.strerror(ctypes.get_errno()), str(a))


def link_race(root: Path) -> Outcome:
    """While requests for ``/sub/passwd`` and ``/passwd`` run, ``sub`` is swapped again and again with a link to
    ``/etc`` and ``passwd`` with a link to ``/etc/passwd``: no answer holds the system's file."""
    x = _site(root)
    (x / "passwd").write_text("inside, not the system's")
    os.symlink("/etc", x / ".sub-link")
    os.symlink(SECRET, x / ".passwd-link")
    secret = SECRET.read_bytes()
    halt = threading.Event()

    def flip() -> None:
        while not halt.is_set():
            for a, b in ((x / "sub", x / ".sub-link"), (x / "passwd", x / ".passwd-link")):
                _exchange(a, b)

    flipper = threading.Thread(target=flip, daemon=True)
    leaked = asked = 0
    with serving(x, root) as server:
        flipper.start()
        try:
            deadline = time.monotonic() + RACE_S
            while asked < RACE_REQUESTS and time.monotonic() < deadline:
                for target in ("/sub/passwd", "/passwd"):
                    _, reply = ask(server.port, target)
                    asked += 1
                    leaked += secret in reply
        finally:
            halt.set()
            flipper.join(10)
        traced = server.traceback()
    figure = f"the system's file served in {leaked} of {asked} requests"
    return Outcome(leaked == 0 and not traced and asked > 0, figure + ("; a traceback" if traced else ""))
