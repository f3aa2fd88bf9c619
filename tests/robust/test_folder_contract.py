"""What a run may touch around its output folder X: its own entries only, on X's file system only, through no
link it did not make, with X's mode and group kept; and what it refuses up front.

Each test plants what an attack or an accident leaves (a mount inside X, a program writing into X while the run
runs, a link at the lock's or a hidden folder's name, a read-only parent) and checks every file concerned, byte
for byte, afterwards. Where the machine does not let the test mount or make a folder immutable, the test is
skipped with the reason. The moments that matter (between the carry and the switch, the switch itself) are
reached by wrapping stackx's own steps or by strace's fault injection, never by timing.
"""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from typer.testing import CliRunner

from benchmarks.robust_folder import command, environ, snapshot
from stackx.cli import app
from stackx.output.folder import FolderUpdate
from tests.conftest import CONFIGS, REPO, Cli
from tests.limits import hang_limit

CONFIG = CONFIGS / "03-sink.yaml"
OTHER_GID = 12345  # a group no file here has: that X kept it shows it was not the default


def _run(out: Path, config: Path = CONFIG) -> tuple[int, str]:
    """``stackx run CONFIG --out NAME -q`` in this process, from the folder holding ``out`` (so its lines name
    it as ``NAME``): (exit code, stderr)."""
    here = Path.cwd()
    os.chdir(out.parent)
    try:
        result = CliRunner().invoke(app, ["run", str(config), "--out", out.name, "-q"])
    finally:
        os.chdir(here)
    return result.exit_code, result.stderr


def _said(err: str, *parts: str) -> None:
    """``err`` is one error line holding each of ``parts``."""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    for part in parts:
        assert part in lines[0], (part, lines[0])


NOT_MADE = "stackx uses only lock files and hidden folders it made itself and follows or repairs nothing else: " \
           "remove it and run again"


def _beside(out: Path) -> list[str]:
    """The hidden entries stackx may leave beside ``out`` (staging, lock, kept folders)."""
    return sorted(p.name for p in out.parent.iterdir() if p.name.startswith(f".{out.name}."))


