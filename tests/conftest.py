"""Shared fixtures: the repository root and a way to run the real ``stackx`` command."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from tests.limits import hang_limit

REPO = Path(__file__).resolve().parents[1]
CONFIGS = REPO / "configs"

Cli = Callable[..., subprocess.CompletedProcess[str]]


def run_cli(*args: object, cwd: Path = REPO, env: dict[str, str] | None = None,
            timeout: float | None = 120) -> subprocess.CompletedProcess[str]:
    """Run ``python -m stackx ARGS`` in a subprocess and return the completed process (text output). The
    package is this checkout's, from any working folder (not whichever copy is installed). ``timeout``: the
    command's time on an idle machine with room, a guard against a hang scaled by ``tests.limits.hang_limit``
    (None: no limit)."""
    path = os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p)
    return subprocess.run([sys.executable, "-m", "stackx", *map(str, args)], cwd=cwd, capture_output=True,
                          text=True, timeout=None if timeout is None else hang_limit(timeout),
                          env={**os.environ, "PYTHONPATH": path, **(env or {})})


@pytest.fixture
def cli() -> Cli:
    """``run_cli`` as a fixture."""
    return run_cli


Shown = Callable[[str], None]


@pytest.fixture
def shown(request: pytest.FixtureRequest) -> Shown:
    """``shown(text)``: a line for the log, printed after the tests whether this one passes or not (a trial's
    tally, a screenshot's path). The tests run in several processes, where a test's own output stays."""
    return lambda text: request.node.user_properties.append(("shown", text))


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    """The lines the tests asked to show (``shown``), in the order their tests ended."""
    lines = [value for reports in terminalreporter.stats.values() for report in reports
             if getattr(report, "when", None) == "call"
             for name, value in getattr(report, "user_properties", ()) if name == "shown"]
    if lines:
        terminalreporter.section("shown by the tests")
        for line in lines:
            terminalreporter.write_line(line)


@pytest.fixture(autouse=True, scope="session")
def _one_click_command() -> Iterator[None]:
    """typer's ``CliRunner.invoke`` builds the click command afresh from every command function's signature on
    each call, which was a third of the time of the tests that invoke ``stackx`` in-process a thousand times;
    the command is the same every time, so it is built once per app (as the ``stackx`` program does)."""
    import functools

    import typer.testing

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(typer.testing, "_get_command", functools.cache(typer.testing._get_command))
        yield


def pytest_xdist_auto_num_workers(config: pytest.Config) -> int:
    """``-n auto``: a process per core, at most four: each loads numba and compiles or loads the kernels its
    tests use (about a gigabyte a process), so more processes than that mostly repeat the same work."""
    return max(1, min(os.cpu_count() or 1, 4))
