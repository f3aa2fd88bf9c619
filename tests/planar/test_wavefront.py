"""The soft step's visiting order (waves of manifolds that share no body) against what it must keep: each
body's order of visits, and so every number of a pass over the manifolds in table order. The table-order
soft step is transcribed here from the contact stages it is made of (``contacts``, ``substep``), in plain
Python, and the solver must match it to the bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stackx.kernel import compiled
from stackx.solvers.column.soft_step import STATIC_HERTZ, soft
from stackx.solvers.planar.contacts import (A, B, KN, KT, MU, NX, NY, PN, PT, contact_workspace, find_contacts,
                                            gravity, integrate_positions, manifold_impulse, manifold_velocity,
                                            prepare, recall, remember, warm_start)
from stackx.solvers.planar.soft_step import SUBSTEP_HERTZ, PlanarSoftStep, PlanarSoftStepParams
from stackx.solvers.planar.substep import base_separations, moved, separation, step_start
from stackx.solvers.planar.wavefront import manifold_end, manifold_starts, wavefronts
from stackx.solvers.planar.wide import BLOCK, LANES, line_aligned
from stackx.models.planar.state import PlanarState
from tests.planar.hand_states import boxes, pyramid

DT = 1 / 60
G = -9.8


def _random_contacts(rng: np.random.Generator, bodies: int, manifolds: int) -> np.ndarray:
    """``ids`` of ``manifolds`` distinct manifolds (1 or 2 points each) sorted by ``(A, B)`` as ``collide``
    lists them, the ground (-1) among the ``A``s."""
    pairs = set()
    while len(pairs) < manifolds:
        a = int(rng.integers(-1, bodies - 1))
        b = int(rng.integers(max(a + 1, 0), bodies))
        pairs.add((a, b))
    rows = [(a, b, f) for a, b in sorted(pairs) for f in range(int(rng.integers(1, 3)))]
    return np.array(rows, np.int64)


@pytest.mark.parametrize("seed", range(6))
def test_waves_share_no_body_and_keep_every_bodys_order(seed: int) -> None:
    rng = np.random.default_rng(seed)
    ids = _random_contacts(rng, 12, 30)
    count = ids.shape[0]
    first, order = np.empty(count + 1, np.int64), np.empty(count, np.int64)
    latest, wave, tally = np.empty(12, np.int64), np.empty(count, np.int64), np.empty(count + 1, np.int64)
    with compiled(False):
        m = manifold_starts(ids, count, first)
        waves = wavefronts(ids, first, m, latest, wave, tally, order)
    starts = [k for k in range(count) if k == 0 or tuple(ids[k, :2]) != tuple(ids[k - 1, :2])]
    assert list(first[:m]) == starts and first[m] == count
    assert sorted(order[:m]) == list(range(m))
    begin = 0
    for v in range(waves):
        wave_bodies = [int(x) for j in order[begin:tally[v]] for x in ids[first[j], :2] if x >= 0]
        assert len(wave_bodies) == len(set(wave_bodies)), "two manifolds of one wave share a body"
        assert list(order[begin:tally[v]]) == sorted(order[begin:tally[v]]), "table order within a wave"
        begin = tally[v]
    assert begin == m
    for body in range(12):  # a body's manifolds come in table order
        seen = [j for j in order[:m] if body in ids[first[j], :2]]
        assert seen == sorted(seen)
    # each manifold's wave is as early as its bodies allow: one after the latest earlier manifold it shares
    # a body with (so on a chain of manifolds the waves count the links)
    place = {int(j): v for v in range(waves) for j in order[(tally[v - 1] if v else 0):tally[v]]}
    for j in range(m):
        mine = {x for x in ids[first[j], :2] if x >= 0}
        before = [place[i] for i in range(j) if mine & {x for x in ids[first[i], :2] if x >= 0}]
        assert place[j] == (max(before) + 1 if before else 0)


def _table_order_pass(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray,
                      inv_inertia: np.ndarray, ids: np.ndarray, table: np.ndarray, count: int, base: np.ndarray,
                      since: np.ndarray, h: float, use_bias: bool, push_out: float, softness: np.ndarray) -> None:
    """The soft pass over the manifolds in table order, each one's points normal first, then friction."""
    start = 0
    while start < count:
        end = manifold_end(ids, start, count)
        a, b = ids[start, A], ids[start, B]
        grounded = a < 0
        vax, vay, wa, ima, iia = 0.0, 0.0, 0.0, 0.0, 0.0
        if not grounded:
            vax, vay, wa, ima, iia = vx[a], vy[a], w[a], inv_mass[a], inv_inertia[a]
        vbx, vby, wb, imb, iib = vx[b], vy[b], w[b], inv_mass[b], inv_inertia[b]
        row = 1 if grounded or ima == 0.0 or imb == 0.0 else 0
        for k in range(start, end):
            s = separation(ids, table, base, since, k)
            target, mass_scale, impulse_scale = 0.0, 1.0, 0.0
            if s > 0.0:
                target = -s / h
            elif use_bias:
                target = min(-softness[row, 0] * s, push_out)
                mass_scale, impulse_scale = softness[row, 1], softness[row, 2]
            nx, ny = table[k, NX], table[k, NY]
            un = manifold_velocity(vax, vay, wa, vbx, vby, wb, grounded, table, k, nx, ny)
            old = table[k, PN]
            total = max(old + table[k, KN] * mass_scale * (target - un) - impulse_scale * old, 0.0)
            vax, vay, wa, vbx, vby, wb = manifold_impulse(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb, iib,
                                                          table, k, (total - old) * nx, (total - old) * ny)
            table[k, PN] = total
        for k in range(start, end):
            nx, ny = table[k, NX], table[k, NY]
            limit = table[k, MU] * table[k, PN]
            old = table[k, PT]
            total = old - table[k, KT] * manifold_velocity(vax, vay, wa, vbx, vby, wb, grounded, table, k, -ny, nx)
            total = min(max(total, -limit), limit)
            vax, vay, wa, vbx, vby, wb = manifold_impulse(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb, iib,
                                                          table, k, -(total - old) * ny, (total - old) * nx)
            table[k, PT] = total
        if not grounded:
            vx[a], vy[a], w[a] = vax, vay, wa
        vx[b], vy[b], w[b] = vbx, vby, wb
        start = end


