"""An output folder is all-or-nothing: one writer at a time, and a write that fails changes nothing.

Each test starts from an earlier complete run (or no folder) and checks the whole folder, byte for byte,
after the failure: a file too large for the process's file-size limit (how a full disk shows to a writer),
too little free space, and three runs into one folder at once.
"""

from __future__ import annotations

import os
import resource
import select
import shutil
import signal
import subprocess
from pathlib import Path

import pytest
from typer.testing import CliRunner

from benchmarks.robust_folder import command, environ, snapshot, together_trial
from stackx.cli import app
from tests.conftest import CONFIGS, REPO
from tests.limits import hang_limit


@pytest.fixture(scope="module")
def earlier(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A complete run of the lab with another gravity: what every failing run below must leave alone."""
    out = tmp_path_factory.mktemp("earlier") / "out"
    subprocess.run(command(out, "--set", "gravity=-9.0"), check=True, cwd=REPO, env=environ(), timeout=hang_limit(300))
    return out


def _limited(max_bytes: int) -> None:
    """In the child: files may not grow past ``max_bytes`` (writes fail with EFBIG, as on a full disk)."""
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (max_bytes, max_bytes))


def _run_limited(out: Path, max_bytes: int) -> subprocess.CompletedProcess[str]:
    return subprocess.run(command(out), cwd=REPO, env=environ(), timeout=hang_limit(300), capture_output=True, text=True,
                          preexec_fn=lambda: _limited(max_bytes))


def test_a_write_failing_over_an_earlier_run_leaves_it_as_it_was(earlier: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    shutil.copytree(earlier, out)
    before = snapshot(out)
    small = min(len(data) for name, data in before.items() if name.endswith(".png"))
    done = _run_limited(out, small + 1)  # the first picture of the new run cannot be written whole
    assert done.returncode == 1, done.stderr
    [line] = done.stderr.strip().splitlines()
    assert line.startswith(f"error: cannot write {out}/") and line.endswith(f"File too large; {out} left as it was")
    assert snapshot(out) == before
    assert [p.name for p in tmp_path.iterdir()] == ["out"]  # no staging folder, no lock file left beside it


def test_a_first_run_that_fails_to_write_leaves_no_folder(tmp_path: Path) -> None:
    out = tmp_path / "deeper" / "out"
    done = _run_limited(out, 2000)
    assert done.returncode == 1, done.stderr
    assert "File too large" in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "deeper").exists()


def test_too_little_free_space_is_refused_before_writing(earlier: Path, tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "out"
    shutil.copytree(earlier, out)
    before = snapshot(out)
    monkeypatch.setattr("stackx.output.folder.shutil.disk_usage",
                        lambda path: shutil._ntuple_diskusage(10 << 30, (10 << 30) - 4096, 4096))  # type: ignore
    result = CliRunner().invoke(app, ["run", str(CONFIGS / "06-stack.yaml"), "--out", str(out), "-q"])
    assert result.exit_code == 1, result.output
    assert f"error: not enough free space for {out}: the run's files take" in result.stderr
    assert "but the disk has 0.0 MiB left" in result.stderr
    assert snapshot(out) == before


def test_a_second_writer_waits_for_the_first_and_says_so(tmp_path: Path) -> None:
    from stackx.output.folder import FolderLock

    out = tmp_path / "out"
    lock = FolderLock(tmp_path / ".out.stackx-lock")
    lock.acquire(out, None)
    proc = subprocess.Popen(command(out, configs=CONFIGS / "03-sink.yaml"), cwd=REPO, env=environ(),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stderr is not None
        ready, _, _ = select.select([proc.stderr], [], [], 120)
        assert ready, "the second writer did not say it waits"
        assert proc.stderr.readline().strip() == f"waiting: another stackx run (pid {os.getpid()}) is writing {out}"
        assert proc.poll() is None and not out.exists()
    finally:
        lock.release()
    assert proc.wait(timeout=hang_limit(120)) == 0
    assert (out / "manifest.json").is_file() and (out / "03-sink.txt").is_file()


def test_three_runs_into_one_folder_at_once_all_land(tmp_path: Path) -> None:
    for trial in range(2):
        assert together_trial(tmp_path / f"together{trial}") == ""


def test_init_failing_part_way_leaves_nothing(tmp_path: Path) -> None:
    """``stackx init`` stages its files as a run does; a write failing part-way leaves no folder, no staging
    folder and no lock beside the user's own file."""
    from stackx.config.starter import shipped_files, source_root

    root = source_root()
    sizes = [(root / name).stat().st_size for name in sorted(shipped_files(root))]
    limit = sizes[0] + 1  # the first file fits, a later and larger one does not
    assert any(size > limit for size in sizes[1:])
    (tmp_path / "mine.txt").write_text("the user's own file")
    target = tmp_path / "lab"
    done = subprocess.run([*command(target)[:3], "init", str(target)], cwd=REPO, env=environ(), timeout=hang_limit(120),
                          capture_output=True, text=True, preexec_fn=lambda: _limited(limit))
    assert done.returncode == 1, done.stdout + done.stderr
    [line] = done.stderr.strip().splitlines()
    assert line.startswith(f"error: cannot write {target}/") and line.endswith(f"File too large; {target} left "
                                                                                 f"as it was")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine.txt"]
