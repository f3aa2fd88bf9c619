"""A command's peak memory as the kernel counts it, measured from a small process.

The kernel's peak of a process (``ru_maxrss`` from ``wait4``) starts from its parent's at the fork: a command
started by a test process that holds the whole suite's imports (hundreds of MB once numba and the engines are
loaded) would report that parent's size, not its own. So the command is started by a fresh interpreter that
imports only the standard library, which waits for it and reports its peak.
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

from tests.limits import hang_limit

LAUNCH = """
import json, os, subprocess, sys, threading
with open(sys.argv[1], "w") as out, open(sys.argv[2], "w") as err:
    child = subprocess.Popen(sys.argv[4:], stdout=out, stderr=err)
    seconds = float(sys.argv[3])
    watchdog = threading.Timer(seconds or threading.TIMEOUT_MAX, child.kill)
    watchdog.start()
    _, status, usage = os.wait4(child.pid, 0)
    watchdog.cancel()
print(json.dumps([os.waitstatus_to_exitcode(status), usage.ru_maxrss * 1024]))
"""


def peak_run(argv: Sequence[str], cwd: Path, env: dict[str, str], tmp: Path,
             timeout: float = 300) -> tuple[subprocess.CompletedProcess[str], int]:
    """Run ``argv`` to its end: what it did (exit code, output) and the most resident bytes it held. ``tmp`` is a
    folder for its output; ``timeout`` guards against a hang (scaled by ``hang_limit``): the command is killed
    then, and its exit code says so."""
    out, err = tmp / "peak.stdout", tmp / "peak.stderr"
    launched = subprocess.run([sys.executable, "-S", "-c", LAUNCH, str(out), str(err), str(hang_limit(timeout) or 0),
                               *argv], cwd=cwd, env=env, capture_output=True, text=True)
    assert launched.returncode == 0, launched.stderr
    code, peak = json.loads(launched.stdout)
    return subprocess.CompletedProcess(list(argv), code, out.read_text(), err.read_text()), peak
