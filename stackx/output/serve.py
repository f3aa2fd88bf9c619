"""A small static file server for previewing an output folder's HTML player.

It serves the files under its folder and nothing else, whatever happens to the folder while it serves:
- The folder is opened once, at start, and every file is opened from that open folder one name at a time
  (``os.open`` with ``dir_fd`` and ``O_NOFOLLOW``), so the kernel never follows a link: replacing the folder, or
  any folder or file under it, by a link afterwards cannot lead a request out. A link under the folder is read
  by the server itself and followed only while it stays inside (a relative target that never climbs above the
  folder, at most ``MAX_LINKS`` per request): a link out (absolute, or climbing out) gets 403.
- A request path is decoded once; a NUL or another control character, a name over ``NAME_MAX`` bytes, a path
  over ``PATH_MAX`` bytes or one that is not UTF-8 gets 400; a missing file 404; a folder answers with its
  ``index.html`` (never a listing); methods other than GET and HEAD get 405. Errors are one log line, never a
  traceback.
- Connections cost threads only while they are answered: one thread waits for every connection's request head
  (``timeout`` seconds at most, then the connection is dropped), and only a complete head is handed to one of
  ``workers`` threads. At most ``waiting`` connections wait at once: a new one pushes out the oldest, so a flood
  of idle connections cannot keep a real request out for long.
"""

from __future__ import annotations

import email.utils
import errno
import io
import os
import selectors
import socket
import stat
import sys
import threading
import time
import unicodedata
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from http import HTTPStatus
from http.server import SimpleHTTPRequestHandler
from pathlib import Path
from typing import Any, BinaryIO
from urllib.parse import quote, unquote_to_bytes, urlsplit

ALLOWED = ("GET", "HEAD")
NAME_MAX = 255  # bytes in one name (Linux NAME_MAX): a longer one cannot exist, so it is a bad request
PATH_MAX = 4096  # bytes in a whole path (Linux PATH_MAX)
MAX_LINKS = 16  # links followed for one request (the kernel allows 40): a deeper chain is refused, not walked
MAX_DEPTH = 256  # folders open at once while walking one path
TIMEOUT = 10.0
"""Seconds a connection may take to send its request head, and each send of the answer may take: longer, it is
dropped. Shorter frees a slow client's socket sooner; a client on a slow link needs more."""
WORKERS = 32
"""Threads answering requests at once: more answer more large files in parallel, at a thread (stack, file) each;
requests beyond wait their turn (each answer is bounded by ``TIMEOUT`` per send)."""
WAITING = 256
"""Connections waiting for their request head at once (a socket each, no thread); beyond, the oldest is dropped.
More lets more slow clients start at once; fewer means a flood of idle connections pushes a real one out sooner
(only when that many newer ones arrive before it has sent its request)."""
HEAD_MAX = 65536  # bytes of request line and headers: a longer head is refused with 431
CONTROL = {c: f"\\x{c:02x}" for c in (*range(0x20), *range(0x7F, 0xA0))}  # escaped in log lines


class Refused(Exception):
    """A request answered with an error status: ``status`` and why, in words."""

    def __init__(self, status: HTTPStatus, why: str) -> None:
        super().__init__(why)
        self.status, self.why = status, why


