"""verify reads the folder's own JSON as untrusted data, and names every file its manifest does not know; verify
and run read a folder's files with bounds: sizes compared first, hashes in chunks, records over a bound refused."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from tests.conftest import CONFIGS, Cli
from tests.peak import peak_run

CONFIG = CONFIGS / "06-stack.yaml"


@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from tests.conftest import run_cli

    out = tmp_path_factory.mktemp("made") / "out"
    done = run_cli("run", CONFIG, "--out", out, "-q")
    assert done.returncode == 0, done.stderr
    return out


@pytest.fixture
def copy(made: Path, tmp_path: Path) -> Path:
    out = tmp_path / "out"
    shutil.copytree(made, out)
    return out


def test_stray_files_are_listed_and_count_as_differences(cli: Cli, copy: Path) -> None:
    done = cli("verify", copy, CONFIG)
    assert done.returncode == 0, done.stdout + done.stderr
    frames = sorted(p.name for p in copy.iterdir() if p.name.startswith("f") and p.suffix == ".png")
    assert frames
    extra = [f"f{len(frames) + i:02d}.png" for i in range(3)]  # frames an older, longer run left behind
    for name in extra:
        shutil.copy(copy / frames[0], copy / name)
    (copy / "old").mkdir()
    (copy / "old" / "notes.txt").write_text("kept by hand")
    (copy / "06-stack.failed.json").write_text("{}")  # a failed run's record is the folder's own, not a stray
    done = cli("verify", copy, CONFIG)
    assert done.returncode == 1
    listed = [line for line in done.stdout.splitlines() if line.startswith("DIFF stray: ")]
    assert listed == [f"DIFF stray: {name}: in {copy} but not in its manifest (left by another run, or put there)"
                      for name in [*extra, "old/notes.txt"]]
    assert f"verify: 4 difference(s) in {copy}" in done.stdout


@pytest.mark.parametrize("name", ["manifest.json", "timing.json"])
@pytest.mark.parametrize("depth", [100_000, 500])
def test_deeply_nested_json_is_one_line(cli: Cli, copy: Path, name: str, depth: int) -> None:
    (copy / name).write_text("[" * depth + "]" * depth)
    verified = cli("verify", copy, CONFIG)
    again = cli("run", CONFIG, "--out", copy, "-q")
    for done in (verified, again):
        assert "Traceback" not in done.stderr and "RecursionError" not in done.stderr
    if name == "manifest.json":
        for done in (verified, again):
            assert done.returncode == 2
            assert done.stderr.strip() == f"error: {copy / name}: not a readable stackx manifest (nested deeper " \
                                          f"than 64 levels); move it away to start a new one"
    else:  # wall-clock times are not verified; a run rebuilds a timing file it cannot read
        assert verified.returncode == 0, verified.stdout
        assert again.returncode == 0, again.stderr
        assert (copy / name).read_text().startswith('{\n  "06-stack"')


HUGE = 6_000_000_000  # a sparse file this size takes no disk, and is free to send in a tar
MEMORY = 500 << 20  # most a command may take, in bytes, when the folder holds a huge file


def measured(*args: object, timeout: float = 300) -> tuple[subprocess.CompletedProcess[str], int]:
    """``run_cli``, with the most memory (resident bytes) the command's own process took (``tests.peak``)."""
    from tests.conftest import REPO

    path = os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p)
    with tempfile.TemporaryDirectory() as tmp:
        return peak_run([sys.executable, "-m", "stackx", *map(str, args)], REPO, {**os.environ, "PYTHONPATH": path},
                        Path(tmp), timeout)


def _listing(folder: Path) -> dict[str, tuple[int, int]]:
    """Every file under ``folder`` with its size and modification time: what a refused run must not change."""
    return {p.relative_to(folder).as_posix(): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in sorted(folder.rglob("*"))}


def test_a_huge_artifact_of_another_size_is_a_difference_without_being_read(copy: Path) -> None:
    frame = copy / "f05.png"
    made = frame.stat().st_size
    os.truncate(frame, HUGE)  # the frame, then zeros to 6 GB
    done, memory = measured("verify", copy, CONFIG)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "Traceback" not in done.stderr
    assert f"DIFF 06-stack: f05.png: the file on disk differs from the manifest (changed after the run); {HUGE} " \
           f"bytes, the manifest lists {made}; against the re-run: first different byte at offset {made} ({HUGE} " \
           f"bytes against {made})" in done.stdout
    assert memory < MEMORY, f"{memory >> 20} MiB"


def test_an_artifact_of_the_listed_size_is_hashed_in_chunks(copy: Path) -> None:
    size = 1 << 30
    doc = json.loads((copy / "manifest.json").read_text())
    entry = doc["experiments"]["06-stack"]["artifacts"]["f05.png"]
    made = entry["bytes"]
    entry["bytes"] = size  # the manifest and the file agree on the size: only the bytes can tell
    (copy / "manifest.json").write_text(json.dumps(doc))
    os.truncate(copy / "f05.png", size)
    done, memory = measured("verify", copy, CONFIG)
    assert done.returncode == 1, done.stdout + done.stderr
    assert f"DIFF 06-stack: f05.png: the file on disk differs from the manifest (changed after the run); against " \
           f"the re-run: first different byte at offset {made} ({size} bytes against {made})" in done.stdout
    assert memory < MEMORY, f"{memory >> 20} MiB"


@pytest.mark.parametrize("name", ["manifest.json", "timing.json"])
def test_a_huge_record_is_refused_unread(copy: Path, name: str) -> None:
    record = copy / name
    os.truncate(record, HUGE)
    before = _listing(copy)
    ran, ran_memory = measured("run", CONFIG, "--out", copy, "-q")
    verified, verified_memory = measured("verify", copy, CONFIG)
    assert _listing(copy) == before
    assert ran.returncode == 2, ran.stderr
    lines = ran.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {record}: "), ran.stderr
    assert lines[0].endswith("move it away to start a new one"), ran.stderr
    if name == "manifest.json":
        assert verified.returncode == 2 and verified.stderr == ran.stderr
    else:  # wall-clock times are neither hashed nor verified, so verify does not read them
        assert verified.returncode == 0, verified.stdout + verified.stderr
    assert ran_memory < MEMORY and verified_memory < MEMORY, f"{ran_memory >> 20}, {verified_memory >> 20} MiB"


@pytest.mark.parametrize("name", ["manifest.json", "timing.json"])
def test_a_record_that_is_a_fifo_or_a_link_is_refused_without_waiting(cli: Cli, copy: Path, tmp_path: Path,
                                                                        name: str) -> None:
    record = copy / name
    elsewhere = tmp_path / "elsewhere.json"
    elsewhere.write_bytes(record.read_bytes())
    for planted in ("fifo", "link"):
        record.unlink()
        os.mkfifo(record) if planted == "fifo" else os.symlink(elsewhere, record)
        done = cli("run", CONFIG, "--out", copy, "-q", timeout=120)
        assert done.returncode == 2, done.stderr
        assert len(done.stderr.splitlines()) == 1 and done.stderr.startswith(f"error: {record}: "), done.stderr
        assert record.is_symlink() == (planted == "link") and elsewhere.read_bytes()