def _table_order_steps(state: PlanarState, params: PlanarSoftStepParams, steps: int) -> None:
    """Box2D v3's soft step as the module doc states it, every pass in table order (row 0 of ``state``)."""
    x, y, angle, vx, vy, w = state.x[0], state.y[0], state.angle[0], state.vx[0], state.vy[0], state.w[0]
    im, ii, mu = state.inv_mass[0], state.inv_inertia[0], state.friction[0]
    n = x.shape[0]
    h = DT / params.substeps
    hertz = min(params.contact_hertz if params.contact_hertz is not None else math.inf, SUBSTEP_HERTZ / h)
    softness = np.array([soft(hertz, params.damping_ratio, h), soft(STATIC_HERTZ * hertz, params.damping_ratio, h)])
    room = 8 * n + 8
    keys, carried, held = np.zeros((room, 3), np.int64), np.zeros((room, 2)), 0
    ids, table = contact_workspace(room)
    start, since, base = np.empty((n, 3)), np.empty((n, 4)), np.empty(room)
    for _ in range(steps):
        ids, table, count = find_contacts(x, y, angle, state.hx[0], state.hy[0], im, params.speculative, ids, table)
        prepare(x, y, im, ii, mu, ids, table, count)
        base_separations(ids, table, count, base)
        if params.warm_start:
            recall(ids, table, count, keys, carried, held)
        step_start(x, y, angle, start, since)
        for _ in range(params.substeps):
            gravity(vy, im, G, h)
            warm_start(vx, vy, w, im, ii, ids, table, count)
            _table_order_pass(vx, vy, w, im, ii, ids, table, count, base, since, h, True, params.push_out, softness)
            integrate_positions(x, y, angle, vx, vy, w, h)
            moved(x, y, angle, start, since)
            if params.relax:
                _table_order_pass(vx, vy, w, im, ii, ids, table, count, base, since, h, False, params.push_out,
                                  softness)
        held = remember(ids, table, count, keys, carried)


def _tumbling_pile() -> PlanarState:
    """Boxes landing and sliding on each other and on a static slab: one- and two-point manifolds, points
    coming and going, the ground and a static box as sides."""
    state = pyramid(4, mu=0.5, jitter=0.2, seed=3)
    state.vx[0] = np.linspace(-1.0, 1.0, state.bodies)
    state.w[0, -1] = 3.0
    state.y[0] += 0.02 * np.arange(state.bodies)
    slab = boxes([6.0], [0.25], [0.1], [(2.0, 0.25)], [0.0], [0.5])
    box = boxes([6.2], [1.1], [0.3], [(0.4, 0.3)], [1.0], [0.5])
    return PlanarState(*(np.concatenate([getattr(s, f) for s in (state, slab, box)], axis=1)
                         for f in PlanarState.BODY))


@pytest.mark.parametrize("params", [{"substeps": 4}, {"substeps": 2, "relax": False, "warm_start": False},
                                    {"substeps": 3, "contact_hertz": None}])
