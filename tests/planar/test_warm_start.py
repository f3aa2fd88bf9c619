"""planar-warm-start: accumulated impulses with friction and warm start, against analytic answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stackx import kernel
from stackx.models.planar.state import box_mass
from stackx.solvers.planar.warm_start import PlanarWarmStartParams
from tests.planar.worlds import DT, G, deepest, held_memory, ramp, run, solver, world

MIXED = [{"x": 0.0, "y": 0.48, "angle": 0.05}, {"x": 0.3, "y": 1.5, "angle": -0.1, "vx": 0.5},
         {"x": 2.0, "y": 1.0, "angle": 0.7, "w": 2.0, "mu": 0.9}]
needs_numba = pytest.mark.skipif(not kernel.available(), reason="numba not installed")


@needs_numba
@pytest.mark.parametrize("name", ["planar-warm-start", "planar-ngs"])
def test_plain_and_compiled_give_the_same_numbers(name: str) -> None:
    plain, fast = world(MIXED), world(MIXED)
    slow_solver, fast_solver = solver(name), solver(name)
    for _ in range(3):  # the memory carried between calls too
        with kernel.compiled(False):
            slow_solver.advance(plain, 15)
        with kernel.compiled(True):
            fast_solver.advance(fast, 15)
    for name_ in plain.FIELDS:
        assert np.array_equal(getattr(plain, name_), getattr(fast, name_)), name_
    assert held_memory(slow_solver, plain) == held_memory(fast_solver, fast)


def test_a_box_dropped_flat_rests_within_slop_without_turning() -> None:
    # the speculative point stops it where it touches: it rests between touching and slop deep
    s = run("planar-warm-start", world([{"x": 0.0, "y": 0.6}]), 120)
    assert 0.0 <= deepest(s) <= PlanarWarmStartParams().correction.slop
    assert abs(s.angle[0, 0]) < 1e-9 and abs(s.x[0, 0]) < 1e-9
    assert abs(s.vy[0, 0]) < 1e-9


def _downhill(s, angle: float) -> float:  # type: ignore[no-untyped-def]
    """The box's velocity down the ramp (m/s)."""
    return -(s.vx[0, 1] * math.cos(angle) + s.vy[0, 1] * math.sin(angle))


@pytest.mark.parametrize("name", ["planar-warm-start", "planar-ngs"])
def test_a_box_on_a_ramp_slides_with_the_acceleration_coulomb_gives(name: str) -> None:
    mu, angle = 0.5, math.radians(35.0)  # atan(0.5) = 26.6 degrees: it slides
    expected = -G * (math.sin(angle) - mu * math.cos(angle))  # the box's own weight against kinetic friction
    s = ramp(angle, mu)
    box = solver(name, {"iterations": 50})
    with kernel.compiled(True):
        box.advance(s, 10)
        v1, turned = _downhill(s, angle), s.angle[0, 1]
        box.advance(s, 30)
    accel = (_downhill(s, angle) - v1) / (30 * DT)
    assert accel == pytest.approx(expected, abs=1e-6)
    assert abs(s.w[0, 1]) < 1e-9 and abs(s.angle[0, 1] - turned) < 1e-9  # it slides flat, not tumbling
    # every point slides: its friction is at the Coulomb bound, never past it
    held = box.held[0]
    pn, pt = box.carried[0, :held, 0], box.carried[0, :held, 1]
    assert held == 2 and np.all(pn > 0)
    assert np.abs(pt) == pytest.approx(mu * pn, rel=1e-9)


@pytest.mark.parametrize("name", ["planar-warm-start", "planar-ngs"])
def test_a_box_on_a_ramp_below_the_friction_angle_sticks(name: str) -> None:
    mu, angle = 0.5, math.radians(20.0)
    s = ramp(angle, mu)
    start = (s.x[0, 1], s.y[0, 1])
    with kernel.compiled(True):
        run(name, s, 120, {"iterations": 50})
    assert math.hypot(s.x[0, 1] - start[0], s.y[0, 1] - start[1]) < 1e-6
    assert abs(_downhill(s, angle)) < 1e-9


