"""Planar measures against hand-worked states: depths, the final motion, drift, the ramp's slide and the
bench's top-of-pile figures, each computed here without the code under test."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from stackx.bench.criteria import Criteria, judge
from stackx.models.planar import measures
from stackx.models.planar.state import PlanarState
from stackx.scenes.planar import Planar, PlanarParams


def _state(poses: list[tuple[float, float, float]], hx: float = 0.5, hy: float = 0.5,
           static: tuple[int, ...] = ()) -> PlanarState:
    row = lambda values: np.array([values], dtype=np.float64)  # noqa: E731
    n = len(poses)
    x, y, a = (row(list(v)) for v in zip(*poses))
    inv = row([0.0 if i in static else 1.0 for i in range(n)])
    return PlanarState(x, y, a, row([0.0] * n), row([0.0] * n), row([0.0] * n), inv, inv.copy(),
                       row([hx] * n), row([hy] * n), row([0.5] * n))


def test_final_depth_is_the_deepest_overlap_by_hand() -> None:
    s = _state([(0.0, 0.46, 0.0), (0.3, 1.43, 0.0)])  # ground: 0.04; boxes: 0.46 + 1 - 1.43 = 0.03
    assert measures.max_depth(s) == pytest.approx(0.04, abs=1e-12)
    tilted = _state([(0.0, math.sqrt(0.5) - 0.02, math.pi / 4)])  # on a corner, 2 cm into the ground
    assert measures.max_depth(tilted) == pytest.approx(0.02, abs=1e-12)
    apart = _state([(0.0, 0.7, 0.0)])
    assert measures.max_depth(apart) == 0.0


def test_rms_motion_counts_translation_and_rotation_of_movable_boxes_only() -> None:
    steps, dt = 70, 0.1
    frames = {}
    for k in range(steps + 1):  # box 0 moves 1 mm right and turns 2 mrad per step; box 1 is static
        frames[k] = _state([(0.001 * k, 3.0, 0.002 * k), (9.0, 0.5, 0.0)], hx=0.3, hy=0.4, static=(1,))
    rms = measures.rms_motion(frames, steps, np.array([dt]))
    r = math.hypot(0.3, 0.4)
    assert rms[0] == pytest.approx(math.sqrt(0.001 ** 2 + (r * 0.002) ** 2) / dt, rel=1e-9)
    found = measures.measure(frames, steps, np.array([dt]))[0]
    assert found["rms_motion"] == rms[0]
    assert found["x"] == pytest.approx([0.07, 9.0]) and found["angle"] == pytest.approx([0.14, 0.0])


def test_drift_is_the_largest_sideways_move_and_turn_of_the_resting_boxes() -> None:
    start = _state([(0.0, 0.5, 0.0), (0.1, 1.5, 0.0), (5.0, 0.5, 0.0)])
    end = _state([(0.03, 0.49, 0.01), (-0.05, 1.48, -0.2), (9.0, 0.5, 3.0)])
    assert measures.drift(start, end, [0, 1]) == pytest.approx({"drift_x": 0.15, "drift_angle": 0.2})
    assert measures.drift(start, end, []) == {}


def test_slide_acceleration_is_the_velocity_down_the_slope_over_the_time() -> None:
    a = math.radians(35.0)
    s = _state([(0.0, 0.0, a), (1.0, 1.0, a)])
    speed = 3.2  # m/s down the slope, towards -x
    s.vx[0, 1], s.vy[0, 1] = -speed * math.cos(a), -speed * math.sin(a)
    found = measures.slide(s, 1, a, expected=1.5, time=2.0)
    assert found["slide_acceleration"] == pytest.approx(1.6, abs=1e-12)
    assert found["slide_error"] == pytest.approx(0.1, abs=1e-12)


def _result(scene: Planar, final: PlanarState, frames: dict[int, PlanarState], steps: int) -> SimpleNamespace:
    spec = SimpleNamespace(scene=scene, steps=steps, dt=0.1, gravity=-9.8)
    return SimpleNamespace(spec=spec, final=final, frames=frames)


def test_bench_measures_of_a_stack_give_drift_and_the_top_against_a_rigid_pile() -> None:
    scene = Planar(PlanarParams.model_validate({"stack": {"count": 3}}))
    start = scene.build()
    steps = 80
    frames = {}
    for k in range(steps + 1):
        s = start.copy()
        s.y[0] -= [0.001, 0.003, 0.004 + 0.0001 * (k % 2)]  # sunk a little, the top jittering by 0.1 mm
        s.x[0, 1] += 0.02
        s.angle[0, 2] = -0.01
        frames[k] = s
    found = measures.bench_measures(_result(scene, frames[steps], frames, steps))  # type: ignore[arg-type]
    assert found["boxes"] == 3.0 and found["rest_contacts"] == 3.0
    assert found["drift_x"] == pytest.approx(0.02) and found["drift_angle"] == pytest.approx(0.01)
    assert found["top_rest_error"] == pytest.approx(2.5 - 0.004 - 2.5, abs=1e-12)
    assert found["top_p2p"] == pytest.approx(0.0001, abs=1e-12)
    assert "slide_error" not in found


def test_a_ramp_is_judged_on_its_slide_and_a_sliding_box_is_not_judged_settled() -> None:
    scene = Planar(PlanarParams.model_validate({"ramp": {"angle": 35, "mu": 0.5}}))
    start = scene.build()
    a = math.radians(35.0)
    expected = 9.8 * (math.sin(a) - 0.5 * math.cos(a))
    final = start.copy()
    final.vx[0, 1], final.vy[0, 1] = -expected * 2.0 * math.cos(a), -expected * 2.0 * math.sin(a)  # after 2 s
    found = measures.bench_measures(_result(scene, final, {20: final}, 20))  # type: ignore[arg-type]
    assert found["slide_error"] == pytest.approx(0.0, abs=1e-12)
    assert "drift_x" not in found and "top_rest_error" not in found  # the sliding box does not rest
    assert measures.unjudged(scene) == ("rms_motion",)
    verdicts = judge({**found, "max_depth": 0.0, "reach": 0.0, "rms_motion": 2.4, "launch": 0.0}, Criteria(),
                     measures.unjudged(scene))
    assert verdicts["settled"].checks == () and verdicts["settled"].passed
    assert [c.measure for c in verdicts["holds"].checks] == ["max_depth", "reach", "slide_error", "slide_turn"]
    late = judge({**found, "slide_error": 0.01, "max_depth": 0.0, "reach": 0.0, "rms_motion": 2.4, "launch": 0.0},
                 Criteria(), ())
    assert not late["holds"].passed and not late["settled"].passed  # a box made to settle would fail it
    stick = Planar(PlanarParams.model_validate({"ramp": {"angle": 20, "mu": 0.5}}))
    assert measures.unjudged(stick) == ()


def test_drift_fails_holds_past_its_limits() -> None:
    base = {"max_depth": 0.0, "reach": 0.0, "rms_motion": 0.0, "launch": 0.0, "top_rest_error": 0.0,
            "rest_contacts": 3, "boxes": 3}
    c = Criteria(drift=0.05, turn=0.05)
    assert judge({**base, "drift_x": 0.05, "drift_angle": 0.05}, c)["holds"].passed
    assert judge({**base, "drift_x": 0.051, "drift_angle": 0.0}, c)["holds"].failing == "drift_x 0.051 > 0.05"
    assert judge({**base, "drift_x": 0.0, "drift_angle": 1.57}, c)["holds"].failing == "drift_angle 1.57 > 0.05"
    # the rest height is allowed rest_factor x slop per contact under the top box
    assert judge({**base, "top_rest_error": -0.045}, c)["holds"].passed
    assert not judge({**base, "top_rest_error": -0.046}, c)["holds"].passed
