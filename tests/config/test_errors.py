"""Bad configs end with one located line, exit code 2 and nothing written."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.conftest import CONFIGS, Cli

STACK = (CONFIGS / "06-stack.yaml").read_text()


def _position(text: str, needle: str) -> tuple[int, int]:
    """1-based line and column of the first occurrence of ``needle`` in ``text``."""
    before = text[: text.index(needle)]
    return before.count("\n") + 1, len(before) - (before.rfind("\n") + 1) + 1


# (name, original, replacement, what the error must point at in the edited text, key path, words in the message)
CASES = [
    ("typo-key", "iterations: 15", "iteratons: 15", "iteratons", "solver.iteratons", ["unknown key", "iterations"]),
    ("wrong-type", "iterations: 15", "iterations: many", "many", "solver.iterations", ["integer"]),
    ("unknown-solver", "name: pgs", "name: pgz", "pgz", "solver.name", ["unknown solver", "did you mean 'pgs'"]),
    ("percent-range", "percent: 0.2", "percent: 1.5", "1.5", "solver.correction.percent", ["less than or equal to 1"]),
    ("negative-dt", "dt: 1/60", "dt: -0.1", "-0.1", "dt", ["greater than 0"]),
    ("bad-index", "y5: y[4]", "y5: y[7]", "y[7]", "outputs[0].values.y5", ["out of range"]),
    ("unknown-measure", "max_depth: max_depth", "max_depth: maxdepth", "maxdepth", "outputs[0].values.max_depth",
     ["unknown measure"]),
    ("unknown-renderer", "render: stack ", "render: stak ", "stak", "outputs[1].render", ["did you mean 'stack'"]),
    ("escaping-path", "path: stack.png", "path: ../stack.png", "../stack.png", "outputs[1].path", ["output folder"]),
]


@pytest.mark.parametrize("name, old, new, at, key, words", CASES, ids=[c[0] for c in CASES])
def test_bad_config_is_one_located_line(cli: Cli, tmp_path: Path, name: str, old: str, new: str, at: str,
                                        key: str, words: list[str]) -> None:
    assert old in STACK
    text = STACK.replace(old, new, 1)
    config = tmp_path / f"{name}.yaml"
    config.write_text(text)
    out = tmp_path / "out"
    done = cli("run", config, "--out", out)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    line, col = _position(text, at)
    assert lines[0].startswith(f"error: {config}:{line}:{col}: {key}: "), lines[0]
    for word in words:
        assert word in lines[0]
    assert "Traceback" not in done.stderr + done.stdout
    assert not out.exists()


def test_yaml_syntax_error_is_located(cli: Cli, tmp_path: Path) -> None:
    config = tmp_path / "broken.yaml"
    config.write_text(STACK.replace("steps: 900", "steps: [900"))
    done = cli("run", config, "--out", tmp_path / "out")
    assert done.returncode == 2
    assert re.fullmatch(rf"error: {re.escape(str(config))}:\d+:\d+: YAML syntax error: .+", done.stderr.strip())
    assert not (tmp_path / "out").exists()


def test_duplicate_key_is_refused(cli: Cli, tmp_path: Path) -> None:
    config = tmp_path / "dup.yaml"
    text = STACK.replace("steps: 900", "steps: 900\nsteps: 901")
    config.write_text(text)
    done = cli("validate", config)
    line, col = _position(text, "steps: 901")
    assert done.returncode == 2
    assert done.stderr.strip() == f"error: {config}:{line}:{col}: steps: duplicate key 'steps'"


def test_one_bad_config_in_a_folder_writes_nothing(cli: Cli, tmp_path: Path) -> None:
    folder = tmp_path / "configs"
    folder.mkdir()
    for name in ("03-sink.yaml", "06-stack.yaml"):
        (folder / name).write_text((CONFIGS / name).read_text())
    (folder / "99-bad.yaml").write_text(STACK.replace("steps: 900", "steps: -5"))
    done = cli("run", folder, "--out", tmp_path / "out")
    assert done.returncode == 2
    assert "99-bad.yaml" in done.stderr and "steps" in done.stderr
    assert not (tmp_path / "out").exists()


def test_set_override_error_points_into_the_option(cli: Cli, tmp_path: Path) -> None:
    done = cli("run", CONFIGS / "06-stack.yaml", "--set", "solver.iterations=abc", "--out", tmp_path / "out")
    assert done.returncode == 2
    assert done.stderr.startswith("error: --set solver.iterations=abc:1:19: solver.iterations: ")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("args, words", [
    (["run", "no/such/file.yaml"], ["no/such/file.yaml", "no such file"]),
    (["validate", "pyproject.toml"], ["pyproject.toml"]),
])
def test_bad_paths(cli: Cli, args: list[str], words: list[str]) -> None:
    done = cli(*args)
    assert done.returncode == 2
    # pyproject.toml's folder holds plugins/, which is imported (and named) before the file is read
    said = [line for line in done.stderr.strip().splitlines() if not line.startswith("plugins: imported ")]
    assert len(said) == 1
    assert all(w in said[0] for w in words)


def test_value_index_counts_the_boxes_left_after_removals(cli: Cli, tmp_path: Path) -> None:
    text = """scene:
  name: column
  stack: {count: 5, y0: 0.501, spacing: 1.0}
  remove: [{step: 10, box: -1}]
solver: {name: pgs, iterations: 4}
steps: 100
outputs:
  - sink: keyvalue
    path: top.txt
    values: {top: "y[4]"}
"""
    config = tmp_path / "removal.yaml"
    config.write_text(text)
    done = cli("run", config, "--out", tmp_path / "out")
    line, col = _position(text, 'y[4]')
    assert done.returncode == 2
    assert done.stderr.startswith(f"error: {config}:{line}:{col - 1}: outputs[0].values.top: index 4 out of range")
    config.write_text(text.replace("y[4]", "y[3]"))
    assert cli("run", config, "--out", tmp_path / "out", "-q").returncode == 0


LISTED = """scene: {name: column, boxes: [{y: 0.5}, {y: 1.5}]}
solver: {name: pgs, iterations: 4}
steps: 120
"""


@pytest.mark.parametrize("tail, at, key, words", [
    ("sweep:\n  grid:\n    solver.iterations: [2, 3]\n    limits.max_speed: [5, 6]\n", "limits.max_speed",
     "sweep.grid.limits.max_speed", "only scene, solver, gravity, dt, steps can be overridden per run"),
    ("sweep:\n  grid:\n    solver..iterations: [5, 6]\n", "solver..iterations", "sweep.grid.solver..iterations",
     "malformed key 'solver..iterations'"),
    ("runs:\n  a: {steps: 60}\n  b: {outputs: []}\n", "outputs", "runs.b.outputs",
     "only scene, solver, gravity, dt, steps can be overridden per run"),
    ("sweep:\n  grid:\n    scene.boxes.5.y: [3.0]\n", "3.0", "sweep.grid.scene.boxes.5.y[0]",
     "no such place in the config: scene.boxes[5]"),
], ids=["sweep-key-outside-a-run", "malformed-sweep-key", "runs-key-outside-a-run", "sweep-into-missing-box"])
def test_a_bad_override_points_at_its_key(cli: Cli, tmp_path: Path, tail: str, at: str, key: str, words: str) -> None:
    """A grid key that cannot be overridden is refused at the key itself (once, not at a value of a run)."""
    text = LISTED + tail
    config = tmp_path / "override.yaml"
    config.write_text(text)
    done = cli("validate", config)
    line, col = _position(text, at)
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().startswith(f"error: {config}:{line}:{col}: {key}: {words}"), done.stderr
