"""What every attack trial uses: its outcome, a bounded ``stackx`` process with its peak memory, tmpfs mounts
that are always taken down, and the reference runs a trial attacks.

A trial gets a fresh folder of its own and returns an ``Outcome``: passed (or skipped, with the reason) and the
figure it measured, for one printed line. Every process a trial starts is bounded in time and in memory (a
process over ``MEMORY_CAP_MB`` is killed, so an attack that makes stackx read a 6 GB file cannot take the
machine's memory from everyone else), and every mount it makes is taken down afterwards, passed or failed.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
CONFIGS = REPO / "configs"
MEMORY_CAP_MB = 2048
"""A stackx process past this resident size is killed: the attack has already shown it is not bounded."""
POLL_S = 0.02


@dataclass(frozen=True)
class Outcome:
    """What a trial found: ``passed`` (None: skipped, ``figure`` says why) and the figure it measured."""

    passed: bool | None
    figure: str


@dataclass(frozen=True)
class Trial:
    """One attack: its name, the function that makes it in a fresh folder, whether it needs root (mounts,
    another user), and whether it is cheap enough (a few seconds) for the test suite."""

    name: str
    run: Callable[[Path], Outcome]
    needs_root: bool = False
    quick: bool = False


@dataclass(frozen=True)
class Finished:
    """A finished process: exit code (negative: the signal that ended it), its output, wall time, processor
    time (user and system, its children's included: what a time bound judges, as it does not grow with the
    machine's load), peak resident memory, and why the trial stopped it ('' when it ended by itself)."""

    code: int
    stdout: str
    stderr: str
    seconds: float
    peak_mb: float
    stopped: str
    cpu_s: float = 0.0

    @property
    def traceback(self) -> bool:
        return "Traceback" in self.stderr or "Traceback" in self.stdout

    def error_lines(self) -> list[str]:
        return [ln for ln in self.stderr.splitlines() if ln.strip()]

    def one_line_refusal(self) -> bool:
        """Exit 2 with exactly one ``error:`` line and no traceback: the shape of every refusal."""
        errors = [ln for ln in self.error_lines() if ln.startswith("error:")]
        return self.code == 2 and len(errors) == 1 and not self.traceback

    def brief(self) -> str:
        """The exit and, when stopped, why: for a figure."""
        return f"exit {self.code}" + (f" ({self.stopped})" if self.stopped else "")


def environ(**extra: str) -> dict[str, str]:
    """This checkout's stackx first on the path, whatever the working folder."""
    path = os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p)
    return {**os.environ, "PYTHONPATH": path, **extra}


def stackx_argv(*args: object) -> list[str]:
    return [sys.executable, "-m", "stackx", *map(str, args)]


def _resident_mb(pid: int) -> float:
    try:
        with open(f"/proc/{pid}/status") as fh:
            for line in fh:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024
    except (OSError, ValueError):
        pass
    return 0.0


def run(argv: Sequence[str], cwd: Path, timeout: float = 120.0, memory_mb: float = MEMORY_CAP_MB,
        env: dict[str, str] | None = None, preexec: Callable[[], None] | None = None,
        on_start: Callable[[subprocess.Popen[bytes]], None] | None = None) -> Finished:
    """Run ``argv`` to its end, or stop it (SIGKILL to its whole session) after ``timeout`` seconds or once it
    holds more than ``memory_mb``; the peak memory is the kernel's own count (``wait4``), not a sample.
    ``on_start`` is called with the process once it runs (to signal it)."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        start = time.perf_counter()
        proc = subprocess.Popen(list(argv), cwd=cwd, env=env or environ(), stdin=subprocess.DEVNULL, stdout=out,
                                stderr=err, start_new_session=True, preexec_fn=preexec)
        stopped = ""
        try:
            if on_start is not None:
                on_start(proc)
            while os.waitid(os.P_PID, proc.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT) is None:
                if not stopped and time.perf_counter() - start > timeout:
                    stopped = f"stopped after {timeout:g} s"
                elif not stopped and _resident_mb(proc.pid) > memory_mb:
                    stopped = f"stopped over {memory_mb:g} MB"
                if stopped:
                    _kill_session(proc.pid)
                time.sleep(POLL_S)
        finally:
            _kill_session(proc.pid)  # still a zombie, so its session is still its own: whatever it left running
            _, status, usage = os.wait4(proc.pid, 0)
        seconds = time.perf_counter() - start
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        return Finished(proc.returncode, out.read().decode(errors="replace"), err.read().decode(errors="replace"),
                        seconds, usage.ru_maxrss / 1024, stopped, usage.ru_utime + usage.ru_stime)


def stackx(*args: object, cwd: Path, timeout: float = 120.0, memory_mb: float = MEMORY_CAP_MB,
           env: dict[str, str] | None = None, preexec: Callable[[], None] | None = None,
           on_start: Callable[[subprocess.Popen[bytes]], None] | None = None) -> Finished:
    """``python -m stackx ARGS`` in ``cwd``, bounded as ``run`` says."""
    return run(stackx_argv(*args), cwd, timeout, memory_mb, env, preexec, on_start)


def _kill_session(pid: int) -> None:
    try:
        os.killpg(pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


def complete_run(config: str, out: Path, cwd: Path, *sets: str) -> Finished:
    """A run of a shipped config (``06-stack``) into ``out`` that must succeed: the folder a trial attacks."""
    done = stackx("run", CONFIGS / f"{config}.yaml", "--out", out, "-q", *sets, cwd=cwd)
    if done.code != 0:
        raise RuntimeError(f"the reference run of {config} failed ({done.brief()}): {done.stderr.strip()[-300:]}")
    return done


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every entry under ``folder`` (relative name -> bytes); links and other non-files are named by kind."""
    files: dict[str, bytes] = {}
    for top, dirs, names in os.walk(folder):
        for name in names + [d for d in dirs if os.path.islink(os.path.join(top, d))]:
            path = Path(top) / name
            rel = path.relative_to(folder).as_posix()
            files[rel] = path.read_bytes() if path.is_file() and not path.is_symlink() else b"<not a file>"
    return files