@pytest.fixture(scope="module")
def earlier(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A complete run of 03-sink with another gravity, plus a file of the user's: copied before each test."""
    out = tmp_path_factory.mktemp("earlier") / "out"
    subprocess.run(command(out, "--set", "gravity=-9.0", configs=CONFIG), check=True, cwd=REPO, env=environ(),
                   timeout=hang_limit(60))
    (out / "notes.txt").write_text("the user's own notes\n")
    return out


@pytest.fixture
def folder(earlier: Path, tmp_path: Path) -> Path:
    out = tmp_path / "X"
    shutil.copytree(earlier, out)
    return out


@pytest.fixture
def no_stepping(monkeypatch: pytest.MonkeyPatch) -> None:
    """Make any stepping fail the test: what must be refused up front is refused before a run steps."""
    def stepped(*args: object, **kwargs: object) -> None:
        raise AssertionError("the run started stepping")

    monkeypatch.setattr("stackx.run.session.open_executor", stepped)


def _mount(kind: str, target: Path, source: Path | None = None) -> None:
    """Mount a tmpfs (or bind ``source``) at ``target``; skip the test when this machine does not allow it."""
    args = ["mount", "-t", "tmpfs", "none", str(target)] if kind == "tmpfs" else \
        ["mount", "--bind", str(source), str(target)]
    if shutil.which("mount") is None:
        pytest.skip("no mount command here")
    done = subprocess.run(args, capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount here ({done.stderr.strip() or done.returncode}): needs root or CAP_SYS_ADMIN")


@pytest.fixture
def mounts() -> Iterator[list[Path]]:
    """Mount points made by a test, unmounted after it whatever happened."""
    made: list[Path] = []
    yield made
    for point in reversed(made):
        subprocess.run(["umount", "-l", str(point)], capture_output=True)


@pytest.mark.parametrize("kind", ["tmpfs", "bind"])
def test_a_file_system_mounted_inside_the_folder_is_refused_and_its_files_survive(
        folder: Path, tmp_path: Path, mounts: list[Path], no_stepping: None, kind: str) -> None:
    source = tmp_path / "elsewhere"
    source.mkdir()
    (folder / "data").mkdir()
    _mount(kind, folder / "data", source)
    mounts.append(folder / "data")
    (folder / "data" / "one.bin").write_bytes(b"\x01" * 100)
    (folder / "data" / "two.txt").write_text("second file on the mounted volume\n")
    before = snapshot(folder)
    code, err = _run(folder)
    assert code == 2, err
    assert err == ("error: X: X/data is another file system mounted inside it; stackx never switches, moves or "
                   "removes across file systems: unmount it or choose another output folder\n")
    assert snapshot(folder) == before and before["data/two.txt"] == b"second file on the mounted volume\n"
    assert _beside(folder) == []


def test_a_stale_staging_folder_holding_a_mount_is_not_emptied(folder: Path, mounts: list[Path]) -> None:
    """A killed run's staging folder is removed by the next run, but never across a mount found inside it."""
    stale = folder.parent / f".{folder.name}.stackx-next"
    (stale / "m").mkdir(parents=True)
    _mount("tmpfs", stale / "m")
    mounts.append(stale / "m")
    (stale / "m" / "keep.txt").write_text("on another file system\n")
    code, err = _run(folder)
    assert code == 2, err
    assert err == ("error: X: cannot clear .X.stackx-next, a killed run's staging folder: it holds a mount or an "
                   "entry stackx cannot remove; remove it and run again\n")
    assert (stale / "m" / "keep.txt").read_text() == "on another file system\n"


def test_entries_made_in_the_folder_while_a_run_runs_are_all_kept(folder: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """Another program writes into X during the run: before the carry (carried over), between the carry and
    the switch (moved into the new X where the name is free), and over names the new X holds (kept aside in a
    hidden folder the run names). Nothing it wrote is lost."""
    stage, carry = FolderUpdate.write_records, FolderUpdate._carry

    def stage_then_write(self: FolderUpdate, files: dict[str, bytes]) -> None:
        stage(self, files)
        (self.root / "during.txt").write_text("written while the run stepped\n")

    def carry_then_write(self: FolderUpdate) -> None:
        carry(self)
        (self.root / "after.txt").write_text("written after the carry\n")
        (self.root / "late").mkdir()
        (self.root / "late" / "deep.txt").write_text("a new folder after the carry\n")
        for name, text in (("notes.txt", "notes saved again\n"), ("03-sink.txt", "the writer's own\n")):
            (self.root / f"{name}.new").write_text(text)
            os.replace(self.root / f"{name}.new", self.root / name)  # a new file at a name the new X holds

    monkeypatch.setattr(FolderUpdate, "write_records", stage_then_write)
    monkeypatch.setattr(FolderUpdate, "_carry", carry_then_write)
    code, err = _run(folder)
    assert code == 0, err
    kept = folder.parent / f".{folder.name}.stackx-kept-1"
    assert err == ("kept: 2 entries of X that stackx did not write had no free place in the new folder; they are "
                   "in .X.stackx-kept-1\n")
    files = snapshot(folder)
    assert files["during.txt"] == b"written while the run stepped\n"
    assert files["after.txt"] == b"written after the carry\n"
    assert files["late/deep.txt"] == b"a new folder after the carry\n"
    assert files["notes.txt"] == b"the user's own notes\n"  # as it was when carried
    assert files["03-sink.txt"].startswith(b"depth_final=")  # the run's
    assert snapshot(kept) == {"notes.txt": b"notes saved again\n", "03-sink.txt": b"the writer's own\n"}
    assert _beside(folder) == [kept.name]


def test_a_run_killed_after_its_switch_is_settled_by_the_next_run(folder: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """Killed between the switch and the settling of the old folder: the next run tells stackx's old files
    (removed) from a file another program wrote meanwhile (moved into X) by the journal in the lock file."""
    class Killed(BaseException):
        pass

    carry = FolderUpdate._carry

    def carry_then_write(self: FolderUpdate) -> None:
        carry(self)
        (self.root / "after.txt").write_text("written after the carry\n")

    def killed(self: FolderUpdate, old: Path, known: object) -> bool:
        raise Killed

    with monkeypatch.context() as patch, pytest.raises(Killed):
        patch.setattr(FolderUpdate, "_carry", carry_then_write)
        patch.setattr(FolderUpdate, "_settle", killed)
        _run(folder)
    assert set(_beside(folder)) == {f".{folder.name}.stackx-lock", f".{folder.name}.stackx-next"}
    assert not (folder / "after.txt").exists()
    code, err = _run(folder)
    assert (code, err) == (0, "")
    assert (folder / "after.txt").read_text() == "written after the carry\n"
    assert _beside(folder) == []


@pytest.mark.parametrize("how", ["symlink", "hard link"])
def test_a_planted_lock_link_is_refused_and_its_target_unchanged(folder: Path, tmp_path: Path, how: str) -> None:
    victim = tmp_path / "victim.txt"
    victim.write_text("a file the run must not write\n")
    lock = folder.parent / f".{folder.name}.stackx-lock"
    os.symlink(victim, lock) if how == "symlink" else os.link(victim, lock)
    before = snapshot(folder)
    code, err = _run(folder)
    assert code == 2, err
    what = "a link" if how == "symlink" else "a file with 2 names (hard links)"
    assert err == f"error: X: .X.stackx-lock is {what}; {NOT_MADE}\n"
    assert victim.read_text() == "a file the run must not write\n"
    assert snapshot(folder) == before


@pytest.mark.parametrize("hidden, x_there", [("prev", True), ("prev", False), ("next", True)])
def test_planted_staging_or_backup_links_are_refused_not_followed(folder: Path, tmp_path: Path, hidden: str,
                                                                  x_there: bool) -> None:
    planted = tmp_path / "planter"
    planted.mkdir()
    (planted / "planted.txt").write_text("the planter's file\n")
    link = folder.parent / f".{folder.name}.stackx-{hidden}"
    os.symlink(planted, link)
    if not x_there:
        shutil.rmtree(folder)
    before = snapshot(folder) if x_there else None
    code, err = _run(folder)
    assert code == 2, err
    assert err == f"error: X: .X.stackx-{hidden} is a link; {NOT_MADE}\n"
    assert snapshot(planted) == {"planted.txt": b"the planter's file\n"}
    assert (snapshot(folder) == before) if x_there else not os.path.lexists(folder)
    assert link.is_symlink()


def test_a_staging_folder_of_another_user_is_refused_not_removed(folder: Path) -> None:
    theirs = folder.parent / f".{folder.name}.stackx-next"
    theirs.mkdir()
    (theirs / "work.txt").write_text("another user's file\n")
    try:
        os.chown(theirs, 54321, -1)
    except PermissionError:
        pytest.skip("giving a folder to another user needs root")
    code, err = _run(folder)
    assert code == 2, err
    assert err == f"error: X: .X.stackx-next is another user's folder; {NOT_MADE}\n"
    assert (theirs / "work.txt").read_text() == "another user's file\n"


@pytest.mark.parametrize("mode", [0o700, 0o2750])
def test_the_folder_keeps_its_mode_owner_group_and_setgid(folder: Path, tmp_path: Path, mode: int) -> None:
    """X and a folder of the user's inside it keep their modes and group; a folder the run makes inside X takes
    X's group as ``mkdir`` would there."""
    config = tmp_path / "deep.yaml"
    config.write_text(CONFIG.read_text().replace("path: 03-sink.txt", "path: deep/03-sink.txt"))
    (folder / "private").mkdir(mode=0o700)
    (folder / "private" / "diary.txt").write_text("mine\n")
    os.chmod(folder / "private", 0o700)
    try:
        os.chown(folder, -1, OTHER_GID)
    except PermissionError:
        pytest.skip("giving a folder a group this user is not in needs root")
    os.chmod(folder, mode)
    code, err = _run(folder, config)
    assert code == 0, err
    info = os.stat(folder)
    assert (stat.S_IMODE(info.st_mode), info.st_gid) == (mode, OTHER_GID)
    assert stat.S_IMODE(os.stat(folder / "private").st_mode) == 0o700
    assert (folder / "private" / "diary.txt").read_text() == "mine\n"
    deep = os.stat(folder / "deep")
    assert deep.st_gid == (OTHER_GID if mode & stat.S_ISGID else os.getegid())
    assert bool(deep.st_mode & stat.S_ISGID) == bool(mode & stat.S_ISGID)


def test_a_first_run_makes_the_folder_as_mkdir_would(tmp_path: Path) -> None:
    out = tmp_path / "fresh"
    done = subprocess.run(command(out, configs=CONFIG), cwd=REPO, env=environ(), timeout=hang_limit(60),
                          capture_output=True, text=True, preexec_fn=lambda: os.umask(0o027))
    assert done.returncode == 0, done.stderr
    assert stat.S_IMODE(os.stat(out).st_mode) == 0o750


def test_an_out_that_is_a_mount_point_is_refused_up_front(tmp_path: Path, mounts: list[Path],
                                                          no_stepping: None) -> None:
    point = tmp_path / "volume"
    point.mkdir()
    _mount("tmpfs", point)
    mounts.append(point)
    code, err = _run(point)
    assert code == 2, err
    assert err == ("error: volume: a mount point; stackx switches an output folder whole and cannot switch a mount: "
                   "choose a folder inside it, e.g. volume/run\n")
    assert list(point.iterdir()) == [] and _beside(point) == []


@pytest.fixture
def unwritable(tmp_path: Path, mounts: list[Path]) -> Iterator[tuple[Path, str]]:
    """A folder that not even root may write into (immutable, else a read-only mount), holding an output folder
    with a file; and what the refusal says of it."""
    parent = tmp_path / "locked"
    parent.mkdir()
    (parent / "X").mkdir()
    (parent / "X" / "kept.txt").write_text("stays\n")
    if shutil.which("chattr") and subprocess.run(["chattr", "+i", str(parent)], capture_output=True).returncode == 0:
        yield parent, "not writable by this user"
        subprocess.run(["chattr", "-i", str(parent)], check=True)
        return
    shutil.rmtree(parent)
    parent.mkdir()
    _mount("tmpfs", parent)
    mounts.append(parent)
    (parent / "X").mkdir()
    (parent / "X" / "kept.txt").write_text("stays\n")
    if subprocess.run(["mount", "-o", "remount,ro", str(parent)], capture_output=True).returncode != 0:
        pytest.skip("neither chattr +i nor a read-only remount is permitted here")
    yield parent, "on a read-only file system"


def test_an_out_in_an_unwritable_folder_is_refused_up_front(unwritable: tuple[Path, str],
                                                            no_stepping: None) -> None:
    parent, why = unwritable
    out = parent / "X"
    code, err = _run(out)
    assert code == 2, err
    hint = "choose a folder inside it" if "writable" in why else "choose one in a writable place"
    assert err == (f"error: X: {parent} is {why}, and stackx switches an output folder with a hidden folder made "
                   f"beside it: {hint}\n")
    assert snapshot(out) == {"kept.txt": b"stays\n"}


def test_bench_refuses_an_out_it_cannot_write_before_benching(unwritable: tuple[Path, str],
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """``bench`` takes the lock and makes its staging folder before the first case steps: an ``--out`` it
    cannot switch is refused then, with the same line as ``run``, not after the whole bench."""
    def stepped(*args: object, **kwargs: object) -> None:
        raise AssertionError("the bench started stepping")

    monkeypatch.setattr("stackx.bench.command.open_executor", stepped)
    parent, why = unwritable
    here = Path.cwd()
    os.chdir(parent)
    try:
        result = CliRunner().invoke(app, ["bench", str(CONFIG), "--solvers", "pgs", "--out", "X", "-q"])
    finally:
        os.chdir(here)
    assert result.exit_code == 2, result.stderr
    _said(result.stderr, f"{parent} is {why}", "stackx switches an output folder with a hidden folder")
    assert snapshot(parent / "X") == {"kept.txt": b"stays\n"}


@pytest.mark.parametrize("name", ["loop", "long"])
def test_an_out_that_loops_or_is_too_long_is_one_line(cli: Cli, tmp_path: Path, name: str) -> None:
    if name == "loop":
        os.symlink("loop", tmp_path / "loop")
        out, said = "loop", "a link that leads round in a loop"
    else:
        out, said = "a" * 5000, "a path of 5,0"
    done = cli("run", CONFIG, "--out", out, "-q", cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    _said(done.stderr, said)
    assert sorted(p.name for p in tmp_path.iterdir()) == (["loop"] if name == "loop" else [])


needs_strace = pytest.mark.skipif(shutil.which("strace") is None, reason="needs strace to kill at exact points")


def _killed(point: tuple[str, int], args: list[str], cwd: Path = REPO) -> int:
    """Run ``python -m stackx ARGS`` killed with SIGKILL on entering the k-th call ``point`` names."""
    call, k = point
    return subprocess.run(["strace", "-qq", "-o", "/dev/null", "-e", f"trace={call}",
                           "-e", f"inject={call}:signal=KILL:when={k}", sys.executable, "-m", "stackx", *args],
                          cwd=cwd, env={**environ(), "PYTHONDONTWRITEBYTECODE": "1"}, timeout=hang_limit(60),
                          stdout=subprocess.DEVNULL,
                          stderr=subprocess.DEVNULL).returncode


@needs_strace
def test_bench_killed_at_its_switch_leaves_the_old_files_or_the_new(tmp_path: Path) -> None:
    """``bench.json`` and ``report.html`` are both the old ones or both new, never one of each (the new bench
    differs from the old in its timings, so each file tells which bench wrote it)."""
    bench = ["bench", str(CONFIG), "--solvers", "pgs", "-q", "--out"]
    old = tmp_path / "old"
    subprocess.run([sys.executable, "-m", "stackx", *bench, str(old)], check=True, cwd=REPO, env=environ(),
                   timeout=hang_limit(60), capture_output=True)
    (old / "notes.txt").write_text("the user's own\n")
    before = snapshot(old)
    for i, point in enumerate([("renameat2", 1), ("rename", 2), ("unlinkat", 1)]):
        out = tmp_path / f"trial{i}"
        shutil.copytree(old, out)
        _killed(point, [*bench, str(out)])
        files = snapshot(out)
        changed = {name for name in ("bench.json", "report.html") if files[name] != before[name]}
        assert changed in (set(), {"bench.json", "report.html"}), (point, changed)
        assert files["notes.txt"] == b"the user's own\n"
    done = subprocess.run([sys.executable, "-m", "stackx", *bench, str(out)], cwd=REPO, env=environ(),
                          timeout=hang_limit(60), capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert _beside(out) == []


def _shipped() -> dict[str, bytes]:
    from stackx.config.starter import shipped_files, source_root

    root = source_root()
    return {name: (root / name).read_bytes() for name in shipped_files(root)}


@needs_strace
def test_init_killed_part_way_leaves_no_folder_or_a_whole_one_and_init_then_works(tmp_path: Path) -> None:
    shipped = _shipped()
    for i, point in enumerate([("rename", 1), ("rename", 5), ("fsync", 10)]):
        lab = tmp_path / f"lab{i}"
        _killed(point, ["init", str(lab)])
        if lab.exists():  # killed after its switch, or never (a point this init does not reach)
            assert snapshot(lab) == shipped, point
            continue
        done = subprocess.run([sys.executable, "-m", "stackx", "init", str(lab)], cwd=REPO, env=environ(),
                              timeout=hang_limit(30), capture_output=True, text=True)
        assert done.returncode == 0, (point, done.stderr)
        assert snapshot(lab) == shipped and _beside(lab) == []


@needs_strace
def test_init_in_the_working_folder_killed_part_way_is_taken_back(tmp_path: Path) -> None:
    """In the working folder (which cannot be switched) init links its files in one by one: killed after four,
    the next init takes those back and writes every file; the user's own file is untouched throughout."""
    lab = tmp_path / "lab"
    lab.mkdir()
    (lab / "mine.txt").write_text("the user's own\n")
    _killed(("linkat", 5), ["init"], cwd=lab)
    assert len(snapshot(lab)) == 1 + 4
    done = subprocess.run([sys.executable, "-m", "stackx", "init"], cwd=lab, env=environ(), timeout=hang_limit(30),
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert snapshot(lab) == {**_shipped(), "mine.txt": b"the user's own\n"} and _beside(lab) == []
