"""The cheap attack trials of ``python -m benchmarks.robust_folder`` (``benchmarks/attacks``), each redone as it
was first seen: a tmpfs mounted inside the output folder, planted lock and staging links, a private and a setgid
output folder, ``--out`` a mount point, a 6 GB sparse manifest, shapes drawn to 1e18, plugins planted in an
ancestor folder, a keyvalue key that is code, and ``serve`` under odd paths and its folder swapped for a link.

Each trial runs the real command in a subprocess and judges what it did to files outside stackx's own (the
contract in docs/outputs.md and docs/configs.md); the mount trials need root and are skipped without it. The
benchmark runs every trial, the slow ones too (concurrent writers, idle connections, signals, bench and init
killed at their switch).

The tests below them check the measuring itself: a process over its memory bound is stopped and its peak is
the kernel's, and a mount a command moved away is still taken down.

The kernel's peak of a process (``wait4``) starts from its parent's at the fork: a child of a test process that
holds the whole suite's imports would report that. So the trials, and the peak test, run from a fresh small
interpreter, as the benchmark does.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks.attacks import TRIALS
from benchmarks.attacks.kit import Outcome, Trial, can_mount, line, mount_tmpfs, mounts_under, run, trial_folder
from tests.conftest import REPO, Shown
from tests.limits import hang_limit

QUICK = [trial for trial in TRIALS if trial.quick]

ATTEMPT = """
import json, pathlib, sys
from benchmarks.attacks import TRIALS
from benchmarks.attacks.kit import attempt
outcome = attempt(next(t for t in TRIALS if t.name == sys.argv[1]), pathlib.Path(sys.argv[2]))
print(json.dumps([outcome.passed, outcome.figure]))
"""


def _in_a_small_process(code: str, *args: str) -> str:
    """What ``code`` prints, run by a fresh interpreter (whose children's peaks are theirs, not the suite's)."""
    done = subprocess.run([sys.executable, "-c", code, *args], cwd=REPO, capture_output=True, text=True,
                          timeout=hang_limit(120))
    assert done.returncode == 0, done.stderr
    return done.stdout


@pytest.mark.parametrize("trial", QUICK, ids=[t.name for t in QUICK])
def test_attack_leaves_what_stackx_did_not_write_alone(trial: Trial, tmp_path: Path, shown: Shown) -> None:
    if trial.needs_root and can_mount():
        pytest.skip(can_mount())
    outcome = Outcome(*json.loads(_in_a_small_process(ATTEMPT, trial.name, str(tmp_path))))
    shown(line(trial.name, outcome))
    if outcome.passed is None:
        pytest.skip(outcome.figure)
    assert outcome.passed, outcome.figure


def test_every_trial_has_its_own_name() -> None:
    names = [t.name for t in TRIALS]
    assert len(set(names)) == len(names) >= 20
    assert len(QUICK) >= 8


GROW = "import time; b = bytearray({mb} << 20); b[::4096] = b'x' * len(b[::4096]); time.sleep({sleep})"


def test_a_process_over_its_memory_bound_is_stopped(tmp_path: Path) -> None:
    done = run([sys.executable, "-c", GROW.format(mb=400, sleep=60)], tmp_path, timeout=60, memory_mb=150)
    assert done.code == -9 and done.stopped.startswith("stopped over 150"), done
    assert done.seconds < 30


def test_the_peak_memory_is_the_kernels_count() -> None:
    code = ("import json, sys; from benchmarks.attacks.kit import run; "
            f"done = run([sys.executable, '-c', {GROW.format(mb=200, sleep=0)!r}], __import__('pathlib').Path('.'), "
            "timeout=60); print(json.dumps([done.code, done.stopped, done.peak_mb]))")
    code_, stopped, peak_mb = json.loads(_in_a_small_process(code))
    assert code_ == 0 and not stopped
    assert 200 <= peak_mb < 400, peak_mb


@pytest.mark.skipif(bool(can_mount()), reason=can_mount() or "root")
def test_a_mount_moved_by_a_rename_is_still_taken_down(tmp_path: Path) -> None:
    with trial_folder(tmp_path, "moved") as root:
        mount_tmpfs(root / "a" / "volume")
        (root / "a" / "volume" / "f").write_text("on the volume")
        os.rename(root / "a", root / ".b")  # as a run's switch would move it
        assert mounts_under(root) == [root / ".b" / "volume"]
    assert not root.exists()
    assert not mounts_under(tmp_path)
