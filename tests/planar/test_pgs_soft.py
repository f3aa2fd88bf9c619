"""planar-pgs-soft: soft contacts in one full step, against answers worked out apart from it: a soft
contact's steady sink, a box and a short stack at rest, the impulses it reports giving its velocities."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stackx import kernel
from stackx.models.planar.state import PlanarState, box_mass
from tests.planar.worlds import DT, G, held_memory, run, solver, world

needs_numba = pytest.mark.skipif(not kernel.available(), reason="numba not installed")
MIXED = [{"x": 0.0, "y": 0.48, "angle": 0.05}, {"x": 0.3, "y": 1.5, "angle": -0.1, "vx": 0.5},
         {"x": 2.0, "y": 1.0, "angle": 0.7, "w": 2.0, "mu": 0.9}]


def stack3() -> PlanarState:
    """Three unit boxes on each other, the upper two shifted by 2 cm either way."""
    return world([{"x": 0.0, "y": 0.5}, {"x": 0.02, "y": 1.5}, {"x": -0.02, "y": 2.5}])


def ground_sink(hertz: float, hx: float = 0.5, hy: float = 0.5, density: float = 1.0) -> float:
    """Depth at rest of a box lying flat on the ground on two soft points: each carries half the weight
    through a spring of ``k w^2``, ``k = 1 / (1/m + hx^2 / I)`` its effective mass (the lever arm across the
    vertical normal is the half-width) and ``w = 2 pi (2 hertz)``: the ground is static, so twice the hertz."""
    mass, inertia = box_mass(hx, hy, density)
    k = 1.0 / (1.0 / mass + hx * hx / inertia)
    return (mass * -G / 2.0) / (k * (2.0 * math.pi * 2.0 * hertz) ** 2)


@pytest.mark.parametrize("name", ["planar-pgs-soft", "planar-jacobi"])
@pytest.mark.parametrize(("params", "hertz"), [({}, 0.333 / DT), ({"contact_hertz": 12.0}, 12.0),
                                               ({"contact_hertz": 8.0, "iterations": 1}, 8.0)])
def test_a_box_on_the_ground_rests_at_the_soft_contacts_steady_sink(name: str, params: dict[str, object],
                                                                    hertz: float) -> None:
    """At the defaults the 30 Hz are capped at a third of the step rate (19.98 Hz at 60 Hz); below the cap the
    hertz asked for is used. The box starts touching and ends level and still, as deep as its springs say."""
    state = world([{"x": 0.0, "y": 0.5, "hx": 0.5, "hy": 0.5}])
    with kernel.compiled(False):
        run(name, state, 300, params)
    assert 0.5 - state.y[0, 0] == pytest.approx(ground_sink(hertz), rel=1e-4)
    assert abs(state.angle[0, 0]) < 1e-7
    assert np.abs(np.r_[state.vx[0], state.vy[0], state.w[0]]).max() < 1e-6
    assert abs(state.x[0, 0]) < 1e-4  # the corners are visited one after the other: the first visit tips the
    # box by a hair and friction holds the corner it turns about, so it settles some micrometres aside


def test_a_wide_box_sinks_by_its_own_effective_mass() -> None:
    """A 2 m x 0.5 m box of density 2: another mass and lever arm, the same law."""
    state = world([{"x": 0.0, "y": 0.25, "hx": 1.0, "hy": 0.25, "density": 2.0}])
    with kernel.compiled(False):
        run("planar-pgs-soft", state, 300)
    assert 0.25 - state.y[0, 0] == pytest.approx(ground_sink(0.333 / DT, 1.0, 0.25, 2.0), rel=1e-4)


def test_a_three_box_stack_holds_at_the_defaults() -> None:
    """Ten seconds: no box moves sideways by a millimetre or turns by a milliradian, all come to rest, and
    the bottom box sits as deep as three boxes' weight on its two ground springs makes it."""
    state = stack3()
    start = state.copy()
    with kernel.compiled(False):
        run("planar-pgs-soft", state, 600)
    assert np.abs(state.x - start.x).max() < 1e-3
    assert np.abs(state.angle).max() < 1e-3
    assert np.abs(np.r_[state.vx[0], state.vy[0], state.w[0]]).max() < 1e-6
    assert 0.5 - state.y[0, 0] == pytest.approx(3.0 * ground_sink(0.333 / DT), rel=0.05)


