"""Work bounded at load from a config's shape: a comparison's pictures (runs x frames) and named runs are counted
against their limits before anything is made, checks over runs grow linearly with them, and a config's text
is bounded before it is parsed; a drawing's shapes are walked only where they lie on the canvas. Each refusal is
one located line, exit code 2, before any run is resolved."""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap
from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from stackx.cli import app
from stackx.config import experiment
from stackx.config.yamlsrc import MAX_TEXT_BYTES
from stackx.render.compare import Compare
from stackx.render.frames import Frames
from stackx.render.gfxlib import Canvas
from tests.conftest import REPO
from tests.limits import hang_limit
from tests.lab.reference import read_png

WHITE = (255, 255, 255)
LINE = re.compile(r"^error: (?P<file>.+?):(?:(?P<line>\d+):(?P<col>\d+):)?(?: (?P<key>[^\s:]+):)? (?P<msg>\S.*)$")

BASE = """\
scene:
  name: column
  stack: {{count: 1, y0: 0.5, spacing: 1.6, half_height: 0.5, mass: 1.0}}
solver:
  name: pgs
  iterations: 1
dt: 1/60
steps: {steps}
"""


def _sweep(runs: int, steps: int, every: int, count: int | str, limits: str = "") -> str:
    """A config of ``runs`` runs (a sweep over gravity) compared side by side, ``count`` frames each."""
    gravity = ", ".join(f"-{9 + k / 1000:.3f}" for k in range(runs))
    return BASE.format(steps=steps) + textwrap.dedent(f"""\
        sweep:
          name: r{{index}}
          grid:
            gravity: [{gravity}]
        outputs:
          - render: compare
            every: {every}
            count: {count}
        """) + limits


def _named(runs: int, overrides: Callable[[int], str] = lambda k: "{}", limits: str = "") -> str:
    """A config listing ``runs`` named runs, run k overriding ``overrides(k)``."""
    return BASE.format(steps=60) + "runs:\n" + "".join(f"  r{k}: {overrides(k)}\n" for k in range(runs)) + limits


def _position(text: str, needle: str) -> tuple[int, int]:
    before = text[: text.index(needle)]
    return before.count("\n") + 1, len(before) - (before.rfind("\n") + 1) + 1


def _validate(config: Path, *args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, ["validate", str(config), *args])
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exc_info
    return result.exit_code, result.stderr


def _refusal(config: Path, *args: str) -> re.Match[str]:
    """The one error line of a config refused by ``stackx validate`` with exit code 2."""
    code, err = _validate(config, *args)
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    m = LINE.match(lines[0])
    assert m and m["file"] == str(config), lines[0]
    return m


