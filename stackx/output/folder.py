"""A run's update of an output folder: all of it, or nothing.

``stackx run`` never writes into the output folder ``X`` itself. Under a lock (one writer per folder; a
second run waits, saying so), it stages the run's files in a hidden sibling folder, ``.X.stackx-next``; when
the run has finished it carries every file of ``X`` that the run leaves alone into the staging folder
(hard links: no copy), and switches the two folders in one atomic step (Linux ``renameat2`` with
``RENAME_EXCHANGE``). A reader, or a run killed at any moment, sees ``X`` as it was before or as the run left
it, never a mix; a run that fails, or is interrupted, leaves ``X`` untouched (and a first run that fails
leaves no folder at all).

Where the atomic exchange is not available (another system, a file system without it), the switch is two
renames, ``X`` to ``.X.stackx-prev`` and the staging folder to ``X``; a run killed between the two leaves no
``X``, and the next run into it puts the old one back before anything else. Leftover staging folders of a
killed run are hidden and removed by the next run into the same folder.

What it trades: a run's files are on disk twice until the switch (the old and the new version), and a shell
whose working folder is ``X`` keeps seeing the old folder until it changes folder again (it holds the old
folder, not its name). So ``X`` cannot be the working folder or hold it.
"""

from __future__ import annotations

import ctypes
import errno
import os
import re
import shutil
from collections.abc import Callable, Iterator
from pathlib import Path, PurePosixPath
from types import TracebackType

from stackx.errors import ConfigError, RunError
from stackx.run import interrupt
from stackx.output.outdir import check_place, safe_relative, sync_folder

try:
    import fcntl
except ImportError:  # not a POSIX system: no lock
    fcntl = None  # type: ignore[assignment]

STALE_TEMP = re.compile(r"^\..+\.[A-Za-z0-9_]{8}\.tmp$")  # a file-by-file write killed before its rename
RESERVE = 16 << 20  # bytes left free on the disk after staging a run's files
Say = Callable[[str], None]


