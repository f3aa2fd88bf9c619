"""The HTML player in a real browser: ``stackx serve`` + headless Chromium (Debian's, no browser download).

The page must show ``f00.png`` .. ``f11.png`` in order and wrap around to ``f00.png``, every frame must load
as a 256x256 picture (no broken image), the browser must log no console error, page error, failed request
or HTTP error, and what the ``<img>`` shows must be one of the frames pixel for pixel (drawn twice as big,
``image-rendering: pixelated``). A screenshot of the player is kept in ``test-artifacts/player.png``.
Where Chromium or Playwright is missing the test is skipped, and the reason shows in pytest's summary.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from stackx.cli import app
from tests.conftest import CONFIGS, REPO
from tests.lab.reference import read_png

CHROMIUM = Path("/usr/bin/chromium")
ARTIFACTS = REPO / "test-artifacts"
FRAMES = [f"f{i:02d}.png" for i in range(12)]
FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
         "--disable-component-update", "--disable-sync"]

# installed before the page's own script: records every image load and error, first frame included
RECORDER = """
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


@pytest.fixture
def served(tmp_path: Path):  # type: ignore[no-untyped-def]
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["run", str(CONFIGS / "06-stack.yaml"), "--out", str(out), "-q"])
    assert result.exit_code == 0, result.stderr
    server = subprocess.Popen([sys.executable, "-m", "stackx", "serve", str(out), "--port", "0"], cwd=REPO,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = server.stdout.readline() if server.stdout else ""
        assert "http://" in line, line + (server.stderr.read() if server.stderr else "")
        yield out, line.split(" at ")[1].split()[0]
    finally:
        server.terminate()
        server.wait(timeout=10)


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
                                           capsys: pytest.CaptureFixture[str]) -> None:
    sync_playwright = _browser()
    out, url = served
    problems: list[str] = []
    with sync_playwright() as pw:  # type: ignore[operator]
        context = pw.chromium.launch_persistent_context(str(tmp_path / "profile"), executable_path=str(CHROMIUM),
                                                        headless=True, args=FLAGS)
        try:
            page = context.new_page()
            page.on("console", lambda m: problems.append(f"console {m.type}: {m.text}") if m.type == "error" else None)
            page.on("pageerror", lambda e: problems.append(f"page error: {e}"))
            page.on("requestfailed", lambda r: problems.append(f"request failed: {r.url} {r.failure}"))
            page.on("response", lambda r: problems.append(f"HTTP {r.status}: {r.url}") if r.status >= 400 else None)
            page.add_init_script(RECORDER)
            page.goto(url, wait_until="load")
            page.wait_for_function("window.__loads.length >= 13", timeout=20_000)
            loads = page.evaluate("window.__loads")
            image = page.locator("#frame")
            shown = _shown_frame(image.screenshot(), out)
            ARTIFACTS.mkdir(exist_ok=True)
            page.screenshot(path=str(ARTIFACTS / "player.png"))
            with capsys.disabled():
                print(f"\nplayer screenshot: {ARTIFACTS / 'player.png'}")
        finally:
            context.close()
    assert [entry["src"] for entry in loads[:13]] == FRAMES + FRAMES[:1]
    assert all(not entry.get("error") and (entry["w"], entry["h"]) == (256, 256) for entry in loads), loads
    assert not problems, problems
    assert shown in FRAMES, "the <img> does not show any frame pixel for pixel"


def test_skips_are_explained_when_chromium_is_missing(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setattr(sys.modules[__name__], "CHROMIUM", tmp_path / "no-chromium")
    with pytest.raises(pytest.skip.Exception, match="no-chromium is not installed"):
        _browser()