def test_the_soft_step_gives_the_numbers_of_visiting_manifolds_in_table_order(params: dict[str, object]) -> None:
    """Waves reorder manifolds that share no body, which commute exactly: every position, velocity and angle
    after 12 steps is the table-order transcription's, to the bit (compiled as the runner steps)."""
    p = PlanarSoftStepParams(**params)
    expected = _tumbling_pile()
    with compiled(False):
        _table_order_steps(expected, p, 12)
    state = _tumbling_pile()
    solver = PlanarSoftStep([p], np.array([G]), np.array([DT]))
    with compiled(True):
        solver.advance(state, 5)
        solver.advance(state, 7)
    for name in ("x", "y", "angle", "vx", "vy", "w"):
        assert np.array_equal(getattr(state, name), getattr(expected, name)), name
    assert np.abs(expected.vx).max() > 0.1  # the pile is moving: the test compares something that happens


def _wide_pile() -> PlanarState:
    """Waves wider than a block: a static slab (body 0, so side ``A`` of the box on it is a static box), a
    jittered pyramid of 5 rows and ten boxes landing apart on the ground, every other one turned so it
    lands on a corner (one-point manifolds), all moving."""
    slab = boxes([-6.0], [0.25], [0.0], [(1.5, 0.25)], [0.0], [0.5])
    on_slab = boxes([-6.1], [1.0], [0.0], [(0.5, 0.5)], [1.0], [0.5])
    pile = pyramid(5, mu=0.6, jitter=0.15, seed=2)
    xs = [4.0 + 1.4 * i for i in range(10)]
    apart = boxes(xs, [0.52 + 0.03 * (i % 3) for i in range(10)], [0.35 if i % 2 else 0.0 for i in range(10)],
                  [(0.5, 0.4)] * 10, [1.0] * 10, [0.4 + 0.05 * i for i in range(10)])
    state = PlanarState(*(np.concatenate([getattr(s, f) for s in (slab, on_slab, pile, apart)], axis=1)
                          for f in PlanarState.BODY))
    rng = np.random.default_rng(7)
    moving = state.inv_mass[0] > 0
    state.vx[0, moving] = rng.uniform(-0.6, 0.6, moving.sum())
    state.w[0, moving] = rng.uniform(-1.0, 1.0, moving.sum())
    return state


@pytest.mark.parametrize("params", [{"substeps": 4}, {"substeps": 3, "relax": False, "warm_start": False}])
def test_the_pass_in_blocks_of_lanes_gives_the_table_order_numbers_to_the_bit(params: dict[str, object]) -> None:
    """The soft step solves a wave's manifolds ``wide.LANES`` at a time; on waves that fill several blocks
    and leave lanes empty, with one- and two-point manifolds and the ground and a static box as side ``A``,
    every number after 15 steps is the plain table-order transcription's, byte for byte (signs of zeros
    too)."""
    state = _wide_pile()
    ids, table = contact_workspace(8 * state.bodies + 8)
    with compiled(False):
        ids, table, count = find_contacts(state.x[0], state.y[0], state.angle[0], state.hx[0], state.hy[0],
                                          state.inv_mass[0], 0.02, ids, table)
        first, order = np.empty(count + 1, np.int64), np.empty(count, np.int64)
        m = manifold_starts(ids, count, first)
        tally = np.empty(count + 1, np.int64)
        waves = wavefronts(ids, first, m, np.empty(state.bodies, np.int64), np.empty(count, np.int64), tally, order)
    sizes = np.diff(np.concatenate([[0], tally[:waves]]))
    assert sizes.max() > 2 * LANES and any(s % LANES for s in sizes)  # full blocks, and lanes left empty
    points = np.diff(first[:m + 1])
    assert set(points) == {1, 2}
    sides = ids[first[:m], A]
    assert (sides < 0).any() and any(a >= 0 and state.inv_mass[0, a] == 0.0 for a in sides)
    p = PlanarSoftStepParams(**params)
    expected = _wide_pile()
    with compiled(False):
        _table_order_steps(expected, p, 15)
    solver = PlanarSoftStep([p], np.array([G]), np.array([DT]))
    with compiled(True):
        solver.advance(state, 15)
    for name in ("x", "y", "angle", "vx", "vy", "w"):
        assert getattr(state, name).tobytes() == getattr(expected, name).tobytes(), name
    assert np.abs(expected.w).max() > 0.1  # the boxes still turn and slide: the comparison has something to see


