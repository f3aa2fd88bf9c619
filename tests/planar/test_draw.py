"""Pictures of planar worlds, pixel by pixel against membership tests worked out here.

A pixel is expected filled when its centre, taken back to world coordinates, lies in the box: for a box
turned by 45 degrees that is the diamond |dx| + |dy| <= half-diagonal, for any angle the box's own frame
|u| <= hx, |v| <= hy. Pixels whose centre lies within 1e-9 px of an edge could go either way by rounding
and are not judged. The fitted view's numbers are worked out by hand for a row of boxes.
"""

from __future__ import annotations

import math
import re
import json
from pathlib import Path

import numpy as np
import pytest

from stackx.models.planar.state import PlanarState
from stackx.render.draw import framed, picture
from stackx.render.style import Style
from tests.conftest import Cli
from tests.lab.reference import read_png

BACKGROUND, FLOOR, GROUND = (20, 20, 28), (255, 255, 255), (34, 34, 46)
FIRST, SECOND, STATIC = (230, 120, 110), (230, 190, 110), (120, 120, 132)
FIXED = Style(fit=False)  # the lab's mapping: sx = 25.6 x + 128, sy = 255 - 25.6 y


def _state(boxes: list[dict]) -> PlanarState:
    """One batch row of boxes, each ``{x, y, angle, hx, hy}`` and optionally ``static``."""
    row = lambda key, default=0.0: np.array([[b.get(key, default) for b in boxes]], dtype=np.float64)  # noqa: E731
    inv = np.array([[0.0 if b.get("static") else 1.0 for b in boxes]])
    zero = row("none")
    return PlanarState(row("x"), row("y"), row("angle"), zero, zero.copy(), zero.copy(), inv, inv.copy(),
                       row("hx", 0.5), row("hy", 0.5), row("friction", 0.5))


def _pixels(state: PlanarState, style: Style) -> list[list[tuple[int, int, int]]]:
    width, height, pixels = read_png(picture(state, style).png_bytes())
    assert (width, height) == (style.width, style.height)
    return pixels


def _world(px: int, py: int, style: Style) -> tuple[float, float]:
    """The world point at the centre of pixel (px, py)."""
    return (px + 0.5 - style.origin_x) / style.scale, (style.origin_y - (py + 0.5)) / style.scale


def _in_box(x: float, y: float, box: dict, slack: float) -> bool | None:
    """Whether (x, y) is in ``box`` (in its own frame), None when within ``slack`` (m) of its edge."""
    c, s = math.cos(box["angle"]), math.sin(box["angle"])
    u = c * (x - box["x"]) + s * (y - box["y"])
    v = -s * (x - box["x"]) + c * (y - box["y"])
    margin = min(box.get("hx", 0.5) - abs(u), box.get("hy", 0.5) - abs(v))
    return None if abs(margin) < slack else margin > 0


def test_a_box_turned_45_degrees_fills_its_corner_pixels_and_nothing_outside() -> None:
    box = {"x": 0.0, "y": 2.0, "angle": math.pi / 4}
    pixels = _pixels(_state([box]), FIXED)
    r = math.sqrt(0.5) * 25.6  # the half-diagonal on screen: the diamond around (128, 255 - 51.2)
    cx, cy = 128.0, 255.0 - 2.0 * 25.6
    judged = 0
    for py in range(256):
        for px in range(256):
            d = abs(px + 0.5 - cx) + abs(py + 0.5 - cy) - r
            if abs(d) < 1e-9:
                continue
            want = FLOOR if py == 255 else (FIRST if d < 0 else BACKGROUND)
            assert pixels[py][px] == want, (px, py)
            judged += 1
    assert judged > 256 * 256 - 10
    # the right-hand corner is at (146.10.., 203.8): the last pixel of its row inside, the next one outside
    row = math.floor(cy)
    inside = math.floor(cx + r - abs(row + 0.5 - cy) - 0.5)
    assert inside == 145
    assert pixels[row][inside] == FIRST and pixels[row][inside + 1] == BACKGROUND
    # the top corner (128, 185.7..): the pixel under it filled, the one above blank
    top = math.ceil(cy - r - 0.5)
    assert pixels[top][127] == FIRST and pixels[top - 1][127] == BACKGROUND


