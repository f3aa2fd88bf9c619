"""Every error stackx prints is one line a person can read: a value inside it (a file name, a key, a list of
run names) longer than 200 characters is cut with an ellipsis and its length, the line aims at 300 characters
(values cut further, never below 120, so a path to copy stays whole) and is at most 600, however large the input
that caused it."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from stackx.errors import MAX_LINE_CHARS, readable
from stackx.run import interrupt
from stackx.run.interrupt import message
from tests.conftest import CONFIGS, Cli

NAMES = [f"run_number_{i}" for i in range(1, 10_001)]


@pytest.fixture
def before_a_switch(monkeypatch: pytest.MonkeyPatch) -> None:
    """The line as a command that has not switched its folder prints it (runs earlier in this process did)."""
    monkeypatch.setattr(interrupt._state, "switched", False)


def test_a_list_of_ten_thousand_names_is_cut_to_its_ends_and_its_count() -> None:
    where = "configs/big.yaml:9:18: outputs[0].values.depth_final:"
    text = f"{where} 'depth' needs a run name in front (RUN.depth); runs: {', '.join(NAMES)}"
    line = readable(text)
    assert len(text) > 150_000 and len(line) <= 300
    assert line.startswith(f"{where} 'depth' needs a run name in front (RUN.depth); runs: run_number_1, ")
    assert line.endswith(", …, run_number_10000 (10,000 items)")


def test_a_long_value_keeps_its_ends_and_says_how_long_it_was() -> None:
    path = "/data/" + "deep/" * 1000 + "stack.yaml"  # 5,016 characters
    line = readable(f"{path}: no such file or folder")
    assert len(line) <= 300
    assert line.startswith("/data/deep/deep/") and line.endswith("/deep/stack.yaml (5,016 characters): no such "
                                                                  "file or folder")
    assert "…" in line


def test_a_line_of_long_prose_is_cut_in_its_middle() -> None:
    text = "plugin raised: " + "the solver did not converge " * 100 + "at step 7"
    line = readable(text)
    assert len(line) == MAX_LINE_CHARS == 600
    assert line.startswith("plugin raised: the solver") and line.endswith("at step 7")
    assert f"({len(text):,} characters in all)" in line


def test_a_short_message_is_only_put_on_one_line() -> None:
    text = "configs/06-stack.yaml:7:3: solver.iteratons: unknown key 'iteratons';\n  allowed: correction, iterations"
    assert readable(text) == ("configs/06-stack.yaml:7:3: solver.iteratons: unknown key 'iteratons'; allowed: "
                              "correction, iterations")


def test_a_line_that_fits_keeps_every_name_it_lists() -> None:
    known = ", ".join(f"solver_{i:02} (built-in)" for i in range(1, 12))  # 240 characters: one value
    text = f"a.yaml:7:9: solver.name: unknown solver 'no' known: {known}"
    assert len(known) > 200 and len(text) < 300
    assert readable(text) == text


def test_a_line_naming_one_folder_thrice_keeps_every_mention_whole() -> None:
    out = "/tmp/pytest-of-someone/pytest-1234/test_a_line_naming_one_folder0/out"
    text = (f"{out}: name the configs to run again (e.g. 'stackx verify {out} configs/'), or pass --trust to run "
            f"the configs and plugins the manifest records inside {out}")
    assert len(text) > 300
    assert readable(text) == text


def test_a_refused_config_of_a_thousand_runs_prints_a_short_line(cli: Cli, tmp_path: Path) -> None:
    config = yaml.safe_load((CONFIGS / "03-sink.yaml").read_text())
    config["sweep"] = {"name": "run_number_{solver.iterations}", "grid": {"solver.iterations": list(range(1, 1001))}}
    path = tmp_path / "thousand.yaml"
    path.write_text(yaml.safe_dump(config))  # its keyvalue sink names depth[0] without saying which run's
    done = cli("validate", path)
    assert done.returncode == 2
    assert len(done.stderr.splitlines()) == 1 and len(done.stderr) <= 301, len(done.stderr)
    assert done.stderr.startswith(f"error: {path}:")
    assert "run_number_1, run_number_2, " in done.stderr and "…, run_number_1000 (1,000 items)" in done.stderr


def test_a_path_of_thousands_of_characters_prints_a_short_line(cli: Cli, tmp_path: Path) -> None:
    path = str(tmp_path) + "/d" * 2000 + "/stack.yaml"
    done = cli("validate", path)
    assert done.returncode == 2
    assert len(done.stderr.splitlines()) == 1 and len(done.stderr) <= 301, len(done.stderr)
    assert done.stderr.startswith(f"error: {tmp_path}/d/d/") and "/d/d/stack.yaml (" in done.stderr


def test_paths_a_person_must_copy_stay_whole_in_a_long_line() -> None:
    config = "/tmp/pytest-of-someone/pytest-1234/test_speed_limit_names_the_ste0/fast.yaml"
    failed = "/tmp/pytest-of-someone/pytest-1234/test_speed_limit_names_the_ste0/out/fast.failed.json"
    text = (f"{config}: run 'main' blew up at step 62 of 600: box 0 moves at 60.1 m/s, over limits.max_speed = 60 "
            f"m/s (solver 'pgs' (built-in)); partial measures in {failed}")
    line = readable(text)
    assert len(text) > 300 and line == text


def test_the_interrupt_line_cuts_a_long_folder_name(before_a_switch: None) -> None:
    out = "/tmp/" + "o" * 5000
    line = message(["run", "configs", "--out", out])
    assert len(line) <= 300 and line.startswith("interrupted; /tmp/ooo") and line.endswith("left as it was")


def test_the_interrupt_line_names_the_folder_of_every_command_that_switches_one(before_a_switch: None) -> None:
    assert message(["run", "configs", "-o", "lab/out"]) == "interrupted; lab/out left as it was"
    assert message(["bench", "configs/hard"]) == "interrupted; out/bench left as it was"
    assert message(["init", "lab"]) == "interrupted; lab left as it was"
    assert message(["init"]) == "interrupted; . left as it was"
    assert message(["validate", "configs"]) == "interrupted"
