"""Attacks on the output folder ``X``: what other programs keep in it or beside it must come out untouched.

The contract (docs/outputs.md): a run writes, replaces and removes only the entries it wrote, never crosses a
file-system boundary, never follows a link it did not make, keeps X's mode, owner, group and setgid, and
refuses up front an ``--out`` it cannot switch (or falls back to a switch that works there).
"""

from __future__ import annotations

import grp
import os
import shutil
import stat
import threading
import time
from pathlib import Path

from benchmarks.attacks.kit import (CONFIGS, Finished, Outcome, complete_run, is_mount, manifest_problems,
                                    mount_tmpfs, mounts_under, run, snapshot, stackx, stackx_argv)

BLOW_UP = ("--set", "gravity=1e5")
"""Makes 03-sink fail while stepping (exit 1): a run refused with exit 2 instead was refused before it stepped."""
WRITER_PERIOD_S = 0.001
WRITER_RUNS = 3


def _refusal_or_complete(done: Finished, folder: Path) -> str:
    """'' when ``done`` is a one-line refusal or a success leaving ``folder`` complete; else what is wrong."""
    if done.traceback:
        return "a traceback"
    if done.code == 2:
        return "" if done.one_line_refusal() else "exit 2 without one error line"
    if done.code == 0:
        problems = manifest_problems(folder)
        return "; ".join(problems[:2])
    return done.brief()


def mount_inside(root: Path) -> Outcome:
    """A tmpfs mounted at X/data holding two files; a run into X: the files survive, the mount stays, and the
    run is refused (or leaves X complete without touching the mounted volume)."""
    x = root / "X"
    complete_run("03-sink", x, root)
    data = x / "data"
    mount_tmpfs(data)
    theirs = {"a.bin": os.urandom(4096), "b.txt": b"another program's file\n"}
    for name, body in theirs.items():
        (data / name).write_bytes(body)
    done = stackx("run", CONFIGS / "06-stack.yaml", "--out", x, "-q", cwd=root)
    volume = next(iter(mounts_under(root)), None)  # wherever the mount is now: a copy in X is not the volume
    lost = sum(1 for name, body in theirs.items() if volume is None or not _holds(volume / name, body))
    mounted = volume == Path(os.path.realpath(data))
    wrong = _refusal_or_complete(done, x) if mounted else f"the volume is now at {volume}"
    figure = f"files lost {lost} of {len(theirs)}, {done.brief()}" + (f"; {wrong}" if wrong else "")
    return Outcome(lost == 0 and not wrong, figure)


def _holds(path: Path, body: bytes) -> bool:
    try:
        return path.is_file() and not path.is_symlink() and path.read_bytes() == body
    except OSError:
        return False


class Writer(threading.Thread):
    """Another program writing into X: a new file every ``period`` seconds, by name, until stopped; keeps the
    names it created (a creation that failed is counted apart: that program saw an error, nothing was lost)."""

    def __init__(self, folder: Path, period: float) -> None:
        super().__init__(daemon=True)
        self.folder = folder
        self.period = period
        self.created: list[str] = []
        self.failed = 0
        self.halt = threading.Event()

    def run(self) -> None:
        i = 0
        while not self.halt.is_set():
            name = f"theirs-{i:06d}.txt"
            try:
                with open(self.folder / name, "x") as fh:
                    fh.write(name)
                self.created.append(name)
            except OSError:
                self.failed += 1
            i += 1
            time.sleep(self.period)


def concurrent_writer(root: Path) -> Outcome:
    """Runs into X while another program creates a file in X every millisecond: every file it created is
    still there afterwards."""
    x = root / "X"
    complete_run("03-sink", x, root)
    writer = Writer(x, WRITER_PERIOD_S)
    writer.start()
    try:
        codes = [stackx("run", CONFIGS / "06-stack.yaml", "--out", x, "-q", cwd=root).code
                 for _ in range(WRITER_RUNS)]
    finally:
        writer.halt.set()
        writer.join(10)
    lost = [n for n in writer.created if not _holds(x / n, n.encode())]
    figure = (f"files lost {len(lost)} of {len(writer.created)} over {WRITER_RUNS} runs (exits {codes}; "
              f"{writer.failed} creations failed)")
    return Outcome(not lost and codes == [0] * WRITER_RUNS, figure)