def _landing_on_a_pile() -> PlanarState:
    """A pyramid of 4 rows at rest (its pairs stay, its corners on the ground swap places in the list) and a
    box falling onto it, which lands after some steps (new pairs) and settles."""
    pile = pyramid(4, mu=0.6)
    box = boxes([0.3], [5.2], [0.2], [(0.5, 0.4)], [1.0], [0.6])
    return PlanarState(*(np.concatenate([getattr(s, f) for s in (pile, box)], axis=1) for f in PlanarState.BODY))


def test_a_wave_order_kept_while_the_pairs_stay_gives_the_table_order_numbers_to_the_bit() -> None:
    """The soft step keeps a step's wave order for the next while its points are between the same bodies in
    the same order (``contacts.same_pairs``), and finds it again when they are not: over 40 steps in one call
    of a pile at rest with a box landing on it, steps of both kinds happen (seen from the solver's memory in
    calls of one step), and every number is the table-order transcription's, byte for byte."""
    p = PlanarSoftStepParams(substeps=4)
    single = _landing_on_a_pile()
    solver = PlanarSoftStep([p], np.array([G]), np.array([DT]))
    kept, pairs = [], None
    with compiled(True):
        for _ in range(40):
            solver.advance(single, 1)
            keys, _, held = solver.memory(single)
            now = keys[0, :held[0], :2].copy()
            if pairs is not None:
                kept.append(now.shape == pairs.shape and bool((now == pairs).all()))
            pairs = now
    assert any(kept) and not all(kept)
    expected = _landing_on_a_pile()
    with compiled(False):
        _table_order_steps(expected, p, 40)
    state = _landing_on_a_pile()
    with compiled(True):
        PlanarSoftStep([p], np.array([G]), np.array([DT])).advance(state, 40)
    for name in ("x", "y", "angle", "vx", "vy", "w"):
        assert getattr(state, name).tobytes() == getattr(expected, name).tobytes(), name
    assert getattr(single, "y").tobytes() == getattr(expected, "y").tobytes()


@pytest.mark.parametrize("on", [False, True])
def test_same_pairs_tells_points_between_the_same_bodies_in_the_same_order(on: bool) -> None:
    """``same_pairs`` against the memory's keys: the same list, or one whose features differ (a box's corners
    swapped), is the same pairs; another ``B`` or ``A`` at one point, one point more or fewer, or the points
    in another order, is not."""
    from stackx.solvers.planar.contacts import same_pairs

    rng = np.random.default_rng(3)
    keys = _random_contacts(rng, 12, 20)
    held = keys.shape[0]
    ids = np.concatenate([keys, np.zeros((4, 3), np.int64)])  # the table has room beyond its points
    changed = []
    for k, column, value in ((5, B, 99), (9, A, 7), (0, A, 3)):
        other = ids.copy()
        other[k, column] = value
        changed.append((other, held))
    j = int(np.flatnonzero((keys[:, :2] != keys[0, :2]).any(axis=1))[0])  # the first point of another pair
    swapped = ids.copy()
    swapped[[0, j]] = keys[[j, 0]]
    features = ids.copy()
    features[:held, 2] += 1
    with compiled(on):
        assert same_pairs(ids, held, keys, held)
        assert same_pairs(features, held, keys, held)
        for other, count in changed:
            assert not same_pairs(other, count, keys, held)
        assert not same_pairs(ids, held - 1, keys, held)
        assert not same_pairs(ids, held, keys, held - 1)
        assert not same_pairs(swapped, held, keys, held)


@pytest.mark.parametrize("on", [False, True])
def test_records_and_body_rows_begin_a_cache_line(on: bool) -> None:
    """A pass loads a field of a block's lanes as one vector and a body as one row of 64 bytes: the memory the
    soft step keeps for them (``wide.line_aligned``) begins a cache line however numpy or numba placed it,
    plain or compiled (a call grows its blocks with the compiled one), made with the solver's workspace or grown
    after a call, and holds as many numbers as asked."""
    for size in (1, 7, 8, 9, 1000):
        with compiled(on):
            room = line_aligned(size)
        assert room.ctypes.data % 64 == 0 and room.shape == (size,) and room.flags.c_contiguous
    state = pyramid(6, mu=0.6)
    solver = PlanarSoftStep([PlanarSoftStepParams(substeps=4)], np.array([G]), np.array([DT]))
    with compiled(on):
        for _ in range(2):  # the first call's blocks outgrow the workspace's, which grows after it
            solver.advance(state, 1)
            assert solver.work is not None
            assert solver.work.record.ctypes.data % 64 == 0 and solver.work.body_rows.ctypes.data % 64 == 0
    assert solver.work.record.shape[1] > BLOCK  # grown past the room it was made with
