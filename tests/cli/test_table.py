"""The run summary fits an 80-column terminal without cutting a number, and says how each run was stepped."""

from __future__ import annotations

import json
from collections import Counter
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


ENGINE_COLUMN = """
description: a short column stepped by an engine and by the lab's solver, side by side
scene: {name: column, stack: {count: 4, y0: 0.5, spacing: 1.0}}
solver: {name: pgs}
steps: 5
sweep: {name: "{solver.name}", grid: {solver.name: [pymunk, pgs]}}
"""


def test_an_engine_is_marked_as_one_within_80_columns(cli: Cli, tmp_path: Path) -> None:
    """An engine's time is marked as an engine's, compiled kernels on or off, beside the lab solver's ``jit`` or
    ``py``; the marks are explained under the table, and the row still fits 80 columns."""
    (tmp_path / "engine.yaml").write_text(ENGINE_COLUMN)
    for jit, lab in (("0", "py"), ("1", "jit")):
        done = cli("run", tmp_path / "engine.yaml", "--out", tmp_path / f"out{jit}",
                   env={"COLUMNS": "80", "STACKX_JIT": jit})
        assert done.returncode == 0, done.stderr
        lines = done.stdout.splitlines()
        assert max(map(len, lines)) <= 80, max(lines, key=len)
        rows = {cells[0]: cells for cells in map(str.split, lines) if cells[:1] and "/" in cells[0]}
        assert rows["engine/pymunk"][-1] == "engine", rows
        assert rows["engine/pgs"][-1] == lab, rows
        assert "engine = an engine" in " ".join(done.stdout.split())


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


BOX = str.maketrans({c: " " for c in "│┃┏┓┗┛┡┩┳┻╇╈━─└┘┌┐"})  # borders as spaces: columns keep their place


def _name_columns(lines: list[str]) -> tuple[dict[str, list[str]], int]:
    """The run table's ``run`` and ``solver`` columns as the screen shows them, top to bottom: per column, the
    piece of each line that starts where the column's header starts; and how many parts (headers) it has."""
    found: dict[str, list[str]] = {"run": [], "solver": []}
    starts: dict[str, int] = {}
    parts = 0
    for raw in lines:
        line = raw.translate(BOX)
        tokens = line.split()
        if tokens[:1] == ["run"]:  # a header: where each name column starts
            parts += 1
            starts = {name: f" {line}".index(f" {name} ") for name in found if name in tokens}
        elif raw.startswith("└") or tokens[:1] == ["FAIL"] or "stackx run" in line:
            starts = {}  # the part ended: its bottom border, the failures under it, or the next part's title
        else:
            for name, at in starts.items():
                if line[at:at + 1].strip() and (at == 0 or line[at - 1] == " "):
                    found[name].append(line[at:].split()[0])
    return found, parts


def _whole(pieces: list[str], names: list[str]) -> None:
    """``pieces`` (a column's lines, top to bottom) spell every one of ``names`` (in any order), each broken only
    after / - _ : readable, never cut mid-word, never shrunk to nothing."""
    left = Counter(names)
    spelt = ""
    for piece in pieces:
        assert piece, pieces
        spelt += piece
        assert any(name.startswith(spelt) for name in left), (spelt, pieces)
        if left[spelt]:
            left[spelt] -= 1
            spelt = ""
        else:
            assert piece[-1] in "/-_", f"{spelt!r} broken inside a word: {piece!r}"
    assert not spelt and not +left, (spelt, +left)


def test_at_80_columns_with_a_verdict_every_name_is_whole(cli: Cli, tmp_path: Path) -> None:
    """A planar ramp states its outcome, so the table has a verdict column: at 80 columns the run and the solver
    are each still there in full, broken at most after a '/' or '-', and every number whole."""
    done = cli("run", REPO / "configs" / "planar" / "ramp-slide.yaml", "--set", "steps=20", "--out", tmp_path,
               env={"COLUMNS": "80", "STACKX_JIT": "0"})
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert max(map(len, lines)) <= 80, max(lines, key=len)
    assert "verdict" in done.stdout and "FAIL" in done.stdout and "…" not in done.stdout
    found, parts = _name_columns(lines)
    assert parts == 1
    _whole(found["run"], ["ramp-slide/main"])
    _whole(found["solver"], ["planar-pgs"])
    run = json.loads((tmp_path / "ramp-slide.metrics.json").read_text())["runs"]["main"]
    for key in ("max_depth", "peak_depth", "rms_motion"):
        assert format(run[key], ".3g") in done.stdout.split(), key


@pytest.mark.parametrize("configs, sets", [(["planar/ramp-slide"], ["--set", "steps=20"]),
                                          (["03-sink", "05-iters", "06-stack", "planar/ramp-slide"], [])])
def test_wide_at_80_columns_keeps_every_name_and_every_figure(cli: Cli, tmp_path: Path, configs: list[str],
                                                             sets: list[str]) -> None:
    """--wide at 80 columns is too wide for one table: it prints in parts, each repeating the run's name (and
    its solver); every name is whole in every part and every figure is there at full precision, uncut."""
    done = cli("run", *(CONFIGS / f"{name}.yaml" for name in configs), *sets, "--out", tmp_path, "--wide",
               env={"COLUMNS": "80", "STACKX_JIT": "0"})
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert max(map(len, lines)) <= 80, max(lines, key=len)
    assert "…" not in done.stdout
    names, solvers, figures = [], [], []
    for name in configs:
        doc = json.loads((tmp_path / f"{Path(name).name}.metrics.json").read_text())
        for run_name, run in doc["runs"].items():
            names.append(f"{doc['config']}/{run_name}")
            solvers.append(run["solver"])
            figures += [format(run[k], ".6g") for k in ("max_depth", "peak_depth", "rms_motion", "launch", "reach")]
    found, parts = _name_columns(lines)
    assert parts >= 2
    _whole(found["run"], names * parts)
    _whole(found["solver"], solvers * parts)
    words = done.stdout.translate(BOX).split()
    for figure in figures:
        assert figure in words, figure