def lock_link(root: Path) -> Outcome:
    """``.X.stackx-lock`` planted as a link to a file of the user's: a run must not write through it."""
    x = root / "X"
    complete_run("03-sink", x, root)
    victim = root / "precious.txt"
    body = b"a file the lock link points at\n" * 4
    victim.write_bytes(body)
    os.symlink(victim, root / ".X.stackx-lock")
    done = stackx("run", CONFIGS / "06-stack.yaml", "--out", x, "-q", cwd=root)
    kept = _holds(victim, body)
    wrong = _refusal_or_complete(done, x)
    return Outcome(kept and not wrong, f"target {'unchanged' if kept else 'CHANGED'}, {done.brief()}"
                   + (f"; {wrong}" if wrong else ""))


def staging_links(root: Path) -> Outcome:
    """``.X.stackx-prev`` (X missing) and ``.X.stackx-next`` (X a complete run) planted as links to another
    user's folder: the run must not follow them, neither taking their files into X nor writing into them."""
    theirs = root / "planter"
    theirs.mkdir()
    (theirs / "planted.txt").write_text("the planter's file\n")
    before = snapshot(theirs)
    results = []
    for kind, exists in (("prev", False), ("next", True)):
        x = root / f"X{kind}"
        if exists:
            complete_run("03-sink", x, root)
        os.symlink(theirs, root / f".{x.name}.stackx-{kind}")
        done = stackx("run", CONFIGS / "06-stack.yaml", "--out", x, "-q", cwd=root)
        wrong = _taken_in(x, theirs) or _refusal_or_complete(done, x)
        results.append((kind, done, wrong))
    untouched = snapshot(theirs) == before
    wrongs = [f"{kind}: {wrong}" for kind, _, wrong in results if wrong]
    figure = ", ".join(f"{kind} link: {done.brief()}" for kind, done, _ in results)
    figure += f"; the planter's folder {'unchanged' if untouched else 'CHANGED'}"
    return Outcome(untouched and not wrongs, figure + "".join(f"; {w}" for w in wrongs))


def _taken_in(x: Path, theirs: Path) -> str:
    """What of ``theirs`` ended up in ``x``: X itself a link, or one of their files (by name or by inode)."""
    if x.is_symlink():
        return "X became a link"
    if not x.exists():
        return ""
    inodes = {(p.stat().st_dev, p.stat().st_ino) for p in theirs.rglob("*") if p.is_file()}
    for p in x.rglob("*"):
        if p.name == "planted.txt" or (p.is_file() and (p.stat().st_dev, p.stat().st_ino) in inodes):
            return f"their file is in X as {p.relative_to(x)}"
    return ""


def _group() -> int:
    """A group other than root's, for a shared folder."""
    for name in ("users", "staff", "nogroup"):
        try:
            return grp.getgrnam(name).gr_gid
        except KeyError:
            continue
    return 65534


def modes(root: Path) -> Outcome:
    """X kept private (0700, with a 0700 sub-folder of the user's) and X a setgid group folder (02770, another
    group): after a first run into it and a second over it, X's mode, owner and group, and the sub-folder's
    mode, are as they were."""
    cases = {"private": (0o700, None), "shared": (0o2770, _group())}
    changes = []
    for label, (mode, gid) in cases.items():
        x = root / label
        x.mkdir()
        mine = x / "mine"
        mine.mkdir()
        (mine / "note.txt").write_text("kept\n")
        os.chmod(mine, 0o700)
        if gid is not None:
            os.chown(x, -1, gid)
        os.chmod(x, mode)  # after chown, which may clear setgid
        want = _owner_mode(x), _owner_mode(mine)
        for config in ("03-sink", "06-stack"):
            done = stackx("run", CONFIGS / f"{config}.yaml", "--out", x, "-q", cwd=root)
            if done.code != 0:
                changes.append(f"{label}: run of {config} {done.brief()}: {done.stderr.strip()[-160:]}")
                break
        got = _owner_mode(x), _owner_mode(mine) if mine.exists() else "gone"
        if got != want:
            changes.append(f"{label}: {_show(want)} became {_show(got)}")
    figure = "; ".join(changes) if changes else "0700 and 02770 (group kept) after two runs, sub-folder 0700"
    return Outcome(not changes, figure)


