"""Ctrl-C and SIGTERM at any moment of ``stackx``, start-up included: one line, exit 128 + the signal's number
(130, 143), the folder as it was, nothing staged left beside it.

The signals land at exact points, whatever the machine's load: strace's fault injection sends the signal on
entering the k-th ``openat`` (most of them are the imports of typer, rich, numpy, pydantic and the solvers),
from the moment the entry point (``stackx/__main__.py``) has installed its handlers. Before that, Python is
still starting up (its own start-up and the site-packages ``.pth`` files, where stackx has no say; see
docs/outputs.md, "Stopping a command"); what stackx imports before its handlers is pinned here to four tiny
modules and ``signal``.
"""

from __future__ import annotations

import random
import re
import signal as signals
import shutil
import socket
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from benchmarks.robust_folder import command, environ, snapshot
from tests.conftest import CONFIGS, REPO, Shown
from tests.limits import hang_limit

CONFIG = CONFIGS / "03-sink.yaml"
CODES = {"INT": 130, "TERM": 143}
needs_strace = pytest.mark.skipif(shutil.which("strace") is None, reason="needs strace to signal at exact points")

# Signals as a terminal or a supervisor delivers them: a suite started in the background (``pytest &`` from a
# script) ignores SIGINT, its children inherit that, and ``stackx`` rightly keeps ignoring it
AT_DEFAULT = [sys.executable, "-c", "import os, signal, sys\nfor s in (signal.SIGINT, signal.SIGTERM): "
              "signal.signal(s, signal.SIG_DFL)\nsignal.pthread_sigmask(signal.SIG_UNBLOCK, "
              "{signal.SIGINT, signal.SIGTERM}); os.execvp(sys.argv[1], sys.argv[1:])"]
BEFORE_HANDLERS = {"stackx", "stackx.__main__", "stackx.run", "stackx.run.interrupt", "signal"}
STACKX_FILE = re.compile(r"/stackx/(run/)?(__pycache__/)?(__init__|__main__|interrupt)[.]")


@pytest.fixture(scope="module")
def earlier(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, int, int]:
    """OLD and NEW runs of one config, and the range of ``openat`` calls stackx itself makes while a signal still
    leaves the folder as it was: up to the staged manifest, its last file. From there the switch holds a signal
    until the new folder is in place (``test_a_signal_during_the_switch_waits_for_it_and_says_so``)."""
    root = tmp_path_factory.mktemp("interrupt")
    subprocess.run(command(root / "old", "--set", "gravity=-9.0", configs=CONFIG), check=True, cwd=REPO,
                   env=environ(), timeout=hang_limit(300))
    shutil.copytree(root / "old", root / "new")
    trace = root / "trace.txt"
    subprocess.run(["strace", "-qq", "-o", str(trace), "-e", "trace=openat,renameat2",
                    *command(root / "new", configs=CONFIG)], check=True, cwd=REPO, env=environ(),
                   timeout=hang_limit(300))
    lines = trace.read_text().splitlines()
    calls = [line for line in lines if "openat(" in line]
    first = next(i for i, line in enumerate(calls) if "stackx/cli.py" in line or "stackx/__pycache__/cli." in line)
    staged = max(i for i, line in enumerate(calls) if ".new.stackx-next/manifest.json" in line)
    return root / "old", root / "new", first, staged + 1


def _signalled(argv: list[str], call: str, k: int, signal: str = "INT") -> subprocess.CompletedProcess[str]:
    return subprocess.run([*AT_DEFAULT, "strace", "-qq", "-o", "/dev/null", "-e", f"trace={call}",
                           "-e", f"inject={call}:signal={signal}:when={k}", *argv],
                          cwd=REPO, env=environ(), timeout=hang_limit(300), capture_output=True, text=True)


def _interrupted(old: Path, folder: Path, call: str, k: int, signal: str = "INT") -> subprocess.CompletedProcess[str]:
    shutil.copytree(old, folder)
    return _signalled(command(folder, configs=CONFIG), call, k, signal)


def _left_beside(folder: Path) -> list[str]:
    """Hidden entries a run stages beside its folder, other than its lock."""
    return sorted(p.name for p in folder.parent.glob(f".{folder.name}.stackx-*") if not p.name.endswith("-lock"))


def _fresh_python(code: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*AT_DEFAULT, sys.executable, "-c", textwrap.dedent(code)], cwd=REPO, env=environ(),
                          timeout=hang_limit(120), capture_output=True, text=True)