@pytest.mark.parametrize("angle", [0.3, -1.1, 2.0])
def test_static_and_moving_boxes_at_any_angle_and_the_ground(angle: float) -> None:
    """A static slab under a turned box that overlaps it: the slab in the static colour, the moving boxes
    over it in the column's colours, the ground below the floor row, the floor row last."""
    style = Style(fit=False, origin_y=200.0, scale=20.0)
    slab = {"x": -1.0, "y": 1.0, "angle": 0.2, "hx": 2.5, "hy": 0.4, "static": True}
    first = {"x": 0.5, "y": 1.6, "angle": angle, "hx": 0.9, "hy": 0.4}
    second = {"x": -3.0, "y": 3.0, "angle": -angle, "hx": 0.3, "hy": 1.2}
    # listed out of drawing order: the static slab last, yet drawn first
    pixels = _pixels(_state([first, second, slab]), style)
    slack = 1e-9 / style.scale
    for py in range(256):
        for px in range(256):
            x, y = _world(px, py, style)
            inside = [_in_box(x, y, b, slack) for b in (first, second, slab)]
            if None in inside:
                continue
            if py == 200:
                want = FLOOR
            elif inside[0]:
                want = FIRST
            elif inside[1]:
                want = SECOND
            elif inside[2]:
                want = STATIC
            else:
                want = GROUND if py > 200 else BACKGROUND
            assert pixels[py][px] == want, (px, py, x, y)


def test_the_view_is_fitted_to_the_scene_with_the_ground_near_the_bottom() -> None:
    """Ten unit boxes side by side on the ground span x in [-5, 5] and y in [0, 1]: on a 256 x 256 canvas the
    margin is 5% of 256, 13 px, so 230 px hold 10 m across: 23 px per metre, x = 0 at 128, the ground at
    row 255 - 13 = 242."""
    row = _state([{"x": k - 4.5, "y": 0.5, "angle": 0.0} for k in range(10)])
    style = framed([row], Style())
    assert (style.scale, style.origin_x, style.origin_y) == (23.0, 128.0, 242.0)
    pixels = _pixels(row, style)
    filled = [(px, py) for py in range(256) for px in range(256) if pixels[py][px] not in (BACKGROUND, GROUND, FLOOR)]
    assert min(p[0] for p in filled) == 13 and max(p[0] for p in filled) == 242  # centres 13.5 .. 242.5
    assert min(p[1] for p in filled) == 219 and max(p[1] for p in filled) == 241  # y = 1 at row 219
    assert all(pixels[242][px] == FLOOR for px in range(256))
    assert all(pixels[py][0] == GROUND for py in range(243, 256))
    # every state of a player is fitted at once: a box flying high shrinks the view for all of them
    flying = _state([{"x": 0.0, "y": 20.5, "angle": 0.0}])
    both = framed([row, flying], Style())
    assert both.scale == pytest.approx(230 / 21) and both.origin_y == 242.0
    # the column keeps the lab's mapping unless asked to fit
    from stackx.models.column.state import ColumnState

    column = ColumnState(np.array([[0.5, 1.5]]), np.zeros((1, 2)), np.ones((1, 2)), np.full((1, 2), 0.5))
    assert framed([column], Style()) == Style()
    fitted = framed([column], Style(fit=True))
    assert fitted.scale == pytest.approx(230 / 3)  # 3 m wide (half_width 1.5), 2 m tall


def test_same_state_same_bytes() -> None:
    boxes = [{"x": 0.1 * k, "y": 0.5 + k, "angle": 0.05 * k} for k in range(6)]
    state = _state(boxes)
    style = framed([state], Style())
    first = picture(state, style).png_bytes()
    assert picture(state.copy(), framed([state.copy()], Style())).png_bytes() == first
    turned = state.copy()
    turned.angle[0, 5] += 0.2
    assert picture(turned, style).png_bytes() != first


PLANAR = """
description: a box sliding down a ramp beside a small stack
scene:
  name: planar
  ramp: {angle: 30, mu: 0.3, length: 8, at: 2}
  stack: {count: 3, x: 6, offset: 0.1, seed: 3}
solver: {name: planar-pgs}
runs:
  few: {solver: {name: planar-pgs, iterations: 2}}
  many: {solver: {name: planar-pgs, iterations: 20}}
steps: 40
outputs:
  - render: stack
    run: many
  - render: frames
    run: few
    path: f/{index:02d}.png
    every: 10
    count: all
    player: index.html
    controls: true
  - render: compare
    every: 20
    count: all
"""