def _owner_mode(path: Path) -> tuple[int, int, int]:
    st = path.stat()
    return st.st_uid, st.st_gid, stat.S_IMODE(st.st_mode)


def _show(modes: tuple[object, ...]) -> str:
    return "/".join(f"{m[2]:04o} gid {m[1]}" if isinstance(m, tuple) else str(m) for m in modes)


def out_mount_point(root: Path) -> Outcome:
    """``--out`` naming a mount point (the volume holds a file of the user's): refused before anything steps
    (a run that would fail while stepping is refused with exit 2, not 1), or a switch that works there."""
    x = root / "X"
    mount_tmpfs(x)
    body = b"on the volume before any run\n"
    (x / "keep.txt").write_bytes(body)
    late = stackx("run", CONFIGS / "03-sink.yaml", "--out", x, "-q", *BLOW_UP, cwd=root)
    how = ""
    if late.one_line_refusal():
        how = "refused up front"
    elif not _stepped(late):
        how = f"a run that blows up: {late.brief()}: {late.stderr.strip()[-160:]}"
    else:
        good = stackx("run", CONFIGS / "06-stack.yaml", "--out", x, "-q", cwd=root)
        problems = manifest_problems(x) if good.code == 0 else [good.brief()]
        how = "a switch that works there" if not problems else f"only after stepping; then {problems[0]}"
    kept = _holds(x / "keep.txt", body) and is_mount(x)
    passed = how in ("refused up front", "a switch that works there") and kept
    return Outcome(passed, f"{how or late.brief()}; the volume's file {'kept' if kept else 'LOST'}")


def _stepped(done: Finished) -> bool:
    """The run of ``BLOW_UP`` reached its stepping: exit 1 naming the blow-up, no traceback."""
    return done.code == 1 and "blew up" in done.stderr and not done.traceback


UNPRIVILEGED = ("setpriv", "--bounding-set=-dac_override,-dac_read_search,-fowner")
"""Root without the capabilities that pass over file modes: a folder it does not own and may only read is one
it cannot write, as for any other user."""


def unwritable_parent(root: Path) -> Outcome:
    """X writable, in a parent its user cannot write (the parent is another user's, mode 0555): a run is
    refused before anything steps, or a switch that works there leaves X complete."""
    if shutil.which(UNPRIVILEGED[0]) is None:
        return Outcome(None, "needs setpriv to drop root's capabilities")
    parent = root / "shared"
    x = parent / "X"
    x.mkdir(parents=True)
    os.chown(parent, 65534, 65534)
    os.chmod(parent, 0o555)
    late = run([*UNPRIVILEGED, *stackx_argv("run", CONFIGS / "03-sink.yaml", "--out", x, "-q", *BLOW_UP)], root)
    if late.one_line_refusal():
        return Outcome(True, f"refused up front: {late.error_lines()[0][:100]}")
    if not _stepped(late):
        return Outcome(False, f"a run that blows up: {late.brief()}: {late.stderr.strip()[-160:]}")
    good = run([*UNPRIVILEGED, *stackx_argv("run", CONFIGS / "06-stack.yaml", "--out", x, "-q")], root)
    problems = manifest_problems(x) if good.code == 0 else [f"{good.brief()}: {good.stderr.strip()[-160:]}"]
    return Outcome(not problems, "a switch that works there" if not problems else
                   f"failed only after stepping; then {problems[0]}")
