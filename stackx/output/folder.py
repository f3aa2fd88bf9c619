"""An update of an output folder: all of it or nothing, and nothing but stackx's own entries.

``stackx run`` (and ``bench``, and ``init``) never writes into the output folder ``X`` itself. Under a lock
(one writer per folder; a second one waits, saying so), it stages its files in a hidden sibling folder,
``.X.stackx-next``; when it has finished it carries every entry of ``X`` that it leaves alone into the staging
folder (hard links: no copy), and switches the two folders in one atomic step (Linux ``renameat2`` with
``RENAME_EXCHANGE``). A reader, or a run killed at any moment, sees ``X`` as it was before or as the run left
it, never a mix; a run that fails, or is interrupted, leaves ``X`` untouched (and a first run that fails
leaves no folder at all).

What the update may touch (docs/outputs.md, "What a run may touch"):

- It replaces only files its caller owns (``ours``: for a run, the names the previous manifest lists) and
  removes only its own: after the switch the old folder is settled entry by entry. An entry goes when the new
  ``X`` holds the same file at the same name (a carried hard link), when it is a file the update replaced or
  removed and nobody changed since the carry, or when it is an empty folder the new ``X`` has too. Anything
  else (what other programs made in ``X`` while the run ran) is moved into the new ``X`` at its name when that
  name is free; what has no free place stays in a hidden ``.X.stackx-kept-N``, named in one line, never removed.
- It never crosses a file system: a mount at or inside ``X`` is refused before any work, and the carry and
  every removal stop at one. It follows no link it did not make: the lock and the hidden folders are opened
  or examined without following links, and refused when they are links or not the user's.
- ``X`` keeps its mode, owner, group and setgid bit (the staging folder takes them when it is made, so the
  run's own sub-folders inherit the group as they would in ``X``); carried sub-folders keep their own. A
  first run's ``X`` is a plain ``mkdir``'s (the umask decides).

Where the atomic exchange is not available, the switch is two renames, ``X`` to ``.X.stackx-prev`` and the
staging folder to ``X``; a run killed between the two leaves no ``X``, and the next writer puts the old one
back before anything else. What a killed writer needs settled is in its lock file, written before the switch
(a journal: the staging folder's identity and what the carry saw), so the next writer into the folder tells
a staging folder never switched (removed: all of it is stackx's) from an old folder switched out (settled as
above, nothing of anyone else's removed).

A folder that holds the working folder cannot be switched (a shell there would keep seeing the old one).
``init``, which only adds files, may still write there (``here=True``): its staged files are then placed by
hard links one by one, and the next writer into the folder takes back a placing killed part-way.

What it trades: a run's files are on disk twice until the switch (the old and the new version), the folder is
walked once before the run (for mounts) and once at the switch (the carry), and ``X`` cannot be the working
folder of a run, nor hold it.
"""

from __future__ import annotations

import ctypes
import errno
import json
import os
import re
import shutil
import stat
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from types import TracebackType
from typing import Any

from stackx.errors import ConfigError, RunError
from stackx.run import interrupt
from stackx.output.outdir import check_place, safe_relative, sync_folder

try:
    import fcntl
except ImportError:  # not a POSIX system: no lock
    fcntl = None  # type: ignore[assignment]

STALE_TEMP = re.compile(r"^\..+\.[A-Za-z0-9_]{8}\.tmp$")  # a file-by-file write killed before its rename
RESERVE = 16 << 20  # bytes left free on the disk after staging a run's files
NAME_MAX = 255  # bytes in one name, on every file system stackx writes to
PATH_MAX = 4096  # bytes in a path, its terminating zero included (Linux)
HIDDEN = ".stackx-kept-999"  # the longest suffix of the hidden names made beside X (after a leading dot)
KEPT_MAX = 999  # kept folders beside one output folder before stackx stops making more
JOURNAL_BYTES = 64 << 20  # the most of a killed writer's lock file read back (its journal is far smaller)
NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
FLAGS = getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_NOCTTY", 0)
AT_CWD, NOREPLACE, EXCHANGE = -100, 1, 2  # AT_FDCWD, RENAME_NOREPLACE, RENAME_EXCHANGE
Say = Callable[[str], None]
Id = tuple[int, int]  # (st_dev, st_ino): which file an entry is, whatever its name


def _to_stderr(line: str) -> None:
    sys.stderr.write(line + "\n")
    sys.stderr.flush()


def _short(path: Path | str) -> str:
    """A path as an error line names it: whole up to 100 characters, else its two ends."""
    text = str(path)
    return text if len(text) <= 100 else f"{text[:60]}...{text[-30:]}"