def asked_names(target: str) -> tuple[list[str], bool]:
    """The names to walk from the served folder for a request target, and whether it asks for a folder (it ends
    with ``/``). Percent-escapes are decoded once; ``.`` and ``..`` are taken as a URL takes them (``..`` never
    above the top). Raises ``Refused`` (400) for a path that cannot name a file here."""
    if target.startswith(("http://", "https://")):  # the absolute form a proxy sends
        target = urlsplit(target).path or "/"
    path = target.split("?", 1)[0].split("#", 1)[0]
    if not path.startswith("/"):
        raise Refused(HTTPStatus.BAD_REQUEST, "a path begins with /")
    try:
        raw = unquote_to_bytes(path.encode("latin-1"))  # http.server decodes the request line as Latin-1
        text = raw.decode("utf-8")
    except UnicodeError:
        raise Refused(HTTPStatus.BAD_REQUEST, "the path is not UTF-8") from None
    if len(raw) > PATH_MAX:
        raise Refused(HTTPStatus.BAD_REQUEST, f"the path is longer than {PATH_MAX} bytes")
    if any(unicodedata.category(ch) == "Cc" for ch in text):
        raise Refused(HTTPStatus.BAD_REQUEST, "the path holds a NUL or another control character")
    names: list[str] = []
    parts = text.split("/")
    for part in parts:
        if len(part.encode()) > NAME_MAX:
            raise Refused(HTTPStatus.BAD_REQUEST, f"a name in the path is longer than {NAME_MAX} bytes")
        if part == "..":
            names = names[:-1]
        elif part not in ("", "."):
            names.append(part)
    return names, parts[-1] in ("", ".", "..")


def _failed(exc: OSError) -> Refused:
    """The answer to a failed open or stat of a name: 403 for a permission, 404 for anything else."""
    if exc.errno in (errno.EACCES, errno.EPERM):
        return Refused(HTTPStatus.FORBIDDEN, "not readable")
    return Refused(HTTPStatus.NOT_FOUND, "File not found")


def _step(name: str, here: int) -> tuple[int | None, str | None]:
    """Open ``name`` in the open folder ``here`` without following a link: (an fd, None) for a folder or a
    regular file, (None, its target) for a link. Raises ``Refused`` for anything else, or one gone meanwhile."""
    try:
        info = os.stat(name, dir_fd=here, follow_symlinks=False)
        if stat.S_ISLNK(info.st_mode):
            return None, os.readlink(name, dir_fd=here)
        if not (stat.S_ISDIR(info.st_mode) or stat.S_ISREG(info.st_mode)):
            raise Refused(HTTPStatus.NOT_FOUND, "not a file")  # a FIFO or a device is never opened
        kind = os.O_DIRECTORY if stat.S_ISDIR(info.st_mode) else os.O_NONBLOCK
        fd = os.open(name, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC | kind, dir_fd=here)
    except OSError as exc:
        raise _failed(exc) from None
    if stat.S_IFMT(os.fstat(fd).st_mode) != stat.S_IFMT(info.st_mode):  # swapped since the stat
        os.close(fd)
        raise Refused(HTTPStatus.NOT_FOUND, "File not found")
    return fd, None


def open_beneath(root: int, names: list[str]) -> tuple[int, os.stat_result]:
    """Open the entry ``names`` lead to from the open folder ``root``, never leaving it: every name is opened
    from the folder before it with ``O_NOFOLLOW``, a link's target is walked the same way (``..`` steps back
    through the folders this walk opened, never above ``root``), and a link out gets 403. Returns an fd the
    caller closes, and its stat."""
    todo, opened, links = deque(names), [root], 0  # opened: the folders walked into, root first
    try:
        while todo:
            name = todo.popleft()
            if not stat.S_ISDIR(os.fstat(opened[-1]).st_mode) or len(opened) > MAX_DEPTH:
                raise Refused(HTTPStatus.NOT_FOUND, "File not found")  # a file asked for as a folder
            if name in ("", "."):
                continue
            if name == "..":
                if len(opened) == 1:
                    raise Refused(HTTPStatus.FORBIDDEN, "a link leads out of the served folder")
                os.close(opened.pop())
                continue
            fd, target = _step(name, opened[-1])
            if fd is not None:
                opened.append(fd)
                continue
            links += 1
            if links > MAX_LINKS:
                raise Refused(HTTPStatus.FORBIDDEN, f"more than {MAX_LINKS} links on the way")
            if target is None or target.startswith("/"):
                raise Refused(HTTPStatus.FORBIDDEN, "a link leads out of the served folder")
            todo.extendleft(reversed(target.split("/")))
        fd = opened.pop() if len(opened) > 1 else os.dup(root)
        return fd, os.fstat(fd)
    finally:
        for fd in opened[1:]:
            os.close(fd)


