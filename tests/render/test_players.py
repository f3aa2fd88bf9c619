"""The players: the lab's stack played to the end with controls, and several runs side by side in step.

Pictures are compared pixel for pixel with the lab's plain-Python transcription (``tests/lab/reference``);
step and time labels with ``k x dt`` worked out here. What the page does in a browser (keys, slider, speed)
is tested in ``tests/robust/test_player_browser.py``.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from tests.conftest import CONFIGS, Cli
from tests.lab import reference as ref

STACK = (CONFIGS / "06-stack.yaml").read_text()


def _data(page: str) -> dict:
    """The player's frames, labels and panels, as the page's script reads them."""
    match = re.search(r'<script type="application/json" id="data">(.*?)</script>', page, re.S)
    assert match, "the page has no data block"
    return json.loads(match.group(1).replace("<\\/", "</"))


def _picture(path: Path) -> ref.Picture:
    return ref.read_png(path.read_bytes())[2]


def _note(ys: list[float]) -> str:
    return f"top box {ys[-1]:.3f} m · deepest contact {max(ref.max_depth(ys), 0.0):.4f} m"


def test_whole_settling_is_played_with_step_and_time(cli: Cli, tmp_path: Path) -> None:
    """count: all draws every 15th step to the end (61 frames, the last the final state); controls: true
    gives the page with its labels. The numbers of the run do not change."""
    done = cli("run", CONFIGS / "06-stack.yaml", "--out", tmp_path / "all", "-q",
               "--set", "outputs[2].count=all", "--set", "outputs[2].controls=true")
    assert done.returncode == 0, done.stderr
    plain = cli("run", CONFIGS / "06-stack.yaml", "--out", tmp_path / "lab", "-q")
    assert plain.returncode == 0, plain.stderr
    out, lab = tmp_path / "all", tmp_path / "lab"
    steps = list(range(0, 901, 15))
    names = [f"f{k:02d}.png" for k in range(len(steps))]
    assert sorted(p.name for p in out.glob("f*.png")) == names
    run = ref.stack_run()
    states = run.captured + [run.final]  # before steps 0, 15, ..., 885, then the final state (step 900)
    assert len(states) == len(steps)
    for k in (0, 11, 12, 37, 59, 60):
        assert _picture(out / names[k]) == ref.draw_stack(states[k]), names[k]
    assert (out / "f60.png").read_bytes() == (lab / "stack.png").read_bytes()
    for name in ("06-stack.txt", "stack.png", *names[:12]):
        assert (out / name).read_bytes() == (lab / name).read_bytes(), name
    page = (out / "index.html").read_text()
    data = _data(page)
    assert data["labels"] == [f"step {k} · t = {k / 60:.3f} s" for k in steps]
    (panel,) = data["panels"]
    assert panel["images"] == names
    for k in (0, 30, 60):
        assert panel["notes"][k] == _note(states[k])
    assert 'id="slider" type="range" min="0" max="60"' in page
    assert all(f'id="{control}"' in page for control in ("play", "back", "forward", "speed"))
    assert "setInterval" in (lab / "index.html").read_text() and "slider" not in (lab / "index.html").read_text()


COMPARE = STACK.split("outputs:")[0] + """
runs:
  lab: {}
  exact: {solver: {name: exact}}
outputs:
  - render: compare
    path: side.html
    runs: [exact, lab]
    every: 15
    count: 12
"""


def test_runs_are_played_side_by_side_in_step(cli: Cli, tmp_path: Path) -> None:
    """The lab run's panel shows the lab's frames pixel for pixel; the exact solver's differs once the boxes
    land; both panels have one picture per frame, in the order the config names them."""
    config = tmp_path / "side.yaml"
    config.write_text(COMPARE)
    done = cli("run", config, "--out", tmp_path / "out", "-q")
    assert done.returncode == 0, done.stderr
    out = tmp_path / "out"
    data = _data((out / "side.html").read_text())
    assert [p["caption"] for p in data["panels"]] == ["exact", "lab"]
    exact, lab = (p["images"] for p in data["panels"])
    assert lab == [f"compare/lab-{k:03d}.png" for k in range(12)]
    assert exact == [f"compare/exact-{k:03d}.png" for k in range(12)]
    for k, ys in enumerate(ref.frame_states()):
        assert _picture(out / lab[k]) == ref.draw_stack(ys), lab[k]
    assert (out / exact[0]).read_bytes() == (out / lab[0]).read_bytes()  # the same scene at step 0
    assert any((out / a).read_bytes() != (out / b).read_bytes() for a, b in zip(exact, lab))
    assert data["labels"] == [f"step {15 * k} · t = {15 * k / 60:.3f} s" for k in range(12)]
    assert data["panels"][1]["notes"] == [_note(ys) for ys in ref.frame_states()]


@pytest.mark.parametrize("extra, key, message", [
    ("    runs: [lab, nope]\n", "outputs[0].runs[1]", "unknown run 'nope'; runs: lab, exact"),
    ("    runs: [lab, lab]\n", "outputs[0].runs[1]", "run 'lab' is named twice"),
    ("    frames: 'c/{index}.png'\n", "outputs[0].frames", "two pictures the same name"),
    ("    frames: 'c/{run}-{frame}.png'\n", "outputs[0].frames", "bad template"),
    ("    path: compare/lab-000.png\n", "outputs[0].path", "also the name of a picture"),
    ("    start: 901\n", "outputs[0].start", "past the end of the run (900)"),
    ("    count: 0\n", "outputs[0].count", "a number of frames from 1 to 100,000, or 'all'"),
])
def test_bad_compare_settings_stop_at_their_key(cli: Cli, tmp_path: Path, extra: str, key: str, message: str) -> None:
    config = tmp_path / "side.yaml"
    text = COMPARE.replace("    path: side.html\n    runs: [exact, lab]\n", "").replace("    count: 12\n", "")
    text += "    count: 12\n" if "count:" not in extra else ""
    config.write_text(text + extra)
    done = cli("validate", config)
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith("error: ") and done.stderr.count("\n") == 1, done.stderr
    assert f" {key}: " in done.stderr and message in done.stderr, done.stderr


def test_runs_of_different_step_sizes_are_refused(cli: Cli, tmp_path: Path) -> None:
    config = tmp_path / "side.yaml"
    config.write_text(COMPARE.replace("exact: {solver: {name: exact}}", "fine: {dt: 0.01}")
                      .replace("runs: [exact, lab]", "runs: [lab, fine]"))
    done = cli("validate", config)
    assert done.returncode == 2
    assert "outputs[0].runs: runs 'lab' (dt 0.0166667 s) and 'fine' (dt 0.01 s) step differently" in done.stderr
