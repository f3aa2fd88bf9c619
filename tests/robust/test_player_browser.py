"""The pages stackx writes, in a real browser: ``stackx serve`` + headless Chromium (Debian's, no download).

- The lab's player must show ``f00.png`` .. ``f11.png`` in order and wrap around to ``f00.png``, every frame
  must load as a 256x256 picture (no broken image), and what the ``<img>`` shows must be one of the frames
  pixel for pixel (drawn twice as big, ``image-rendering: pixelated``).
- The player with controls, for two runs side by side and for the lab's whole settling: space pauses and
  plays, the arrows step, Home and End jump, the slider picks a frame, ``+`` speeds it up; every panel shows
  the same frame, and the label its step and time.
- The bench report: it opens on speed against error, open, its plot on the first screen; the summary follows;
  its cases are closed until a link in the summary opens one; every picture is drawn.

No page may log a console error or page error, or have a request fail or answer an HTTP error. Screenshots
are kept in ``test-artifacts/`` (``player.png``, ``compare.png``, ``settling.png``, ``report.png``,
``report-case.png``). Where Chromium or Playwright is missing the tests are skipped, and the reason shows
in pytest's summary.
"""

from __future__ import annotations

import contextlib
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from typer.testing import CliRunner

from stackx.cli import app
from tests.conftest import CONFIGS, REPO, Shown
from tests.lab.reference import read_png
from tests.limits import hang_limit

CHROMIUM = Path("/usr/bin/chromium")
ARTIFACTS = REPO / "test-artifacts"
FRAMES = [f"f{i:02d}.png" for i in range(12)]
FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
         "--disable-component-update", "--disable-sync"]

# installed before the page's own script: records every picture the page puts in an <img> (after the first, which
# the page's markup holds) and every image load and error. The order is checked on what the page sets: on a
# busy machine a picture may still be loading when the next one replaces it, and its load event never comes.
RECORDER = """
window.__shown = [];
new MutationObserver((changes) => {
  for (const c of changes) if (c.target.tagName === "IMG") window.__shown.push(c.target.getAttribute("src"));
}).observe(document, {subtree: true, attributes: true, attributeFilter: ["src"]});
window.__loads = [];
document.addEventListener("load", (e) => {
  if (e.target.tagName === "IMG") {
    window.__loads.push({src: e.target.getAttribute("src"), w: e.target.naturalWidth, h: e.target.naturalHeight});
  }
}, true);
document.addEventListener("error", (e) => {
  if (e.target.tagName === "IMG") window.__loads.push({src: e.target.getAttribute("src"), error: true});
}, true);
"""


def _browser() -> object:
    if not CHROMIUM.is_file():
        pytest.skip(f"browser test skipped: {CHROMIUM} is not installed (Debian package 'chromium'; .ci/run "
                    "installs it with apt-get where it can)")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("browser test skipped: the Python package 'playwright' is not installed "
                    "(pip install -e '.[test]')")
    return sync_playwright


@contextlib.contextmanager
def serving(out: Path) -> Iterator[str]:
    """``stackx serve OUT`` on a free port; yields its address."""
    server = subprocess.Popen([sys.executable, "-m", "stackx", "serve", str(out), "--port", "0"], cwd=REPO,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = server.stdout.readline() if server.stdout else ""
        assert "http://" in line, line + (server.stderr.read() if server.stderr else "")
        yield line.split(" at ")[1].split()[0]
    finally:
        server.terminate()
        server.wait(timeout=10)


@pytest.fixture
def served(tmp_path: Path):  # type: ignore[no-untyped-def]
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["run", str(CONFIGS / "06-stack.yaml"), "--out", str(out), "-q"])
    assert result.exit_code == 0, result.stderr
    with serving(out) as url:
        yield out, url


@contextlib.contextmanager
def browsing(profile: Path) -> Iterator[tuple[object, list[str]]]:
    """A fresh Chromium page and the list its problems are added to (console errors, page errors, failed
    requests, HTTP errors)."""
    sync_playwright = _browser()
    problems: list[str] = []
    with sync_playwright() as pw:  # type: ignore[operator]
        context = pw.chromium.launch_persistent_context(str(profile), executable_path=str(CHROMIUM), headless=True,
                                                        args=FLAGS, viewport={"width": 1280, "height": 900})
        try:
            page = context.new_page()
            page.on("console", lambda m: problems.append(f"console {m.type}: {m.text}") if m.type == "error" else None)
            page.on("pageerror", lambda e: problems.append(f"page error: {e}"))
            page.on("requestfailed", lambda r: problems.append(f"request failed: {r.url} {r.failure}"))
            page.on("response", lambda r: problems.append(f"HTTP {r.status}: {r.url}") if r.status >= 400 else None)
            yield page, problems
        finally:
            context.close()


