"""The run summary fits an 80-column terminal without cutting a number, and says how each run was stepped."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.conftest import CONFIGS, REPO, Cli


def test_the_run_table_fits_80_columns_and_cuts_no_number(cli: Cli, tmp_path: Path) -> None:
    done = cli("run", CONFIGS, "--out", tmp_path, env={"COLUMNS": "80", "STACKX_JIT": "0"})
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert all(len(line) <= 80 for line in lines), max(lines, key=len)
    assert "…" not in done.stdout
    rows = {cells[0]: cells for cells in map(str.split, lines) if cells and "/" in cells[0]}
    for metrics in sorted(tmp_path.glob("*.metrics.json")):
        doc = json.loads(metrics.read_text())
        for name, run in doc["runs"].items():
            row = rows[f"{doc['config']}/{name}"]
            expected = [run["solver"], str(run["boxes"]), str(run["steps"]),
                        *(format(run[k], ".3g") for k in ("max_depth", "peak_depth", "rms_motion"))]
            assert row[1:7] == expected
            assert row[8] == "py"  # STACKX_JIT=0: every run plain


def test_wide_adds_the_monitors_at_full_precision(cli: Cli, tmp_path: Path) -> None:
    done = cli("run", CONFIGS / "03-sink.yaml", "--out", tmp_path, "--wide", env={"COLUMNS": "200"})
    assert done.returncode == 0, done.stderr
    run = json.loads((tmp_path / "03-sink.metrics.json").read_text())["runs"]["main"]
    assert "launch m/s" in done.stdout and "reach" in done.stdout
    assert format(run["max_depth"], ".6g") in done.stdout and format(run["reach"], ".6g") in done.stdout


def test_a_table_sent_to_a_file_keeps_each_run_on_one_line(cli: Cli, tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("COLUMNS", raising=False)  # no terminal and no width asked: a log file's width
    done = cli("run", REPO / "configs" / "planar" / "card-house.yaml", "--set", "steps=2", "--out", tmp_path,
               env={"STACKX_JIT": "0"})
    assert done.returncode == 0, done.stderr
    row = next(line for line in done.stdout.splitlines() if "card-house/" in line)
    assert row.split()[:2] == ["card-house/main", "planar-warm-start"]