class FolderHandler(SimpleHTTPRequestHandler):
    """Answers one request of a ``FolderServer`` from its open folder, without caching (a re-run is seen on
    reload). ``head``: the request head the server has already read."""

    server: FolderServer  # type: ignore[assignment]

    def __init__(self, request: socket.socket, client_address: Any, server: FolderServer, head: bytes) -> None:
        self.head = head
        self.timeout = server.timeout
        super().__init__(request, client_address, server, directory=str(server.folder))  # type: ignore[arg-type]

    def setup(self) -> None:
        super().setup()
        self.rfile.close()
        self.rfile = io.BytesIO(self.head)  # one request per connection (HTTP/1.0): its head is all there is

    def end_headers(self) -> None:
        self.send_header("Cache-Control", "no-store")
        if self.command not in ALLOWED:
            self.send_header("Allow", ", ".join(ALLOWED))
        super().end_headers()

    def parse_request(self) -> bool:
        if not super().parse_request():
            return False
        if self.command not in ALLOWED:
            self.send_error(HTTPStatus.METHOD_NOT_ALLOWED, f"only {' and '.join(ALLOWED)}: this server only "
                                                            f"serves files")
            return False
        return True

    def send_head(self) -> BinaryIO | None:  # type: ignore[override]
        try:
            names, folder = asked_names(self.path)
            fd, info = open_beneath(self.server.root, [*names, "index.html"] if folder else names)
        except Refused as refused:
            self.send_error(refused.status, refused.why)
            return None
        if stat.S_ISDIR(info.st_mode):
            os.close(fd)
            if folder:  # its index.html is a folder
                self.send_error(HTTPStatus.NOT_FOUND, "no index.html here, and folders are not listed")
                return None
            self.send_response(HTTPStatus.MOVED_PERMANENTLY)
            query = self.path.partition("?")[2].partition("#")[0]
            where = "/" + "".join(quote(name, safe="") + "/" for name in names) + (f"?{query}" if query else "")
            self.send_header("Location", where)
            self.send_header("Content-Length", "0")
            self.end_headers()
            return None
        fh = os.fdopen(fd, "rb")
        try:
            self.send_response(HTTPStatus.OK)
            self.send_header("Content-type", self.guess_type(names[-1] if not folder else "index.html"))
            self.send_header("Content-Length", str(info.st_size))
            self.send_header("Last-Modified", email.utils.formatdate(info.st_mtime, usegmt=True))
            self.end_headers()
        except BaseException:
            fh.close()
            raise
        return fh


@dataclass
class _Waiting:
    """A connection whose request head is still arriving."""

    address: Any
    deadline: float
    head: bytearray = field(default_factory=bytearray)


def _close(sock: socket.socket) -> None:
    try:
        sock.shutdown(socket.SHUT_RDWR)
    except OSError:
        pass
    sock.close()


