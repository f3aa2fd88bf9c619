"""SIGKILL ``stackx run`` at random moments: every file is the old complete version or the new one.

Two clean runs give the reference bytes: OLD (gravity -9.0) and NEW (the lab as written). Each trial copies
OLD into a folder, starts the NEW run into it and kills it with SIGKILL, either after a random delay or a
random moment after the first file in the folder changed (so that kills land while artifacts are being
replaced). Then every artifact must be byte-equal to its OLD or NEW reference, ``timing.json`` must be
complete JSON, each experiment's entry in ``manifest.json`` must be its OLD or NEW entry (and a NEW entry
only once that experiment's files are all NEW), and the only other files allowed are the hidden temporary
files of an interrupted write, ``.NAME.XXXXXXXX.tmp``, which no artifact name can take.
"""

from __future__ import annotations

import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.conftest import CONFIGS, REPO

TRIALS = 8
TEMP = re.compile(r"^\.(?P<name>.+)\.[A-Za-z0-9_]{8}\.tmp$")
OLD = ("--set", "gravity=-9.0")


def _command(out: Path, *extra: str) -> list[str]:
    return [sys.executable, "-m", "stackx", "run", str(CONFIGS), "--out", str(out), "-q", *extra]


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}


@pytest.fixture(scope="module")
def references(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, bytes], dict[str, bytes], float]:
    root = tmp_path_factory.mktemp("kill-refs")
    subprocess.run(_command(root / "old", *OLD), check=True, cwd=REPO, timeout=300)
    start = time.perf_counter()
    subprocess.run(_command(root / "new"), check=True, cwd=REPO, timeout=300)
    return _snapshot(root / "old"), _snapshot(root / "new"), time.perf_counter() - start


def _changed(folder: Path, old: dict[str, bytes]) -> bool:
    for entry in os.scandir(folder):
        if entry.name not in old or TEMP.match(entry.name):
            return True
    return False


def _check(folder: Path, old: dict[str, bytes], new: dict[str, bytes]) -> tuple[int, int]:
    """Assert the folder holds only complete old or new files; return (#new artifacts, #stale temp files)."""
    files = _snapshot(folder)
    assert not [p for p in folder.iterdir() if not p.is_file()]
    stale = [n for n in files if TEMP.match(n)]
    for name in stale:
        assert TEMP.match(name)["name"] in new, name  # the temp file of a known artifact, hidden
    artifacts = [n for n in files if n not in stale and n not in ("manifest.json", "timing.json")]
    assert set(artifacts) == set(new) - {"manifest.json", "timing.json"}
    fresh = 0
    for name in artifacts:
        assert files[name] in (old[name], new[name]), f"{name} is neither the old nor the new version"
        fresh += files[name] == new[name] != old[name]
    assert isinstance(json.loads(files["timing.json"]), dict)
    entries = json.loads(files["manifest.json"])["experiments"]
    old_entries, new_entries = (json.loads(d["manifest.json"])["experiments"] for d in (old, new))
    for exp, entry in entries.items():
        assert entry in (old_entries[exp], new_entries[exp]), f"manifest entry of {exp} is neither old nor new"
        if entry == new_entries[exp]:
            assert all(files[n] == new[n] for n in entry["artifacts"]), f"{exp} listed as new before its files"
    return fresh, len(stale)


def test_sigkill_at_random_moments_leaves_old_or_new_files(references, tmp_path: Path,  # type: ignore[no-untyped-def]
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    old, new, duration = references
    assert any(old[n] != new[n] for n in new if n != "timing.json")
    seed = random.randrange(2**32)
    rng = random.Random(seed)
    summary = []
    deadline = time.monotonic() + 120  # bounded: stop trying new kills after two minutes
    for trial in range(TRIALS):
        if time.monotonic() > deadline:
            break
        folder = tmp_path / f"trial{trial}"
        shutil.copytree(_old_folder(tmp_path, old), folder)
        proc = subprocess.Popen(_command(folder), cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        if trial % 2 == 0:
            mode = "random delay"
            time.sleep(rng.uniform(0.0, duration * 1.1))
        else:
            mode = "after the first change"
            limit = time.monotonic() + 60
            while proc.poll() is None and not _changed(folder, old) and time.monotonic() < limit:
                time.sleep(0.001)
            time.sleep(rng.uniform(0.0, duration * 0.3))
        proc.send_signal(signal.SIGKILL)
        code = proc.wait(timeout=30)
        fresh, stale = _check(folder, old, new)
        summary.append(f"trial {trial} ({mode}): {'killed' if code == -signal.SIGKILL else 'finished'}, "
                       f"{fresh} new artifact(s), {stale} stale temp file(s)")
    with capsys.disabled():
        print(f"\nkill test, seed {seed}, clean run {duration:.2f} s:\n  " + "\n  ".join(summary))
    assert len(summary) >= 4
    # the last folder, run to completion, is exactly the new reference (stale temp files aside)
    subprocess.run(_command(folder), check=True, cwd=REPO, timeout=300)
    after = {n: b for n, b in _snapshot(folder).items() if not TEMP.match(n)}
    assert {n: b for n, b in after.items() if n != "timing.json"} == \
           {n: b for n, b in new.items() if n != "timing.json"}


def _old_folder(tmp_path: Path, old: dict[str, bytes]) -> Path:
    """A folder holding the OLD reference (written once per test)."""
    folder = tmp_path / "old-copy"
    if not folder.exists():
        folder.mkdir()
        for name, data in old.items():
            (folder / name).write_bytes(data)
    return folder


def test_a_first_run_killed_leaves_nothing_partial(references, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    _, new, duration = references
    rng = random.Random()
    for trial in range(2):
        folder = tmp_path / f"fresh{trial}"
        proc = subprocess.Popen(_command(folder), cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(rng.uniform(duration * 0.4, duration * 1.0))
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
        if not folder.exists():
            continue
        for path in folder.iterdir():
            if TEMP.match(path.name):
                continue
            if path.name == "timing.json":
                assert isinstance(json.loads(path.read_text()), dict)
            elif path.name == "manifest.json":
                entries = json.loads(path.read_text())["experiments"]
                assert entries == {k: v for k, v in json.loads(new["manifest.json"])["experiments"].items()
                                   if k in entries}
            else:
                assert path.read_bytes() == new[path.name], path.name
