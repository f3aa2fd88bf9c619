"""The passes on the laid-out contacts (``passes``: accumulated and the lab's) against the table's passes in
table order, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from stackx import kernel
from stackx.models.planar.state import PlanarState
from stackx.solvers.planar import passes as laid
from stackx.solvers.planar.contacts import (A, B, DEPTH, PN, PT, accumulated_iteration, contact_workspace,
                                            find_contacts, prepare, remember, set_targets, solve_velocities,
                                            warm_start)
from stackx.solvers.planar.wavefront import manifold_end, manifold_starts, wavefronts
from tests.planar.lab_table import lab_table_pass
from tests.planar.worlds import DT, G, laid_step, run, world

MARGIN = 0.02


def _pile() -> PlanarState:
    """A pyramid whose rows' neighbours stand 1 cm apart (points still apart within the 2 cm margin, as a brick
    wall's side joints), a static box in its bottom row, moving after some steps and pushed about, so every
    kind of visit acts: touching and apart, on the ground and between boxes, one and two points."""
    from stackx.scenes.planar import Planar, PlanarParams, Pyramid

    s = Planar(PlanarParams(pyramid=Pyramid(rows=6, gap=0.01, friction=0.5))).build()
    s.inv_mass[0, 3], s.inv_inertia[0, 3] = 0.0, 0.0
    run("planar-warm-start", s, 4, {"iterations": 3})
    s.vx[0] += np.linspace(-0.3, 0.3, s.bodies)
    s.w[0] += np.linspace(0.2, -0.2, s.bodies)
    # and two boxes in the air 1 cm apart, still: their only manifold is apart and its pushes are of zero,
    # which turn the sign of a zero velocity; the laid-out pass must turn it as the table's does
    pair = world([{"x": 0.0, "y": 20.0, "vx": -0.0, "vy": -0.0, "w": -0.0},
                  {"x": 1.01, "y": 20.0, "vx": 0.0, "vy": -0.0, "w": 0.0}])
    return PlanarState(*(np.concatenate([getattr(s, f), getattr(pair, f)], axis=1) for f in PlanarState.BODY))


def _contacts(s: PlanarState) -> tuple[np.ndarray, np.ndarray, int]:
    ids, table = contact_workspace(4)
    return find_contacts(s.x[0], s.y[0], s.angle[0], s.hx[0], s.hy[0], s.inv_mass[0], MARGIN, ids, table)


def _starts(ids: np.ndarray, count: int) -> list[int]:
    starts = [0]
    while manifold_end(ids, starts[-1], count) < count:
        starts.append(manifold_end(ids, starts[-1], count))
    return starts


def _laid_passes(s: PlanarState, ids: np.ndarray, table: np.ndarray, count: int, passes: int, block: bool,
                 relaxation: float, order_of_waves: slice = slice(None)) -> tuple[np.ndarray, np.ndarray]:
    """``passes`` laid-out passes from the table's impulses: the bodies' rows and each point's ``(pn, pt)`` in
    table order. ``order_of_waves`` visits the waves in another order (a broken layout, for the control)."""
    m, waves, tally, links, rows, bodies = laid_step(s, ids, table, count, block)
    apart = [j for j in range(m) if rows[j, laid.M_OPEN] and laid.stays_apart(bodies, links, rows, j)]
    assert len(apart) >= (2 if block else 0)  # passed over by the pass: the fast path is part of what is compared
    if order_of_waves != slice(None):  # the waves' manifolds rearranged: same rows, another visiting order
        begins = [0, *tally[:waves - 1]]
        spans = [(begins[v], tally[v]) for v in range(waves)][order_of_waves]
        pick = np.concatenate([np.arange(b, e) for b, e in spans])
        links[:m], rows[:m] = links[pick].copy(), rows[pick].copy()
        tally[:waves] = np.cumsum([e - b for b, e in spans])
    for _ in range(passes):
        laid.laid_pass(bodies, links, rows, waves, tally, relaxation, False)
    impulses = np.empty((count, 2))
    for j in range(m):
        for q in range(int(links[j, laid.L_POINTS])):
            c = laid.FIRST if q == 0 else laid.SECOND
            impulses[int(links[j, laid.L_ROW]) + q] = rows[j, c + laid.Q_PN], rows[j, c + laid.Q_PT]
    return bodies[:s.bodies, :3].copy(), impulses


@pytest.mark.parametrize("compiled", [False, True])
@pytest.mark.parametrize(("block", "relaxation"), [(True, 1.0), (True, 1.3), (False, 1.0)])
def test_laid_out_passes_give_the_numbers_of_the_tables_pass_in_table_order(compiled: bool, block: bool,
                                                                          relaxation: float) -> None:
    """Every velocity and impulse after four passes is the table's ``accumulated_iteration`` visiting the
    manifolds from top to bottom, to the bit, signed zeros included, with warm-start impulses in place."""
    s = _pile()
    ids, table, count = _contacts(s)
    prepare(s.x[0], s.y[0], s.inv_mass[0], s.inv_inertia[0], s.friction[0], ids, table, count)
    set_targets(table, count, DT)
    assert (table[:count, DEPTH] < 0).sum() >= 4 and (table[:count, DEPTH] >= 0).sum() >= 10
    assert (ids[:count, A] < 0).any() and len(_starts(ids, count)) > (ids[:count, A] >= 0).sum() // 2
    rng = np.random.default_rng(5)  # the impulses a warm start brings, on the touching points
    table[:count, PN] = np.where(table[:count, DEPTH] >= 0, rng.uniform(0.0, 2.0, count), 0.0)
    table[:count, PT] = 0.3 * table[:count, PN] * rng.uniform(-1.0, 1.0, count)
    want, want_table = s.copy(), table.copy()
    table_order = np.array(_starts(ids, count), np.int64)
    with kernel.compiled(compiled):
        for _ in range(4):
            accumulated_iteration(want.vx[0], want.vy[0], want.w[0], want.inv_mass[0], want.inv_inertia[0], ids,
                                  want_table, count, table_order, block, relaxation)
        velocities, impulses = _laid_passes(s, ids, table, count, 4, block, relaxation)
    for i, field in enumerate(("vx", "vy", "w")):
        assert velocities[:, i].tobytes() == getattr(want, field)[0].tobytes(), field
    assert impulses[:, 0].tobytes() == want_table[:count, PN].tobytes()
    assert impulses[:, 1].tobytes() == want_table[:count, PT].tobytes()
    assert not np.array_equal(want.vx, s.vx)  # the passes did act


def test_the_comparison_tells_a_wrong_order_apart() -> None:
    """The control: the same rows visited waves last to first (a wave's manifolds may follow one of a later
    wave they share a body with) give other numbers, so the equality above is not one that always holds."""
    s = _pile()
    ids, table, count = _contacts(s)
    prepare(s.x[0], s.y[0], s.inv_mass[0], s.inv_inertia[0], s.friction[0], ids, table, count)
    set_targets(table, count, DT)
    right, _ = _laid_passes(s, ids, table.copy(), count, 4, True, 1.0)
    wrong, _ = _laid_passes(s, ids, table.copy(), count, 4, True, 1.0, slice(None, None, -1))
    assert not np.array_equal(right, wrong)


@pytest.mark.parametrize("carry", [True, False])
def test_solve_laid_is_solve_velocities_to_the_bit(carry: bool) -> None:
    """The whole velocity half, gravity, warm start from the last step's memory, passes and memory kept,
    against ``contacts.solve_velocities`` on the table: velocities and memory equal to the bit."""
    s = _pile()
    ids, table, count = _contacts(s)
    room = 8 * s.bodies + 8
    keys, carried = np.zeros((room, 3), np.int64), np.zeros((room, 2))
    # a memory of the last step: this table's points, loaded
    table[:count, PN] = np.where(table[:count, DEPTH] >= 0, np.linspace(0.1, 3.0, count), 0.0)
    table[:count, PT] = 0.2 * table[:count, PN] * np.cos(np.arange(count))
    held = remember(ids, table, count, keys, carried)
    keys[3, 2] += 1  # a point whose feature changed: found nowhere, it starts from zero
    want, got = s.copy(), s.copy()
    want_keys, want_carried, got_keys, got_carried = keys.copy(), carried.copy(), keys.copy(), carried.copy()
    with kernel.compiled(True):
        want_held = solve_velocities(want.x[0], want.y[0], want.vx[0], want.vy[0], want.w[0], want.inv_mass[0],
                                     want.inv_inertia[0], want.friction[0], G, DT, carry, 6, True, 1.2, ids,
                                     table.copy(), count, want_keys, want_carried, held)
        got_held = laid.solve_laid(got.x[0], got.y[0], got.vx[0], got.vy[0], got.w[0], got.inv_mass[0],
                                   got.inv_inertia[0], got.friction[0], G, DT, carry, 6, True, 1.2, ids,
                                   table.copy(), count, got_keys, got_carried, held,
                                   *laid.laid_workspace(room, s.bodies))
    assert got_held == want_held == count
    for field in ("vx", "vy", "w"):
        assert getattr(got, field).tobytes() == getattr(want, field).tobytes(), field
    assert got_keys.tobytes() == want_keys.tobytes() and got_carried.tobytes() == want_carried.tobytes()
    assert np.count_nonzero(want_carried[:count, 0]) >= 10


def test_the_warm_start_applies_each_bodys_impulses_in_table_order() -> None:
    """``laid_warm_start`` gives the velocities of ``contacts.warm_start`` over the table, to the bit."""
    s = _pile()
    ids, table, count = _contacts(s)
    prepare(s.x[0], s.y[0], s.inv_mass[0], s.inv_inertia[0], s.friction[0], ids, table, count)
    table[:count, PN] = np.linspace(0.5, 1.5, count)
    table[:count, PT] = np.linspace(-0.2, 0.3, count)
    want = s.copy()
    warm_start(want.vx[0], want.vy[0], want.w[0], want.inv_mass[0], want.inv_inertia[0], ids, table, count)
    first, order, wave, tally, latest, links, rows, bodies = laid.laid_workspace(ids.shape[0], s.bodies)
    m = manifold_starts(ids, count, first)
    laid.visiting_order(ids, table, first, m, latest, wave, tally, order)
    laid.lay_out(s.x[0], s.y[0], s.inv_mass[0], s.inv_inertia[0], s.friction[0], ids, table, first, order, m, DT,
                 True, links, rows)
    laid.load_velocities(s.vx[0], s.vy[0], s.w[0], s.inv_mass[0], s.inv_inertia[0], bodies)
    laid.laid_warm_start(bodies, links, rows, m)
    laid.give_velocities(bodies, s.vx[0], s.vy[0], s.w[0])
    for field in ("vx", "vy", "w"):
        assert getattr(s, field).tobytes() == getattr(want, field).tobytes(), field
    assert np.all(bodies[s.bodies] == 0.0)  # the ground's row: read, never written
    assert (ids[:count, B] >= 0).all()


def test_the_visiting_order_keeps_every_bodys_order_and_sets_the_manifolds_apart_aside() -> None:
    """``visiting_order``: every manifold once; each body meets its manifolds in table order (what makes the
    numbers those of the table-order pass); the manifolds apart and holding nothing go to even groups, the
    rest to odd ones (waves), whose manifolds share no body; and the waves are fewer than ``wavefronts``'
    with the manifolds apart among them."""
    s = _pile()
    ids, table, count = _contacts(s)
    first, order, group, tally, latest, *_ = laid.laid_workspace(ids.shape[0], s.bodies)
    m = manifold_starts(ids, count, first)
    groups = laid.visiting_order(ids, table, first, m, latest, group, tally, order)
    assert sorted(order[:m]) == list(range(m))
    visits = [int(j) for j in order[:m]]
    for body in range(s.bodies):
        mine = [j for j in visits if body in (ids[first[j], A], ids[first[j], B])]
        assert mine == sorted(mine)
    apart = {j for j in range(m) if all(table[k, DEPTH] < 0 for k in range(first[j], first[j + 1]))}
    begins = [0, *tally[:groups - 1]]
    odd = 0
    for g in range(groups):
        members = visits[begins[g]:tally[g]]
        assert all((j in apart) == (g % 2 == 0) for j in members)
        if g % 2 == 1 and members:
            odd += 1
            bodies = [int(b) for j in members for b in ids[first[j], :2] if b >= 0]
            assert len(bodies) == len(set(bodies))
    assert len(apart) >= 4
    plain_waves = wavefronts(ids, first, m, latest, np.empty(m, np.int64), np.empty(m + 1, np.int64),
                             np.empty(m, np.int64))
    assert odd < plain_waves


@pytest.mark.parametrize("compiled", [False, True])
def test_the_lab_pass_on_the_layout_gives_the_numbers_of_lab_pass_in_table_order(compiled: bool) -> None:
    """``laid_pass`` with the lab's visits: the velocities and the visits' summed impulses after four passes are
    ``lab_table_pass``'s over the table from top to bottom, to the bit; points that do not overlap (depth 0 or
    -0.0 here, set by hand) are passed over as there."""
    s = _pile()
    ids, table = contact_workspace(4)
    ids, table, count = find_contacts(s.x[0], s.y[0], s.angle[0], s.hx[0], s.hy[0], s.inv_mass[0], 0.0, ids,
                                      table)
    prepare(s.x[0], s.y[0], s.inv_mass[0], s.inv_inertia[0], s.friction[0], ids, table, count)
    touching = np.flatnonzero(table[:count, DEPTH] > 0.0)
    table[touching[::7], DEPTH] = 0.0
    table[touching[3::7], DEPTH] = -0.0
    want, want_table = s.copy(), table.copy()
    first, order, group, tally, latest, links, rows, bodies = laid.laid_workspace(ids.shape[0], s.bodies)
    with kernel.compiled(compiled):
        for _ in range(4):
            lab_table_pass(want.vx[0], want.vy[0], want.w[0], want.inv_mass[0], want.inv_inertia[0], ids,
                            want_table, count, np.array(_starts(ids, count), np.int64))
        m = manifold_starts(ids, count, first)
        groups = laid.visiting_order(ids, table, first, m, latest, group, tally, order)
        laid.lay_out(s.x[0], s.y[0], s.inv_mass[0], s.inv_inertia[0], s.friction[0], ids, table, first, order, m,
                     DT, False, links, rows)
        laid.load_velocities(s.vx[0], s.vy[0], s.w[0], s.inv_mass[0], s.inv_inertia[0], bodies)
        for _ in range(4):
            laid.laid_pass(bodies, links, rows, groups, tally, 1.0, True)
        laid.give_velocities(bodies, s.vx[0], s.vy[0], s.w[0])
    for field in ("vx", "vy", "w"):
        assert getattr(s, field).tobytes() == getattr(want, field).tobytes(), field
    keys, carried = np.zeros((count, 3), np.int64), np.zeros((count, 2))
    laid.laid_remember(ids, links, rows, m, count, keys, carried)
    assert carried[:, 0].tobytes() == want_table[:count, PN].tobytes()
    assert carried[:, 1].tobytes() == want_table[:count, PT].tobytes()
    assert np.count_nonzero(want_table[:count, PT]) >= 10 and not np.array_equal(want.vx, _pile().vx)
