"""planar-shock: the levels of a pile, and what freezing the supports holds that the passes alone do not."""

from __future__ import annotations

import numpy as np
import pydantic
import pytest

from stackx import kernel
from stackx.models.planar.state import PlanarState
from stackx.registry import solvers
from stackx.solvers.planar.contacts import contact_workspace, find_contacts
from stackx.solvers.planar.shock import UNREACHED, PlanarShockParams, height_levels, support_levels
from tests.planar.worlds import DT, deepest, held_memory, run, solver, world

needs_numba = pytest.mark.skipif(not kernel.available(), reason="numba not installed")

# three rows: a bottom row touching side by side, two boxes on it, one on top
PYRAMID = [{"x": -1.0, "y": 0.5}, {"x": 0.0, "y": 0.5}, {"x": 1.0, "y": 0.5}, {"x": -0.5, "y": 1.5},
           {"x": 0.5, "y": 1.5}, {"x": 0.0, "y": 2.5}]
# a box on two boxes standing 0.1 m apart, and far away two boxes touching in the air, on nothing
BRIDGE = [{"x": -0.55, "y": 0.5}, {"x": 0.55, "y": 0.5}, {"x": 0.0, "y": 1.5}, {"x": 10.0, "y": 5.0},
          {"x": 10.0, "y": 6.0}]


def levels(boxes: list[dict], order: str) -> list[int]:
    """The bodies' levels, then the ground's, from the contacts found within 2 cm."""
    s = world(boxes)
    ids, table = contact_workspace(64)
    ids, table, count = find_contacts(s.x[0], s.y[0], s.angle[0], s.hx[0], s.hy[0], s.inv_mass[0], 0.02, ids,
                                      table)
    level = np.zeros(s.bodies + 2, np.int64)
    if order == "support":
        support_levels(ids, count, s.inv_mass[0], level)
    else:
        height_levels(s.y[0], s.inv_mass[0], level)
    return level[:s.bodies + 1].tolist()


def test_support_levels_count_contacts_from_the_ground() -> None:
    assert levels(PYRAMID, "support") == [1, 1, 1, 2, 2, 3, 0]  # side-by-side boxes share a level
    assert levels(BRIDGE, "support") == [1, 1, 2, UNREACHED, UNREACHED, 0]  # a group on nothing has none


def test_a_static_box_is_a_support_like_the_ground() -> None:
    shelf = [{"x": 5.0, "y": 3.0, "hx": 2.0, "static": True}, {"x": 5.0, "y": 4.0}, {"x": 5.0, "y": 5.0}]
    assert levels(shelf, "support") == [0, 1, 2, 0]


def test_height_levels_rank_every_movable_box_by_its_centre() -> None:
    assert levels(PYRAMID, "height") == [1, 2, 3, 4, 5, 6, 0]  # ties in index order
    assert levels(BRIDGE, "height") == [1, 2, 3, 4, 5, 0]


def heavy_on_light(ratio: float) -> PlanarState:
    return world([{"x": 0.0, "y": 0.5}, {"x": 0.0, "y": 1.5, "density": ratio}])


def test_a_heavy_box_on_a_light_one_stays_up_where_the_passes_alone_let_it_sink() -> None:
    held, sunk = heavy_on_light(1000.0), heavy_on_light(1000.0)
    with kernel.compiled(False):
        run("planar-shock", held, 120)
        run("planar-warm-start", sunk, 120, {"iterations": PlanarShockParams().iterations})
    slop = PlanarShockParams().correction.slop
    assert deepest(sunk) > 2 * slop  # the light box pressed into the ground, the heavy one into it
    assert 1.5 - sunk.y[0, 1] > 2 * slop
    assert deepest(held) <= slop and abs(1.5 - held.y[0, 1]) <= slop
    assert np.abs(held.vy).max() < 1e-6


def test_no_shock_pass_is_planar_warm_start() -> None:
    # a pile at rest: the contacts' margin is the speculative one, so only the shock pass could differ
    boxes = [{"x": 0.02 * i, "y": 0.5 + i, "density": 1.0 + 3 * i} for i in range(4)]
    plain, shocked = world(boxes), world(boxes)
    with kernel.compiled(False):
        run("planar-warm-start", plain, 40)
        run("planar-shock", shocked, 40, {"shock_passes": 0})
    for name in PlanarState.FIELDS:
        assert getattr(plain, name).tobytes() == getattr(shocked, name).tobytes(), name


def test_a_ten_box_stack_holds_and_settles_where_the_passes_alone_leave_it_rocking() -> None:
    rng = np.random.default_rng(3)
    boxes = [{"x": float(rng.uniform(-0.05, 0.05)), "y": 0.5 + i, "mu": 0.6} for i in range(10)]
    shocked, passes = world(boxes), world(boxes)
    with kernel.compiled(False):
        run("planar-shock", shocked, 360)
        run("planar-warm-start", passes, 360, {"iterations": PlanarShockParams().iterations})
    start = world(boxes)
    assert np.abs(shocked.x - start.x).max() < 0.01 and np.abs(shocked.angle).max() < 0.01
    assert deepest(shocked) <= PlanarShockParams().correction.slop
    assert abs(shocked.y[0, -1] - start.y[0, -1]) < 0.02
    speed = lambda s: max(np.abs(s.vx).max(), np.abs(s.vy).max())  # noqa: E731
    assert speed(shocked) < 5e-4 < speed(passes)