class FolderLock:
    """One writer per output folder: an exclusive ``flock`` on ``.X.stackx-lock`` beside it, removed after.

    The file is opened without following a link and taken only when it is a regular file of this user with a
    single name, so a planted link or hard link cannot make stackx write into another file; nothing in it is
    truncated before that. It holds the holder's pid (a waiting writer names it) and, over a switch, the
    journal the next writer needs to finish the work of a holder that was killed.
    """

    def __init__(self, path: Path, shown: Path | None = None) -> None:
        self.path = path
        self.shown = shown or path  # how messages name it: beside the folder as the user named it
        self.fd: int | None = None
        self.pending = False  # the file holds a journal: kept when the lock is let go

    def acquire(self, folder: Path, waiting: Say | None) -> dict[str, Any]:
        """Take the lock, telling ``waiting`` once when another writer holds it; return the journal a killed
        holder left in the file ({} when there is none)."""
        told = False
        while fcntl is not None:
            fd = self._open(folder)
            try:
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                except BlockingIOError:
                    if waiting is not None and not told:
                        holder = os.pread(fd, 32, 0).decode(errors="replace").split("\n")[0].strip() or "?"
                        waiting(f"waiting: another stackx run (pid {holder}) is writing {folder}")
                        told = True
                    fcntl.flock(fd, fcntl.LOCK_EX)
                mine = os.fstat(fd)
                try:
                    now = os.lstat(self.path)
                except FileNotFoundError:
                    now = None
            except BaseException:
                os.close(fd)
                raise
            if now is not None and (now.st_dev, now.st_ino) == (mine.st_dev, mine.st_ino):
                self.fd = fd
                left = _journal(fd)
                self.note(left)  # this holder's pid; the journal stays until the repair has settled it
                return left
            os.close(fd)  # the previous holder removed that file as it let go: lock the new one
        return {}

    def _open(self, folder: Path) -> int:
        """The lock file, opened without following a link; ``ConfigError`` when it is not one stackx made."""
        try:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | NOFOLLOW | FLAGS | getattr(os, "O_NONBLOCK", 0), 0o644)
        except OSError as exc:
            if exc.errno in (errno.ELOOP, errno.EISDIR, errno.ENXIO):
                what = {errno.ELOOP: "a link", errno.EISDIR: "a folder"}.get(exc.errno, "not a regular file")
                raise ConfigError(_not_made(self.shown, what), file=_short(folder)) from None
            raise
        info = os.fstat(fd)
        what = ("not a regular file" if not stat.S_ISREG(info.st_mode) else
                "another user's file" if info.st_uid != os.geteuid() else
                f"a file with {info.st_nlink} names (hard links)" if info.st_nlink > 1 else None)
        if what is not None:
            os.close(fd)
            raise ConfigError(_not_made(self.shown, what), file=_short(folder))
        return fd

    def note(self, journal: dict[str, Any]) -> None:
        """Write the holder's pid and ``journal`` (what a writer killed from here on leaves to settle)."""
        if self.fd is None:
            return
        data = f"{os.getpid()}\n".encode() + (json.dumps(journal).encode() + b"\n" if journal else b"")
        os.pwrite(self.fd, data, 0)
        os.ftruncate(self.fd, len(data))
        if journal:
            os.fsync(self.fd)
        self.pending = bool(journal)

    def release(self) -> None:
        """Let go; the file is removed unless it holds a journal (work a next writer must still settle)."""
        if self.fd is not None:
            if not self.pending:
                self.path.unlink(missing_ok=True)
            os.close(self.fd)
            self.fd = None


def _not_made(path: Path, what: str) -> str:
    return (f"{_short(path)} is {what}; stackx uses only lock files and hidden folders it made itself and follows "
            f"or repairs nothing else: remove it and run again")


def _journal(fd: int) -> dict[str, Any]:
    """The journal in a lock file's second line; {} when there is none or it is not one."""
    size = os.fstat(fd).st_size
    if size > JOURNAL_BYTES:
        return {}
    data = os.pread(fd, size, 0).split(b"\n", 1)
    try:
        doc = json.loads(data[1]) if len(data) == 2 and data[1].strip() else {}
    except ValueError:
        return {}
    return doc if isinstance(doc, dict) else {}