def keep(page: object, name: str, shown: Shown, full: bool = False) -> None:
    """Save a screenshot of the page in test-artifacts/ and say where."""
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / name), full_page=full)  # type: ignore[attr-defined]
    shown(f"screenshot: {ARTIFACTS / name}")


def _shown_frame(screenshot: bytes, out: Path) -> str | None:
    """Which frame the element screenshot shows, each frame pixel drawn as a 2x2 block, or None.

    The element may sit at a fractional position, so its screenshot can be a pixel taller or wider than
    512 with the blocks shifted by one: one pixel of every block is compared, at both offsets.
    """
    width, height, shot = read_png(screenshot)
    assert 512 <= width <= 513 and 512 <= height <= 513, (width, height)
    frames = {name: read_png((out / name).read_bytes())[2] for name in FRAMES}
    for dy in (0, 1):
        for dx in (0, 1):
            halved = [row[dx::2][:256] for row in shot[dy::2][:256]]
            for name, picture in frames.items():
                if picture == halved:
                    return name
    return None


def test_player_plays_every_frame_in_order(served, tmp_path: Path,  # type: ignore[no-untyped-def]
                                           shown: Shown) -> None:
    out, url = served
    with browsing(tmp_path / "profile") as (page, problems):
        page.add_init_script(RECORDER)  # type: ignore[attr-defined]
        page.goto(url, wait_until="load")  # type: ignore[attr-defined]
        page.wait_for_function("window.__shown.length >= 12 && new Set(window.__loads.map(e => e.src)).size >= 12",
                               timeout=30_000)  # type: ignore[attr-defined]
        loads = page.evaluate("window.__loads")  # type: ignore[attr-defined]
        sequence = page.evaluate("window.__shown")  # type: ignore[attr-defined]
        on_screen = _shown_frame(page.locator("#frame").screenshot(), out)  # type: ignore[attr-defined]
        keep(page, "player.png", shown)
    assert sequence[:12] == FRAMES[1:] + FRAMES[:1]  # the first frame is the markup's, not set by the script
    assert sorted({entry["src"] for entry in loads}) == FRAMES
    assert all(not entry.get("error") and (entry["w"], entry["h"]) == (256, 256) for entry in loads), loads
    assert not problems, problems
    assert on_screen in FRAMES, "the <img> does not show any frame pixel for pixel"


SIDE_BY_SIDE = (CONFIGS / "06-stack.yaml").read_text().split("outputs:")[0] + """
runs:
  lab: {}
  exact: {solver: {name: exact}}
outputs:
  - render: compare
    path: compare.html
    every: 15
    count: all
  - render: frames
    run: lab
    path: settle/f{index:02d}.png
    every: 15
    count: all
    player: settle.html
    controls: true
"""
STEPS = list(range(0, 901, 15))  # the frames of both pages: every 15th step to the end, 61 of them


def _label(k: int) -> str:
    return f"frame {k + 1} / {len(STEPS)} · step {STEPS[k]} · t = {STEPS[k] / 60:.3f} s"


def _shown(page: object) -> tuple[str, list[str]]:
    """The label and the picture each panel shows."""
    label = page.locator("#label").text_content()  # type: ignore[attr-defined]
    srcs = page.eval_on_selector_all("img.frame", "els => els.map(e => e.getAttribute('src'))")  # type: ignore[attr-defined]
    return label, srcs


@pytest.fixture
def players(tmp_path: Path):  # type: ignore[no-untyped-def]
    config = tmp_path / "side.yaml"
    config.write_text(SIDE_BY_SIDE)
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["run", str(config), "--out", str(out), "-q"])
    assert result.exit_code == 0, result.stderr
    with serving(out) as url:
        yield url


