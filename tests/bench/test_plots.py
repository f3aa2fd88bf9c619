"""The speed-against-error plot keeps every solver's run in sight where two runs coincide."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from stackx.bench.palette import colour
from stackx.bench.plots import MARKER, RING, marker_sizes, speed_error_png
from stackx.bench.sweep import Record
from tests.lab.reference import read_png

pytest.importorskip("matplotlib")

# the plot's fixed geometry (750 x 460 pixels, axes from 12% to 97% across and 12% to 93% up)
WIDTH, HEIGHT = 750, 460
LEFT, RIGHT, BOTTOM, TOP = 0.12, 0.97, 0.12, 0.93


def run(solver: str, us: float, rms: float, passed: bool = True, value: int = 4) -> Record:
    return Record(case="pile", solver=solver, knob="iterations", value=value, variant="case", params={},
                  error={"rms": rms}, passed=passed, us_per_step=us)


def rgb(solver: str) -> tuple[int, int, int]:
    c = colour(solver)
    return tuple(int(c[i:i + 2], 16) for i in (1, 3, 5))  # type: ignore[return-value]


def pixel(us: float, rms: float, x_range: tuple[float, float], y_range: tuple[float, float]) -> tuple[int, int]:
    """Where a run is drawn on the picture (column, row), from the axes' log ranges."""
    across = (math.log(us) - math.log(x_range[0])) / (math.log(x_range[1]) - math.log(x_range[0]))
    up = (math.log(rms) - math.log(y_range[0])) / (math.log(y_range[1]) - math.log(y_range[0]))
    return (round(WIDTH * (LEFT + (RIGHT - LEFT) * across)),
            round(HEIGHT * (1.0 - BOTTOM - (TOP - BOTTOM) * up)))


def colours_near(png: bytes, at: tuple[int, int], reach: int = 12) -> set[tuple[int, int, int]]:
    _, _, picture = read_png(png)
    col, row = at
    return {picture[r][c] for r in range(row - reach, row + reach + 1) for c in range(col - reach, col + reach + 1)}


@pytest.mark.parametrize("below_passed", [True, False])
def test_a_run_drawn_over_by_another_solvers_still_shows(below_passed: bool) -> None:
    """``pgs`` has one run, at the very speed and error of one of ``warm-start``'s, which is drawn after it.
    Drawn at one size, warm-start's marker covered it whole (pgs has no line to give it away, and its colour
    in the legend is far from the point); now pgs's colour rings warm-start's marker, filled or hollow."""
    records = [run("pgs", 10.0, 1e-3, passed=below_passed),
               run("warm-start", 10.0, 1e-3), run("warm-start", 100.0, 1e-5, value=16)]
    png = speed_error_png("pile", records)
    assert png is not None
    at = pixel(10.0, 1e-3, (10.0 / 1.35, 100.0 * 1.35), (1e-5 / 2.2, 1e-3 * 2.2))
    near = colours_near(png, at)
    assert rgb("warm-start") in near  # the window is on the point
    assert rgb("pgs") in near


def test_marker_sizes_widen_only_markers_drawn_over_by_another_solver() -> None:
    """Sizes in drawing order: a marker another solver's marker covers (centres closer than a marker's width)
    widens by a ring for each; one apart, or covered only by its own solver's, keeps the size."""
    width = MARKER * 100 / 72  # pixels at 100 dpi
    pixels = [(0.0, 0.0), (0.5 * width, 0.0), (0.0, 0.2 * width), (300.0, 300.0), (300.0 + 0.5 * width, 300.0)]
    solvers = ["a", "b", "c", "a", "a"]
    assert marker_sizes(pixels, solvers, 100) == [MARKER + 2 * RING, MARKER + RING, MARKER, MARKER, MARKER]
    assert marker_sizes([(0.0, 0.0), (1.01 * width, 0.0)], ["a", "b"], 100) == [MARKER, MARKER]


def test_the_drift_profile_shows_millimetres_and_pins_what_is_beyond(tmp_path: Path) -> None:
    """A stack of five placed at rest; one run's boxes ended 1, 2, 3, 4 mm to the right of where they started
    and the top one 3 m away (slid off): the sideways panel spans four times the 50 mm limit, draws the four at
    their millimetres and the fifth as a triangle at the right edge; the turn panel the same in degrees."""
    from stackx.bench.plots import BEYOND, drift_profile_figure, _pyplot
    from stackx.config.experiment import load

    (tmp_path / "pile.yaml").write_text("scene: {name: planar, stack: {count: 5, friction: 0.6}}\n"
                                        "solver: {name: planar-exact}\nsteps: 1\n")
    scene = load(str(tmp_path / "pile.yaml")).runs[0].scene
    start, final = scene.build(), scene.build()
    final.x[0] += [0.001, 0.002, 0.003, 0.004, 3.0]
    final.angle[0, 2] += 0.01
    rec = run("planar-exact", 1.0, 1e-3)
    rec.final = final
    fig = drift_profile_figure("pile", [rec], start, scene.rests(), (0.05, 0.05))
    try:
        side, turn = fig.axes[:2]
        assert side.get_xlim() == pytest.approx((-BEYOND * 50 * 1.05, BEYOND * 50 * 1.05))
        line = next(ln for ln in side.get_lines() if ln.get_label().startswith("planar-exact"))
        assert list(line.get_xdata()) == pytest.approx([1.0, 2.0, 3.0, 4.0, BEYOND * 50])  # mm; the fifth pinned
        assert list(line.get_ydata()) == pytest.approx([0.5, 1.5, 2.5, 3.5, 4.5])
        beyond = next(ln for ln in side.get_lines() if ln.get_marker() == ">")
        assert list(beyond.get_ydata()) == [4.5]
        turned = next(ln for ln in turn.get_lines() if len(ln.get_xdata()) == 5)
        assert turned.get_xdata()[2] == pytest.approx(math.degrees(0.01))
    finally:
        _pyplot().close(fig)
