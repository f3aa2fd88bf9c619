"""planar-soft-step against answers worked out apart from it: the steady sink of a soft contact, Coulomb's
stick/slide answer on a ramp, a short stack at rest; plain and compiled steps agree to the bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stackx.kernel import compiled
from stackx.solvers.planar.soft_step import PlanarSoftStep, PlanarSoftStepParams
from tests.planar.hand_states import boxes, pyramid, ramp
from tests.planar.worlds import held_memory

DT = 1 / 60
G = 9.8


def _soft(**params: object) -> PlanarSoftStep:
    return PlanarSoftStep([PlanarSoftStepParams(**params)], np.array([-G]), np.array([DT]))


def test_plain_and_compiled_steps_agree_to_the_bit() -> None:
    out = []
    for on in (False, True):
        state = pyramid(3, mu=0.4, jitter=0.1, seed=5)
        state.vx[0] = np.linspace(-0.5, 0.5, state.bodies)
        state.w[0, -1] = 2.0
        state.y[0] += 0.01 * np.arange(state.bodies)  # a little apart: speculative points, landings
        solver = _soft(substeps=3)
        with compiled(on):
            solver.advance(state, 6)
            solver.advance(state, 4)  # impulses carried from one call to the next
        out.append((state, held_memory(solver, state)))
    for name in out[0][0].FIELDS:
        assert np.array_equal(getattr(out[0][0], name), getattr(out[1][0], name)), name
    assert out[0][1] == out[1][1]


@pytest.mark.parametrize(("params", "hertz"), [({}, 30.0), ({"contact_hertz": None, "substeps": 8}, 60.0),
                                              ({"contact_hertz": 1000.0, "substeps": 16}, 120.0)])
def test_a_box_dropped_flat_comes_to_rest_level_at_the_soft_contacts_steady_sink(params: dict[str, object],
                                                                                 hertz: float) -> None:
    """Level and still, at the sink of its springs: at rest each of the two bottom corners carries half the weight through a spring of ``k w^2``, with
    ``k = 1 / (1/m + (r x n)^2 / I)`` the corner's effective mass and ``w = 2 pi 2 hertz`` (the ground is
    static): the box sits ``(m g / 2) / (k w^2)`` deep. The hertz is at most an eighth of the substep rate
    (null: that cap): 60 Hz at 8 substeps, 120 Hz at 16."""
    state = boxes([0.0], [0.75], [0.0], [(0.5, 0.5)], [1.0], [0.6])  # 25 cm above the ground
    with compiled(True):
        _soft(**params).advance(state, 120)
    mass, inertia = 1.0, 1.0 / 6.0
    k = 1.0 / (1.0 / mass + 0.5 ** 2 / inertia)
    omega = 2.0 * math.pi * 2.0 * hertz
    sink = (mass * G / 2.0) / (k * omega ** 2)
    assert state.y[0, 0] == pytest.approx(0.5 - sink, abs=1e-9)
    assert abs(state.angle[0, 0]) < 1e-9 and abs(state.w[0, 0]) < 1e-9
    assert abs(state.vx[0, 0]) < 1e-9 and abs(state.vy[0, 0]) < 1e-9
    assert abs(state.x[0, 0]) < 1e-4  # the corners are solved one after the other: the landing's first
    # visit tips the box by a hair, and friction holds the corner it turns about, so it lands 2-18 um aside


@pytest.mark.parametrize("degrees", [20.0, 26.0, 27.0, 35.0])
def test_a_box_on_a_ramp_sticks_below_atan_mu_and_slides_above_at_the_coulomb_rate(degrees: float) -> None:
    """atan(0.5) = 26.57 degrees. Sliding, both corners hold ``mu`` times their normal impulse exactly, so
    the box gains ``g (sin a - mu cos a) dt`` a step once the soft contact has settled; what is left of its
    settling after 30 steps is ``exp(-30 dt * bias_rate)`` of the landing's sink (bias_rate = w / (2 zeta + h
    w) = 17.5 /s for 60 Hz, zeta 10): below 2e-8 m, i.e. below 1e-6 m/s^2 in the rate over the next 60 steps.
    Sticking, nothing moves beyond that settling."""
    mu = 0.5
    a = math.radians(degrees)
    state = ramp(a, mu)
    c, s = math.cos(a), math.sin(a)
    solver = _soft()
    with compiled(True):
        solver.advance(state, 30)
        x1, y1, v1 = state.x[0, 1], state.y[0, 1], state.vx[0, 1] * c + state.vy[0, 1] * s
        solver.advance(state, 60)
    v2 = state.vx[0, 1] * c + state.vy[0, 1] * s  # up the slope
    rate = G * (s - mu * c)
    if rate < 0.0:
        assert math.hypot(state.x[0, 1] - x1, state.y[0, 1] - y1) < 1e-6
        assert abs(v2) < 1e-9
    else:
        assert -(v2 - v1) / (60 * DT) == pytest.approx(rate, abs=1e-6)
    assert state.x[0, 0] == 0.0 and state.y[0, 0] == 3.0  # the ramp is static


def test_a_short_stack_with_offsets_holds() -> None:
    """Five unit boxes, each shifted sideways by up to 5 cm: every pile above a contact has its centre of
    mass over the overlap, so it stands. Soft contacts sink further under the more loaded corner, so the
    pile leans a little (0.3 mrad, the top moving 1.4 mm) and stays so: after 5 s no box has moved sideways
    by 3 mm or turned by 1 mrad, and all are at rest."""
    rng = np.random.default_rng(1)
    n = 5
    state = boxes(list(rng.uniform(-0.05, 0.05, n)), [0.5 + i for i in range(n)], [0.0] * n, [(0.5, 0.5)] * n,
                  [1.0] * n, [0.6] * n)
    start = state.copy()
    with compiled(True):
        _soft().advance(state, 300)
    assert np.abs(state.x - start.x).max() < 3e-3
    assert np.abs(state.angle).max() < 1e-3
    assert np.abs(np.concatenate([state.vx, state.vy, state.w])).max() < 1e-6
    assert state.launch[0] < 0.05


def test_stiff_soft_contacts_hold_the_heavy_slab_off_centre() -> None:
    """configs/planar/heavy-slab.yaml: 100 kg 0.3 m off centre on a 1 kg box. A soft contact sinks by its load
    over its effective mass over (2 pi hertz)^2, so at 30 Hz the light box's corners sink 5 cm under the slab;
    as stiff as 8 substeps allow (60 Hz), 16 passes a step, it stands by every criterion of the bench."""
    from stackx.config.experiment import load
    from stackx.bench.criteria import Criteria, judge
    from stackx.models.planar import measures
    from stackx.run.runner import run_experiment
    from tests.conftest import CONFIGS

    spec = load(str(CONFIGS / "planar" / "heavy-slab.yaml"), ["outputs=[]"])
    result = run_experiment(spec).runs[0]
    m = {**result.measures, **measures.bench_measures(result)}
    assert all(v.passed for v in judge(m, Criteria()).values()), judge(m, Criteria())
    assert m["drift_x"] < 0.02 and m["max_depth"] < 0.015
    default = run_experiment(load(str(CONFIGS / "planar" / "heavy-slab.yaml"),
                                  ["outputs=[]", "solver={name: planar-soft-step}"])).runs[0].measures
    assert default["max_depth"] > 0.04  # at its defaults the light box's corners sink under the slab


def test_rows_stepped_together_give_each_rows_numbers_alone() -> None:
    """Rows that share their substeps run their passes as one layout (``step_rows``): seven different
    tumbling piles, a row with other substeps between them (a group boundary), and four piles at rest
    (a group whose pairs all stay from step to step, so its layout keeps what depends on the pairs alone),
    stepped on one thread in calls of 1 and 5 steps with the applied impulses watched: every row's state,
    memory and impulses, byte for byte, as the row stepped alone."""
    from stackx.kernel import threads
    from stackx.models.planar.state import PlanarState

    def pile(seed: int) -> PlanarState:
        if seed >= 8:  # at rest
            return pyramid(5, mu=0.3 + 0.05 * seed, jitter=0.01 * (seed - 8), seed=seed)
        state = pyramid(5, mu=0.3 + 0.05 * seed, jitter=0.2, seed=seed)
        state.vx[0] = np.linspace(-0.8, 0.8, state.bodies) * (1 + seed % 3)
        state.w[0, seed % state.bodies] = 2.0 - seed
        state.y[0] += 0.015 * np.arange(state.bodies) * (seed % 2)  # some apart: landings, speculative points
        return state

    def step(seeds: list[int], substeps: list[int]) -> tuple[PlanarState, PlanarSoftStep, list[object]]:
        state = PlanarState.concat([pile(seed) for seed in seeds])
        solver = PlanarSoftStep([PlanarSoftStepParams(substeps=s) for s in substeps], np.full(len(seeds), -G),
                                np.full(len(seeds), DT))
        solver.watch_impulses()
        with compiled(True), threads(1):
            solver.advance(state, 1)
            solver.advance(state, 5)
        return state, solver, [solver.step_impulses(b) for b in range(len(seeds))]

    seeds, substeps = list(range(12)), [4, 4, 4, 3] + [4] * 8
    with threads(1):
        groups = PlanarSoftStep([PlanarSoftStepParams(substeps=s) for s in substeps], np.full(12, -G),
                                np.full(12, DT)).row_groups(np.zeros((12, 15)))
    assert groups.tolist() == [0, 3, 4, 8, 12]  # rows of the same substeps together, at most four
    resting = PlanarState.concat([pile(seed) for seed in seeds[8:]])
    solver = PlanarSoftStep([PlanarSoftStepParams()] * 4, np.full(4, -G), np.full(4, DT))
    kept, pairs = [], None
    with compiled(True):
        for _ in range(6):
            solver.advance(resting, 1)
            keys, _, count = solver.memory(resting)
            now = [keys[b, :count[b], :2].copy() for b in range(4)]
            if pairs is not None:
                kept.append(all(a.shape == p.shape and (a == p).all() for a, p in zip(now, pairs)))
            pairs = now
    assert any(kept)  # steps on which every resting row keeps its pairs
    together, solver, impulses = step(seeds, substeps)
    for b, seed in enumerate(seeds):
        alone, single, alone_impulses = step([seed], [substeps[b]])
        for name in PlanarState.FIELDS:
            assert getattr(together, name)[b].tobytes() == getattr(alone, name)[0].tobytes(), (b, name)
        assert held_memory(solver, together)[b] == held_memory(single, alone)[0], b
        got, want = impulses[b], alone_impulses[0]
        assert got is not None and want is not None
        assert got.keys.tobytes() == want.keys.tobytes() and got.pn.tobytes() == want.pn.tobytes(), b
        assert got.pt.tobytes() == want.pt.tobytes(), b
    assert np.abs(together.w).max() > 0.1  # the piles still tumble: the comparison has something to see


def test_the_workspace_kept_from_call_to_call_gives_the_numbers_of_a_fresh_one() -> None:
    """The solver keeps its threads' contact tables and blocks and its rows' wave orders from one call to the
    next (``soft_step.Workspace``, ``soft_step.WaveOrders``): on rows of different substeps (groups of
    several sizes), a call on boxes apart on the ground (few blocks), calls of 4 and 2 steps on piles of as
    many boxes (the blocks grow; the orders found by the first call serve the second's resting rows), one
    after a box is taken away (less room: made again) give the bytes of the same calls each in a workspace
    and orders made afresh."""
    from stackx.kernel import threads
    from stackx.models.planar.state import PlanarState

    def without(state: PlanarState, box: int) -> PlanarState:
        return PlanarState(*(np.delete(getattr(state, name), box, axis=1) for name in PlanarState.BODY))

    def calls(fresh: bool) -> list[PlanarState]:
        solver = PlanarSoftStep([PlanarSoftStepParams(substeps=s) for s in (4, 4, 3, 4, 4)], np.full(5, -G),
                                np.full(5, DT))
        piles = PlanarState.concat([pyramid(4, mu=0.4, jitter=0.1, seed=seed) for seed in range(5)])
        piles.vx[:] = np.linspace(-0.5, 0.5, piles.bodies)
        apart = piles.copy()
        apart.x[:], apart.y[:], apart.angle[:] = 2.0 * np.arange(piles.bodies), 0.5, 0.0
        done = []
        with compiled(True), threads(1):
            for state, steps in ((apart, 1), (piles, 4), (piles, 2)):
                if fresh:
                    solver.work, solver.orders = None, None
                solver.advance(state, steps)
                done.append(state.copy())
            solver.remove_box(piles, 3)
            fewer = without(piles, 3)
            if fresh:
                solver.work, solver.orders = None, None
            solver.advance(fewer, 3)
            done.append(fewer)
        return done

    for kept, fresh in zip(calls(False), calls(True)):
        for name in PlanarState.FIELDS:
            assert getattr(kept, name).tobytes() == getattr(fresh, name).tobytes(), name