def test_planar_runs_are_drawn_and_played(cli: Cli, tmp_path: Path) -> None:
    config = tmp_path / "ramp.yaml"
    config.write_text(PLANAR)
    for out in ("a", "b"):
        done = cli("run", config, "--out", tmp_path / out, "-q", env={"STACKX_JIT": "0"})  # small: plain is quicker
        assert done.returncode == 0, done.stderr
    a, b = tmp_path / "a", tmp_path / "b"
    names = sorted(str(p.relative_to(a)) for p in a.rglob("*.png"))
    assert names == ["compare/few-000.png", "compare/few-001.png", "compare/few-002.png", "compare/many-000.png",
                     "compare/many-001.png", "compare/many-002.png", "f/00.png", "f/01.png", "f/02.png", "f/03.png",
                     "f/04.png", "stack.png"]
    for name in [*names, "index.html", "compare.html"]:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name  # same config, same bytes
    frames = [read_png((a / f"f/{k:02d}.png").read_bytes())[2] for k in range(5)]
    assert frames[0] != frames[-1]  # the box slid
    # the same instant of two runs in one view: both start from the same scene
    assert (a / "compare/few-000.png").read_bytes() == (a / "compare/many-000.png").read_bytes()
    for picture_ in frames:  # fitted: no box reaches the picture's edges
        edge = [picture_[0][px] for px in range(256)] + [picture_[py][0] for py in range(256)]
        edge += [picture_[py][255] for py in range(256)]
        assert set(edge) <= {BACKGROUND, GROUND, FLOOR}
    page = (a / "index.html").read_text()
    data = json.loads(re.search(r'id="data">(.*?)</script>', page, re.S).group(1))
    assert data["labels"] == [f"step {k} · t = {k / 60:.3f} s" for k in range(0, 41, 10)]
    notes = data["panels"][0]["notes"]
    assert all(re.fullmatch(r"highest box \d+\.\d{3} m · deepest contact \d+\.\d{4} m", n) for n in notes)
    # the highest box at the start is the one on the ramp (the stack's top is at 2.5 m): the ramp's centre is
    # 4 sin 30 + 0.5 cos 30 high, the box 1 m from it along the normal and 2 m up the slope
    a = math.radians(30)
    assert notes[0].startswith(f"highest box {4 * math.sin(a) + 1.5 * math.cos(a) + 2 * math.sin(a):.3f} m")


LEANING = """
description: two boxes on the ground, one leaning on a static post
scene:
  name: planar
  stack: {count: 2, offset: 0.2, seed: 4}
  boxes:
    - {x: 4, y: 1.0, width: 0.4, height: 2.0, static: true}
    - {x: 3.0, y: 1.2, angle: -30, rests: true}
solver: {name: planar-pgs, iterations: 4}
runs:
  a: {}
  b: {solver: {name: planar-pgs, iterations: 12}}
steps: 30
"""


def test_the_bench_series_follow_the_pile_top_depth_and_drift(tmp_path: Path) -> None:
    """The bench's series of a planar batch, sampled by the step observer, against the same figures read
    here from the states the runner recorded at the same steps: the top is the highest movable box (this
    scene has no rigid pile), the drift that of the boxes placed at rest (the stack's two and the leaning
    one, not the post) from where they began."""
    from stackx.bench.trajectory import SeriesLog
    from stackx.config.experiment import load
    from stackx.models.planar.measures import max_depth
    from stackx.run.runner import run_experiment

    config = tmp_path / "lean.yaml"
    config.write_text(LEANING)
    spec = load(str(config))
    watched = SeriesLog(None)
    result = run_experiment(spec, None, watched, set(range(31)))
    for run in result.runs:
        series = watched.series(run.name)
        assert series is not None and series.steps == list(range(31))
        start = run.frames[0]
        for k in (0, 1, 17, 30):
            state = run.frames[k]
            ys = state.y[0].tolist()
            assert series.top[k] == max(ys[0], ys[1], ys[3])  # the post (body 2) is static
            assert series.depth[k] == max_depth(state)
            rest = (0, 1, 3)
            assert series.drift_x[k] == max(abs(state.x[0, i] - start.x[0, i]) for i in rest)
            assert series.drift_angle[k] == max(abs(state.angle[0, i] - start.angle[0, i]) for i in rest)
        assert series.drift_angle[-1] > 0  # the leaning box turned
    doc = watched.series("a").until(10).as_dict()
    assert sorted(doc) == ["drift_angle", "drift_x", "dt", "max_depth", "steps", "top"] and doc["steps"] == list(range(10))
    # the report's plot gets the two drift panels below the column's two (11.5 x 6.4 inches at 100 dpi)
    import dataclasses

    from stackx.bench.plots import trajectories_png
    from stackx.bench.sweep import Record
    from tests.lab.reference import png_header

    rec = Record("lean", "planar-pgs", "iterations", 4, "case", {}, series=watched.series("a"))
    tall = png_header(trajectories_png("lean", [rec], 0.02, None, (0.05, 0.05)))  # type: ignore[arg-type]
    flat = dataclasses.replace(rec, series=dataclasses.replace(rec.series, drift_x=None, drift_angle=None))
    short = png_header(trajectories_png("lean", [flat], 0.02, None, (0.05, 0.05)))  # type: ignore[arg-type]
    assert (tall.width, tall.height, short.width, short.height) == (1150, 640, 1150, 350)


def test_planar_solvers_have_their_counterparts_hue_darker_and_colours_of_their_own() -> None:
    from stackx.bench.palette import BUILT_IN, OTHERS, colour

    assert colour("planar-pgs") == "#801718"  # the lab solver's #d62728, each channel x 0.6 rounded down
    planar = {colour(f"planar-{name}") for name in BUILT_IN}
    assert len(planar) == len(BUILT_IN) and not planar & (set(BUILT_IN.values()) | set(OTHERS))