@dataclass
class Known:
    """What the carry saw of ``X``: the entries it left out on purpose (files the update replaces or removes,
    a killed file-by-file write's temporaries) and those it had to copy, each by name with its identity then.
    Such an entry, found unchanged in the old folder after the switch, is stackx's to remove; one changed or
    made since (by another program) is not."""

    left: dict[str, Id] = field(default_factory=dict)
    copied: dict[str, tuple[int, int, int, int]] = field(default_factory=dict)  # id, size, mtime_ns

    def owns(self, name: str, info: os.stat_result) -> bool:
        if self.left.get(name) == (info.st_dev, info.st_ino):
            return True
        return self.copied.get(name) == (info.st_dev, info.st_ino, info.st_size, info.st_mtime_ns)

    def journal(self) -> dict[str, Any]:
        return {"left": {k: list(v) for k, v in self.left.items()},
                "copied": {k: list(v) for k, v in self.copied.items()}}

    @classmethod
    def read(cls, doc: dict[str, Any]) -> Known:
        """The entries a journal lists (anything malformed in it is left out: it then owns less, never more)."""
        def pairs(key: str, size: int) -> dict[str, Any]:
            found = doc.get(key)
            return {k: tuple(v) for k, v in (found.items() if isinstance(found, dict) else ())
                    if isinstance(k, str) and isinstance(v, list) and len(v) == size
                    and all(isinstance(n, int) for n in v)}
        return cls(pairs("left", 2), pairs("copied", 4))


