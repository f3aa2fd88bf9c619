"""The planar cases that state their outcome from statics: a near-harmonic overhang that stands and one that
topples, a heavy slab off centre on two light posts, a column of light cubes and heavy slabs by turns, and a
stack whose boxes double in size. Per case the statics are worked out here from the config's own numbers
(centres of mass against the edges that carry them, a slab's reactions), a short exact run agrees, and the
bench judges a standing case pushed past its limit as failed."""

from __future__ import annotations

import numpy as np
import pytest

from stackx.bench.criteria import Criteria, failed_words, judge, passed, run_verdicts
from stackx.config.experiment import load
from stackx.models.planar import measures
from stackx.models.planar.state import PlanarState
from stackx.run.runner import run_experiment
from stackx.scenes.planar import Body, Planar
from tests.conftest import CONFIGS

PLANAR = CONFIGS / "planar"
NEW = ["overhang", "overhang-topples", "slab-on-posts", "alternating-50", "doubling-stack"]


def _scene(name: str, sets: list[str] | None = None) -> Planar:
    return load(str(PLANAR / f"{name}.yaml"), sets).runs[0].scene  # type: ignore[no-any-return]


def _column(bodies: list[Body]) -> tuple[Body | None, list[Body]]:
    """The static table (if any) and the movable boxes bottom up."""
    table = next((b for b in bodies if b.static), None)
    return table, sorted((b for b in bodies if not b.static), key=lambda b: b.y)


def _edges(b: Body) -> tuple[float, float]:
    return b.x - b.width / 2, b.x + b.width / 2


def _margins(bodies: list[Body]) -> list[float]:
    """Per movable box from the bottom: how far the centre of mass of it and every box above it lies inside the
    face carrying it (the overlap of its bottom face with the top face of the table, the box below or, for the
    lowest without a table, its own base), in m; negative: past the edge."""
    table, column = _column(bodies)
    out = []
    for i, box in enumerate(column):
        group = column[i:]
        mass = np.array([b.mass_inertia()[0] for b in group])
        com = float(np.dot(mass, [b.x for b in group]) / mass.sum())
        below = column[i - 1] if i > 0 else table
        left, right = _edges(box)
        if below is not None:
            assert below.y + below.height / 2 == pytest.approx(box.y - box.height / 2)  # resting on it
            left, right = max(left, _edges(below)[0]), min(right, _edges(below)[1])
        else:
            assert box.y == pytest.approx(box.height / 2)  # on the ground
        out.append(min(com - left, right - com))
    return out


def _judged(name: str, steps: int, sets: list[str] | None = None) -> tuple[bool, str, dict[str, float]]:
    """``planar-exact`` on the case for ``steps`` steps: (passed, what failed in words, measures)."""
    spec = load(str(PLANAR / f"{name}.yaml"), ["solver={name: planar-exact}", "outputs=[]", f"steps={steps}",
                                                 *(sets or [])])
    result = run_experiment(spec).runs[0]
    judged = run_verdicts(result, spec.bench.criteria if spec.bench is not None else None)
    assert judged is not None
    verdicts, found = judged
    return passed(verdicts), failed_words(verdicts, found), found


def test_the_new_cases_load_with_what_they_judge() -> None:
    for name in NEW:
        scene = _scene(name)
        assert scene.rests(), name
        assert scene.build().peak_depth[0] < 1e-12, name  # placed touching, never overlapping
    assert _scene("overhang-topples").drops() == [5]


def test_the_overhang_stands_by_its_statics() -> None:
    bodies = _scene("overhang").bodies()
    table, column = _column(bodies)
    assert table is not None
    tops = [b.x for b in reversed(column)]  # from the top: each cube's shift over the one below it
    below = tops[1:] + [_edges(table)[1] - 0.5]  # the table's edge stands for the right edge of a cube under all
    shifts = [a - b for a, b in zip(tops, below)]
    harmonic = [1.0 / (2 * k) for k in range(1, 6)]
    assert all(0.85 * h < s < h for s, h in zip(shifts, harmonic))  # a little below L / (2k)
    margins = _margins(bodies)
    assert min(margins) == pytest.approx(0.05)  # every partial stack 5 cm inside its support
    assert column[-1].x + 0.5 > 1.0  # and the top cube wholly past the table


def test_the_overhang_that_topples_drops_only_its_top_cube_by_its_statics() -> None:
    margins = _margins(_scene("overhang-topples").bodies())
    assert margins[-1] == pytest.approx(-0.1)  # the top cube's centre 0.1 m past the edge under it
    assert min(margins[:-1]) > 0.05 - 1e-12  # every group of two or more stays 5 cm or more inside
    _, column = _column(_scene("overhang-topples").bodies())
    top, second, third = column[-1], column[-2], column[-3]
    # while the top cube tips, its weight (a cube's, as the second's) bears on the second's right edge; about
    # the third's right edge the second's own weight turns the pair back harder than that load tips it
    edge = third.x + 0.5
    assert (second.x - edge) + (second.x + 0.5 - edge) < 0 and top.drops