def test_side_by_side_player_steps_every_panel_together(players: str, tmp_path: Path,
                                                        shown: Shown) -> None:
    with browsing(tmp_path / "profile") as (page, problems):
        page.goto(players + "compare.html", wait_until="load")  # type: ignore[attr-defined]
        page.wait_for_function("document.querySelectorAll('img.frame').length === 2")  # type: ignore[attr-defined]
        page.keyboard.press(" ")  # type: ignore[attr-defined]
        assert page.locator("#play").text_content() == "play"  # type: ignore[attr-defined]
        label, _ = _shown(page)
        k = int(label.split()[1]) - 1
        steps = []
        for key, want in (("ArrowRight", (k + 1) % 61), ("ArrowRight", (k + 2) % 61), ("ArrowLeft", (k + 1) % 61),
                          ("End", 60), ("ArrowRight", 0), ("ArrowLeft", 60), ("Home", 0)):
            page.keyboard.press(key)  # type: ignore[attr-defined]
            steps.append((key, want, _shown(page)))
        page.locator("#slider").fill("30")  # type: ignore[attr-defined]
        steps.append(("slider", 30, _shown(page)))
        page.keyboard.press("+")  # type: ignore[attr-defined]
        faster = page.locator("#speed").input_value()  # type: ignore[attr-defined]
        page.keyboard.press(" ")  # type: ignore[attr-defined]
        page.wait_for_function("!document.getElementById('label').textContent.startsWith('frame 31 ')")  # type: ignore[attr-defined]
        playing = page.locator("#play").text_content()  # type: ignore[attr-defined]
        page.keyboard.press(" ")  # type: ignore[attr-defined]
        page.keyboard.press("End")  # type: ignore[attr-defined]
        sizes = page.eval_on_selector_all("img.frame", "els => els.map(e => [e.complete, e.naturalWidth])")  # type: ignore[attr-defined]
        keep(page, "compare.png", shown)
    for key, want, (label, srcs) in steps:
        assert label == _label(want), (key, label)
        assert srcs == [f"compare/lab-{want:03d}.png", f"compare/exact-{want:03d}.png"], (key, srcs)
    assert faster == "2" and playing == "pause"
    assert sizes == [[True, 256], [True, 256]]
    assert not problems, problems


def test_settling_player_reaches_the_end(players: str, tmp_path: Path, shown: Shown) -> None:
    with browsing(tmp_path / "profile") as (page, problems):
        page.goto(players + "settle.html", wait_until="load")  # type: ignore[attr-defined]
        page.keyboard.press("End")  # type: ignore[attr-defined]
        label, srcs = _shown(page)
        note = page.locator("p.note").text_content()  # type: ignore[attr-defined]
        keep(page, "settling.png", shown)
    assert label == _label(60) and srcs == ["settle/f60.png"]
    assert note.startswith("top box 4.3")  # the lab's top box settles near 4.37 m
    assert not problems, problems


BENCH_CASE = """
description: six equal boxes resting on each other
scene: {name: column, stack: {count: 6, y0: 0.501, spacing: 1.0}}
solver: {name: pgs, iterations: 15}
steps: 120
bench: {knob: [2, 16], timing: {steps: 10, repeats: 1}}
"""


def test_report_opens_on_speed_against_error_and_opens_a_case_from_its_summary(tmp_path: Path,
                                                                               shown: Shown) -> None:
    _browser()
    (tmp_path / "cases").mkdir()
    (tmp_path / "cases" / "tall-6.yaml").write_text(BENCH_CASE)
    done = subprocess.run([sys.executable, "-m", "stackx", "bench", str(tmp_path / "cases"), "--out",
                           str(tmp_path / "out"), "--solvers", "pgs,warm-start,exact", "-q"],
                          cwd=REPO, capture_output=True, text=True, timeout=hang_limit(600))
    assert done.returncode == 0, done.stderr
    with serving(tmp_path / "out") as url, browsing(tmp_path / "profile") as (page, problems):
        page.goto(url + "report.html", wait_until="load")  # type: ignore[attr-defined]
        heads = page.eval_on_selector_all("h2", "els => els.map(e => e.textContent)")  # type: ignore[attr-defined]
        opened = page.eval_on_selector("h2", "h => h.closest('details') !== null && h.closest('details').open")  # type: ignore[attr-defined]
        plot = page.locator("figure.speed img").first.bounding_box()  # type: ignore[attr-defined]
        closed = page.eval_on_selector("details.case", "d => d.open")  # type: ignore[attr-defined]
        keep(page, "report.png", shown)
        page.click("table.summary a[href='#tall-6']")  # type: ignore[attr-defined]
        page.wait_for_function("document.getElementById('tall-6').open")  # type: ignore[attr-defined]
        images = page.eval_on_selector_all("img", "els => els.map(e => [e.complete, e.naturalWidth])")  # type: ignore[attr-defined]
        keep(page, "report-case.png", shown)
    assert heads[:2] == ["Speed against error", "Summary"], heads
    assert opened is True, "the speed-against-error section is open without a click"
    assert plot is not None and plot["height"] > 200 and plot["y"] + plot["height"] <= 900, \
        f"the plot is drawn on the first screen: {plot}"
    assert closed is False
    assert len(images) == 2 and all(done and width > 300 for done, width in images), images
    assert not problems, problems


def test_skips_are_explained_when_chromium_is_missing(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setattr(sys.modules[__name__], "CHROMIUM", tmp_path / "no-chromium")
    with pytest.raises(pytest.skip.Exception, match="no-chromium is not installed"):
        _browser()
