"""A small static file server for previewing an output folder's HTML player.

It serves the files under its folder and nothing else: no directory listings (a folder answers with its
``index.html``, else 404), no link followed out of the folder (every path is resolved, and what it opens must
be the file it resolved inside the folder: 403 otherwise), and only GET and HEAD (405 for any other method).
"""

from __future__ import annotations

import email.utils
import functools
import os
from http import HTTPStatus
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import BinaryIO
from urllib.parse import urlsplit

ALLOWED = ("GET", "HEAD")


class FolderHandler(SimpleHTTPRequestHandler):
    """Serves the files of one folder without caching, so a re-run is seen on reload."""

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

    def list_directory(self, path: str | os.PathLike[str]) -> None:
        self.send_error(HTTPStatus.NOT_FOUND, "no directory listings")
        return None

    def _inside(self, path: str) -> Path | None:
        """``path`` resolved, when it lies inside the served folder (links followed); else None."""
        root = Path(self.directory).resolve()
        real = Path(os.path.realpath(path))
        return real if real == root or real.is_relative_to(root) else None

    def send_head(self) -> BinaryIO | None:  # type: ignore[override]
        path = self.translate_path(self.path)
        real = self._inside(path)
        if real is None:
            self.send_error(HTTPStatus.FORBIDDEN, "leads out of the served folder")
            return None
        asked = urlsplit(self.path)
        if real.is_dir():
            parts = asked
            if not parts.path.endswith("/"):
                self.send_response(HTTPStatus.MOVED_PERMANENTLY)
                self.send_header("Location", parts._replace(path=parts.path + "/").geturl())
                self.send_header("Content-Length", "0")
                self.end_headers()
                return None
            real = self._inside(os.path.join(real, "index.html"))
            if real is None:
                self.send_error(HTTPStatus.FORBIDDEN, "leads out of the served folder")
                return None
        elif asked.path.endswith("/"):  # a file asked for as a folder
            real = None
        if real is None or not real.is_file():
            self.send_error(HTTPStatus.NOT_FOUND, "File not found")
            return None
        try:
            fh = open(real, "rb")
        except OSError:
            self.send_error(HTTPStatus.NOT_FOUND, "File not found")
            return None
        try:
            st = os.fstat(fh.fileno())
            now = os.stat(real)
            if (st.st_dev, st.st_ino) != (now.st_dev, now.st_ino):  # a link swapped in since it was resolved
                self.send_error(HTTPStatus.FORBIDDEN, "leads out of the served folder")
                fh.close()
                return None
            self.send_response(HTTPStatus.OK)
            self.send_header("Content-type", self.guess_type(str(real)))
            self.send_header("Content-Length", str(st.st_size))
            self.send_header("Last-Modified", email.utils.formatdate(st.st_mtime, usegmt=True))
            self.end_headers()
            return fh  # type: ignore[return-value]
        except BaseException:
            fh.close()
            raise


def serve_folder(folder: Path, host: str, port: int) -> None:
    """Serve ``folder`` at ``host:port`` until Ctrl-C (``port`` 0: any free port, printed)."""
    from stackx.errors import ConfigError

    if not 0 <= port <= 65535:
        raise ConfigError(f"--port: a TCP port is 1 to 65535 (or 0 for any free port), not {port}")
    handler = functools.partial(FolderHandler, directory=str(folder))
    try:
        server = ThreadingHTTPServer((host, port), handler)
    except (OSError, OverflowError, UnicodeError) as exc:
        raise ConfigError(f"cannot listen on {host}:{port}: {getattr(exc, 'strerror', None) or exc}") from None
    print(f"serving {folder} at http://{host}:{server.server_address[1]}/  (Ctrl-C to stop)", flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.server_close()