def test_the_slab_stands_on_both_posts_by_its_statics() -> None:
    posts = sorted((b for b in _scene("slab-on-posts").bodies() if b.width < 1), key=lambda b: b.x)
    slab = next(b for b in _scene("slab-on-posts").bodies() if b.width > 1)
    left, right = posts
    assert slab.mass_inertia()[0] / left.mass_inertia()[0] == pytest.approx(500)
    share_right = (slab.x - left.x) / (right.x - left.x)  # moments about the left post
    assert 0 < 1 - share_right < share_right < 1  # both push up, the right one more: off centre between them
    assert share_right == pytest.approx(0.75)
    for post in posts:
        assert slab.y - slab.height / 2 == pytest.approx(post.y + post.height / 2)
        assert _edges(slab)[0] < _edges(post)[0] and _edges(post)[1] < _edges(slab)[1]  # the post's top under it


def test_the_alternating_column_stands_by_its_statics() -> None:
    bodies = _scene("alternating-50").bodies()
    masses = [b.mass_inertia()[0] for b in _column(bodies)[1]]
    assert masses == [1.0, 50.0] * 3
    assert min(_margins(bodies)) == pytest.approx(0.5)  # on the axis, half a cube inside


def test_the_doubling_stack_stands_by_its_statics() -> None:
    bodies = _scene("doubling-stack").bodies()
    column = _column(bodies)[1]
    assert [b.width for b in column] == [0.25, 0.5, 1.0, 2.0, 4.0]
    assert all(b.width == b.height for b in column)
    assert _margins(bodies) == pytest.approx([0.125, 0.125, 0.25, 0.5, 1.0])  # the axis over each face


@pytest.mark.parametrize("name", ["overhang", "slab-on-posts", "alternating-50", "doubling-stack"])
def test_an_exact_short_run_stands_each_standing_case(name: str) -> None:
    ok, words, found = _judged(name, 90)
    assert ok, words
    assert found["drift_x"] < 1e-6 and found["drift_angle"] < 1e-6


def test_an_exact_run_drops_the_top_cube_and_stands_the_rest() -> None:
    ok, words, found = _judged("overhang-topples", 150)
    assert found["drop"] >= 4.0  # from the fifth level to the ground
    assert found["drift_x"] < 1e-6 and found["drift_angle"] < 1e-6
    assert words in ("", "moving"), words  # after 2.5 s the fallen cube may still rock on the ground


def test_the_bench_fails_a_standing_overhang_pushed_past_its_limit() -> None:
    ok, words, found = _judged("overhang", 150, ["scene.boxes[5].x=0.7"])  # the top cube 0.12 m past its limit
    assert not ok and words.split(", ")[0] in ("drifted", "turned"), words
    assert found["drift_x"] > 0.5


def test_the_bench_fails_a_toppling_overhang_whose_top_cube_stays() -> None:
    ok, words, found = _judged("overhang-topples", 90, ["scene.boxes[5].x=0.285"])  # 0.1 m inside the edge
    assert not ok and "did not fall" in words.split(", "), words
    assert found["drop"] == pytest.approx(0.0, abs=1e-6)


def _state(y: list[float], hy: list[float]) -> PlanarState:
    n = len(y)
    row = lambda v: np.array([v], dtype=np.float64)  # noqa: E731
    return PlanarState(row([0.0] * n), row(y), row([0.0] * n), row([0.0] * n), row([0.0] * n), row([0.0] * n),
                       row([1.0] * n), row([1.0] * n), row([0.5] * n), row(hy), row([0.6] * n))


def test_drop_is_the_smallest_fall_in_own_heights_and_judged_at_least_the_limit() -> None:
    start, end = _state([5.5, 3.0, 1.0], [0.5, 0.25, 0.5]), _state([0.5, 2.0, 1.0], [0.5, 0.25, 0.5])
    assert measures.dropped(start, end, [0, 1])["drop"] == pytest.approx(2.0)  # 5 heights and 2 heights
    assert measures.dropped(start, end, [0, 2])["drop"] == pytest.approx(0.0)
    assert measures.dropped(start, end, []) == {}
    assert judge({"drop": 0.99}, Criteria())["holds"].failing == "drop 0.99 < 1"
    assert judge({"drop": 1.0}, Criteria())["holds"].passed


def test_a_box_is_marked_for_one_outcome_only() -> None:
    with pytest.raises(ValueError, match="rests, lands, falls or drops"):
        Body(y=0.5, rests=True, drops=True)