class FolderUpdate:
    """The files one update writes into ``root`` and the ones it removes, switched in whole by ``commit``.

    Use as a context manager: entering checks that ``root`` can be switched (no mount at or inside it, a
    writable parent), takes the folder's lock (``say`` is told once when another writer holds it, and where
    entries that had no place were kept) and settles what a killed writer left; leaving without ``commit``
    throws the staged files away. ``ours`` names the files of ``root`` the update may replace (the caller's
    own, e.g. those its manifest lists); ``here`` lets ``root`` hold the working folder (adding files only).
    """

    def __init__(self, root: Path, say: Say | None = None, here: bool = False) -> None:
        self.shown = root
        self.root = _absolute(root)
        name = self.root.name
        self.parent = self.root.parent
        self.next = self.parent / f".{name}.stackx-next"
        self.prev = self.parent / f".{name}.stackx-prev"
        named = Path(os.path.abspath(root)) == self.root  # not a link: name what is beside it as the user did
        self.near = root.parent if named else self.parent  # the parent, for messages
        self.lock = FolderLock(self.parent / f".{name}.stackx-lock", self.near / f".{name}.stackx-lock")
        self.say = say or _to_stderr
        self.here = here
        self.placing = False  # root holds the working folder: files are placed, not switched
        self.ours: set[str] = set()
        self.added: dict[str, int] = {}
        self.removed: set[str] = set()
        self.made: list[Path] = []  # parents made for the lock, removed again if the run commits nothing
        self.known = Known()
        self.staged: Id | None = None  # the staging folder this update made (the only one it may clear)
        self.switched = False
        self.kept: Path | None = None

    def __enter__(self) -> FolderUpdate:
        self.placing = _holds(self.root)
        if self.placing and not self.here:
            raise ConfigError("the output folder is replaced whole when the run ends, so it cannot be the working "
                              "folder or hold it; choose another folder", file=_short(self.shown))
        if os.path.lexists(self.root) and not os.path.isdir(self.root):
            raise ConfigError("the output folder is a file", file=_short(self.shown))
        self._check_switchable()
        try:
            for folder in reversed([p for p in (self.parent, *self.parent.parents) if not p.exists()]):
                folder.mkdir()
                self.made.append(folder)
            journal = self.lock.acquire(self.shown, self.say)
        except OSError as exc:
            self._tidy()
            raise RunError(f"cannot lock the output folder {_short(self.shown)}: {exc.strerror or exc}") from None
        except BaseException:
            self._tidy()
            raise
        try:
            self._repair(journal)
            self._check_mounts()
            self._stage()
        except BaseException as exc:
            self.__exit__(None, None, None)
            if isinstance(exc, OSError):
                raise RunError(f"cannot stage files beside {_short(self.shown)}: {exc.strerror or exc}") from None
            raise
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        try:
            if not self.switched and self.staged is not None and _id(self.next) == self.staged:
                _remove_tree(self.next)  # all of it is the update's: its files and links to X's
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

    def _check_switchable(self) -> None:
        """Refuse, before any work, a folder that cannot be switched: a mount point, or one in a folder this
        user cannot write (where neither the lock nor the staging folder can be made)."""
        info = _lstat(self.root)
        if info is not None and _is_mount(self.root, info):
            raise ConfigError(f"a mount point; stackx switches an output folder whole and cannot switch a mount: "
                              f"choose a folder inside it, e.g. {_short(self.shown / 'run')}", file=_short(self.shown))
        base = next(p for p in (self.parent, *self.parent.parents) if os.path.lexists(p))
        if not os.access(base, os.W_OK | os.X_OK):
            why = "on a read-only file system" if _read_only(base) else "not writable by this user"
            inside = info is not None and os.access(self.root, os.W_OK | os.X_OK) and not _read_only(self.root)
            hint = "choose a folder inside it" if inside else "choose one in a writable place"
            raise ConfigError(f"{_short(base)} is {why}, and stackx switches an output folder with a hidden folder "
                              f"made beside it: {hint}", file=_short(self.shown))

    def _check_mounts(self) -> None:
        """Refuse a folder with another file system mounted inside it (the switch would carry it off)."""
        if _lstat(self.root) is None:
            return
        found = _mount_inside(self.root)
        if found is not None:
            shown = self.shown / os.path.relpath(found, os.path.realpath(self.root))
            raise ConfigError(f"{_short(shown)} is another file system mounted inside it; stackx never switches, "
                              f"moves or removes across file systems: unmount it or choose another output folder",
                              file=_short(self.shown))

    def _repair(self, journal: dict[str, Any]) -> None:
        """Settle what a killed writer left beside the folder, as its journal says (see the module's text)."""
        for hidden in (self.prev, self.next):
            _check_own(hidden, self.near / hidden.name, self.shown)
        if _lstat(self.root) is None and os.path.isdir(self.prev):
            os.rename(self.prev, self.root)  # a switch killed between its two renames: the old folder back
        state, staged = journal.get("state"), journal.get("staged")
        switched = state == "switching" and staged == list(_id(self.root) or ())
        known = Known.read(journal) if switched else Known()
        settled = True
        if os.path.isdir(self.prev):
            settled = self._settle(self.prev, known)  # the old folder of a switch by two renames
        if os.path.isdir(self.next):
            if switched:
                settled = self._settle(self.next, known) and settled  # the old folder of an exchange
            else:
                if state == "placing" and staged == list(_id(self.next) or ()):
                    _take_back(self.next, self.root, journal.get("made"))
                if not _remove_tree(self.next):
                    raise ConfigError(f"cannot clear {_short(self.near / self.next.name)}, a killed run's staging "
                                      f"folder: it holds a mount or an entry stackx cannot remove; remove it and "
                                      f"run again", file=_short(self.shown))
        if not settled:
            raise RunError(f"cannot settle the folder a killed stackx switched out beside {_short(self.shown)}; "
                           f"remove some .{self.root.name}.stackx-kept-N folders, then run again")
        self.lock.note({})

    def _stage(self) -> None:
        """Make the staging folder, with ``root``'s owner, group and mode (kept writable by its owner until the
        switch), so what the update makes inside it takes the group it would take in ``root``."""
        os.mkdir(self.next)
        self.staged = _id(self.next)
        info = _lstat(self.root)
        if info is not None:
            _dress(self.next, info, writable=True)

    def read(self, name: str) -> bytes | None:
        """The bytes of record ``name`` (``timing.json``) as the update leaves it (None: no such file after the
        update). Read with the bound of a folder's records: a link, a non-file or a file over
        ``manifest.RECORD_BYTES`` is refused in one line naming it (``manifest.read_record``)."""
        from stackx.output.manifest import read_record

        if name in self.removed:
            return None
        path = (self.next if name in self.added else self.root) / name
        return read_record(path, shown=self.shown / name)

    def write(self, files: dict[str, bytes]) -> None:
        """Stage an experiment's ``files`` (name -> bytes); refuse them all, before writing any, when a name
        leaves the folder, meets a link or a file in the way, or names a file of the folder that is not the
        update's own (``ours``), or when the disk cannot hold them."""
        try:
            for name in files:
                self._check_free(safe_relative(name))
        except ValueError as exc:
            raise ConfigError(str(exc), file=_short(self.shown)) from None
        self.write_records({safe_relative(name): data for name, data in files.items()})

    def _check_free(self, name: str) -> None:
        check_place(self.root, name)
        if name not in self.ours and name not in self.added and os.path.lexists(self.root / name):
            raise ValueError(f"{self.root / name} is not a file stackx wrote (manifest.json does not list it), "
                             f"and stackx replaces only its own files: move it away or choose another path")

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
        """Carry the entries the update leaves alone into the staged folder, switch it in for ``root`` and
        settle the old folder (or, where ``root`` holds the working folder, place the staged files)."""
        with interrupt.held():  # a Ctrl-C waits for the switch (an instant), so its message stays true
            if self.placing:
                self._place()
            else:
                self._switch()
            interrupt.switched()
        self.made = []

    def _switch(self) -> None:
        try:
            there = _lstat(self.root)
            if there is not None:
                self._carry()
                _dress(self.next, there, writable=False)
            for folder in self._folders():
                sync_folder(folder)
            if there is None:
                os.rename(self.next, self.root)
                self.switched = True
                sync_folder(self.parent)
                return
            self.lock.note({"state": "switching", "staged": list(self.staged or ()), **self.known.journal()})
            if _exchange(self.next, self.root):
                old = self.next
            else:
                os.rename(self.root, self.prev)
                try:
                    os.rename(self.next, self.root)
                except OSError:
                    os.rename(self.prev, self.root)
                    raise
                old = self.prev
            self.switched = True
            sync_folder(self.parent)
        except OSError as exc:
            if not self.switched:  # a failed exchange changed nothing: what is beside X is only staging
                self.lock.note({})
            raise RunError(f"cannot switch {self.shown} to the run's files: {exc.strerror or exc}; "
                           f"{self.shown} left as it was") from None
        if self._settle(old, self.known):
            self.lock.note({})

    def _folders(self) -> Iterator[Path]:
        yield self.next
        for top, dirs, _ in os.walk(self.next):
            for d in dirs:
                yield Path(top) / d

    def _carry(self) -> None:
        """Link every entry of ``root`` that the update neither replaces nor removes into the staged folder,
        noting what it leaves out (``known``); a mount met on the way stops the update."""
        src = _open_dir(self.root)
        try:
            dst = _open_dir(self.next)
            try:
                self._carry_into(src, dst, "", os.fstat(src).st_dev)
            finally:
                os.close(dst)
        finally:
            os.close(src)

    def _carry_into(self, src: int, dst: int, rel: str, dev: int) -> None:
        for name in os.listdir(src):
            path = rel + name
            info = _lstat_at(src, name)
            if info is None:
                continue
            if info.st_dev != dev:
                raise RunError(f"{_short(self.shown / path)} is another file system, mounted while the run ran; "
                               f"stackx carries nothing across file systems, so {self.shown} is left as it was")
            if stat.S_ISDIR(info.st_mode):
                self._carry_folder(src, dst, name, path, info)
            elif path in self.added or path in self.removed or STALE_TEMP.match(name):
                self.known.left[path] = (info.st_dev, info.st_ino)
            else:
                self._carry_file(src, dst, name, path, info)

    def _carry_folder(self, src: int, dst: int, name: str, path: str, info: os.stat_result) -> None:
        try:
            os.mkdir(name, dir_fd=dst)
        except FileExistsError:
            pass  # the update wrote files into it: it is its own folder, dressed as X's below
        inner_src, inner_dst = _open_dir_at(src, name), None
        try:
            inner_dst = _open_dir_at(dst, name)
            self._carry_into(inner_src, inner_dst, path + "/", info.st_dev)
        finally:
            os.close(inner_src)
            if inner_dst is not None:
                os.close(inner_dst)
        _dress_at(dst, name, info)  # last: a read-only folder is filled first

    def _carry_file(self, src: int, dst: int, name: str, path: str, info: os.stat_result) -> None:
        try:
            os.link(name, name, src_dir_fd=src, dst_dir_fd=dst, follow_symlinks=False)
        except FileExistsError:
            self.known.left[path] = (info.st_dev, info.st_ino)
        except OSError as exc:
            if exc.errno == errno.EXDEV or not stat.S_ISREG(info.st_mode):
                raise
            _copy_at(src, dst, name, info)  # e.g. another user's file, which this one may not link
            self.known.copied[path] = (info.st_dev, info.st_ino, info.st_size, info.st_mtime_ns)

    def _settle(self, old: Path, known: Known) -> bool:
        """Empty the old folder of a switch into the new ``root`` (see the module's text) and remove it; what
        has no place there is moved to a kept folder, named in one line. False when the old folder could not
        be moved aside (it stays, and the journal sends the next writer to it)."""
        try:
            left = _settle_tree(old, self.root, known)
        except OSError:
            left = -1
        if left == 0:
            try:
                os.rmdir(old)
                return True
            except OSError:
                pass
        try:
            self.kept = _keep(old, self.parent, self.root.name)
        except OSError:
            return False
        count = "some entries" if left < 0 else "1 entry" if left == 1 else f"{left} entries"
        self.say(f"kept: {count} of {self.shown} that stackx did not write had no free place in the new folder; "
                 f"they are in {self.near / self.kept.name}")
        return True

    def _place(self) -> None:
        """Link the staged files into ``root`` one by one (it holds the working folder, so it cannot be
        switched): only new names, never over an entry; a failure takes back what was placed."""
        made: list[str] = []
        self.lock.note({"state": "placing", "staged": list(self.staged or ()), "made": made})
        try:
            for top, dirs, files in os.walk(self.next):
                rel = Path(top).relative_to(self.next)
                for d in sorted(dirs):
                    target = self.root / rel / d
                    if not os.path.lexists(target):
                        made.append((rel / d).as_posix())
                        self.lock.note({"state": "placing", "staged": list(self.staged or ()), "made": made})
                        target.mkdir()
                    elif target.is_symlink() or not target.is_dir():
                        raise ConfigError(f"{_short(target)} appeared while stackx wrote, and is not a folder; "
                                          f"{self.shown} left as it was", file=_short(self.shown))
                for f in sorted(files):
                    os.link(Path(top) / f, self.root / rel / f, follow_symlinks=False)
            for top, _, _ in os.walk(self.next):
                sync_folder(self.root / Path(top).relative_to(self.next))
        except BaseException as exc:
            _take_back(self.next, self.root, made)
            self.lock.note({})
            if isinstance(exc, OSError):
                raise RunError(f"cannot write into {self.shown}: {exc.strerror or exc}; {self.shown} left as "
                               f"it was") from None
            raise
        self.lock.note({"state": "placed"})
        _remove_tree(self.next)
        self.switched = True
        self.lock.note({})