def test_the_handlers_come_first_after_four_tiny_modules() -> None:
    done = _fresh_python("""
        import sys
        before = set(sys.modules)
        from stackx.__main__ import main  # what the installed script does before calling main()
        print(sorted(set(sys.modules) - before - {"__future__"}))
        from stackx.run import interrupt
        interrupt.install()  # main()'s first line
        import signal
        print(signal.getsignal(signal.SIGINT).__qualname__, signal.getsignal(signal.SIGTERM).__qualname__)
    """)
    imported, handlers = done.stdout.splitlines()
    assert set(eval(imported)) <= BEFORE_HANDLERS, imported
    assert handlers == "on_signal on_signal"


def test_signals_ignored_at_launch_stay_ignored() -> None:
    done = _fresh_python("""
        import signal
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        from stackx.run import interrupt
        interrupt.install()
        print(signal.getsignal(signal.SIGTERM) is signal.SIG_IGN, signal.getsignal(signal.SIGINT).__qualname__)
    """)
    assert done.stdout.split() == ["True", "on_signal"]


def test_worker_processes_of_the_installed_script_keep_their_own_signals(tmp_path: Path) -> None:
    # multiprocessing's spawn (Dask's workers) runs the program's script again in each worker, as __mp_main__
    script = tmp_path / "stackx-script.py"
    script.write_text(textwrap.dedent("""
        import multiprocessing, signal
        from stackx.__main__ import main, interrupt  # the installed script's import, run again in the worker

        def report():
            print("worker", signal.getsignal(signal.SIGTERM) is signal.SIG_DFL, flush=True)

        if __name__ == "__main__":
            interrupt.install()  # main()'s first line: the command, later, starts a worker
            worker = multiprocessing.get_context("spawn").Process(target=report)
            worker.start()
            worker.join()
            print("command", signal.getsignal(signal.SIGTERM).__qualname__, flush=True)
    """))
    done = subprocess.run([*AT_DEFAULT, sys.executable, str(script)], cwd=REPO, env=environ(), timeout=hang_limit(120),
                          capture_output=True, text=True)
    assert done.stdout.splitlines() == ["worker True", "command on_signal"], done.stderr


@needs_strace
def test_a_signal_at_every_point_of_start_up_is_one_line(tmp_path: Path, shown: Shown) -> None:
    argv = [sys.executable, "-m", "stackx", "validate", str(CONFIG)]
    trace = tmp_path / "trace.txt"
    subprocess.run(["strace", "-qq", "-o", str(trace), "-e", "trace=openat,rt_sigaction", *argv], check=True,
                   cwd=REPO, env=environ(), timeout=hang_limit(300), capture_output=True)
    calls = [c for c in trace.read_text().splitlines() if re.search(r"rt_sigaction\(SIG(INT|TERM), \{|openat\(", c)]
    ours = next(i for i, c in enumerate(calls) if STACKX_FILE.search(c))  # stackx's first file
    handlers = next(i for i, c in enumerate(calls) if i > ours and "rt_sigaction" in c)
    opened = [c for c in calls[:handlers] if "openat(" in c]
    ours = next(i for i, c in enumerate(opened) if STACKX_FILE.search(c))
    before = [re.search(r'"([^"]*)"', c).group(1) for c in opened[ours:]]  # type: ignore[union-attr]
    assert all(STACKX_FILE.search(p) or p.endswith(("/stackx", "/stackx/run")) or "/signal." in p
               for p in before), before  # between stackx's first file and its handlers: four tiny modules
    cli = next(i for i, c in enumerate(calls) if "openat(" in c and "stackx/" in c and "/cli." in c)
    first = len(opened) + 1  # the first openat after the handlers, counted from 1
    last = len([c for c in calls[:cli] if "openat(" in c]) + 1
    later = len([c for c in calls if "openat(" in c])
    points = sorted({*range(first, last + 6), *random.Random(56).sample(range(last + 6, later + 1), 4)})
    for signal, code in CODES.items():
        for k in points:
            done = _signalled(argv, "openat", k, signal)
            assert (done.returncode, done.stderr) == (code, "interrupted\n"), (signal, k, done.stderr[-800:])
    shown(f"start-up: handlers after openat #{first - 1} ({first - 1 - ours} of them stackx's); SIGINT and SIGTERM "
          f"at openat #{points[0]}..#{last + 5} and 4 later points: one line each")


@needs_strace
@pytest.mark.parametrize("signal", ["INT", "TERM"])
def test_a_signal_while_importing_or_running_is_one_line(earlier: tuple[Path, Path, int, int], tmp_path: Path,
                                                          signal: str) -> None:
    old, _, first, last = earlier
    rng = random.Random(31 if signal == "INT" else 143)
    sampled = rng.sample(range(first + 1, last + 1), 4 if signal == "INT" else 3)
    points = sorted({first + 1, first + 40, last, *sampled})
    for k in points:
        folder = tmp_path / f"at{k}"
        done = _interrupted(old, folder, "openat", k, signal)
        assert (done.returncode, done.stderr) == (CODES[signal], f"interrupted; {folder} left as it was\n"), k
        assert snapshot(folder) == snapshot(old), k
        assert _left_beside(folder) == [], k


