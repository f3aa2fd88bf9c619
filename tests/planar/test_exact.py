"""planar-exact against analytic answers: a box on a ramp sticks below atan(mu) and slides above it at
g (sin a - mu cos a); a resting pyramid stays put; plain and compiled steps agree to the bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stackx.kernel import compiled
from stackx.solvers.planar import step_problem
from stackx.solvers.planar.reference import ReferenceFailure
from stackx.solvers.planar.exact import PlanarExact, PlanarExactParams
from tests.planar.hand_states import pyramid, ramp

DT = 1 / 60
G = 9.8


def _exact(rows: int = 1, **params: object) -> PlanarExact:
    return PlanarExact([PlanarExactParams(**params)] * rows, np.full(rows, -G), np.full(rows, DT))


@pytest.mark.parametrize("degrees", [20.0, 35.0])
def test_a_box_on_a_ramp_sticks_below_atan_mu_and_slides_above_at_the_coulomb_rate(degrees: float) -> None:
    mu, steps = 0.5, 30  # atan(0.5) = 26.6 degrees
    a = math.radians(degrees)
    state = ramp(a, mu)
    _exact().advance(state, steps)
    c, s = math.cos(a), math.sin(a)
    along = state.vx[0, 1] * c + state.vy[0, 1] * s  # up the slope
    across = -state.vx[0, 1] * s + state.vy[0, 1] * c
    rate = max(G * (s - mu * c), 0.0)  # down the slope, 0 when friction holds
    assert along == pytest.approx(-rate * steps * DT, abs=1e-9)
    assert across == pytest.approx(0.0, abs=1e-9)
    assert state.w[0, 1] == pytest.approx(0.0, abs=1e-9)
    assert state.x[0, 0] == 0.0 and state.y[0, 0] == 3.0  # the ramp is static


def test_a_resting_pyramid_stays_exactly_where_it_is() -> None:
    state = pyramid(6, mu=0.5)
    start = state.copy()
    _exact().advance(state, 20)
    for name in ("x", "y", "angle", "vx", "vy", "w"):
        assert np.abs(getattr(state, name) - getattr(start, name)).max() < 1e-9, name


def test_plain_and_compiled_steps_agree_to_the_bit() -> None:
    out = []
    for on in (False, True):
        state = pyramid(3, mu=0.4, jitter=0.1, seed=5)
        state.vx[0] = np.linspace(-0.5, 0.5, state.bodies)
        state.y[0] += 0.05 * np.arange(state.bodies)  # a little apart: speculative points, landings
        with compiled(on):
            _exact(correction={"slop": 0.005, "percent": 0.4}).advance(state, 8)
        out.append(state)
    for name in out[0].FIELDS:
        assert np.array_equal(getattr(out[0], name), getattr(out[1], name)), name


def test_a_step_the_reference_cannot_solve_keeps_the_closest_answer_and_is_counted(monkeypatch) -> None:
    from stackx.models.planar.measures import state_measures
    from stackx.solvers.planar.problem import residual, velocities_after

    seen = []

    def fail(problem, pn, pt, **kwargs):  # the warm start stands for the closest answer found
        seen.append((problem, pn.copy(), pt.copy()))
        raise ReferenceFailure("best residual 3e-07 m/s", 3e-7, pn.copy(), pt.copy())

    state = pyramid(2)
    state = state.concat([state, state])
    solver = _exact(2)
    solver.advance(state, 2)
    held = state.copy()
    monkeypatch.setattr(step_problem, "solve", fail)
    solver.advance(state, 2)  # the run goes on
    assert state.unsolved.tolist() == [2, 2] and state.first_unsolved.tolist() == [2, 2]
    problem, pn, pt = seen[-2]  # row 0's last step: its velocities are those of the kept impulses
    v = velocities_after(problem, pn, pt)
    assert np.array_equal(np.stack([state.vx[0], state.vy[0], state.w[0]], axis=1), v)
    assert state.worst_unsolved[0] == max(residual(p, a, b) for p, a, b in seen[0::2])
    assert pn.sum() > 0.0  # the remembered impulses of the resting pile were carried
    assert np.abs(state.y - held.y).max() < 1e-6  # a resting pile's kept answer still holds it
    measures = state_measures(state.row(1))
    assert (measures["unsolved_steps"], measures["first_unsolved"]) == (2, 2)
    fresh = pyramid(2)
    assert state_measures(fresh)["unsolved_steps"] == 0 and state_measures(fresh)["first_unsolved"] == -1


def test_the_run_table_flags_a_run_with_unsolved_steps() -> None:
    from pathlib import Path
    from types import SimpleNamespace

    from rich.console import Console

    from stackx.run.session import summary

    def run(name: str, missed: int) -> SimpleNamespace:
        spec = SimpleNamespace(solver_cls=PlanarExact,
                               scene=SimpleNamespace(final_size=lambda: 20), steps=360)
        return SimpleNamespace(name=name, spec=spec, compiled=True, us_per_step=1.0,
                               measures={"max_depth": 0.0, "peak_depth": 0.0, "rms_motion": 0.0,
                                         "unsolved_steps": missed})

    console = Console(width=120, record=True)
    result = SimpleNamespace(spec=SimpleNamespace(name="dominoes"), runs=[run("held", 0), run("missed", 2)])
    console.print(summary([result], Path("out")))
    lines = console.export_text().splitlines()
    assert any("dominoes/missed" in line and "360 (2 unsolved)" in line for line in lines)
    assert any("dominoes/held" in line and "360 " in line and "unsolved" not in line for line in lines)
    assert any("K unsolved" in line for line in lines)
