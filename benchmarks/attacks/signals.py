"""Attacks by signals: SIGTERM during a run, Ctrl-C and SIGTERM in start-up, and ``bench`` and ``init`` killed
at their switch (or two benches into one folder at once).

The contract (docs/outputs.md): SIGTERM is answered like Ctrl-C (one line, exit 143, the folder left as it was
or, after the switch, holding the run's files); the start-up window is closed (no traceback whenever the signal
comes); ``bench`` and ``init`` are folder-atomic like ``run``: a killed one leaves the old files or the new
ones, never a mix, and two at once into one folder leave one's files.

Exact kill points come from strace's fault injection (a signal on entering the k-th call of a system call), so
they do not depend on the machine's speed; without strace those trials are skipped.
"""

from __future__ import annotations

import json
import random
import re
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from benchmarks.attacks.kit import CONFIGS, Finished, Outcome, environ, run, snapshot, stackx, stackx_argv

WRITES = ("mkdir", "write", "fsync", "unlinkat", "rmdir", "rename", "renameat", "renameat2", "link", "linkat")
RENAMES = ("rename", "renameat", "renameat2")
SEED = 56
SIGTERM_POINTS = 6
STARTUP_DELAYS_MS = [20 + 110 * k / 15 for k in range(16)]  # 20 to 130 ms, evenly
BENCH_POINTS = 3
INIT_POINTS = 8
OLD = ("--set", "gravity=-9.0")
HOLD_S = 20.0
"""How long the first of two benches is held at its second rename: longer than the second bench takes."""


def _strace() -> str:
    return "" if shutil.which("strace") else "needs strace to signal at exact system calls"


