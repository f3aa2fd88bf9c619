"""SIGKILL ``stackx run configs/ --out X`` over an earlier complete run: X is always the old run or the new one.

The trials and the verdict are those of ``benchmarks/robust_folder.py`` (50 trials there): OLD is a run with
``--set gravity=-9.0`` plus a file of the user's, NEW the lab as written run over it. Each trial kills the run
on entering a chosen write-type system call (strace's fault injection: an exact point, whatever the machine's
load) or after a delay, both chosen by a fixed seed; the folder must then hold every file of OLD or every file
of NEW, byte for byte, and the next run must finish with NEW and leave nothing beside the folder.
"""

from __future__ import annotations

import shutil
import signal
import subprocess
from pathlib import Path

import pytest

from benchmarks.robust_folder import (References, after_kill, command, environ, kill_points, kill_trial, references,
                                      snapshot)
from tests.conftest import REPO, Shown
from tests.limits import hang_limit

SEED = 20261125


@pytest.fixture(scope="module")
def refs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, References]:
    root = tmp_path_factory.mktemp("kill")
    return root, references(root)


def test_sigkill_leaves_the_old_run_or_the_new_one(refs: tuple[Path, References],
                                                   shown: Shown) -> None:
    root, found = refs
    assert any(found.old[n] != found.new.get(n) for n in found.old if n != "timing.json")
    points = kill_points(found, 6, SEED)
    if shutil.which("strace"):
        points = [("renameat2", 1), ("unlinkat", 1), *points[:4]]  # just before and just after the switch
    seen = []
    for i, point in enumerate(points):
        where, verdict, code = kill_trial(root / f"trial{i}", found, point)
        seen.append((where, verdict, code))
        assert verdict in ("old", "new"), seen[-1]
    shown("kill trials: " + "; ".join(f"{w}: {v} (exit {c})" for w, v, c in seen))
    if shutil.which("strace"):  # killed on entering the switch: old; on removing the old folder after it: new
        assert seen[:2] == [("renameat2 #1", "old", -signal.SIGKILL), ("unlinkat #1", "new", -signal.SIGKILL)]
    assert after_kill(root / "trial0", found) == "new"


def test_a_first_run_killed_leaves_no_folder_or_a_complete_one(refs: tuple[Path, References]) -> None:
    root, found = refs
    if not shutil.which("strace"):
        pytest.skip("needs strace to kill at exact points")
    for i, point in enumerate([("fsync", 3), ("renameat2", 1), ("rename", 1)]):
        folder = root / f"fresh{i}"
        base = ["strace", "-qq", "-o", "/dev/null", "-e", f"trace={point[0]}",
                "-e", f"inject={point[0]}:signal=KILL:when={point[1]}"]
        subprocess.run([*base, *command(folder)], cwd=REPO, env=environ(), timeout=hang_limit(300),
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        if folder.exists():
            files = snapshot(folder)
            assert {n: b for n, b in files.items() if n != "timing.json"} == \
                   {n: b for n, b in found.new.items() if n not in ("timing.json", "notes.txt")}, point