class FolderLock:
    """One writer per output folder: an exclusive ``flock`` on ``.X.stackx-lock`` beside it, removed after."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.fd: int | None = None

    def acquire(self, folder: Path, waiting: Say | None) -> None:
        told = False
        while fcntl is not None:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                if waiting is not None and not told:
                    holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
                    waiting(f"waiting: another stackx run (pid {holder}) is writing {folder}")
                    told = True
                fcntl.flock(fd, fcntl.LOCK_EX)
            mine = os.fstat(fd)
            try:
                now = os.stat(self.path)
            except FileNotFoundError:
                now = None
            if now is not None and (now.st_dev, now.st_ino) == (mine.st_dev, mine.st_ino):
                os.ftruncate(fd, 0)
                os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
                self.fd = fd
                return
            os.close(fd)  # the previous holder removed that file as it let go: lock the new one

    def release(self) -> None:
        if self.fd is not None:
            self.path.unlink(missing_ok=True)
            os.close(self.fd)
            self.fd = None


def _exchange(a: Path, b: Path) -> bool:
    """Swap two folders atomically; False when the system cannot (then nothing happened)."""
    try:
        renameat2 = ctypes.CDLL(None, use_errno=True).renameat2
    except (AttributeError, OSError):
        return False
    at_cwd, exchange = -100, 2  # AT_FDCWD, RENAME_EXCHANGE
    if renameat2(at_cwd, os.fsencode(a), at_cwd, os.fsencode(b), exchange) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP):
        return False
    raise OSError(code, os.strerror(code), str(b))


class FolderUpdate:
    """The files one run writes into ``root`` and the ones it removes, switched in whole by ``commit``.

    Use as a context manager: entering takes the folder's lock (``waiting`` is told once when another run
    holds it) and repairs what a killed run left; leaving without ``commit`` throws the staged files away.
    """

    def __init__(self, root: Path, waiting: Say | None = None) -> None:
        self.shown = root
        self.root = Path(os.path.abspath(root.resolve() if root.is_symlink() else root))
        name = self.root.name
        self.parent = self.root.parent
        self.next = self.parent / f".{name}.stackx-next"
        self.prev = self.parent / f".{name}.stackx-prev"
        self.lock = FolderLock(self.parent / f".{name}.stackx-lock")
        self.waiting = waiting
        self.added: dict[str, int] = {}
        self.removed: set[str] = set()
        self.made: list[Path] = []  # parents made for the lock, removed again if the run commits nothing

    def __enter__(self) -> FolderUpdate:
        here = Path.cwd().resolve()
        if here == self.root.resolve() or here.is_relative_to(self.root.resolve()):
            raise ConfigError("the output folder is replaced whole when the run ends, so it cannot be the working "
                              "folder or hold it; choose another folder", file=str(self.shown))
        if self.root.exists() and not self.root.is_dir():
            raise ConfigError("the output folder is a file", file=str(self.shown))
        try:
            for folder in reversed([p for p in (self.parent, *self.parent.parents) if not p.exists()]):
                folder.mkdir()
                self.made.append(folder)
            self.lock.acquire(self.shown, self.waiting)
        except OSError as exc:
            self._tidy()
            raise RunError(f"cannot lock the output folder {self.shown}: {exc.strerror or exc}") from None
        try:
            if not self.root.exists() and self.prev.is_dir():
                os.rename(self.prev, self.root)  # a switch killed between its two renames: the old folder back
            for stale in (self.next, self.prev):
                if stale.is_dir() and not stale.is_symlink():
                    shutil.rmtree(stale)
            self.next.mkdir()
        except OSError as exc:
            self.__exit__(None, None, None)
            raise RunError(f"cannot stage files beside {self.shown}: {exc.strerror or exc}") from None
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        try:
            if self.next.is_dir():
                shutil.rmtree(self.next, ignore_errors=True)
        finally:
            self.lock.release()
            self._tidy()

    def _tidy(self) -> None:
        for folder in reversed(self.made):
            try:
                folder.rmdir()  # only when empty: a run committed into it, or someone else wrote there
            except OSError:
                break
        self.made = []

    def read(self, name: str) -> bytes | None:
        """The bytes of file ``name`` as the update leaves it (None: no such file after the update)."""
        if name in self.removed:
            return None
        path = (self.next if name in self.added else self.root) / name
        try:
            return path.read_bytes() if path.is_file() else None
        except OSError:
            return None

    def write(self, files: dict[str, bytes]) -> None:
        """Stage an experiment's ``files`` (name -> bytes); refuse them all, before writing any, when a name
        leaves the folder or meets a link or a file in the way, or when the disk cannot hold them."""
        try:
            for name in files:
                check_place(self.root, safe_relative(name))
        except ValueError as exc:
            raise ConfigError(str(exc), file=str(self.shown)) from None
        self.write_records({safe_relative(name): data for name, data in files.items()})

    def write_records(self, files: dict[str, bytes]) -> None:
        """Stage ``files`` whose names stackx chose (the manifest, timing, failed-run files), after checking
        that the disk can hold them."""
        need = sum(len(data) for data in files.values())
        free = shutil.disk_usage(self.next).free
        if need + RESERVE > free:
            raise RunError(f"not enough free space for {self.shown}: the run's files take {_size(need)} and "
                           f"{_size(RESERVE)} stays free, but the disk has {_size(free)} left; "
                           f"{self.shown} left as it was")
        for name, data in sorted(files.items()):
            target = self.next / name
            try:
                target.parent.mkdir(parents=True, exist_ok=True)
                with open(target, "wb") as fh:
                    fh.write(data)
                    fh.flush()
                    os.fsync(fh.fileno())
            except OSError as exc:
                raise RunError(f"cannot write {self.shown / name}: {exc.strerror or exc}; {self.shown} left as "
                               f"it was") from None
            self.added[name] = len(data)
            self.removed.discard(name)

    def remove(self, name: str) -> None:
        """Leave file ``name`` out of the updated folder."""
        if name in self.added:
            (self.next / name).unlink()
            del self.added[name]
        self.removed.add(name)

    def commit(self) -> None:
        """Carry the files the run leaves alone into the staged folder, then switch it in for ``root``."""
        with interrupt.held():  # a Ctrl-C waits for the switch (an instant), so its message stays true
            self._switch()
            interrupt.switched()
        self.made = []

    def _switch(self) -> None:
        try:
            if self.root.is_dir():
                self._carry()
            for folder in self._folders():
                sync_folder(folder)
            if self.root.exists():
                if not _exchange(self.next, self.root):
                    os.rename(self.root, self.prev)
                    try:
                        os.rename(self.next, self.root)
                    except OSError:
                        os.rename(self.prev, self.root)
                        raise
                    self.next = self.prev  # what __exit__ removes: the old folder
                sync_folder(self.parent)
                shutil.rmtree(self.next, ignore_errors=True)
            else:
                os.rename(self.next, self.root)
                sync_folder(self.parent)
        except OSError as exc:
            raise RunError(f"cannot switch {self.shown} to the run's files: {exc.strerror or exc}; "
                           f"{self.shown} left as it was") from None

    def _folders(self) -> Iterator[Path]:
        yield self.next
        for top, dirs, _ in os.walk(self.next):
            for d in dirs:
                yield Path(top) / d

    def _carry(self) -> None:
        """Link every entry of ``root`` that the run neither replaces nor removes into the staged folder."""
        for top, dirs, files in os.walk(self.root):
            rel = Path(top).relative_to(self.root)
            for d in list(dirs):
                source, target = Path(top) / d, self.next / rel / d
                if source.is_symlink():
                    dirs.remove(d)
                    files.append(d)
                elif not target.exists():
                    target.mkdir()
            for f in files:
                name = PurePosixPath(*rel.parts, f).as_posix()
                if name in self.added or name in self.removed or STALE_TEMP.match(f):
                    continue
                source, target = Path(top) / f, self.next / rel / f
                if target.exists() or target.is_symlink():
                    continue
                if source.is_symlink():
                    os.symlink(os.readlink(source), target)
                    continue
                try:
                    os.link(source, target)
                except OSError:
                    shutil.copy2(source, target)


def _size(n: int) -> str:
    return f"{n / (1 << 20):.1f} MiB"