def test_a_frictionless_collision_keeps_momentum_and_loses_the_energy_of_a_plastic_impact() -> None:
    # no gravity, no friction: box 0 at 2 m/s into box 1 at rest, equal masses; restitution 0 means both
    # end at the centre of mass's 1 m/s, and half the kinetic energy is gone
    boxes = [{"x": 0.0, "y": 5.0, "vx": 2.0, "mu": 0.0}, {"x": 1.05, "y": 5.0, "mu": 0.0}]
    s = run("planar-warm-start", world(boxes), 30, g=0.0)
    mass, _ = box_mass(0.5, 0.5, 1.0)
    assert mass * (s.vx[0, 0] + s.vx[0, 1]) == pytest.approx(mass * 2.0, abs=1e-12)
    assert s.vx[0].tolist() == pytest.approx([1.0, 1.0], abs=1e-12)
    assert np.abs(s.vy[0]).max() < 1e-12 and np.abs(s.w[0]).max() < 1e-12
    energy = 0.5 * mass * float(np.sum(s.vx[0] ** 2 + s.vy[0] ** 2))
    assert energy == pytest.approx(0.5 * (0.5 * mass * 2.0 ** 2), rel=1e-12)
    assert deepest(s) <= PlanarWarmStartParams().correction.slop


def test_friction_never_exceeds_mu_times_the_normal_impulse() -> None:
    boxes = [{"x": 0.0, "y": 0.5, "mu": 0.2}, {"x": 0.2, "y": 1.5, "vx": 1.5, "mu": 0.9},
             {"x": 1.2, "y": 0.5, "angle": 0.3, "w": -1.0, "mu": 0.6}, {"x": -0.3, "y": 2.6, "vx": -2.0}]
    s = world(boxes)
    ws = solver("planar-warm-start", {"iterations": 8})
    at_bound = 0
    with kernel.compiled(True):
        for _ in range(40):
            ws.advance(s, 1)
            for k in range(ws.held[0]):
                a, b, _ = ws.keys[0, k]
                mu = s.friction[0, b] if a < 0 else math.sqrt(s.friction[0, a] * s.friction[0, b])
                pn, pt = ws.carried[0, k]
                assert pn >= 0.0 and abs(pt) <= mu * pn * (1 + 1e-12)
                at_bound += pn > 0 and abs(pt) >= mu * pn * (1 - 1e-12)
    assert at_bound > 0  # some point slid, so the bound was reached, not only respected


@needs_numba
def test_a_ten_box_stack_with_offsets_stands_for_300_steps() -> None:
    rng = np.random.default_rng(5)
    boxes = [{"x": float(rng.uniform(-0.05, 0.05)), "y": 0.5 + i, "mu": 0.6} for i in range(10)]
    s = world(boxes)
    x0 = s.x.copy()
    with kernel.compiled(True):
        run("planar-warm-start", s, 300)
    assert np.abs(s.x - x0).max() < 0.02  # the top leans by millimetres at the default 30 passes
    assert np.abs(s.angle).max() < 5e-3
    assert deepest(s) <= PlanarWarmStartParams().correction.slop
    assert s.y[0, -1] > 9.5 - 10 * PlanarWarmStartParams().correction.slop


@needs_numba
def test_warm_start_holds_a_stack_few_iterations_let_sink() -> None:
    boxes = [{"x": 0.0, "y": 0.5 + i} for i in range(10)]
    held, forgot = world(boxes), world(boxes)
    with kernel.compiled(True):
        run("planar-warm-start", held, 120, {"iterations": 4, "correction": "off"})
        run("planar-warm-start", forgot, 120, {"iterations": 4, "correction": "off", "warm_start": False})
    sunk = lambda s: 9.5 - s.y[0, -1]  # noqa: E731
    assert sunk(held) < 0.05 and sunk(forgot) > 1.0  # without memory the boxes sink into each other


def test_removing_a_box_forgets_its_points_and_renumbers_the_rest() -> None:
    s = world([{"x": 0.0, "y": 0.5}, {"x": 0.0, "y": 1.5}, {"x": 0.0, "y": 2.5}])
    ws = solver("planar-warm-start")
    ws.advance(s, 5)
    before = {tuple(k): tuple(c) for k, c in zip(ws.keys[0, :ws.held[0]], ws.carried[0, :ws.held[0]])}
    ws.remove_box(s, 1)
    after = {tuple(k): tuple(c) for k, c in zip(ws.keys[0, :ws.held[0]], ws.carried[0, :ws.held[0]])}
    expected = {(a - (a > 1), b - (b > 1), f): c for (a, b, f), c in before.items() if 1 not in (a, b)}
    assert after == expected and len(after) == 2  # the ground's two points under box 0 remain
