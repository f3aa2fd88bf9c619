"""The output folder's names and records: what a file may be called, and an experiment's files held in memory.

An experiment's outputs write into an ``OutputDir``, which only holds their bytes: nothing reaches the disk
until the whole update of the folder is switched in (``stackx.output.folder``, which ``stackx run``, ``bench``
and ``init`` use alike). A name starting with a dot is never an artifact (``safe_relative`` refuses it): such
names are kept for stackx's own hidden entries (``.X.stackx-next`` and the like beside the folder) and for the
temporary file of ``atomic_write`` (``.NAME.XXXXXXXX.tmp``), which a process killed between its write and its
rename can leave behind; such a file is never taken for an artifact, never listed in the manifest, and can be
deleted at any time.

Paths are confined to the folder: absolute paths, ``..``, hidden names and links on the way are refused
(``stackx.outputs.confine`` checks an output's paths this way before anything runs, so a bad path fails with
the config's ``file:line:col``, not after a long run).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path, PurePosixPath

from stackx.errors import RunError

TEMP_SUFFIX = ".tmp"
MANIFEST = "manifest.json"  # what the folder holds and how it was made (see stackx.output.manifest)
TIMING = "timing.json"  # wall-clock times, the one file that differs between two runs
FAILED_SUFFIX = ".failed.json"  # NAME.failed.json: the partial measures of experiment NAME that blew up


def failed_file(experiment: str) -> str:
    """The name of the failed-run file of an experiment."""
    return experiment + FAILED_SUFFIX


def safe_relative(name: str) -> str:
    """Check that ``name`` stays inside the output folder; return it normalised, or raise ``ValueError``."""
    p = PurePosixPath(name.replace("\\", "/"))
    if not name or p.is_absolute() or ".." in p.parts or any(":" in part for part in p.parts):
        raise ValueError(f"{name!r} must be a relative path inside the output folder (no '..', not absolute)")
    if any(ch < " " for ch in name):
        raise ValueError(f"{name!r} holds a control character")
    if any(part.startswith(".") for part in p.parts):
        raise ValueError(f"{name!r}: names starting with '.' are kept for temporary files; drop the dot")
    if str(p) in (MANIFEST, TIMING) or (len(p.parts) == 1 and p.name.endswith(FAILED_SUFFIX)):
        raise ValueError(f"{name!r} is kept for the folder's own records ({MANIFEST}, {TIMING}, "
                         f"NAME{FAILED_SUFFIX}); choose another name")
    return str(p)


def check_place(root: Path, name: str) -> None:
    """Refuse, with ``ValueError``, a path under ``root`` that passes through a link or a file in the way."""
    here = root
    parts = PurePosixPath(safe_relative(name)).parts
    for i, part in enumerate(parts):
        here = here / part
        if here.is_symlink():
            raise ValueError(f"{name!r}: {here} is a link; outputs are not written through links")
        last = i == len(parts) - 1
        if here.exists() and (here.is_dir() if last else not here.is_dir()):
            raise ValueError(f"{name!r}: {here} is {'a folder' if last else 'a file, not a folder'}")


class OutputDir:
    """Artifacts of one experiment (or a bench's report), held in memory (``staged``: name -> bytes) until the
    update of the folder writes them."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.staged: dict[str, bytes] = {}

    def write_bytes(self, name: str, data: bytes) -> None:
        if not isinstance(data, bytes):
            raise TypeError(f"{name!r}: an output writes bytes, not {type(data).__name__}")
        self.staged[safe_relative(name)] = data

    def write_text(self, name: str, text: str) -> None:
        if not isinstance(text, str):
            raise TypeError(f"{name!r}: write_text takes a str, not {type(text).__name__}")
        self.write_bytes(name, text.encode("utf-8"))


def atomic_write(target: Path, data: bytes) -> None:
    """Write ``data`` to ``target`` through a temporary file in the same folder and a rename.

    A failure of the file system (full disk, no permission) is a ``RunError`` naming the file.
    """
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=TEMP_SUFFIX, dir=target.parent)
    except OSError as exc:
        raise RunError(f"cannot write {target}: {exc.strerror or exc}") from None
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, target)
    except BaseException as exc:
        if os.path.exists(tmp):
            os.unlink(tmp)
        if isinstance(exc, OSError):
            raise RunError(f"cannot write {target}: {exc.strerror or exc}") from None
        raise
    sync_folder(target.parent)


def sync_folder(folder: Path) -> None:
    """Make a folder's entries durable (a rename survives a crash of the machine, not only of the process);
    best effort."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


MAX_DEPTH = 64  # nesting a folder's own JSON files may have (a manifest nests about 10 deep)


def json_bytes(doc: object) -> bytes:
    """``doc`` as sorted, indented JSON: the same bytes for the same content."""
    import json

    return (json.dumps(doc, indent=2, sort_keys=True) + "\n").encode()


def load_json(data: bytes) -> object:
    """JSON from a folder's own file, which anyone may have edited: ``ValueError`` saying why when it is not
    JSON, or nests deeper than ``MAX_DEPTH`` (a file nested 100,000 deep must not reach the recursion limit)."""
    import json

    try:
        doc = json.loads(data.decode("utf-8"))
    except RecursionError:
        raise ValueError(f"nested deeper than {MAX_DEPTH} levels") from None
    except UnicodeDecodeError as exc:
        raise ValueError(f"not UTF-8 ({exc.reason} at byte {exc.start})") from None
    level = [(doc, 1)]
    while level:
        value, depth = level.pop()
        if isinstance(value, (dict, list)):
            if depth > MAX_DEPTH:
                raise ValueError(f"nested deeper than {MAX_DEPTH} levels")
            level.extend((v, depth + 1) for v in (value.values() if isinstance(value, dict) else value))
    return doc


def read_json(data: bytes | None) -> object | None:
    """``load_json``, with None for no file or a file that is not JSON (for records that may be rebuilt)."""
    if data is None:
        return None
    try:
        return load_json(data)
    except ValueError:
        return None