def _size(n: int) -> str:
    return f"{n / (1 << 20):.1f} MiB"


def _absolute(root: Path) -> Path:
    """``root`` as an absolute path (a link to a folder followed, once: the user named it); ``ConfigError``
    for a link that loops or a path longer than a file system takes."""
    try:
        path = root.resolve() if root.is_symlink() else root
    except RuntimeError:  # Python before 3.13 reports a loop so
        path = None
    except OSError as exc:
        if exc.errno not in (errno.ELOOP, errno.ENAMETOOLONG):
            raise ConfigError(f"cannot use it as an output folder: {exc.strerror or exc}",
                              file=_short(root)) from None
        path = None if exc.errno == errno.ELOOP else root
    if path is None:
        raise ConfigError("a link that leads round in a loop (to itself, or through other links back to itself); "
                          "name a folder", file=_short(root))
    absolute = Path(os.path.abspath(path))
    try:
        os.lstat(absolute)
    except (FileNotFoundError, NotADirectoryError):
        pass
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise ConfigError("its path goes through a link that leads round in a loop; name a folder",
                              file=_short(root)) from None
        if exc.errno != errno.ENAMETOOLONG:
            raise ConfigError(f"cannot use it as an output folder: {exc.strerror or exc}",
                              file=_short(root)) from None
    size = len(os.fsencode(absolute))
    names = [len(os.fsencode(part)) for part in absolute.parts[1:]] or [0]
    if size + len(HIDDEN) + 1 >= PATH_MAX or max(names) > NAME_MAX or names[-1] + len(HIDDEN) + 1 > NAME_MAX:
        raise ConfigError(f"a path of {size:,} bytes (longest name {max(names):,}): too long for the hidden folders "
                          f"stackx makes beside it (at most {PATH_MAX - 2 - len(HIDDEN):,} bytes, last name "
                          f"{NAME_MAX - 1 - len(HIDDEN)}); choose a shorter one", file=_short(root))
    return absolute


