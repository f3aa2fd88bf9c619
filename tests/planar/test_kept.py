"""The contacts the soft step keeps from one call to the next (``stackx.solvers.planar.kept``): taken back only
where they are what a fresh collision test would find, so stepping in calls of any length, and changing the
state between calls, gives the numbers of finding them afresh, byte for byte."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from stackx.kernel import compiled
from stackx.models.planar.state import PlanarState
from stackx.solvers.planar.kept import Kept
from stackx.solvers.planar.soft_step import PlanarSoftStep, PlanarSoftStepParams
from tests.planar.hand_states import pyramid
from tests.planar.worlds import held_memory

DT = 1 / 60
G = -9.8
FIELDS = ("x", "y", "angle", "vx", "vy", "w")


def _pile() -> PlanarState:
    state = pyramid(4, mu=0.5, jitter=0.1, seed=4)
    state.vx[0] = np.linspace(-0.3, 0.3, state.bodies)
    return state


def _solver() -> PlanarSoftStep:
    return PlanarSoftStep([PlanarSoftStepParams()], np.array([G]), np.array([DT]))


def _lift(state: PlanarState) -> None:
    state.y[0, -1] += 0.3  # the top box off its neighbours: its contacts are gone


def _pin(state: PlanarState) -> None:
    for i in (0, 4):  # a bottom box and one resting on it made static: static boxes do not touch each other
        state.inv_mass[0, i], state.inv_inertia[0, i] = 0.0, 0.0
        state.vx[0, i], state.vy[0, i], state.w[0, i] = 0.0, 0.0, 0.0


def _shrink(state: PlanarState) -> None:
    state.hx[0, 3] *= 0.8  # a box narrower: its bounds change, not its centre


def _nothing(state: PlanarState) -> None:
    pass


def test_calls_of_one_step_give_the_numbers_of_one_call() -> None:
    one, many = _pile(), _pile()
    with compiled(True):
        _solver().advance(one, 12)
        solver = _solver()
        for _ in range(12):
            solver.advance(many, 1)
    assert solver.kept is not None and solver.kept.count[0] > 0  # the calls did hand their contacts on
    for name in FIELDS:
        assert getattr(one, name).tobytes() == getattr(many, name).tobytes(), name


@pytest.mark.parametrize("change", [_lift, _pin, _shrink, _nothing])
def test_a_state_changed_between_calls_steps_as_if_its_contacts_were_found_afresh(
        change: Callable[[PlanarState], None]) -> None:
    """The same two calls with a change of the state between them, once with the kept contacts and
    candidates forgotten before the second call: the same bytes."""
    out = []
    for forget in (False, True):
        state, solver = _pile(), _solver()
        with compiled(True):
            solver.advance(state, 6)
            change(state)
            if forget:
                assert solver.kept is not None
                solver.kept.forget()
            solver.advance(state, 6)
        out.append((state, held_memory(solver, state)))
    (kept, kept_memory), (fresh, fresh_memory) = out
    for name in FIELDS:
        assert getattr(kept, name).tobytes() == getattr(fresh, name).tobytes(), name
    assert kept_memory == fresh_memory  # the same points found, with the same impulses
    assert not np.array_equal(kept.x, _pile().x)  # the pile moved: the steps did something


def test_a_batch_stepped_on_threads_equals_its_rows_stepped_alone() -> None:
    """32 different piles in one batch (large enough for the parallel build to split it over threads when
    there are several), stepped in calls of 1 and 5 steps: each row, byte for byte, as stepped alone."""
    from stackx import kernel

    def pile(seed: int) -> PlanarState:
        state = pyramid(6, mu=0.4 + 0.01 * seed, jitter=0.1, seed=seed)
        state.vx[0] = np.linspace(-0.2, 0.2, state.bodies) * (seed % 3)
        return state

    def step(seeds: list[int]) -> PlanarState:
        state = PlanarState.concat([pile(seed) for seed in seeds])
        solver = PlanarSoftStep([PlanarSoftStepParams(substeps=2 + seed % 3) for seed in seeds],
                                np.full(len(seeds), G), np.full(len(seeds), DT))
        with compiled(True):
            solver.advance(state, 1)
            solver.advance(state, 5)
        return state

    seeds = list(range(32))
    assert len(seeds) * pile(0).bodies >= 2 * kernel.GRAIN
    together = step(seeds)
    for b in range(0, len(seeds), 5):
        alone = step([b])
        for name in FIELDS:
            assert getattr(together, name)[b].tobytes() == getattr(alone, name)[0].tobytes(), (b, name)


def test_a_fresh_solver_reads_nothing_of_its_rooms_but_what_it_wrote() -> None:
    """The memory and the kept contacts are made empty, not cleared: a solver whose rooms hold anything
    at all (points that look like the pile's, boxes where the pile's are, impulses not a number) steps, and
    hands on, the numbers of one whose rooms are zeros."""
    out = []
    for poisoned in (False, True):
        state, solver = _pile(), _solver()
        solver.watch_impulses()
        if poisoned:
            keys, carried, _ = solver.memory(state)
            keys[:] = np.arange(keys.size).reshape(keys.shape) % state.bodies
            carried[:] = np.nan
            kept = Kept(state.batch, state.bodies, keys.shape[1])
            kept.ids[:] = keys
            kept.points[:] = np.nan
            kept.at[0] = np.stack([state.x[0], state.y[0], state.angle[0], state.hx[0], state.hy[0],
                                   (state.inv_mass[0] == 0.0) * 1.0], axis=1)  # where the boxes are
            kept.near[:, 1:] = 1
            kept.fat[:] = [-np.inf, np.inf, -np.inf, np.inf]  # bounds no box leaves
            solver.kept = kept
        with compiled(True):
            solver.advance(state, 3)
            solver.advance(state, 3)
        impulses = solver.step_impulses(0)
        assert impulses is not None
        out.append((state, impulses))
    (clean, clean_impulses), (dirty, dirty_impulses) = out
    for name in FIELDS:
        assert getattr(clean, name).tobytes() == getattr(dirty, name).tobytes(), name
    assert clean_impulses.keys.tobytes() == dirty_impulses.keys.tobytes()
    assert clean_impulses.pn.tobytes() == dirty_impulses.pn.tobytes()


def test_a_row_whose_points_outgrow_its_table_hands_them_on_as_one_call_steps() -> None:
    """Twelve boxes dropped into one another find more points than a row's table has room for (the
    call steps in a larger one, and hands its points on by copying them back once they fit again):
    calls of one step give the numbers of one call, and the kept table then holds the points a fresh
    collision test finds where the boxes are."""
    from stackx.models.planar.monitor import contact_room
    from stackx.solvers.planar.contacts import contact_workspace, find_contacts
    from tests.planar.hand_states import boxes

    def heap() -> PlanarState:
        rng = np.random.default_rng(7)
        n = 12
        return boxes(list(rng.uniform(-0.1, 0.1, n)), list(0.5 + rng.uniform(0.0, 0.3, n)),
                     list(rng.uniform(-0.2, 0.2, n)), [(0.5, 0.5)] * n, [1.0] * n, [0.5] * n)

    start = heap()
    ids, table = contact_workspace(1)
    found = find_contacts(start.x[0], start.y[0], start.angle[0], start.hx[0], start.hy[0], start.inv_mass[0],
                          PlanarSoftStepParams().speculative, ids, table)[2]
    assert found > contact_room(start.bodies)  # the heap does outgrow the room
    one, many = heap(), heap()
    solver = _solver()
    with compiled(True):
        _solver().advance(one, 30)
        for _ in range(30):
            solver.advance(many, 1)
    for name in FIELDS:
        assert getattr(one, name).tobytes() == getattr(many, name).tobytes(), name
    kept = solver.kept
    assert kept is not None and kept.count[0] >= 0
    ids, table = contact_workspace(1)
    ids, table, count = find_contacts(many.x[0], many.y[0], many.angle[0], many.hx[0], many.hy[0],
                                      many.inv_mass[0], PlanarSoftStepParams().speculative, ids, table)
    assert kept.count[0] == count
    assert kept.ids[0, :count].tobytes() == ids[:count].tobytes()
    assert kept.points[0, :count].tobytes() == np.ascontiguousarray(table[:count, :kept.points.shape[2]]).tobytes()
