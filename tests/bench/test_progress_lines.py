"""Where no progress bar is drawn (standard error not a terminal), ``stackx bench`` says each solver's case as
it finishes, so a long first bench is not silent; on a terminal, and with ``-q``, it does not."""

from __future__ import annotations

import io
import re
from pathlib import Path

from rich.console import Console

from stackx.run.lines import Finished
from tests.conftest import CONFIGS, Cli

LINE = re.compile(r"bench: (\d+)/(\d+) done: (\S+) (\S+) \((\d+) s\)")


def test_a_bench_into_a_pipe_prints_a_line_per_finished_solver(cli: Cli, tmp_path: Path) -> None:
    done = cli("bench", CONFIGS / "06-stack.yaml", "--solvers", "pgs,jacobi", "--out", tmp_path / "out")
    assert done.returncode == 0, done.stderr
    said = [LINE.fullmatch(line) for line in done.stderr.splitlines() if line.startswith("bench: ")]
    assert [m.groups()[:4] if m else None for m in said] == [("1", "2", "06-stack", "pgs"),
                                                            ("2", "2", "06-stack", "jacobi")], done.stderr
    seconds = [int(m.group(5)) for m in said if m]
    assert seconds == sorted(seconds)


def test_quiet_prints_no_progress_lines(cli: Cli, tmp_path: Path) -> None:
    done = cli("bench", CONFIGS / "06-stack.yaml", "--solvers", "pgs", "--out", tmp_path / "out", "-q")
    assert done.returncode == 0, done.stderr
    assert "bench: " not in done.stderr


def test_a_terminal_gets_the_bar_and_no_lines() -> None:
    written = io.StringIO()
    finished = Finished(Console(file=written, force_terminal=True), "bench", 2)
    finished.done("06-stack pgs")
    assert written.getvalue() == "" and finished.count == 1
    piped = io.StringIO()
    Finished(Console(file=piped, force_terminal=False), "bench", 2).done("06-stack pgs")
    assert LINE.fullmatch(piped.getvalue().strip())


def test_a_run_into_a_pipe_prints_a_line_per_finished_experiment(cli: Cli, tmp_path: Path) -> None:
    configs = [CONFIGS / "03-sink.yaml", CONFIGS / "04-fixed.yaml"]
    done = cli("run", *configs, "--out", tmp_path / "out")
    assert done.returncode == 0, done.stderr
    said = [re.fullmatch(r"run: (\d+)/(\d+) done: (\S+) \(\d+ s\)", line)
            for line in done.stderr.splitlines() if line.startswith("run: ")]
    assert [m.groups() if m else None for m in said] == [("1", "2", "03-sink"), ("2", "2", "04-fixed")]
    quiet = cli("run", *configs, "--out", tmp_path / "out", "-q")
    assert quiet.returncode == 0 and "run: " not in quiet.stderr