def _counts(argv: Sequence[str], cwd: Path, calls: Sequence[str], before: Path | None = None,
            fresh: Path | None = None) -> list[tuple[str, int]]:
    """Every (call, k) of ``calls`` that ``argv`` makes (its main thread), counted by ``strace -c``; ``fresh`` is
    removed and ``before`` copied to it first, so each count starts from the same folder."""
    table = cwd / "strace-counts.txt"
    for _ in range(2):  # the first may also write the byte-code of files changed since the last run
        if fresh is not None:
            shutil.rmtree(fresh, ignore_errors=True)
            if before is not None:
                shutil.copytree(before, fresh, symlinks=True)
        subprocess.run(["strace", "-c", "-o", str(table), "-e", "trace=" + ",".join(calls), *argv], cwd=cwd,
                       env=environ(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=600, check=True)
    points = []
    for line in table.read_text().splitlines():
        cells = line.split()
        if len(cells) >= 5 and cells[-1] in calls:
            points += [(cells[-1], k) for k in range(1, int(cells[3]) + 1)]
    return points


def _at(point: tuple[str, int], sig: str, argv: Sequence[str]) -> list[str]:
    """``argv`` under strace, sent ``sig`` on entering the ``point``-th call."""
    call, k = point
    return ["strace", "-qq", "-o", "/dev/null", "-e", f"trace={call}", "-e", f"inject={call}:signal={sig}:when={k}",
            *argv]


def _generation(folder: Path, old: dict[str, bytes], new: dict[str, bytes]) -> str:
    """'old' or 'new' when ``folder`` holds exactly that run's files (``timing.json`` complete, its times
    aside); else what is wrong."""
    files = snapshot(folder)
    try:
        if not isinstance(json.loads(files.pop("timing.json", b"")), dict):
            return "timing.json is not an object"
    except ValueError:
        return "timing.json is missing or torn"
    for name, ref in (("old", old), ("new", new)):
        if files == {n: b for n, b in ref.items() if n != "timing.json"}:
            return name
    return f"a mix: {sorted(n for n in files if files[n] != old.get(n))[:4]} differ from the old run"


def sigterm_run(root: Path) -> Outcome:
    """SIGTERM at exact points of a run over an earlier complete one: exit 143 with one line and no traceback;
    the folder exactly the old run (or the new one, once switched)."""
    if _strace():
        return Outcome(None, _strace())
    config = CONFIGS / "06-stack.yaml"
    old_dir, new_dir = root / "old", root / "new"
    if stackx("run", config, "--out", old_dir, "-q", *OLD, cwd=root).code != 0:
        raise RuntimeError("the old run failed")
    (old_dir / "notes.txt").write_text("the user's own file\n")
    argv = stackx_argv("run", config, "--out", new_dir, "-q")
    points = _counts(argv, root, WRITES, before=old_dir, fresh=new_dir)
    old, new = snapshot(old_dir), snapshot(new_dir)
    chosen = sorted(random.Random(SEED).sample(points, min(SIGTERM_POINTS, len(points))))
    seen, wrongs = {"old": 0, "new": 0}, []
    for point in chosen:
        folder = root / "X"
        shutil.rmtree(folder, ignore_errors=True)
        shutil.copytree(old_dir, folder)
        done = run(_at(point, "TERM", stackx_argv("run", config, "--out", folder, "-q")), root, timeout=120)
        found = _generation(folder, old, new)
        if found in seen:
            seen[found] += 1
        lines = done.error_lines()
        if done.code != 143 or done.traceback or len(lines) != 1 or found not in seen:
            wrongs.append(f"at {point[0]} #{point[1]}: {done.brief()}, {len(lines)} line(s)"
                          f"{', a traceback' if done.traceback else ''}, {found}")
    figure = (f"{len(chosen) - len(wrongs)} of {len(chosen)} exit 143 in one line; folder old {seen['old']}, "
              f"new {seen['new']}")
    return Outcome(not wrongs, figure + "".join(f"; {w}" for w in wrongs[:3]))


def _command() -> list[str]:
    """The ``stackx`` program as a user starts it (the installed script), else ``python -m stackx``."""
    script = Path(sys.executable).parent / "stackx"
    return [sys.executable, str(script)] if script.is_file() else stackx_argv()


STACKX_FRAME = re.compile(r'File "[^"]*/stackx/[^"]*\.py"')
"""A traceback line in stackx's own code: a signal that came once stackx ran, which stackx must answer."""


def _where(stderr: str) -> str:
    """Where a traceback left stackx's code: its last stackx frame (file and line), for the figure."""
    frames = re.findall(r'File "[^"]*/(stackx/[^"]*\.py)", line (\d+)', stderr)
    return f", a traceback in stackx (last at {frames[-1][0]}:{frames[-1][1]})" if frames else ", a traceback"


def startup_signals(root: Path) -> Outcome:
    """Ctrl-C (SIGINT) and SIGTERM 20 to 130 ms after launch, 16 times each: no traceback once stackx's code
    runs, exit 130 or 143 (or the signal's own death). A signal during Python's own start-up, before the first
    line of stackx (the interpreter, site packages, the script's first import), is Python's to report: counted
    apart."""
    config = CONFIGS / "03-sink.yaml"
    python_own, odd = 0, []
    for sig, code in ((signal.SIGINT, 130), (signal.SIGTERM, 143)):
        for i, delay in enumerate(STARTUP_DELAYS_MS):
            def send(proc: subprocess.Popen[bytes], delay: float = delay, sig: int = sig) -> None:
                time.sleep(delay / 1000)
                proc.send_signal(sig)

            done = run([*_command(), "run", config, "--out", root / f"X{sig}-{i}", "-q"], root, timeout=60,
                       on_start=send)
            if done.traceback and not STACKX_FRAME.search(done.stderr):
                python_own += 1
            elif done.code not in (code, -sig) or done.traceback:
                odd.append(f"{signal.Signals(sig).name} at {delay:.0f} ms: {done.brief()}"
                           f"{_where(done.stderr) if done.traceback else ''}")
    total = 2 * len(STARTUP_DELAYS_MS)
    figure = (f"tracebacks once stackx runs {sum('traceback' in w for w in odd)} of {total}; in Python's own "
              f"start-up {python_own}")
    return Outcome(not odd, figure + "".join(f"; {w}" for w in odd[:3]))


def _bench(out: Path, *sets: str) -> list[str]:
    return stackx_argv("bench", CONFIGS / "03-sink.yaml", "--solvers", "pgs", "--out", out, "-q", *sets)


def _bench_generation(folder: Path) -> str:
    """'old' or 'new' when the bench files agree (each names the command that made it), complete; else what
    is wrong."""
    kinds = set()
    for name in ("bench.json", "report.html"):
        try:
            text = (folder / name).read_text()
        except OSError:
            return f"{name} missing"
        if name == "bench.json":
            try:
                json.loads(text)
            except ValueError:
                return "bench.json torn"
        elif not text.rstrip().endswith("</html>"):
            return "report.html torn"
        kinds.add("old" if "gravity=-9.0" in text else "new")
    return kinds.pop() if len(kinds) == 1 else "a mix of the two benches' files"


def bench_switch(root: Path) -> Outcome:
    """``bench`` killed (SIGKILL) over an earlier bench on entering each of its renames (the switch),
    ``BENCH_POINTS`` other writing calls (seeded) and its last: the folder holds the old bench's files or the new
    one's, never a mix; the next bench finishes and leaves nothing beside the folder."""
    if _strace():
        return Outcome(None, _strace())
    old_dir = root / "old"
    if run(_bench(old_dir, *OLD), root, timeout=300).code != 0:
        raise RuntimeError("the old bench failed")
    points = _counts(_bench(root / "probe"), root, WRITES, before=old_dir, fresh=root / "probe")
    renames = [p for p in points if p[0] in RENAMES]
    others = [p for p in points if p[0] not in RENAMES]
    sampled = random.Random(SEED).sample(others, min(BENCH_POINTS, len(others)))
    chosen = sorted(set(renames + sampled + points[-1:]))  # the last: after the switch, tidying up
    seen, wrongs = {"old": 0, "new": 0}, []
    folder = root / "X"
    for point in chosen:
        shutil.rmtree(folder, ignore_errors=True)
        shutil.copytree(old_dir, folder)
        run(_at(point, "KILL", _bench(folder)), root, timeout=300)
        found = _bench_generation(folder)
        if found in seen:
            seen[found] += 1
        else:
            wrongs.append(f"killed at {point[0]} #{point[1]}: {found}")
    after = run(_bench(folder), root, timeout=300)
    left = [p.name for p in root.iterdir() if p.name.startswith(".X.")]
    if after.code != 0 or _bench_generation(folder) != "new" or left:
        wrongs.append(f"the next bench: {after.brief()}, {_bench_generation(folder)}, left beside it {left}")
    figure = (f"{len(chosen)} kills ({len(renames)} at renames): folder old {seen['old']}, new {seen['new']}, "
              f"anything else {len(chosen) - seen['old'] - seen['new']}")
    return Outcome(not wrongs and bool(renames), figure + "".join(f"; {w}" for w in wrongs))


def bench_together(root: Path) -> Outcome:
    """Two benches into one folder: the first held ``HOLD_S`` on entering its second rename (strace's fault
    injection), the second started once the first's first file is in the folder; both finish, and the folder
    holds one bench's files (file by file, the second's would land in the pause and the first's last file
    after them)."""
    if _strace():
        return Outcome(None, _strace())
    folder = root / "X"
    calls = ",".join(RENAMES)
    held = ["strace", "-qq", "-o", "/dev/null", "-e", f"trace={calls}", "-e",
            f"inject={calls}:delay_enter={int(HOLD_S * 1e6)}:when=2+", *_bench(folder, *OLD)]
    env = environ(PYTHONDONTWRITEBYTECODE="1")  # no byte-code renames before the bench's own
    first = subprocess.Popen(held, cwd=root, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 300
        while first.poll() is None and time.monotonic() < deadline and not (folder / "bench.json").exists():
            time.sleep(0.01)
        second = run(_bench(folder, "--set", "gravity=-9.5"), root, timeout=300, env=env)
        code = first.wait(timeout=300 + HOLD_S * 4)
    finally:
        if first.poll() is None:
            first.kill()
            first.wait()
    found = _bench_generation(folder)
    whose = {"old": "the first bench's files", "new": "the second bench's files"}
    passed = (code, second.code) == (0, 0) and found in whose
    return Outcome(passed, f"exits {code} and {second.code}; the folder holds {whose.get(found, found)}")


def init_switch(root: Path) -> Outcome:
    """``init`` killed (SIGKILL) at exact points of its writing: the folder is absent (or empty) or complete,
    and the next ``init`` into it completes it."""
    if _strace():
        return Outcome(None, _strace())
    reference = root / "reference"
    points = _counts(stackx_argv("init", reference), root, WRITES, fresh=reference)
    whole = snapshot(reference)
    chosen = sorted(random.Random(SEED).sample(points, min(INIT_POINTS, len(points))))
    seen, wrongs = {"nothing": 0, "complete": 0}, []
    for i, point in enumerate(chosen):
        folder = root / f"X{i}"
        run(_at(point, "KILL", stackx_argv("init", folder)), root, timeout=120)
        now = snapshot(folder) if folder.exists() else {}
        found = "nothing" if not now else "complete" if now == whole else f"{len(now)} of {len(whole)} files"
        if found not in seen:
            wrongs.append(f"killed at {point[0]} #{point[1]}: {found}")
            continue
        seen[found] += 1
        if found == "nothing":
            again: Finished = stackx("init", folder, cwd=root)
            left = [p.name for p in root.iterdir() if p.name.startswith(f".{folder.name}.")]
            if again.code != 0 or snapshot(folder) != whole or left:
                wrongs.append(f"init after a kill at {point[0]} #{point[1]}: {again.brief()} "
                              f"{again.stderr.strip()[-120:]}{f', left beside it {left}' if left else ''}")
    figure = f"{len(chosen)} kills: nothing {seen['nothing']}, complete {seen['complete']}"
    return Outcome(not wrongs, figure + "".join(f"; {w}" for w in wrongs[:3]))