def test_the_impulses_it_reports_give_its_velocities() -> None:
    """What ``step_impulses`` says the last step applied, summed over the ground's points, is the pile's
    change of momentum over the step less gravity's: the boxes' impulses on each other cancel."""
    state = world(MIXED)
    s = solver("planar-pgs-soft")
    with kernel.compiled(False):
        s.advance(state, 20)
        before = state.copy()
        s.advance(state, 1)
    got = s.step_impulses(0)
    assert got is not None
    mass = 1.0 / state.inv_mass[0]
    px = float(np.sum(mass * (state.vx[0] - before.vx[0])))
    py = float(np.sum(mass * (state.vy[0] - before.vy[0] - G * DT)))
    ground = got.keys[:, 0] == -1
    assert ground.any()
    # the ground's normal is (0, 1) and its tangent (-1, 0)
    assert float(np.sum(-got.pt[ground])) == pytest.approx(px, abs=1e-12)
    assert float(np.sum(got.pn[ground])) == pytest.approx(py, abs=1e-12)


def test_impulses_carry_from_one_call_to_the_next() -> None:
    """Ten steps in one call or in calls of 6 and 4: the same numbers, memory included."""
    one, two = world(MIXED), world(MIXED)
    a, b = solver("planar-pgs-soft"), solver("planar-pgs-soft")
    with kernel.compiled(False):
        a.advance(one, 10)
        b.advance(two, 6)
        b.advance(two, 4)
    for name in one.FIELDS:
        assert np.array_equal(getattr(one, name), getattr(two, name)), name
    assert held_memory(a, one) == held_memory(b, two)


def test_without_warm_start_the_stack_sinks_further() -> None:
    """One pass a step rebuilds the loads from zero each step when nothing is carried: the stack sinks into
    itself, where the carried impulses hold it near its springs' sink."""
    held, forgot = stack3(), stack3()
    with kernel.compiled(False):
        run("planar-pgs-soft", held, 120, {"iterations": 1})
        run("planar-pgs-soft", forgot, 120, {"iterations": 1, "warm_start": False})
    assert 2.5 - held.y[0, 2] < 0.01 and 2.5 - forgot.y[0, 2] > 0.02


def test_removing_a_box_keeps_stepping_the_rest() -> None:
    """The middle box of three taken away: the top one falls onto the bottom one and comes to rest on it."""
    state = stack3()
    s = solver("planar-pgs-soft")
    with kernel.compiled(False):
        s.advance(state, 30)
        s.remove_box(state, 1)
        state = PlanarState(*(np.delete(getattr(state, name), 1, axis=1) for name in PlanarState.BODY))
        s.advance(state, 180)
    assert state.y[0, 1] == pytest.approx(1.5, abs=5e-3)
    assert np.abs(np.r_[state.vx[0], state.vy[0], state.w[0]]).max() < 1e-6


@needs_numba
@pytest.mark.parametrize("name", ["planar-pgs-soft", "planar-jacobi"])
def test_plain_and_compiled_give_the_same_numbers(name: str) -> None:
    plain, fast = world(MIXED), world(MIXED)
    slow_solver, fast_solver = solver(name), solver(name)
    for _ in range(3):
        with kernel.compiled(False):
            slow_solver.advance(plain, 10)
        with kernel.compiled(True):
            fast_solver.advance(fast, 10)
    for field in plain.FIELDS:
        assert np.array_equal(getattr(plain, field), getattr(fast, field)), field
    assert held_memory(slow_solver, plain) == held_memory(fast_solver, fast)


@pytest.mark.parametrize("name", ["planar-pgs-soft", "planar-jacobi"])
def test_rows_of_a_batch_step_as_they_would_alone(name: str) -> None:
    """Two rows with their own knobs, stepped as one batch: each row's numbers are its single run's."""
    rows = [({"iterations": 2}, MIXED), ({"iterations": 5, "relax_iterations": 0, "contact_hertz": 10.0},
                                         [{**box, "vx": box.get("vx", 0.0) - 0.2} for box in MIXED])]
    cls = type(solver(name))
    batch = PlanarState.concat([world(boxes) for _, boxes in rows])
    together = cls([cls.Params(**p) for p, _ in rows], np.full(2, G), np.full(2, DT))
    with kernel.compiled(False):
        together.advance(batch, 12)
        for b, (params, boxes) in enumerate(rows):
            alone = run(name, world(boxes), 12, params)
            for field in alone.FIELDS:
                assert np.array_equal(getattr(batch, field)[b], getattr(alone, field)[0]), (b, field)