class FolderServer:
    """Serves one folder over HTTP: one thread gathers every connection's request head, ``workers`` threads
    answer complete ones (see the module's text for what each knob trades)."""

    def __init__(self, folder: Path, host: str = "127.0.0.1", port: int = 0, *, timeout: float = TIMEOUT,
                 workers: int = WORKERS, waiting: int = WAITING) -> None:
        from stackx.errors import ConfigError

        self.folder, self.timeout, self.waiting_max = folder, timeout, waiting
        try:
            self.root = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
        except OSError as exc:
            raise ConfigError(f"cannot serve it: {exc.strerror or exc}", file=str(folder)) from None
        try:
            self.socket = _listen(host, port)
        except (OSError, OverflowError, UnicodeError) as exc:
            os.close(self.root)
            raise ConfigError(f"cannot listen on {host}:{port}: {getattr(exc, 'strerror', None) or exc}") from None
        self.server_address = self.socket.getsockname()[:2]
        self._pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="stackx-serve")
        self._selector = selectors.DefaultSelector()
        self._wake_in, self._wake_out = socket.socketpair()
        self._waiting: dict[socket.socket, _Waiting] = {}  # oldest first
        self._answering: set[socket.socket] = set()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._stopped = threading.Event()
        self._stopped.set()
        self._closed = False

    def serve_forever(self) -> None:
        """Accept connections, gather their request heads and hand complete ones out, until ``shutdown``."""
        self._stopped.clear()
        self._selector.register(self.socket, selectors.EVENT_READ, self._accept)
        self._selector.register(self._wake_in, selectors.EVENT_READ, lambda sock: sock.recv(64))
        try:
            while not self._stop.is_set():
                for key, _ in self._selector.select(self._wait()):
                    key.data(key.fileobj)
                self._expire()
        finally:
            self._selector.unregister(self.socket)
            self._selector.unregister(self._wake_in)
            self._stopped.set()

    def shutdown(self) -> None:
        """Stop ``serve_forever`` (running in another thread) and wait until it has."""
        self._stop.set()
        self._wake_out.send(b"x")
        self._stopped.wait()

    def server_close(self) -> None:
        """Close every connection and the folder; requests being answered end at their next send."""
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        self.socket.close()
        for sock in list(self._waiting):
            self._drop(sock)
        with self._lock:
            answering = list(self._answering)
        for sock in answering:
            try:
                sock.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
        self._pool.shutdown(wait=True, cancel_futures=True)
        for sock in answering:
            sock.close()
        self._selector.close()
        self._wake_in.close()
        self._wake_out.close()
        os.close(self.root)  # only now: no thread opens from it any more

    def __enter__(self) -> FolderServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.server_close()

    def _wait(self) -> float:
        """Seconds until the oldest waiting connection's deadline (at most one)."""
        if not self._waiting:
            return 1.0
        return min(1.0, max(0.0, next(iter(self._waiting.values())).deadline - time.monotonic()))

    def _accept(self, listener: socket.socket) -> None:
        for _ in range(64):  # a burst at a time, then the waiting connections get their turn
            try:
                sock, address = listener.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:  # out of file descriptors, or the client gave up
                if exc.errno in (errno.EMFILE, errno.ENFILE, errno.ENOBUFS, errno.ENOMEM):
                    _log("-", f"cannot accept a connection: {exc.strerror}; the oldest waiting one dropped")
                    if self._waiting:
                        self._drop(next(iter(self._waiting)))
                    else:
                        time.sleep(0.05)
                return
            if len(self._waiting) >= self.waiting_max:
                oldest = next(iter(self._waiting))
                _log(self._waiting[oldest].address, "dropped: the most connections are waiting for a request")
                self._drop(oldest)
            sock.setblocking(False)
            self._waiting[sock] = _Waiting(address, time.monotonic() + self.timeout)
            self._selector.register(sock, selectors.EVENT_READ, self._receive)

    def _receive(self, sock: socket.socket) -> None:
        waiting = self._waiting.get(sock)
        if waiting is None:  # dropped earlier in the same round of events (pushed out by a newer connection)
            return
        try:
            data = sock.recv(16384)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            self._drop(sock)
            return
        if not data:  # the client gave up before its request was complete
            self._drop(sock)
            return
        start = max(0, len(waiting.head) - 3)
        waiting.head += data
        if waiting.head.find(b"\n\n", start) >= 0 or waiting.head.find(b"\n\r\n", start) >= 0:
            self._dispatch(sock)
        elif len(waiting.head) > HEAD_MAX:
            _log(waiting.address, f"refused: a request head over {HEAD_MAX} bytes")
            try:
                sock.send(b"HTTP/1.0 431 Request Header Fields Too Large\r\nContent-Length: 0\r\n\r\n")
            except OSError:
                pass
            self._drop(sock)

    def _expire(self) -> None:
        now = time.monotonic()
        while self._waiting:
            sock, waiting = next(iter(self._waiting.items()))
            if waiting.deadline > now:
                return
            _log(waiting.address, f"dropped: no complete request within {self.timeout:g} s")
            self._drop(sock)

    def _drop(self, sock: socket.socket) -> None:
        self._selector.unregister(sock)
        del self._waiting[sock]
        _close(sock)

    def _dispatch(self, sock: socket.socket) -> None:
        self._selector.unregister(sock)
        waiting = self._waiting.pop(sock)
        with self._lock:
            self._answering.add(sock)
        try:
            self._pool.submit(self._answer, sock, waiting.address, bytes(waiting.head))
        except RuntimeError:  # shutting down
            self._done(sock)

    def _answer(self, sock: socket.socket, address: Any, head: bytes) -> None:
        """Answer one request (in a worker thread); whatever goes wrong is one log line."""
        try:
            sock.setblocking(True)
            FolderHandler(sock, address, self, head)
        except Exception as exc:  # a client gone mid-answer, a send timed out: never a traceback
            _log(address, f"connection ended: {type(exc).__name__}: {exc}")
        finally:
            self._done(sock)

    def _done(self, sock: socket.socket) -> None:
        with self._lock:
            self._answering.discard(sock)
        _close(sock)