@needs_strace
@pytest.mark.parametrize("signal", ["INT", "TERM"])
def test_a_signal_during_the_switch_waits_for_it_and_says_so(earlier: tuple[Path, Path, int, int],
                                                            tmp_path: Path, signal: str) -> None:
    old, new, _, _ = earlier
    folder = tmp_path / "switch"
    done = _interrupted(old, folder, "renameat2", 1, signal)
    assert (done.returncode, done.stderr) == (CODES[signal], f"interrupted; {folder} already holds the run's files\n")
    got, want = snapshot(folder), snapshot(new)
    assert {n: b for n, b in got.items() if n != "timing.json"} == {n: b for n, b in want.items()
                                                                    if n != "timing.json"}
    assert _left_beside(folder) == []


def test_sigterm_stops_serve_cleanly(tmp_path: Path) -> None:
    (tmp_path / "index.html").write_text("<p>frames</p>")
    server = subprocess.Popen([*AT_DEFAULT, sys.executable, "-m", "stackx", "serve", str(tmp_path), "--port", "0"],
                              cwd=REPO, env=environ(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = server.stdout.readline()  # type: ignore[union-attr]
        port = int(re.search(r":(\d+)/", line).group(1))  # type: ignore[union-attr]
        with socket.create_connection(("127.0.0.1", port), timeout=30) as conn:  # it serves
            conn.sendall(b"HEAD /index.html HTTP/1.0\r\n\r\n")
            assert conn.recv(64).startswith(b"HTTP/1.0 200")
        server.terminate()
        _, err = server.communicate(timeout=hang_limit(60))
    finally:
        server.kill()
    assert (server.returncode, err.splitlines()[1:]) == (143, ["interrupted"])  # after the request's log line


FINALIZER = """
    from stackx.run import interrupt

    class Slow:
        def __del__(self):
            print("finalizing", flush=True)
            while True:
                pass

    def main():
        Slow()
        print("went on", flush=True)

    interrupt.install()
    interrupt.run(main)
"""
LINGERING = """
    import signal, threading, time
    from stackx.run import interrupt

    def linger():
        while not interrupt._state.over:  # the command is over; the process waits for this thread
            time.sleep(0.01)
        THEN
        threading.Event().wait()

    def main():
        threading.Thread(target=linger).start()

    interrupt.install()
    interrupt.run(main)
"""
AT_EXIT = LINGERING.replace("THEN", 'print("done", flush=True)')
# the signal handed to the lingering thread, not the main one
SELF_SIGNALLED = LINGERING.replace("THEN", "signal.pthread_kill(threading.get_ident(), signal.SIGNAME)")


@pytest.mark.parametrize("name", ["SIGINT", "SIGTERM"])
def test_a_signal_in_a_finalizer_is_one_line_not_a_printed_traceback(name: str) -> None:
    # Python cannot raise from a finalizer (``__del__``, a weakref callback): it prints the exception, goes on
    assert _stopped_after(FINALIZER, "finalizing", name) == (128 + signals.Signals[name], "", "interrupted\n")


@pytest.mark.parametrize("name", ["SIGINT", "SIGTERM"])
def test_a_signal_while_the_process_ends_is_one_line(name: str) -> None:
    # the command is over, but Python waits for a thread at exit (as it does for a pool or a cluster)
    assert _stopped_after(AT_EXIT, "done", name) == (128 + signals.Signals[name], "", "interrupted\n")


@pytest.mark.parametrize("name", ["SIGINT", "SIGTERM"])
def test_a_signal_handed_to_another_thread_at_exit_is_answered(name: str) -> None:
    # Python's own wait for threads at exit wakes only for a signal the main thread takes: this one never would
    code = textwrap.dedent(SELF_SIGNALLED).replace("SIGNAME", name)
    done = subprocess.run([*AT_DEFAULT, sys.executable, "-c", code], cwd=REPO, env=environ(), capture_output=True,
                          text=True, timeout=hang_limit(60))
    assert (done.returncode, done.stdout, done.stderr) == (128 + signals.Signals[name], "", "interrupted\n")


def _stopped_after(code: str, line: str, name: str) -> tuple[int, str, str]:
    """Run ``code``; once it has printed ``line`` (it then waits for nothing but a signal), send it ``name``:
    (exit code, the rest of stdout, stderr)."""
    proc = subprocess.Popen([*AT_DEFAULT, sys.executable, "-c", textwrap.dedent(code)], cwd=REPO, env=environ(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None and proc.stdout.readline() == line + "\n"
        proc.send_signal(signals.Signals[name])
        out, err = proc.communicate(timeout=hang_limit(60))
    finally:
        proc.kill()
    return proc.returncode, out, err