def manifest_problems(folder: Path) -> list[str]:
    """What keeps ``folder`` from being a complete run: a listed artifact missing or with other bytes."""
    try:
        manifest = json.loads((folder / "manifest.json").read_text())
    except (OSError, ValueError) as exc:
        return [f"manifest.json unreadable: {exc}"]
    problems = []
    for entry in manifest.get("experiments", {}).values():
        for name, art in entry.get("artifacts", {}).items():
            path = folder / name
            if not path.is_file() or hashlib.sha256(path.read_bytes()).hexdigest() != art.get("sha256"):
                problems.append(f"{name} is not as listed")
    return problems


# mounts ---------------------------------------------------------------------------------------------------


def can_mount() -> str:
    """'' when this process may mount a tmpfs; else why not."""
    if os.geteuid() != 0:
        return "needs root to mount a tmpfs"
    if shutil.which("mount") is None or shutil.which("umount") is None:
        return "needs mount and umount"
    return ""


def mount_tmpfs(at: Path, size_mb: int = 16) -> None:
    """A fresh tmpfs at ``at`` (made if missing). ``unmount_under`` takes it down, wherever it went."""
    at.mkdir(parents=True, exist_ok=True)
    subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size_mb}m,mode=0755", "none", str(at)], check=True,
                   capture_output=True, timeout=30)


def _decode(field: str) -> str:
    """A path as /proc/self/mountinfo writes it (space, tab, newline and backslash in octal)."""
    for code, char in (("\\040", " "), ("\\011", "\t"), ("\\012", "\n"), ("\\134", "\\")):
        field = field.replace(code, char)
    return field


def mounts_under(root: Path) -> list[Path]:
    """Every mount point at or under ``root``, deepest first (a mount stackx moved is still found)."""
    real = os.path.realpath(root)
    found = []
    with open("/proc/self/mountinfo") as fh:
        for line in fh:
            point = _decode(line.split()[4])
            if point == real or point.startswith(real.rstrip("/") + "/"):
                found.append(Path(point))
    return sorted(found, key=lambda p: len(p.parts), reverse=True)


def unmount_under(root: Path) -> list[Path]:
    """Take down every mount at or under ``root``; return those that stayed (then nothing may remove root)."""
    for point in mounts_under(root):
        if subprocess.run(["umount", str(point)], capture_output=True, timeout=30).returncode != 0:
            subprocess.run(["umount", "-l", str(point)], capture_output=True, timeout=30)
    return mounts_under(root)


def is_mount(path: Path) -> bool:
    return any(p == Path(os.path.realpath(path)) for p in mounts_under(path)) if path.exists() else False


# running trials -------------------------------------------------------------------------------------------


@contextmanager
def trial_folder(base: Path, name: str) -> Iterator[Path]:
    """A fresh folder for one trial, readable by every user (a trial may run stackx as another one); taken
    down afterwards whatever happened: mounts first, then the files (never across a mount still up)."""
    root = Path(tempfile.mkdtemp(prefix=f"{name}-", dir=base))
    os.chmod(root, 0o755)
    try:
        yield root
    finally:
        left = unmount_under(root)
        if not left:
            _remove(root)


def _remove(root: Path) -> None:
    """Remove a trial's folder, whatever modes the trial left on it."""
    def unlock(func: Callable[..., object], path: str, exc: object) -> None:
        try:
            os.chmod(os.path.dirname(path), 0o755)
            func(path)
        except OSError:
            pass
    shutil.rmtree(root, onerror=unlock)


def attempt(trial: Trial, base: Path) -> Outcome:
    """Run ``trial`` in a fresh folder under ``base``: its outcome, a skip when it needs what is not here, or a
    failure naming what went wrong in the trial itself."""
    if trial.needs_root and can_mount():
        return Outcome(None, can_mount())
    with trial_folder(base, trial.name) as root:
        try:
            return trial.run(root)
        except Exception as exc:  # noqa: BLE001 - a broken trial is reported as such, and the others still run
            return Outcome(False, f"the trial could not be made: {type(exc).__name__}: {str(exc)[:300]}")


def line(name: str, outcome: Outcome) -> str:
    """The printed line of one trial: name, PASS, FAIL or SKIP, the figure."""
    verdict = "SKIP" if outcome.passed is None else "PASS" if outcome.passed else "FAIL"
    return f"{name:<22} {verdict}  {outcome.figure}"


def write_config(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path
