"""The planar hard cases in configs/planar: every one loads, builds the scene it describes, and runs as long
as the acceptance asks."""

from __future__ import annotations

import math

import pytest

from stackx import api
from tests.conftest import CONFIGS

PLANAR = CONFIGS / "planar"
CASES = ["alternating-50", "brick-wall", "card-house", "dominoes", "doubling-stack", "fast-into-stack",
         "heavy-on-light-100", "heavy-on-light-1000", "heavy-slab", "overhang", "overhang-topples", "pyramid-10",
         "pyramid-20", "pyramid-drop", "ramp-above", "ramp-below", "ramp-pivot", "ramp-slide", "ramp-slide-tall",
         "ramp-stick", "ramp-tip", "skid", "slab-on-posts", "stack-10", "stack-40", "tilted-drop"]
SHORT = {"ramp-slide": 120, "ramp-above": 120, "tilted-drop": 180, "pyramid-drop": 240, "dominoes": 480,
         "brick-wall": 300, "ramp-tip": 180, "ramp-pivot": 180, "ramp-slide-tall": 120,
         "skid": 120}
# the cases judged before 10 s: a slide, a landing, an impact, a fall, a wall, a box going over, a skid


def _run(name: str):  # type: ignore[no-untyped-def]
    spec = api.load(PLANAR / f"{name}.yaml")
    assert len(spec.runs) == 1
    return spec.runs[0]


def test_every_planar_case_is_there_and_loads_on_the_planar_model() -> None:
    assert sorted(p.stem for p in PLANAR.glob("*.yaml")) == CASES
    for name in CASES:
        run = _run(name)
        assert run.model.plugin_name == "planar" and run.scene.plugin_name == "planar"
        assert run.gravity == -9.8 and run.dt == pytest.approx(1 / 60)
        state = run.scene.build()
        assert state.bodies == run.scene.size()
        assert state.peak_depth[0] < 1e-12, name  # placed touching, never overlapping


@pytest.mark.parametrize("name", CASES)
def test_resting_cases_last_10_s_at_60_hz(name: str) -> None:
    assert _run(name).steps == SHORT.get(name, 600)


@pytest.mark.parametrize(("name", "boxes"), [("stack-10", 10), ("stack-40", 40), ("pyramid-10", 55),
                                             ("pyramid-20", 210), ("heavy-on-light-100", 2), ("fast-into-stack", 6),
                                             ("card-house", 7), ("overhang", 6), ("overhang-topples", 6),
                                             ("slab-on-posts", 3), ("alternating-50", 6), ("doubling-stack", 5)])
def test_each_case_has_the_boxes_its_name_says(name: str, boxes: int) -> None:
    assert _run(name).scene.size() == boxes


@pytest.mark.parametrize(("name", "ratio"), [("heavy-on-light-100", 100), ("heavy-on-light-1000", 1000)])
def test_heavy_on_light_ratios(name: str, ratio: int) -> None:
    inv = _run(name).scene.build().inv_mass[0]
    assert inv[0] / inv[1] == pytest.approx(ratio)


def test_the_ramps_lie_either_side_of_atan_mu() -> None:
    stick, slide = _run("ramp-stick").scene.params.ramp, _run("ramp-slide").scene.params.ramp
    assert stick.mu == slide.mu
    assert stick.angle < math.degrees(math.atan(stick.mu)) < slide.angle


def test_the_thrown_box_is_fast_enough_to_pass_a_box_in_one_step() -> None:
    run = _run("fast-into-stack")
    state = run.scene.build()
    assert -state.vy[0, -1] * run.dt > 0.3  # a third of a box per step: a missed contact passes into the stack