def _holds(root: Path) -> bool:
    """Whether ``root`` is the working folder or holds it."""
    try:
        here = Path.cwd().resolve()
        real = root.resolve()
    except (OSError, RuntimeError):
        return False
    return here == real or real in here.parents


def _lstat(path: Path) -> os.stat_result | None:
    try:
        return os.lstat(path)
    except (FileNotFoundError, NotADirectoryError):
        return None


def _lstat_at(dir_fd: int, name: str) -> os.stat_result | None:
    try:
        return os.stat(name, dir_fd=dir_fd, follow_symlinks=False)
    except FileNotFoundError:
        return None


def _id(path: Path) -> Id | None:
    info = _lstat(path)
    return None if info is None else (info.st_dev, info.st_ino)


def _open_dir(path: Path) -> int:
    return os.open(path, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) | NOFOLLOW | FLAGS)


def _open_dir_at(dir_fd: int, name: str) -> int:
    return os.open(name, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) | NOFOLLOW | FLAGS, dir_fd=dir_fd)


def _check_own(path: Path, named: Path, shown: Path) -> None:
    """Refuse a hidden name beside the folder that is a link, not a folder, or not this user's."""
    info = _lstat(path)
    if info is None:
        return
    what = ("a link" if stat.S_ISLNK(info.st_mode) else "not a folder" if not stat.S_ISDIR(info.st_mode) else
            "another user's folder" if info.st_uid != os.geteuid() else None)
    if what is not None:
        raise ConfigError(_not_made(named, what), file=_short(shown))


def _read_only(path: Path) -> bool:
    try:
        return bool(os.statvfs(path).f_flag & os.ST_RDONLY)
    except (OSError, AttributeError):
        return False


def _mount_points() -> list[str]:
    """Every mount point this process sees (Linux's ``/proc/self/mountinfo``; none elsewhere, where
    ``st_dev`` alone tells a mount). Bind mounts of one file system share its ``st_dev``, so they are found
    only here."""
    try:
        with open("/proc/self/mountinfo", "rb") as fh:
            lines = fh.read().splitlines()
    except OSError:
        return []
    unescape = re.compile(rb"\\([0-7]{3})")
    points = []
    for line in lines:
        fields = line.split(b" ")
        if len(fields) > 4:
            points.append(os.fsdecode(unescape.sub(lambda m: bytes([int(m[1], 8)]), fields[4])))
    return points


