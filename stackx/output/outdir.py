"""The output folder: files are staged in memory and written only when a whole experiment succeeded.

``stackx run`` switches its whole output folder in one step (``stackx.output.folder``); ``OutputDir.commit`` is for
the writers of a few files into a folder that may hold other things (``stackx init``, ``stackx bench``). Each
file is written to a temporary file in the same folder and renamed into place, so a reader (or a process
killed at any moment) sees either the old complete file or the new complete one, and a commit failing
part-way puts back what it had written. A process killed between a write and its rename can leave a
temporary file behind: it is named ``.NAME.XXXXXXXX.tmp``, a hidden name that no artifact may have
(``safe_relative`` refuses names starting with a dot), so it is never taken for an artifact, never listed in
the manifest, and can be deleted at any time.

Paths are confined to the folder: absolute paths, ``..``, hidden names and links on the way are refused
(``stackx.outputs.confine`` checks an output's paths this way before anything runs, so a bad path fails with
the config's ``file:line:col``, not after a long run).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path, PurePosixPath

from stackx.errors import ConfigError, RunError

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
    """Artifacts of one experiment, held until ``commit``."""

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

    def commit(self) -> list[Path]:
        """Write every staged file atomically, in name order; return their paths.

        All or nothing for a failure it sees (a full disk, a file in the way): the files already written are
        put back as they were (a replaced file from a hard-linked copy kept until the end, a new one removed,
        with the folders made for it). A process killed part-way leaves whole files only, some of them new;
        ``stackx run`` switches its whole folder instead (``stackx.output.folder``).
        """
        if self.root.exists() and not self.root.is_dir():
            raise ConfigError("the output folder is a file", file=str(self.root))
        written: list[tuple[Path, Path | None]] = []  # (file, the copy of the file it replaced)
        made: list[Path] = []
        try:
            for name, data in sorted(self.staged.items()):
                target = self.root / name
                try:
                    check_place(self.root, name)
                    made += _make_folders(target.parent)
                    check_place(self.root, name)  # again: a link could have appeared while making folders
                    kept = _keep(target)
                    written.append((target, kept))
                    atomic_write(target, data)
                except ValueError as exc:
                    raise ConfigError(str(exc), file=str(self.root)) from None
                except OSError as exc:
                    raise RunError(f"cannot write {target}: {exc.strerror or exc}") from None
        except BaseException:
            _undo(written, made)
            raise
        for _, kept in written:
            if kept is not None:
                kept.unlink(missing_ok=True)
        return [target for target, _ in written]


def _make_folders(folder: Path) -> list[Path]:
    """Make ``folder`` and its missing parents; return those made, outermost first."""
    missing = [p for p in (folder, *folder.parents) if not p.exists()][::-1]
    for p in missing:
        p.mkdir()
    return missing


def _keep(target: Path) -> Path | None:
    """A hidden hard link to the file ``target`` is about to replace (None: there is none), to put it back."""
    if not target.is_file():
        return None
    kept = target.with_name(f".{target.name}.{os.urandom(4).hex()}{TEMP_SUFFIX}")
    os.link(target, kept)
    return kept


def _undo(written: list[tuple[Path, Path | None]], made: list[Path]) -> None:
    """Put the files of a failed commit back as they were, best effort."""
    for target, kept in reversed(written):
        try:
            if kept is not None:
                os.replace(kept, target)
            else:
                target.unlink(missing_ok=True)
        except OSError:
            pass
    for folder in reversed(made):
        try:
            folder.rmdir()
        except OSError:
            pass


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
