"""planar-jacobi: every manifold solved from the velocities its pass began with, so the answer does not
depend on the order the boxes are listed in; with no body shared between manifolds it is Gauss-Seidel's."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from stackx import kernel
from stackx.models.planar.state import PlanarState
from tests.planar.worlds import DT, G, solver, world

# two boxes on the ground, the right one landing, bridged by a third that slides and turns a little
BRIDGE = [{"x": -0.55, "y": 0.5}, {"x": 0.55, "y": 0.52, "mu": 0.7},
          {"x": 0.03, "y": 1.53, "angle": 0.01, "vx": 0.1, "mu": 0.4}]


def trajectory(name: str, boxes: list[dict[str, Any]], order: list[int], steps: int = 60) -> np.ndarray:
    """Poses and velocities after every step of ``boxes`` listed in ``order``, given back in the boxes'
    own order: ``(steps, 6, boxes)``."""
    state = world([boxes[i] for i in order])
    back = np.argsort(order)
    s = solver(name)
    out = []
    with kernel.compiled(False):
        for _ in range(steps):
            s.advance(state, 1)
            out.append([getattr(state, f)[0, back] for f in ("x", "y", "angle", "vx", "vy", "w")])
    return np.array(out)


def test_listing_the_boxes_in_another_order_gives_the_same_trajectory() -> None:
    """The two supports swapped: the bridge's two manifolds are met in the other order, and its change is
    the same sum; only the warm start's rounding may differ. (Each pair keeps its lower-numbered box as
    ``A``, so every manifold, its points and their order are the same in both listings.)"""
    one = trajectory("planar-jacobi", BRIDGE, [0, 1, 2])
    other = trajectory("planar-jacobi", BRIDGE, [1, 0, 2])
    assert np.abs(one - other).max() < 1e-12
    assert np.abs(one[-1, 3:]).max() < 1e-3  # it did something: the landing and the slide were stopped
    assert np.abs(one[:, 3]).max() > 0.05


def test_gauss_seidel_tells_the_two_orders_apart() -> None:
    """The same comparison on planar-pgs-soft: each manifold sees what the one before it did, so the
    order shows, by far more than rounding."""
    one = trajectory("planar-pgs-soft", BRIDGE, [0, 1, 2])
    other = trajectory("planar-pgs-soft", BRIDGE, [1, 0, 2])
    assert np.abs(one - other).max() > 1e-9


def test_without_shared_bodies_it_is_gauss_seidel() -> None:
    """Boxes apart from each other, each on the ground: no body has two manifolds, so visiting them from the
    same velocities changes nothing but rounding (``v + (new - v)`` for ``new``)."""
    boxes = [{"x": 0.0, "y": 0.52, "vx": 0.5, "w": 0.3}, {"x": 3.0, "y": 0.6, "angle": 0.2},
             {"x": 6.0, "y": 0.5, "vx": -2.0, "mu": 0.2}]
    params = {"relaxation": 1.0, "push_out": 2.0, "iterations": 4}
    states = []
    for name in ("planar-jacobi", "planar-pgs-soft"):
        state = world(boxes)
        with kernel.compiled(False):
            solver(name, params if name == "planar-jacobi" else {"iterations": 4}).advance(state, 90)
        states.append(state)
    for f in PlanarState.BODY:
        assert np.abs(getattr(states[0], f) - getattr(states[1], f)).max() < 1e-12, f


def test_a_three_box_stack_holds_at_the_defaults() -> None:
    """Unit boxes shifted by 2 cm either way, ten seconds: no box moves sideways by a millimetre or turns by
    a milliradian, and all are at rest."""
    state = world([{"x": 0.0, "y": 0.5}, {"x": 0.02, "y": 1.5}, {"x": -0.02, "y": 2.5}])
    start = state.copy()
    with kernel.compiled(False):
        solver("planar-jacobi").advance(state, 600)
    assert np.abs(state.x - start.x).max() < 1e-3
    assert np.abs(state.angle).max() < 1e-3
    assert np.abs(np.r_[state.vx[0], state.vy[0], state.w[0]]).max() < 1e-4


def test_the_impulses_it_reports_give_its_velocities() -> None:
    """The ground's impulses of the last step are the pile's change of momentum less gravity's."""
    state = world(BRIDGE)
    s = solver("planar-jacobi")
    with kernel.compiled(False):
        s.advance(state, 20)
        before = state.copy()
        s.advance(state, 1)
    got = s.step_impulses(0)
    assert got is not None
    mass = 1.0 / state.inv_mass[0]
    ground = got.keys[:, 0] == -1
    px = float(np.sum(mass * (state.vx[0] - before.vx[0])))
    py = float(np.sum(mass * (state.vy[0] - before.vy[0] - G * DT)))
    assert float(np.sum(-got.pt[ground])) == pytest.approx(px, abs=1e-12)
    assert float(np.sum(got.pn[ground])) == pytest.approx(py, abs=1e-12)