def _listen(host: str, port: int) -> socket.socket:
    """A listening, non-blocking TCP socket at ``host:port`` (IPv6 when ``host`` is an IPv6 address)."""
    sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((host, port))
        sock.listen(128)
        sock.setblocking(False)
    except BaseException:
        sock.close()
        raise
    return sock


def _log(address: Any, message: str) -> None:
    """One line in the server's log, as http.server writes its own (control characters escaped)."""
    who = address[0] if isinstance(address, tuple) else str(address)
    text = message.translate(CONTROL)
    sys.stderr.write(f"{who} - - [{time.strftime('%d/%b/%Y %H:%M:%S')}] {text}\n")


PAGES_SHOWN = 20
"""HTML pages ``stackx serve`` names when it starts; more are counted, not listed (a folder of many players)."""


def html_pages(folder: Path) -> list[str]:
    """The URL path of every HTML page under ``folder`` (regular files, no link followed, hidden folders left
    out), shallowest first: a folder's ``index.html`` as the folder itself (``/``, ``/sub/``), every other page
    by its own path."""
    found = []
    for here, dirs, files in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))  # a staging folder is no page to open
        parts = Path(here).relative_to(folder).parts
        for name in sorted(files):
            page = Path(here) / name
            if name.lower().endswith((".html", ".htm")) and page.is_file() and not page.is_symlink():
                found.append(_url_path([*parts, name]))
    return sorted(found, key=lambda url: (url.count("/"), url))


def _url_path(parts: list[str]) -> str:
    """The URL path of the file at ``parts`` under the served folder; an ``index.html`` as its folder's."""
    folder = parts[-1] == "index.html"
    names = parts[:-1] if folder else parts
    return "/" + "/".join(quote(name, safe="") for name in names) + ("/" if folder and names else "")


def served_lines(folder: Path, host: str, port: int, shown: int = PAGES_SHOWN) -> str:
    """What ``stackx serve`` prints when it starts: the folder, and the URL of each HTML page in it (a run's
    players, a bench's report), or that it holds none, since the folder's own URL is a 404 without an
    ``index.html``."""
    base = f"http://{f'[{host}]' if ':' in host else host}:{port}"
    pages = html_pages(folder)
    top = "" if "/" in pages else ", no page at /"
    lines = [f"serving {folder} at {base}/ (Ctrl-C to stop{top}); "
             + ("its HTML pages:" if pages else "it holds no HTML page: files are served by their paths")]
    lines += [f"  {base}{page}" for page in pages[:shown]]
    if len(pages) > shown:
        lines.append(f"  and {len(pages) - shown} more HTML page(s)")
    return "\n".join(lines)


def serve_folder(folder: Path, host: str, port: int, timeout: float = TIMEOUT, workers: int = WORKERS) -> None:
    """Serve ``folder`` at ``host:port`` until Ctrl-C (``port`` 0: any free port, printed)."""
    from stackx.errors import ConfigError

    if not 0 <= port <= 65535:
        raise ConfigError(f"--port: a TCP port is 1 to 65535 (or 0 for any free port), not {port}")
    server = FolderServer(folder, host, port, timeout=timeout, workers=workers)
    print(served_lines(folder, host, server.server_address[1]), flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.server_close()
