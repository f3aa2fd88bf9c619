"""``stackx run --check``: a FAIL verdict exits 1 (named, the artifacts still written); a passing verdict and a
run with nothing stated to judge exit 0; without ``--check`` a FAIL verdict is reported and exits 0."""

from __future__ import annotations

import json
from pathlib import Path

from tests.conftest import CONFIGS, Cli

RAMP = CONFIGS / "planar" / "ramp-slide.yaml"  # 20 steps from rest: the box has not reached the analytic slide
PLAIN = {"STACKX_JIT": "0"}


def test_a_fail_verdict_exits_0_and_with_check_exits_1(cli: Cli, tmp_path: Path) -> None:
    plain = cli("run", RAMP, "--set", "steps=20", "--out", tmp_path / "a", env=PLAIN)
    assert plain.returncode == 0, plain.stderr
    assert "FAIL ramp-slide/main: slides wrong" in plain.stdout
    checked = cli("run", RAMP, "--set", "steps=20", "--out", tmp_path / "b", "--check", env=PLAIN)
    assert checked.returncode == 1, checked.stderr
    progress, said = checked.stderr.splitlines()  # a line per finished experiment: stderr is not a terminal
    assert progress.startswith("run: 1/1 done: ramp-slide (")
    assert said.startswith("error: --check: verdict FAIL for 1 of 1 judged run: ramp-slide/main")
    assert "Traceback" not in said
    assert "FAIL ramp-slide/main" in checked.stdout, "the table is printed before the command fails"
    written = json.loads((tmp_path / "b" / "ramp-slide.metrics.json").read_text())
    assert written == json.loads((tmp_path / "a" / "ramp-slide.metrics.json").read_text())


def test_check_passes_a_run_that_holds(cli: Cli, tmp_path: Path) -> None:
    """A box a degree below the friction angle stays where it was put under the config's own solver: pass."""
    done = cli("run", CONFIGS / "planar" / "ramp-below.yaml", "--out", tmp_path, "--check", "-q", env=PLAIN)
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""


def test_check_says_when_nothing_was_judged(cli: Cli, tmp_path: Path) -> None:
    done = cli("run", CONFIGS / "03-sink.yaml", "--out", tmp_path, "--check", "-q", env=PLAIN)
    assert done.returncode == 0, done.stderr
    assert done.stderr.startswith("note: --check: no run states what must hold") and done.stderr.count("\n") == 1
