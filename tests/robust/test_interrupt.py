"""Ctrl-C at any moment of ``stackx run``, importing included: one line, exit 130, the folder as it was.

The interrupts land at exact points, whatever the machine's load: strace's fault injection sends SIGINT on
entering the k-th ``openat`` (most of them are the imports of typer, rich, numpy, pydantic and the solvers)
of a run over an earlier complete one, from the moment the entry point (``stackx/__main__.py``) has installed
its handler and starts importing the command line (before that, Python is still starting up: about 30 ms in
which stackx has no say).
"""

from __future__ import annotations

import random
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks.robust_folder import command, environ, snapshot
from tests.conftest import CONFIGS, REPO

CONFIG = CONFIGS / "03-sink.yaml"
pytestmark = pytest.mark.skipif(shutil.which("strace") is None, reason="needs strace to interrupt at exact points")


@pytest.fixture(scope="module")
def earlier(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, int, int]:
    """OLD and NEW runs of one config, and the range of ``openat`` calls stackx itself makes."""
    root = tmp_path_factory.mktemp("interrupt")
    subprocess.run(command(root / "old", "--set", "gravity=-9.0", configs=CONFIG), check=True, cwd=REPO,
                   env=environ(), timeout=300)
    shutil.copytree(root / "old", root / "new")
    trace = root / "trace.txt"
    subprocess.run(["strace", "-qq", "-o", str(trace), "-e", "trace=openat", *command(root / "new", configs=CONFIG)],
                   check=True, cwd=REPO, env=environ(), timeout=300)
    calls = trace.read_text().splitlines()
    first = next(i for i, line in enumerate(calls) if "stackx/cli.py" in line or "stackx/__pycache__/cli." in line)
    return root / "old", root / "new", first, len(calls)


# Ctrl-C as a terminal delivers it: a suite started in the background (``pytest &`` from a script) ignores
# SIGINT, its children inherit that, and ``stackx`` rightly keeps ignoring it (``interrupt.install``)
AT_DEFAULT = [sys.executable, "-c", "import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); "
              "signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT}); os.execvp(sys.argv[1], sys.argv[1:])"]


def _interrupted(old: Path, folder: Path, call: str, k: int) -> subprocess.CompletedProcess[str]:
    shutil.copytree(old, folder)
    return subprocess.run([*AT_DEFAULT, "strace", "-qq", "-o", "/dev/null", "-e", f"trace={call}",
                           "-e", f"inject={call}:signal=INT:when={k}", *command(folder, configs=CONFIG)],
                          cwd=REPO, env=environ(), timeout=300, capture_output=True, text=True)


def test_ctrl_c_while_importing_or_running_is_one_line(earlier: tuple[Path, Path, int, int], tmp_path: Path) -> None:
    old, _, first, last = earlier
    rng = random.Random(31)
    points = sorted({first + 1, first + 40, *rng.sample(range(first + 1, last + 1), 4)})
    for k in points:
        folder = tmp_path / f"at{k}"
        done = _interrupted(old, folder, "openat", k)
        assert (done.returncode, done.stderr) == (130, f"interrupted; {folder} left as it was\n"), k
        assert snapshot(folder) == snapshot(old), k


def test_ctrl_c_during_the_switch_waits_for_it_and_says_so(earlier: tuple[Path, Path, int, int],
                                                          tmp_path: Path) -> None:
    old, new, _, _ = earlier
    folder = tmp_path / "switch"
    done = _interrupted(old, folder, "renameat2", 1)
    assert (done.returncode, done.stderr) == (130, f"interrupted; {folder} already holds the run's files\n")
    got, want = snapshot(folder), snapshot(new)
    assert {n: b for n, b in got.items() if n != "timing.json"} == {n: b for n, b in want.items()
                                                                    if n != "timing.json"}
