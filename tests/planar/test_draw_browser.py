"""The planar players in a real browser (``stackx serve`` + headless Chromium, as the column's players are
tested in ``tests/robust/test_player_browser.py``, whose helpers this uses): a run's frames with controls
and two runs side by side step together to the end, every picture loads, and no page logs an error.
Screenshots: ``test-artifacts/planar-player.png`` and ``planar-compare.png``."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from stackx.cli import app
from tests.conftest import Shown
from tests.planar.test_draw import PLANAR
from tests.robust.test_player_browser import _shown, browsing, keep, serving
from tests.limits import hang_limit


def _label(k: int, steps: list[int]) -> str:
    return f"frame {k + 1} / {len(steps)} · step {steps[k]} · t = {steps[k] / 60:.3f} s"


def test_planar_players_step_to_the_end(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                        shown: Shown) -> None:
    config = tmp_path / "ramp.yaml"
    config.write_text(PLANAR)
    out = tmp_path / "out"
    monkeypatch.setenv("STACKX_JIT", "0")  # a few hundred box-steps: plain Python is quicker than loading numba
    result = CliRunner().invoke(app, ["run", str(config), "--out", str(out), "-q"])
    assert result.exit_code == 0, result.stderr
    seen = {}
    with serving(out) as url, browsing(tmp_path / "profile") as (page, problems):
        for name, count in (("index.html", 5), ("compare.html", 3)):
            page.goto(url + name, wait_until="load")  # type: ignore[attr-defined]
            page.keyboard.press(" ")  # type: ignore[attr-defined]
            walk = []
            for key in ("Home", "ArrowRight", "End", "ArrowRight", "ArrowLeft"):
                page.keyboard.press(key)  # type: ignore[attr-defined]
                walk.append(_shown(page))
            page.keyboard.press("End")  # type: ignore[attr-defined]
            sizes = page.eval_on_selector_all("img.frame", "els => els.map(e => [e.complete, e.naturalWidth])")  # type: ignore[attr-defined]
            note = page.locator("p.note").first.text_content()  # type: ignore[attr-defined]
            keep(page, "planar-player.png" if name == "index.html" else "planar-compare.png", shown)
            seen[name] = (walk, sizes, note, count)
    player, sizes, note, _ = seen["index.html"]
    steps = [0, 10, 20, 30, 40]
    assert [label for label, _ in player] == [_label(k, steps) for k in (0, 1, 4, 0, 4)]
    assert [srcs for _, srcs in player] == [[f"f/{k:02d}.png"] for k in (0, 1, 4, 0, 4)]
    assert sizes == [[True, 256]] and note.startswith("highest box ")
    side, sizes, _, _ = seen["compare.html"]
    steps = [0, 20, 40]
    assert [label for label, _ in side] == [_label(k, steps) for k in (0, 1, 2, 0, 2)]
    assert [srcs for _, srcs in side] == [[f"compare/few-{k:03d}.png", f"compare/many-{k:03d}.png"]
                                          for k in (0, 1, 2, 0, 2)]
    assert sizes == [[True, 256], [True, 256]]
    assert not problems, problems


BENCH_CASE = """
description: three boxes with small offsets
scene: {name: planar, stack: {count: 3, offset: 0.1, seed: 1}}
solver: {name: planar-pgs, iterations: 8}
steps: 60
bench: {knob: [2, 8], timing: {steps: 5, repeats: 1}}
"""


def test_the_report_draws_a_planar_case(tmp_path: Path, shown: Shown) -> None:
    """A planar case's section: its plot against time with the drift panels and its start and final states,
    every picture loaded."""
    import subprocess
    import sys

    from tests.conftest import REPO
    from tests.robust.test_player_browser import _browser

    _browser()
    (tmp_path / "cases").mkdir()
    (tmp_path / "cases" / "stack-3.yaml").write_text(BENCH_CASE)
    done = subprocess.run([sys.executable, "-m", "stackx", "bench", str(tmp_path / "cases"), "--out",
                           str(tmp_path / "out"), "--solvers", "planar-pgs", "-q"],
                          cwd=REPO, capture_output=True, text=True, timeout=hang_limit(600))
    assert done.returncode == 0, done.stderr
    with serving(tmp_path / "out") as url, browsing(tmp_path / "profile") as (page, problems):
        page.goto(url + "report.html#stack-3", wait_until="load")  # type: ignore[attr-defined]
        page.wait_for_function("document.getElementById('stack-3').open")  # type: ignore[attr-defined]
        images = page.eval_on_selector_all("#stack-3 img", "els => els.map(e => [e.alt, e.complete, e.naturalWidth, e.naturalHeight])")  # type: ignore[attr-defined]
        captions = page.eval_on_selector_all("figure.state figcaption", "els => els.map(e => e.textContent)")  # type: ignore[attr-defined]
        keep(page, "planar-report-case.png", shown)
    plot = next(i for i in images if i[0].startswith("top box height"))
    assert "drift and turn" in plot[0] and plot[1:] == [True, 1150, 640]
    states = [i[1:] for i in images if i[0] in captions]
    assert len(states) == 2 and states[0] == states[1] and states[0][0]  # one view, at one scale, both loaded
    assert states[0][2] == 480 and 96 <= states[0][1] < 480  # shaped like the pile: three boxes stand tall
    assert captions[0] == "start" and captions[1].startswith("planar-pgs (iterations ")
    assert not problems, problems