@pytest.fixture
def never_named(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail the test if a comparison enumerates its pictures' names (which a refusal by count must not need)."""
    def names(self: Compare, run: str) -> list[str]:
        raise AssertionError("the pictures' names were listed")
    monkeypatch.setattr(Compare, "names", names)


def test_a_comparison_counts_every_runs_frames(tmp_path: Path, never_named: None) -> None:
    """100 runs x 10,000 frames is a million pictures: refused at `count`, though 10,000 frames of one run are
    within max_frames, and without listing the million names."""
    config = tmp_path / "compare.yaml"
    text = _sweep(100, 10_000, 1, 10_000)
    config.write_text(text)
    m = _refusal(config)
    line, col = _position(text, "count: 10000")
    assert (int(m["line"]), int(m["col"]), m["key"]) == (line, col + len("count: "), "outputs[0].count")
    for words in ("100 runs x 10,000 frames = 1,000,000 pictures", "limits.max_frames = 10,000", "runs: [",
                  "max_frames: N"):
        assert words in m["msg"], m["msg"]


def test_count_all_of_a_comparison_is_counted_for_every_run(tmp_path: Path, never_named: None) -> None:
    config = tmp_path / "compare.yaml"
    config.write_text(_sweep(20, 600, 1, "all"))
    assert "20 runs x 601 frames = 12,020 pictures" in _refusal(config)["msg"]


@pytest.mark.parametrize("runs, count, limit, accepted", [(10, 1000, "", True), (10, 1001, "", False),
                                                          (10, 1000, "limits: {max_frames: 9999}\n", False),
                                                          (10, 1001, "limits: {max_frames: 10010}\n", True)])
def test_a_comparison_may_draw_exactly_max_frames_pictures(tmp_path: Path, runs: int, count: int, limit: str,
                                                           accepted: bool) -> None:
    config = tmp_path / "compare.yaml"
    config.write_text(_sweep(runs, 1000, 1, count, limit))
    code, err = _validate(config)
    assert code == (0 if accepted else 2), err
    if not accepted:
        assert f"{runs} runs x {count:,} frames" in err


def test_the_pictures_of_every_renderer_are_counted_together(tmp_path: Path,
                                                             monkeypatch: pytest.MonkeyPatch) -> None:
    """300 `frames` outputs of 10,000 pictures each are within max_frames one by one and three million pictures
    together: refused at the output that passes the limit, before the later ones list their file names."""
    outputs = "".join(f"  - {{render: frames, every: 1, count: 10000, path: 'o{k}_{{index}}.png'}}\n"
                      for k in range(300))
    text = BASE.format(steps=10_000) + "outputs:\n" + outputs
    config = tmp_path / "many.yaml"
    config.write_text(text)
    listed = []
    names = Frames.names
    monkeypatch.setattr(Frames, "names", lambda self: listed.append(1) or names(self))
    m = _refusal(config)
    assert m["key"] == "outputs[1]" and "20,000 pictures, over limits.max_frames = 10,000" in m["msg"], m["msg"]
    assert int(m["line"]) == _position(text, "{render: frames, every: 1, count: 10000, path: 'o1_")[0]
    assert len(listed) < 10  # the first two outputs' names (their checks list them), never the 300 outputs'


def test_outputs_of_one_file_each_do_not_count_as_pictures(tmp_path: Path) -> None:
    outputs = "".join(f"  - {{sink: metrics, path: m{k}.json}}\n" for k in range(3)) + \
        "  - {render: frames, every: 1, count: 60, path: 'f_{index}.png'}\n"
    config = tmp_path / "few.yaml"
    config.write_text(BASE.format(steps=60) + "outputs:\n" + outputs + "limits: {max_frames: 60}\n")
    code, err = _validate(config)
    assert code == 0, err


def test_named_runs_over_max_runs_are_refused_before_any_run_is_made(tmp_path: Path,
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """20,000 named runs, each a valid run: refused at the `runs` key before the first run is resolved."""
    def made(*args: object) -> None:
        raise AssertionError("a run was resolved")
    monkeypatch.setattr(experiment, "_resolve_run", made)
    config = tmp_path / "named.yaml"
    text = _named(20_000, lambda k: f"{{solver.iterations: {1 + k % 7}}}")
    config.write_text(text)
    m = _refusal(config)
    assert (int(m["line"]), int(m["col"]), m["key"]) == (*_position(text, "runs:"), "runs")
    assert "20,000 named runs" in m["msg"] and "limits.max_runs = 10,000" in m["msg"], m["msg"]


@pytest.mark.parametrize("limit, accepted", [("limits: {max_runs: 3}\n", True), ("limits: {max_runs: 2}\n", False)])
def test_max_runs_counts_named_runs(tmp_path: Path, limit: str, accepted: bool) -> None:
    config = tmp_path / "named.yaml"
    config.write_text(_named(3, limits=limit))
    code, err = _validate(config)
    assert code == (0 if accepted else 2), err
    assert accepted or "3 named runs" in err


def _events(action: Callable[[], object]) -> int:
    """How many calls (Python and built-in) ``action`` makes: a count of its work that is the same on any machine
    and under any load, where a time is not."""
    count = 0

    def tally(frame: object, event: str, arg: object) -> None:
        nonlocal count
        count += 1

    sys.setprofile(tally)
    try:
        action()
    finally:
        sys.setprofile(None)
    return count


@pytest.mark.parametrize("shape", ["named", "sweep"])
def test_checking_runs_grows_linearly_with_their_number(tmp_path: Path, shape: str) -> None:
    """Loading twice the runs (each overriding a value; a comparison of all of them, listed) costs about twice
    the work, not four times: every check over runs is linear in them."""
    def config(runs: int) -> Path:
        path = tmp_path / f"{shape}-{runs}.yaml"
        if shape == "named":
            names = ", ".join(f"r{k}" for k in range(runs))
            text = _named(runs, lambda k: f"{{solver.iterations: {1 + k % 7}}}") + textwrap.dedent(f"""\
                outputs:
                  - render: compare
                    every: 60
                    count: 1
                    runs: [{names}]
                """)
        else:
            text = _sweep(runs, 60, 60, 1)
        path.write_text(text)
        return path

    small, large = config(250), config(500)
    experiment.load(str(small))  # plugins discovered, caches filled: what is counted is the loading itself
    ratio = _events(lambda: experiment.load(str(large))) / _events(lambda: experiment.load(str(small)))
    assert ratio < 2.5, ratio


def test_a_config_longer_than_the_text_limit_is_refused_by_its_size(tmp_path: Path) -> None:
    config = tmp_path / "long.yaml"
    text = _named(1) + "# padding\n" * (MAX_TEXT_BYTES // 10)
    config.write_text(text)
    m = _refusal(config)
    assert m["line"] is None and f"{len(text):,} bytes" in m["msg"] and "1 MiB" in m["msg"], m["msg"]


def test_a_config_of_exactly_the_text_limit_is_read(tmp_path: Path) -> None:
    config = tmp_path / "full.yaml"
    text = _named(1)
    config.write_text(text + "#" * (MAX_TEXT_BYTES - len(text) - 1) + "\n")
    assert config.stat().st_size == MAX_TEXT_BYTES
    code, err = _validate(config)
    assert code == 0, err


def test_a_set_value_longer_than_the_text_limit_is_refused(tmp_path: Path) -> None:
    config = tmp_path / "c.yaml"
    config.write_text(_named(1))
    long = "x" * (MAX_TEXT_BYTES + 1)
    code, err = _validate(config, "--set", f"description={long}")
    assert code == 2 and f"{MAX_TEXT_BYTES + 1:,} bytes of YAML" in err, err[:300]


def test_a_config_that_never_ends_is_read_no_further_than_the_limit() -> None:
    """A device or pipe has no size to check first: reading stops one byte past the limit (the child is given
    512 MiB of memory, so reading on would end in a MemoryError, not a refusal)."""
    code = ("import resource\nresource.setrlimit(resource.RLIMIT_AS, (512 << 20, 512 << 20))\n"
            "from stackx.config.yamlsrc import load_file\nfrom stackx.errors import ConfigError\n"
            "try:\n    load_file('/dev/zero')\nexcept ConfigError as exc:\n    print(exc)\n")
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True,
                          timeout=hang_limit(60))
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.startswith(f"/dev/zero: more than {MAX_TEXT_BYTES:,} bytes of YAML"), done.stdout


def _whole_walk(x0: int, y0: int, x1: int, y1: int) -> list[tuple[int, int]]:
    """Every pixel of the Bresenham walk from ``(x0, y0)`` to ``(x1, y1)``, on the canvas or not: what a line
    is, independently of how a canvas finds its visible part."""
    dx, dy = abs(x1 - x0), -abs(y1 - y0)
    sx, sy = (1 if x0 < x1 else -1), (1 if y0 < y1 else -1)
    err, out = dx + dy, []
    while True:
        out.append((x0, y0))
        if x0 == x1 and y0 == y1:
            return out
        e2 = 2 * err
        if e2 >= dy:
            err += dy
            x0 += sx
        if e2 <= dx:
            err += dx
            y0 += sy


def _lit(canvas: Canvas) -> set[tuple[int, int]]:
    return {(x, y) for y in range(canvas.h) for x in range(canvas.w) if canvas.get(x, y) != (0, 0, 0)}


_ENDS = st.integers(-300, 300)


@settings(max_examples=3000, deadline=None)
@given(st.integers(1, 40), st.integers(1, 40), _ENDS, _ENDS, _ENDS, _ENDS)
def test_a_line_lights_exactly_the_visible_pixels_of_its_whole_walk(w: int, h: int, x0: int, y0: int, x1: int,
                                                                     y1: int) -> None:
    """Lines inside the canvas, crossing its edges, and wholly off it: the pixels lit are those of the whole
    walk that fall on the canvas, no more and no fewer."""
    canvas = Canvas(w, h)
    canvas.line(x0, y0, x1, y1, WHITE)
    assert _lit(canvas) == {(x, y) for x, y in _whole_walk(x0, y0, x1, y1) if 0 <= x < w and 0 <= y < h}


@pytest.mark.parametrize("x0, y0, x1, y1", [(0, 0, 10**18, 10**18), (10**18, 5, -10**18, 9),
                                            (-10**18, -10**18, 10**18, 10**18 + 7), (31, -10**18, 33, 10**18),
                                            (10**18, 10**18, 10**18 + 1, 10**18)])
def test_a_line_far_past_the_canvas_costs_its_visible_pixels(x0: int, y0: int, x1: int, y1: int) -> None:
    """A line to a point 1e18 pixels away colours at most the canvas's 64 x 64 pixels, counted by the calls it
    makes (stopped past a bound, so a walk over every off-canvas pixel fails here instead of running for ever)."""
    canvas = Canvas(64, 64)
    _bounded(lambda: canvas.line(x0, y0, x1, y1, WHITE), 20_000)
    lit = _lit(canvas)
    assert len(lit) <= 128
    if x0 == 0:  # the diagonal from the corner: every pixel of it
        assert lit == {(k, k) for k in range(64)}


def _bounded(action: Callable[[], object], most: int) -> None:
    """Run ``action``, failing once it has made more than ``most`` calls."""
    count = 0

    def tally(frame: object, event: str, arg: object) -> None:
        nonlocal count
        count += 1
        if count > most:
            raise AssertionError(f"more than {most:,} calls")

    sys.setprofile(tally)
    try:
        action()
    finally:
        sys.setprofile(None)


DRAWING = """\
outputs:
  - render: drawing
    path: d.png
    width: 64
    height: 64
    shapes:
      - line: {{from: [0, 0], to: {to}, rgb: [255, 255, 255]}}
      - rect: {{from: [-1e18, 60], to: [1e18, 1e18], rgb: [255, 0, 0]}}
"""


def test_a_drawing_of_lines_to_far_points_is_written_at_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`stackx run` of a drawing whose line ends at [1e18, 1e18]: the picture holds the visible diagonal and
    the rectangle's visible rows; no pixel off the canvas is visited (a walk over them is stopped here)."""
    visits = 0
    set_pixel = Canvas.set

    def counted(self: Canvas, x: int, y: int, rgb: tuple[int, int, int]) -> None:
        nonlocal visits
        visits += 1
        if visits > 100_000:
            raise AssertionError("the line was walked off the canvas")
        set_pixel(self, x, y, rgb)

    monkeypatch.setattr(Canvas, "set", counted)
    config = tmp_path / "d.yaml"
    config.write_text(DRAWING.format(to="[1e18, 1e18]"))
    result = CliRunner().invoke(app, ["run", str(config), "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, (result.stderr, result.exc_info)
    w, h, rows = read_png((tmp_path / "out" / "d.png").read_bytes())
    colour = {(x, y): rows[y][x] for y in range(h) for x in range(w) if rows[y][x] != (0, 0, 0)}
    assert colour == {**{(k, k): (255, 255, 255) for k in range(60)},
                      **{(x, y): (255, 0, 0) for x in range(64) for y in range(60, 64)}}


@pytest.mark.parametrize("to", ["[.inf, 3]", "[1, .nan]", "[1.5, 3]"])
def test_a_drawing_with_a_point_that_is_not_a_whole_number_is_refused(tmp_path: Path, to: str) -> None:
    config = tmp_path / "d.yaml"
    text = DRAWING.format(to=to)
    config.write_text(text)
    m = _refusal(config)
    assert m["key"].startswith("outputs[0].shapes[0].line.to[") and int(m["line"]) == _position(text, to)[0]
