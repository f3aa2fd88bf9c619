"""planar-xpbd against answers worked out apart from it: a box landing flat, Coulomb's stick/slide answer
on a ramp, a short stack at rest, the 2x2 projection against brute force; plain and compiled steps agree
to the bit."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from stackx.kernel import compiled
from stackx.solvers.planar.xpbd import PlanarXPBD, PlanarXPBDParams, pair_solve
from tests.planar.hand_states import boxes, pyramid, ramp

DT = 1 / 60
G = 9.8


def _xpbd(**params: object) -> PlanarXPBD:
    return PlanarXPBD([PlanarXPBDParams(**params)], np.array([-G]), np.array([DT]))


def test_plain_and_compiled_steps_agree_to_the_bit() -> None:
    out = []
    for on in (False, True):
        state = pyramid(3, mu=0.4, jitter=0.1, seed=5)
        state.vx[0] = np.linspace(-0.5, 0.5, state.bodies)
        state.w[0, -1] = 2.0
        state.y[0] += 0.01 * np.arange(state.bodies)
        with compiled(on):
            _xpbd(substeps=4, compliance=1e-6).advance(state, 6)
        out.append(state)
    for name in out[0].FIELDS:
        assert np.array_equal(getattr(out[0], name), getattr(out[1], name)), name


def test_the_two_point_projection_solves_its_complementarity_problem() -> None:
    """Against brute force on random problems: of the four sets of pushed points, the one whose impulses are
    >= 0 and leave every point apart or touching (a positive definite K has exactly one)."""
    rng = np.random.default_rng(7)
    for _ in range(300):
        r = rng.normal(size=(2, 2))
        k = r @ r.T + 0.05 * np.eye(2)  # symmetric positive definite, as J M^-1 J^T of two points is
        s = rng.normal(size=2)
        got = np.array(pair_solve(k[0, 0], k[0, 1], k[1, 1], s[0], s[1]))
        found = []
        for active in itertools.product((False, True), repeat=2):
            lam = np.zeros(2)
            idx = [i for i in range(2) if active[i]]
            if idx:
                lam[idx] = np.linalg.solve(k[np.ix_(idx, idx)], -s[idx])
            if (lam >= -1e-12).all() and (s + k @ lam >= -1e-9).all():
                found.append(lam)
        assert len(found) == 1
        assert np.allclose(got, found[0], rtol=1e-9, atol=1e-9)


def test_a_box_dropped_flat_comes_to_rest_level_on_the_ground() -> None:
    state = boxes([0.0], [0.75], [0.0], [(0.5, 0.5)], [1.0], [0.6])  # 25 cm above the ground
    with compiled(True):
        _xpbd().advance(state, 120)
    assert state.y[0, 0] == pytest.approx(0.5, abs=1e-12)  # projected to touching, rigid
    assert state.angle[0, 0] == 0.0 and state.w[0, 0] == 0.0 and state.x[0, 0] == 0.0
    assert abs(state.vy[0, 0]) < 1e-12


@pytest.mark.parametrize("degrees", [20.0, 26.0, 27.0, 35.0])
def test_a_box_on_a_ramp_sticks_below_atan_mu_and_slides_above_at_the_coulomb_rate(degrees: float) -> None:
    """atan(0.5) = 26.57 degrees. Each substep the projection puts the box back on the ramp, removing the
    normal speed gravity gave, so the normal impulse is the weight's share ``m g cos a h`` from the first
    substep on; sliding, friction takes exactly ``mu`` times it. What is left is rounding over 1,200
    substeps and the tilt the corners' friction gives (1e-5 rad): 1e-8 m/s^2 is a hundred times what it
    measures."""
    mu = 0.5
    a = math.radians(degrees)
    state = ramp(a, mu)
    c, s = math.cos(a), math.sin(a)
    solver = _xpbd()
    with compiled(True):
        solver.advance(state, 30)
        x1, y1, v1 = state.x[0, 1], state.y[0, 1], state.vx[0, 1] * c + state.vy[0, 1] * s
        solver.advance(state, 60)
    v2 = state.vx[0, 1] * c + state.vy[0, 1] * s
    rate = G * (s - mu * c)
    if rate < 0.0:
        assert math.hypot(state.x[0, 1] - x1, state.y[0, 1] - y1) < 1e-8
        assert abs(v2) < 1e-9
    else:
        assert -(v2 - v1) / (60 * DT) == pytest.approx(rate, abs=1e-8)
    assert state.x[0, 0] == 0.0 and state.y[0, 0] == 3.0


def test_a_short_stack_with_offsets_holds() -> None:
    """Five unit boxes shifted sideways by up to 5 cm stand; XPBD's one pass per substep leaves a drift that
    falls with h^2: at 20 substeps under 3 mm and 1 mrad over 5 s, and no box sinks in."""
    rng = np.random.default_rng(1)
    n = 5
    state = boxes(list(rng.uniform(-0.05, 0.05, n)), [0.5 + i for i in range(n)], [0.0] * n, [(0.5, 0.5)] * n,
                  [1.0] * n, [0.6] * n)
    start = state.copy()
    with compiled(True):
        _xpbd().advance(state, 300)
    assert np.abs(state.x - start.x).max() < 3e-3
    assert np.abs(state.angle).max() < 1e-3
    assert np.abs(state.y - start.y).max() < 1e-3
    assert state.peak_depth[0] < 1e-3


@pytest.mark.parametrize("substeps", [4, 20, 40, 80])
@pytest.mark.parametrize("mu", [0.6, 0.0])
def test_a_tilted_box_dropped_on_a_corner_never_gains_energy(substeps: int, mu: float) -> None:
    """A 1 m box tilted 30 degrees, its centre 2.5 m up, lands on a corner at 6.3 m/s, about 0.1 m per step:
    the substeps must see the ground the corner reaches within the step, and no push-out may give back more
    than the fall brought. Its energy (potential, linear and rotational, worked out here from the state) never
    rises above the start's, the corner never goes 1 cm into the ground, and the box ends at rest."""
    state = boxes([0.0], [2.5], [math.radians(30.0)], [(0.5, 0.5)], [1.0], [mu])
    m, inertia = 1.0 / state.inv_mass[0, 0], 1.0 / state.inv_inertia[0, 0]

    def energy() -> float:
        v2 = state.vx[0, 0] ** 2 + state.vy[0, 0] ** 2
        return m * G * state.y[0, 0] + 0.5 * m * v2 + 0.5 * inertia * state.w[0, 0] ** 2

    start, highest = energy(), -math.inf
    solver = _xpbd(substeps=substeps)
    with compiled(True):
        for _ in range(240):
            solver.advance(state, 1)
            highest = max(highest, energy())
    assert highest <= start + 1e-9
    assert state.peak_depth[0] < 0.01
    assert state.launch[0] <= 1.0
    assert state.y[0, 0] < 0.53 and abs(state.vy[0, 0]) < 1e-6