def test_a_box_landing_on_a_pile_does_not_press_it_down_within_the_step() -> None:
    # what the shock pass gives up: the light box under the landing heavy one is frozen, so the landing is
    # stopped as by the ground and the light box gains no downward speed; the passes alone press it down
    boxes = [{"x": 0.0, "y": 0.5}, {"x": 0.0, "y": 1.51, "vy": -3.0, "density": 100.0}]
    shocked, passes = world(boxes), world(boxes)
    with kernel.compiled(False):
        run("planar-shock", shocked, 1, {"correction": "off"})
        run("planar-shock", passes, 1, {"correction": "off", "shock_passes": 0})
    assert passes.vy[0, 0] < -0.01  # pressed into the ground by the passes' exchange of momentum
    assert shocked.vy[0, 0] >= -1e-9  # not pressed down at all
    assert shocked.vy[0, 1] >= -0.01 / DT - 1e-9  # the heavy box closes its 1 cm gap in the step, no more


def test_the_step_impulses_are_not_given_where_the_shock_pass_moved_only_the_upper_bodies() -> None:
    s = world([{"x": 0.0, "y": 0.5}, {"x": 0.0, "y": 1.5}])
    shocked, positions, none = (solver("planar-shock"), solver("planar-shock", {"acts_on": "positions"}),
                                solver("planar-shock", {"shock_passes": 0}))
    with kernel.compiled(False):
        for sv in (shocked, positions, none):
            sv.advance(s.copy(), 3)
    assert shocked.step_impulses(0) is None
    assert positions.step_impulses(0) is not None and none.step_impulses(0) is not None


def test_the_position_variant_needs_the_correction() -> None:
    with pytest.raises(pydantic.ValidationError, match="acts_on: positions"):
        PlanarShockParams(acts_on="positions", correction="off")
    with pytest.raises(pydantic.ValidationError):
        PlanarShockParams(order="depth")


def test_removing_a_box_keeps_the_rest_of_the_pile_standing() -> None:
    s = world([{"x": 0.0, "y": 0.5}, {"x": 0.0, "y": 1.5, "density": 50.0}, {"x": 0.0, "y": 2.5}])
    sv = solver("planar-shock")
    with kernel.compiled(False):
        sv.advance(s, 30)
        sv.remove_box(s, 1)
        fewer = PlanarState(*(np.delete(getattr(s, name), 1, axis=1) for name in PlanarState.BODY))
        sv.advance(fewer, 60)
    assert fewer.bodies == 2 and fewer.y[0, 0] == pytest.approx(0.5, abs=0.01)
    assert fewer.vy[0, 1] < 0.5  # the top box falls onto the bottom one without being thrown


@needs_numba
def test_plain_and_compiled_give_the_same_numbers() -> None:
    boxes = PYRAMID + [{"x": 3.0, "y": 1.0, "angle": 0.4, "vx": -1.0, "w": 1.0}]
    for params in ({}, {"order": "height"}, {"acts_on": "positions", "shock_passes": 1}):
        plain, fast = world(boxes), world(boxes)
        slow_solver, fast_solver = solver("planar-shock", params), solver("planar-shock", params)
        for _ in range(2):
            with kernel.compiled(False):
                slow_solver.advance(plain, 15)
            with kernel.compiled(True):
                fast_solver.advance(fast, 15)
        for name in plain.FIELDS:
            assert np.array_equal(getattr(plain, name), getattr(fast, name)), (params, name)
        assert held_memory(slow_solver, plain) == held_memory(fast_solver, fast)


def test_the_summary_is_the_docstring_first_line() -> None:
    assert solvers.get("planar-shock").__doc__.splitlines()[0].startswith("Shock propagation")


@needs_numba
def test_a_forty_box_stack_stays_upright_and_in_place() -> None:
    # the shock pass's one-sided impulses are not carried into the next step: carried, they build a shear that
    # slides a tall stack apart; its normals come last, so each box turns with the one under it
    rng = np.random.default_rng(1)
    boxes = [{"x": float(rng.uniform(-0.05, 0.05)), "y": 0.5 + i, "mu": 0.6} for i in range(40)]
    s, start = world(boxes), world(boxes)
    with kernel.compiled(True):
        run("planar-shock", s, 600)
    assert np.abs(s.angle).max() < 1e-9
    assert np.abs(s.x - start.x).max() < 0.005
    assert deepest(s) <= PlanarShockParams().correction.slop
    assert max(np.abs(s.vx).max(), np.abs(s.vy).max()) < 1e-3
