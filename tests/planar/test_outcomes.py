"""The planar outcomes beyond standing and sliding: a box dropped to land on a face (``lands``, judged by
``land_tilt``) and boxes placed to topple (``falls``, judged by ``fall_tilt`` at least ``criteria.fall``), with
the two scenes that need them: a row of dominoes and a brick wall, laid out as their docs say."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stackx.config.experiment import load
from stackx.bench.criteria import Check, Criteria, judge
from stackx.models.planar import measures
from stackx.run.runner import run_experiment
from stackx.scenes.planar import Dominoes, Planar, PlanarParams, Wall
from tests.conftest import CONFIGS
from tests.planar.hand_states import boxes


def corners(x: float, y: float, angle: float, w: float, h: float) -> list[tuple[float, float]]:
    c, s = math.cos(angle), math.sin(angle)
    return [(x + c * px - s * py, y + s * px + c * py) for px in (-w / 2, w / 2) for py in (-h / 2, h / 2)]


def test_the_first_domino_is_tipped_on_its_corner_nearer_the_row_and_the_others_stand() -> None:
    scene = Planar(PlanarParams(dominoes=Dominoes(count=4, width=0.2, height=2.0, pitch=1.0, tip=15)))
    first, *rest = scene.bodies()
    points = corners(first.x, first.y, math.radians(first.angle), 0.2, 2.0)
    low = min(points, key=lambda p: p[1])
    assert low == pytest.approx((0.1, 0.0), abs=1e-12)  # where the upright domino's right corner stood
    assert first.angle == -15.0  # clockwise, towards the row
    top = max(points, key=lambda p: p[0])
    assert top[0] == pytest.approx(0.1 + 2.0 * math.sin(math.radians(15)), abs=1e-12)  # its top corner leans out
    assert [(b.x, b.y, b.angle) for b in rest] == [(1.0, 1.0, 0.0), (2.0, 1.0, 0.0), (3.0, 1.0, 0.0)]
    assert scene.falls() == [0, 1, 2, 3] and scene.rests() == [] and scene.size() == 4


def test_every_brick_of_the_wall_lies_on_the_row_below_and_the_ends_are_flush() -> None:
    scene = Planar(PlanarParams(wall=Wall(rows=4, bricks=3, width=1.0, height=0.5, gap=0.02)))
    bodies = scene.bodies()
    assert len(bodies) == scene.size() == 3 + 4 + 3 + 4
    rows: dict[int, list[tuple[float, float]]] = {}
    for b in bodies:
        r = round((b.y - 0.25) / 0.5)
        assert b.y == pytest.approx(0.25 + 0.5 * r) and b.height == 0.5
        rows.setdefault(r, []).append((b.x - b.width / 2, b.x + b.width / 2))
    for r, spans in rows.items():
        spans.sort()
        assert spans[0][0] == pytest.approx(-1.52) and spans[-1][1] == pytest.approx(1.52)  # 3 bricks, 2 gaps
        assert all(b[0] - a[1] == pytest.approx(0.02) for a, b in zip(spans, spans[1:]))  # the gap
    joints = {r: [(a[1] + b[0]) / 2 for a, b in zip(spans, spans[1:])] for r, spans in rows.items()}
    for r in range(1, 4):  # the running bond: every joint lies half a brick from the joints below
        assert min(abs(j - k) for j in joints[r] for k in joints[r - 1]) == pytest.approx(0.51)
    assert scene.rest_top() == (len(bodies) - 1, 4 * 0.5 - 0.25, 4)


def test_land_and_fall_tilts_fold_angles_as_their_docs_say() -> None:
    start = boxes([0.0, 2.0, 4.0, 6.0, 8.0], [0.5] * 5, [0.0] * 5, [(0.5, 0.5)] * 5, [1.0] * 5, [0.5] * 5)
    end = start.copy()
    end.angle[0] = [0.02, math.pi / 2 + 0.01, 0.5, -0.4, math.pi - 0.2]
    got = measures.tilts(start, end, lands=[0, 1], falls=[2, 3, 4])
    assert got["land_tilt"] == pytest.approx(0.02)
    assert got["fall_tilt"] == pytest.approx(0.2)  # turned over to 180 - 11.5 degrees: 11.5 from upright
    assert measures.tilts(start, end, [], []) == {}


def test_fall_tilt_is_judged_at_least_the_limit() -> None:
    c = Criteria()
    low, high = judge({"fall_tilt": 0.1}, c)["holds"], judge({"fall_tilt": 0.5}, c)["holds"]
    assert not low.passed and low.failing == "fall_tilt 0.1 < 0.35"
    assert high.passed
    assert not Check("fall_tilt", float("nan"), 0.35, least=True).passed


@pytest.mark.parametrize(("steps", "holds"), [(1, False), (480, True)])
def test_the_domino_row_holds_only_once_every_domino_has_fallen(steps: int, holds: bool) -> None:
    spec = load(str(CONFIGS / "planar" / "dominoes.yaml"), [f"steps={steps}", "outputs=[]"])
    result = run_experiment(spec).runs[0]
    m = measures.bench_measures(result)
    final = result.final.angle[0]
    assert m["fall_tilt"] == pytest.approx(float(np.min(np.abs(final))), abs=1e-12)  # no domino turned past 90
    assert judge(m, Criteria())["holds"].passed is holds