def _is_mount(path: Path, info: os.stat_result) -> bool:
    try:
        parent = os.stat(path.parent)
    except OSError:
        return False
    return info.st_dev != parent.st_dev or os.path.realpath(path) in _mount_points()


def _mounts_under(path: Path) -> list[str]:
    """The mount points strictly inside ``path``, as real paths."""
    real = os.path.realpath(path).rstrip("/") + "/"
    return [p for p in _mount_points() if p.startswith(real)]


def _mount_inside(root: Path) -> str | None:
    """The first mount found inside ``root`` (by the mount table, then by walking it without following
    links: an entry on another device), None when there is none."""
    listed = _mounts_under(root)
    if listed:
        return listed[0]
    dev = os.lstat(root).st_dev
    folders = [str(root)]
    while folders:
        try:
            entries = list(os.scandir(folders.pop()))
        except (FileNotFoundError, NotADirectoryError):
            continue
        for entry in entries:
            try:
                info = entry.stat(follow_symlinks=False)
            except FileNotFoundError:
                continue
            if info.st_dev != dev:
                return entry.path
            if stat.S_ISDIR(info.st_mode):
                folders.append(entry.path)
    return None


def _dress(path: Path, info: os.stat_result, writable: bool) -> None:
    """Give folder ``path`` the owner, group and mode (setgid bit included) of ``info``, where this user may;
    ``writable`` keeps it writable by its owner meanwhile."""
    try:
        os.chown(path, info.st_uid, info.st_gid, follow_symlinks=False)
    except OSError:
        pass  # not permitted: the update's own owner and group stay
    os.chmod(path, stat.S_IMODE(info.st_mode) | (stat.S_IRWXU if writable else 0))


def _dress_at(dir_fd: int, name: str, info: os.stat_result) -> None:
    try:
        os.chown(name, info.st_uid, info.st_gid, dir_fd=dir_fd, follow_symlinks=False)
    except OSError:
        pass
    os.chmod(name, stat.S_IMODE(info.st_mode), dir_fd=dir_fd)


def _copy_at(src: int, dst: int, name: str, info: os.stat_result) -> None:
    """Copy the regular file ``name`` (the one ``info`` describes) within one file system, keeping its mode,
    times and, where permitted, owner and group."""
    fin = os.open(name, os.O_RDONLY | NOFOLLOW | FLAGS, dir_fd=src)
    try:
        found = os.fstat(fin)
        if (found.st_dev, found.st_ino) != (info.st_dev, info.st_ino):
            raise OSError(errno.EAGAIN, "the file changed while it was carried", name)
        fout = os.open(name, os.O_WRONLY | os.O_CREAT | os.O_EXCL | NOFOLLOW | FLAGS, 0o600, dir_fd=dst)
        try:
            while chunk := os.read(fin, 1 << 20):
                os.write(fout, chunk)
            try:
                os.fchown(fout, info.st_uid, info.st_gid)
            except OSError:
                pass
            os.fchmod(fout, stat.S_IMODE(info.st_mode))
            os.utime(fout, ns=(info.st_atime_ns, info.st_mtime_ns))
        finally:
            os.close(fout)
    finally:
        os.close(fin)


def _renameat2(src_fd: int, src: str | Path, dst_fd: int, dst: str | Path, flags: int) -> bool:
    """``renameat2``; False when the system has no such call or the file system not the flag (then nothing
    happened)."""
    try:
        call = ctypes.CDLL(None, use_errno=True).renameat2
    except (AttributeError, OSError):
        return False
    if call(src_fd, os.fsencode(src), dst_fd, os.fsencode(dst), flags) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP):
        return False
    raise OSError(code, os.strerror(code), str(dst))


def _exchange(a: Path, b: Path) -> bool:
    """Swap two folders atomically; False when the system cannot (then nothing happened)."""
    return _renameat2(AT_CWD, a, AT_CWD, b, EXCHANGE)


def _move(src_fd: int, dst_fd: int, name: str) -> bool:
    """Move entry ``name`` between two folders of one file system, only to a free name; False when taken."""
    try:
        if _renameat2(src_fd, name, dst_fd, name, NOREPLACE):
            return True
    except FileExistsError:
        return False
    if _lstat_at(dst_fd, name) is not None:  # no such flag here: look, then move (a narrow race, no loss)
        return False
    os.rename(name, name, src_dir_fd=src_fd, dst_dir_fd=dst_fd)
    return True


