"""The TGS family (planar-tgs-soft, planar-tgs-sticky, planar-tgs-ngs) on small scenes: a box at rest stays,
a short stack holds at the defaults, plain and compiled steps agree to the bit; TGS soft is the soft step but
for its turning anchors; the sticky solver's friction anchors hold a box on a ramp where a solver without
them or a warm start creeps, and survive a box's removal."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stackx.kernel import compiled
from stackx.registry import solvers
from tests.planar.hand_states import pyramid, ramp
from tests.planar.worlds import run, solver, world

FAMILY = ("planar-tgs-soft", "planar-tgs-sticky", "planar-tgs-ngs")


@pytest.mark.parametrize("name", FAMILY)
def test_a_box_at_rest_on_the_ground_stays(name: str) -> None:
    """The first steps settle it (a rigid pass meets one corner before the other, so the box may tip by a few
    tens of microradians); then it does not move."""
    state = world([{"x": 0.0, "y": 0.5}])
    s = solver(name)
    with compiled(True):
        s.advance(state, 60)
        settled = (state.x[0, 0], state.y[0, 0], state.angle[0, 0])
        s.advance(state, 120)
    assert abs(settled[0]) < 1e-4 and abs(settled[2]) < 1e-4 and abs(settled[1] - 0.5) < 2e-3
    assert abs(state.x[0, 0] - settled[0]) < 1e-8 and abs(state.angle[0, 0] - settled[2]) < 1e-8
    assert abs(state.y[0, 0] - settled[1]) < 1e-6


@pytest.mark.parametrize("name", FAMILY)
def test_a_three_box_stack_holds_at_the_defaults(name: str) -> None:
    state = run(name, world([{"x": 0.0, "y": 0.5 + i} for i in range(3)]), 300, compiled=True)
    for i in range(3):
        assert abs(state.x[0, i]) < 1e-3 and abs(state.angle[0, i]) < 1e-3
        assert abs(state.y[0, i] - (0.5 + i)) < 1e-2
        assert math.hypot(state.vx[0, i], state.vy[0, i]) < 0.05


@pytest.mark.parametrize("name", FAMILY)
def test_plain_and_compiled_steps_agree_to_the_bit(name: str) -> None:
    out = []
    for on in (False, True):
        state = pyramid(3, mu=0.4, jitter=0.1, seed=5)
        state.vx[0] = np.linspace(-0.5, 0.5, state.bodies)
        state.w[0, -1] = 2.0
        state.y[0] += 0.01 * np.arange(state.bodies)  # a little apart: speculative points, landings
        s = solver(name, {"substeps": 3})
        with compiled(on):
            s.advance(state, 6)
            s.advance(state, 4)  # what is kept carried from one call to the next
        keys, carried, held = s.memory(state)
        out.append((state, keys[0, :held[0]].tobytes(), carried[0, :held[0]].tobytes()))
    for field in out[0][0].FIELDS:
        assert np.array_equal(getattr(out[0][0], field), getattr(out[1][0], field)), field
    assert out[0][1:] == out[1][1:]


def test_tgs_soft_is_the_soft_step_but_for_anchors_that_turn() -> None:
    """A stack at rest barely turns within a step: the two agree to far below a millimetre. A box landing on a
    corner while spinning turns a lot within a step, and impulses at turned or fixed arms part the two."""
    def both(boxes: list[dict[str, float]], steps: int) -> tuple[np.ndarray, np.ndarray]:
        got = []
        for name in ("planar-tgs-soft", "planar-soft-step"):
            state = run(name, world(boxes), steps, compiled=True)
            got.append(np.concatenate([state.x[0], state.y[0], state.angle[0]]))
        return got[0], got[1]

    tgs, soft = both([{"x": 0.0, "y": 0.5 + i} for i in range(3)], 60)
    assert np.abs(tgs - soft).max() < 1e-6
    tgs, soft = both([{"x": 0.0, "y": 0.75, "angle": 0.6, "w": 15.0, "vx": 2.0}], 30)
    assert np.abs(tgs - soft).max() > 1e-4


def _corner_slip(name: str, degrees: float, steps: int, params: dict[str, object] | None = None) -> float:
    """How far the box's two lower corners moved along the ramp over ``steps`` steps (m, the larger)."""
    a = math.radians(degrees)
    state = ramp(a, 0.5)  # atan(0.5) = 26.6 degrees

    def corners() -> np.ndarray:
        c, s = math.cos(state.angle[0, 1]), math.sin(state.angle[0, 1])
        along = []
        for qx in (-0.5, 0.5):
            px, py = state.x[0, 1] + c * qx + s * 0.5, state.y[0, 1] + s * qx - c * 0.5
            along.append(px * math.cos(a) + py * math.sin(a))
        return np.array(along)

    before = corners()
    with compiled(True):
        solver(name, params).advance(state, steps)
    return float(np.abs(corners() - before).max())


@pytest.mark.parametrize("degrees", [20.0, 25.0])
def test_sticky_friction_holds_a_box_on_a_ramp_where_a_memoryless_velocity_solve_creeps(degrees: float) -> None:
    assert _corner_slip("planar-tgs-sticky", degrees, 120) < 1e-5
    assert _corner_slip("planar-pgs", degrees, 120) > 1e-3  # no warm start, no anchors: each step slips


def test_sticky_slides_above_the_friction_angle_at_the_coulomb_rate() -> None:
    """At 28 degrees the anchors are let go and the box slides: ``g (sin a - mu cos a) t^2 / 2`` in 2 s."""
    a = math.radians(28.0)
    expected = 0.5 * 9.8 * (math.sin(a) - 0.5 * math.cos(a)) * 2.0 ** 2
    assert _corner_slip("planar-tgs-sticky", 28.0, 120) == pytest.approx(expected, rel=0.03)


def test_sticky_keeps_the_anchors_of_the_boxes_left_when_one_is_removed() -> None:
    boxes = [{"x": 2.0 * i, "y": 0.5} for i in range(3)]
    state = world(boxes)
    s = solver("planar-tgs-sticky")
    with compiled(True):
        s.advance(state, 10)
    keys, carried, held = s.memory(state)
    before = {tuple(k): c.copy() for k, c in zip(keys[0, :held[0]], carried[0, :held[0]])}
    s.remove_box(state, 1)
    keys, carried, held = s.memory(world(boxes[:2]))
    after = {tuple(k): c for k, c in zip(keys[0, :held[0]], carried[0, :held[0]])}
    assert sorted(k[1] for k in after) == [0, 0, 1, 1]
    for (a, b, f), c in before.items():
        if b == 0:
            assert np.array_equal(after[(a, 0, f)], c)
        elif b == 2:
            assert np.array_equal(after[(a, 1, f)], c)


@pytest.mark.parametrize("name", FAMILY)
def test_the_cost_knob_is_substeps_and_the_summary_is_the_docstring(name: str) -> None:
    cls = solvers.get(name)
    assert "substeps" in cls.Params.model_fields
    assert cls.__doc__ and "TGS" in cls.__doc__.splitlines()[0] + cls.__doc__.splitlines()[1]
