"""Hostile edits of a shipped config, each one line: refused at load with one located line, exit 2, nothing
written, never a traceback. The position each error must name is found in the edited text here, independently
of stackx's YAML reader."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from stackx.cli import app
from tests.conftest import CONFIGS

ITERS = (CONFIGS / "05-iters.yaml").read_text()
STACK = (CONFIGS / "06-stack.yaml").read_text()
LINE = re.compile(r"^error: (?P<file>.+?):(?P<line>\d+):(?P<col>\d+): (?P<key>[^\s:]+): (?P<msg>\S.*)$")
DEEP = "/".join(["d"] * 2000) + "/m.json"
LISTED = "boxes: [" + ", ".join(f"{{y: {i + 1}}}" for i in range(10_001)) + "]"
TWENTY = ITERS.replace("[1, 4, 10]", "[" + ", ".join(map(str, range(1, 21))) + "]") + \
    "  - render: compare\n    every: 1\n    count: 500\n"
SWEPT = "sweep:\n  name: iters{solver.iterations}\n  grid:\n    solver.iterations: [1, 4, 10]"
NAMED = "runs:\n" + "".join(f"  iters{k}: {{solver.iterations: {k % 20 + 1}}}\n" for k in range(10_001))

# (id, base text, old line part, new line part, the text the error points at, key, words in the message)
ROWS = [
    ("division-by-zero", ITERS, "iters1: iters1.max_depth", 'iters1: "1/0"', '"1/0"', "outputs[0].values.iters1",
     ["division by zero"]),
    ("wrong-arity", ITERS, "iters1: iters1.max_depth", 'iters1: "abs(1,2)"', '"abs(1,2)"',
     "outputs[0].values.iters1", ["abs()", "1 value", "not 2"]),
    ("int-tag", ITERS, "steps: 600", "steps: !!int x", "!!int x", "steps", ["!!int", "whole number"]),
    ("bool-tag", ITERS, "steps: 600", "steps: !!bool maybe", "!!bool maybe", "steps", ["!!bool", "true or false"]),
    ("other-tag", ITERS, "steps: 600", "steps: !!timestamp 2001-12-14", "!!timestamp", "steps", ["tag"]),
    ("custom-tag", ITERS, "steps: 600", "steps: !big 600", "!big", "steps", ["tag"]),
    ("5000-digits", ITERS, "steps: 600", "steps: " + "9" * 5000, "9" * 50, "steps", ["5,000 digits"]),
    ("2000-folders", ITERS, "path: 05-iters.txt", f"path: {DEEP}", DEEP[:50], "outputs[0].path", ["at most"]),
    ("300-char-name", ITERS, "path: 05-iters.txt", "path: " + "n" * 300, "n" * 50, "outputs[0].path",
     ["300 bytes", "at most 255"]),
    ("dot-path", ITERS, "path: 05-iters.txt", 'path: "."', '"."', "outputs[0].path", ["'.'"]),
    ("sub-dot-path", ITERS, "path: 05-iters.txt", 'path: "sub/."', '"sub/."', "outputs[0].path", ["'.'"]),
    ("empty-folder", ITERS, "path: 05-iters.txt", 'path: "a//b.txt"', '"a//b.txt"', "outputs[0].path", ["empty"]),
    ("lone-surrogate", ITERS, "path: 05-iters.txt", 'path: "a\\udc80.txt"', '"a\\udc80', "outputs[0].path",
     ["surrogate"]),
    ("base-60", ITERS, "steps: 600", "steps: 1:30", "1:30", "steps", ["'1:30'"]),
    ("hex", ITERS, "steps: 600", "steps: 0x258", "0x258", "steps", ["'0x258'"]),
    ("file-and-folder", ITERS, "path: 05-iters.metrics.json", "path: 05-iters.txt/m.json", "05-iters.txt/m.json",
     "outputs[1].path", ["'05-iters.txt'", "outputs[0] (line 18, column 11)"]),
    ("frames-beside-picture", STACK, "path: stack.png", "path: f00.png/x.png", "f{index:02d}.png", "outputs[2].path",
     ["'f00.png' would be a file", "outputs[1] (line 23"]),
    ("same-file-by-case", STACK, "path: stack.png", "path: F00.png", "f{index:02d}.png", "outputs[2].path",
     ["differ only in case"]),
    ("wide-format", STACK, "path: f{index:02d}.png", 'path: "{index:>1000000000}.png"', '"{index:>1000000000}',
     "outputs[2].path", ["width up to 9"]),
    ("huge-zero-pad", STACK, "path: f{index:02d}.png", 'path: "{index:099999999999}.png"', '"{index:0999',
     "outputs[2].path", ["width up to 9"]),
    ("format-attribute", STACK, "path: f{index:02d}.png", 'path: "{index.real}.png"', '"{index.real}',
     "outputs[2].path", ["unknown field"]),
    ("million-stack", STACK, "count: 5,", "count: 1000000,", "1000000", "scene.stack.count", ["max_bodies"]),
    ("listed-boxes", STACK, "stack: {count: 5, y0: 2.5, spacing: 1.6, half_height: 0.5, mass: 1.0}", LISTED, "[",
     "scene.boxes", ["10,001 boxes", "max_bodies"]),
    ("steps-times-boxes", STACK.replace("count: 5,", "count: 1000,"), "steps: 900", "steps: 10000000", "10000000",
     "steps", ["1e+10", "max_box_steps"]),
    ("all-frames", STACK.replace("steps: 900", "steps: 100000"), "every: 15\n    count: 12",
     "every: 1\n    count: all", "all\n    player", "outputs[2].count",
     ["max_frames"]),
    ("grid-7x10", ITERS, "solver.iterations: [1, 4, 10]",
     "\n    ".join(f"solver.iterations{'' if k == 0 else f'_{k}'}: [{', '.join(map(str, range(1, 11)))}]"
                    for k in range(7)), "solver.iterations:", "sweep.grid", ["10,000,000 runs", "max_runs"]),
    ("compare-runs-x-frames", TWENTY, "count: 500", "count: 599", "599", "outputs[2].count",
     ["20 runs x 599 frames = 11,980 pictures", "max_frames"]),
    ("10001-named-runs", ITERS, SWEPT, NAMED, "runs:", "runs", ["10,001 named runs", "max_runs"]),
    ("3000-terms", STACK, "y1: y[0]", "y1: " + "+".join(["1"] * 3000), "1+1+1", "outputs[0].values.y1",
     ["at most 1,000 characters"]),
    ("deep-expression", STACK, "y1: y[0]", "y1: " + "+".join(["1"] * 300), "1+1+1", "outputs[0].values.y1",
     ["nested more than"]),
]


def _position(text: str, needle: str) -> tuple[int, int]:
    before = text[: text.index(needle)]
    return before.count("\n") + 1, len(before) - (before.rfind("\n") + 1) + 1


@pytest.mark.parametrize("base, old, new, at, key, words", [r[1:] for r in ROWS], ids=[r[0] for r in ROWS])
def test_one_hostile_line_is_refused_where_it_is_written(tmp_path: Path, base: str, old: str, new: str, at: str,
                                                         key: str, words: list[str]) -> None:
    assert old in base
    text = base.replace(old, new, 1)
    config, out = tmp_path / "X.yaml", tmp_path / "O"
    config.write_text(text)
    result = CliRunner().invoke(app, ["run", str(config), "--out", str(out), "-q"])
    assert isinstance(result.exception, SystemExit), result.exc_info  # an error raised, not reported, is a traceback
    assert result.exit_code == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    m = LINE.match(lines[0])
    assert m, lines[0]
    line, col = _position(text, at)
    assert (m["file"], int(m["line"]), int(m["col"]), m["key"]) == (str(config), line, col, key), lines[0]
    for word in words:
        assert word in m["msg"], lines[0]
    assert not out.exists()


def test_the_limits_key_raises_each_limit(tmp_path: Path) -> None:
    """Every size limit is a default, and a config that says so gets past it."""
    text = STACK.replace("count: 5,", "count: 20000,").replace("steps: 900", "steps: 100000")
    text = text.replace("every: 15\n    count: 12", "every: 1\n    count: all")
    config = tmp_path / "big.yaml"
    config.write_text(text)
    runner = CliRunner()
    refused = runner.invoke(app, ["validate", str(config)])
    assert refused.exit_code == 2 and "max_bodies" in refused.stderr
    config.write_text(text + "limits: {max_bodies: 20000, max_box_steps: 2.0e9, max_frames: 100001, "
                             "max_memory_mb: 1.0e6, max_work: 1.0e15}\n")
    allowed = runner.invoke(app, ["validate", str(config)])
    assert allowed.exit_code == 0, allowed.stderr