def _settle_tree(old: Path, new: Path, known: Known) -> int:
    """Remove from ``old`` what is stackx's, move the rest into ``new`` where its name is free; return how
    many entries of ``old`` stay (a mount is never entered, moved or removed)."""
    mounts = _mounts_under(old)
    old_fd = _open_dir(old)
    try:
        new_fd = _open_dir(new)
        try:
            base = os.path.realpath(old).rstrip("/") + "/"
            skip = {m[len(base):] for m in mounts}
            return _settle_in(old_fd, new_fd, "", os.fstat(old_fd).st_dev, known, skip)
        finally:
            os.close(new_fd)
    finally:
        os.close(old_fd)


def _settle_in(old_fd: int, new_fd: int, rel: str, dev: int, known: Known, skip: set[str]) -> int:
    left = 0
    for name in os.listdir(old_fd):
        try:
            left += _settle_entry(old_fd, new_fd, name, rel, dev, known, skip)
        except FileNotFoundError:
            continue
        except OSError:
            left += 1
    return left


def _settle_entry(old_fd: int, new_fd: int, name: str, rel: str, dev: int, known: Known, skip: set[str]) -> int:
    """Settle one entry of the old folder; 1 when it stays there, else 0."""
    path = rel + name
    info = os.stat(name, dir_fd=old_fd, follow_symlinks=False)
    if info.st_dev != dev or path in skip:
        return 1
    there = _lstat_at(new_fd, name)
    if stat.S_ISDIR(info.st_mode):
        if there is None:
            return 0 if _move(old_fd, new_fd, name) else 1
        if not stat.S_ISDIR(there.st_mode) or there.st_dev != dev:
            return 1
        inner_old = _open_dir_at(old_fd, name)
        try:
            inner_new = _open_dir_at(new_fd, name)
            try:
                inside = _settle_in(inner_old, inner_new, path + "/", dev, known, skip)
            finally:
                os.close(inner_new)
        finally:
            os.close(inner_old)
        if inside:
            return 1
        os.rmdir(name, dir_fd=old_fd)  # empty, and the new folder has it too
        return 0
    same = there is not None and (there.st_dev, there.st_ino) == (info.st_dev, info.st_ino)
    if same or known.owns(path, info):
        os.unlink(name, dir_fd=old_fd)
        return 0
    if there is None:
        return 0 if _move(old_fd, new_fd, name) else 1
    return 1


def _keep(old: Path, parent: Path, name: str) -> Path:
    """Move an old folder that still holds entries to the first free ``.NAME.stackx-kept-N`` beside it
    (``OSError`` when there is none)."""
    for n in range(1, KEPT_MAX + 1):
        kept = parent / f".{name}.stackx-kept-{n}"
        try:
            if _renameat2(AT_CWD, old, AT_CWD, kept, NOREPLACE):
                return kept
        except FileExistsError:
            continue
        if not os.path.lexists(kept):
            os.rename(old, kept)
            return kept
    raise OSError(errno.EEXIST, "every kept folder name is taken", str(parent))


def _remove_tree(path: Path) -> bool:
    """Remove a folder stackx made (a staging folder), without following a link or crossing into another
    file system; False when something stays (a mount inside, or an entry it could not remove)."""
    if _mounts_under(path):
        return False
    try:
        fd = _open_dir(path)
    except FileNotFoundError:
        return True
    except OSError:
        return False
    try:
        whole = _empty(fd, os.fstat(fd).st_dev)
    finally:
        os.close(fd)
    if whole:
        try:
            os.rmdir(path)
        except OSError:
            return False
    return whole


def _empty(fd: int, dev: int) -> bool:
    whole = True
    for name in os.listdir(fd):
        try:
            info = os.stat(name, dir_fd=fd, follow_symlinks=False)
            if info.st_dev != dev:
                whole = False
            elif stat.S_ISDIR(info.st_mode):
                inner = _open_dir_at(fd, name)
                try:
                    done = _empty(inner, dev)
                finally:
                    os.close(inner)
                if done:
                    os.rmdir(name, dir_fd=fd)
                else:
                    whole = False
            else:
                os.unlink(name, dir_fd=fd)
        except FileNotFoundError:
            continue
        except OSError:
            whole = False
    return whole


def _take_back(staging: Path, root: Path, made: object) -> None:
    """Undo a placing: remove from ``root`` each file that is the staged file itself (the same inode), then
    the folders the placing made, if empty; nothing else of ``root`` is touched."""
    for top, _, files in os.walk(staging):
        rel = Path(top).relative_to(staging)
        for f in files:
            staged, placed = _id(Path(top) / f), _id(root / rel / f)
            if staged is not None and staged == placed:
                (root / rel / f).unlink()
    for folder in reversed(made if isinstance(made, list) else []):
        if isinstance(folder, str) and folder and ".." not in PurePosixPath(folder).parts:
            try:
                (root / folder).rmdir()
            except OSError:
                pass
