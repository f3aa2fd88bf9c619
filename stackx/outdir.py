"""The output folder: files are staged in memory and written only when a whole experiment succeeded.

Each file is written to a temporary file in the same folder and renamed into place, so a reader (or a run
killed halfway) sees either the old complete file or the new complete one. Paths are confined to the
folder: absolute paths, ``..`` and links pointing out are refused.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path, PurePosixPath

from stackx.errors import ConfigError


def safe_relative(name: str) -> str:
    """Check that ``name`` stays inside the output folder; return it normalised, or raise ``ValueError``."""
    p = PurePosixPath(name.replace("\\", "/"))
    if not name or p.is_absolute() or ".." in p.parts or any(":" in part for part in p.parts):
        raise ValueError(f"{name!r} must be a relative path inside the output folder (no '..', not absolute)")
    return str(p)


class OutputDir:
    """Artifacts of one experiment, held until ``commit``."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.staged: dict[str, bytes] = {}

    def write_bytes(self, name: str, data: bytes) -> None:
        self.staged[safe_relative(name)] = data

    def write_text(self, name: str, text: str) -> None:
        self.write_bytes(name, text.encode("utf-8"))

    def commit(self) -> list[Path]:
        """Write every staged file atomically; return their paths."""
        written = []
        root = self.root.resolve()
        for name, data in self.staged.items():
            target = self.root / name
            target.parent.mkdir(parents=True, exist_ok=True)
            real = target.parent.resolve()
            if real != root and root not in real.parents:
                raise ConfigError(f"{name!r} leads out of the output folder {self.root} through a link")
            if target.is_symlink():
                raise ConfigError(f"{name!r} is a link in the output folder; refusing to write through it")
            atomic_write(target, data)
            written.append(target)
        return written


def atomic_write(target: Path, data: bytes) -> None:
    """Write ``data`` to ``target`` through a temporary file in the same folder and a rename."""
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, target)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
