"""The shared planar stages against independent computations: matrices, brute force, geometry by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stackx.models.planar.state import PlanarState
from stackx.solvers.planar.contacts import (A, B, DEPTH, FEATURE, KN, KT, MU, NX, NY, PN, PT, PX, PY, TARGET,
                                            anchor_locals, apply_impulse, block_normal, contact_workspace,
                                            correct_positions, find_contacts, normal_visit, prepare, recall,
                                            recall_impulses, relative_velocity, remember, same_pairs,
                                            separation_push)
from tests.planar.worlds import lowest_corner, world


def _table(s: PlanarState, margin: float = 0.0) -> tuple[np.ndarray, np.ndarray, int]:
    ids, table = contact_workspace(2)  # too small on purpose: the table must grow
    ids, table, count = find_contacts(s.x[0], s.y[0], s.angle[0], s.hx[0], s.hy[0], s.inv_mass[0], margin, ids,
                                      table)
    prepare(s.x[0], s.y[0], s.inv_mass[0], s.inv_inertia[0], s.friction[0], ids, table, count)
    return ids, table, count


def _jacobian(s: PlanarState, ids: np.ndarray, table: np.ndarray, k: int, dx: float, dy: float) -> np.ndarray:
    """The row of J (bodies x (vx, vy, w)) of point k along d, from the point and the centres directly."""
    j = np.zeros(3 * s.bodies)
    px, py = table[k, PX], table[k, PY]
    for body, sign in ((ids[k, B], 1.0), (ids[k, A], -1.0)):
        if body >= 0:
            rx, ry = px - s.x[0, body], py - s.y[0, body]
            j[3 * body:3 * body + 3] = sign * np.array([dx, dy, rx * dy - ry * dx])
    return j


def _inverse_mass(s: PlanarState) -> np.ndarray:
    return np.diag(np.ravel(np.column_stack([s.inv_mass[0], s.inv_mass[0], s.inv_inertia[0]])))


SCENE = [{"x": 0.0, "y": 0.45, "angle": 0.1, "mu": 0.3}, {"x": 0.35, "y": 1.4, "angle": -0.2, "hx": 0.7, "mu": 0.8},
         {"x": 1.3, "y": 0.5, "hy": 0.6, "density": 3.0, "mu": 0.5}]


def test_effective_masses_and_friction_match_the_contact_jacobian() -> None:
    s = world(SCENE)
    ids, table, count = _table(s)
    assert count >= 4 and ids.shape[0] >= count
    w = _inverse_mass(s)
    for k in range(count):
        nx, ny = table[k, NX], table[k, NY]
        jn, jt = _jacobian(s, ids, table, k, nx, ny), _jacobian(s, ids, table, k, -ny, nx)
        assert table[k, KN] == pytest.approx(1.0 / (jn @ w @ jn), rel=1e-12)
        assert table[k, KT] == pytest.approx(1.0 / (jt @ w @ jt), rel=1e-12)
        a, b = ids[k, A], ids[k, B]
        mu = s.friction[0, b] if a < 0 else math.sqrt(s.friction[0, a] * s.friction[0, b])
        assert table[k, MU] == pytest.approx(mu, rel=1e-15)


def test_an_impulse_changes_velocities_by_the_inverse_mass_and_the_point_velocity_by_jmj() -> None:
    s = world(SCENE)
    rng = np.random.default_rng(3)
    s.vx[0], s.vy[0], s.w[0] = rng.normal(size=(3, s.bodies))
    ids, table, count = _table(s)
    w = _inverse_mass(s)
    for k in range(count):
        before = np.ravel(np.column_stack([s.vx[0], s.vy[0], s.w[0]]))
        nx, ny = table[k, NX], table[k, NY]
        jn, jt = _jacobian(s, ids, table, k, nx, ny), _jacobian(s, ids, table, k, -ny, nx)
        assert relative_velocity(s.vx[0], s.vy[0], s.w[0], ids, table, k, nx, ny) == pytest.approx(jn @ before)
        pn, pt = 0.7, -0.3
        apply_impulse(s.vx[0], s.vy[0], s.w[0], s.inv_mass[0], s.inv_inertia[0], ids, table, k,
                      pn * nx - pt * ny, pn * ny + pt * nx)
        after = np.ravel(np.column_stack([s.vx[0], s.vy[0], s.w[0]]))
        assert after == pytest.approx(before + w @ (jn * pn + jt * pt), abs=1e-12)


def test_the_block_solve_of_a_two_point_manifold_is_the_limit_of_point_by_point_passes() -> None:
    # a box tilted onto a wider one: two points, unequal lever arms; the target asks one to separate
    for vy, w0, target in ((-2.0, 0.0, 0.0), (-1.0, 3.0, 0.0), (-1.0, -4.0, 0.5), (0.5, 0.2, 0.0)):
        s = world([{"x": 0.0, "y": 0.5, "hx": 2.0}, {"x": 0.6, "y": 1.49, "vy": vy, "w": w0}])
        ids, table, count = _table(s)
        pair = [k for k in range(count) if ids[k, A] == 0]
        assert len(pair) == 2
        table[pair[1], TARGET] = target
        block = s.copy()
        t_block = table.copy()
        assert block_normal(block.vx[0], block.vy[0], block.w[0], s.inv_mass[0], s.inv_inertia[0], ids, t_block,
                            pair[0], 1.0)
        for _ in range(20000):
            for k in pair:
                normal_visit(s.vx[0], s.vy[0], s.w[0], s.inv_mass[0], s.inv_inertia[0], ids, table, k, 1.0)
        assert t_block[pair, PN] == pytest.approx(table[pair, PN], abs=1e-9)
        assert block.w[0] == pytest.approx(s.w[0], abs=1e-9)


def test_the_lab_correction_pushes_each_point_after_the_pushes_before_it() -> None:
    s = world([{"x": 0.0, "y": 0.45}])  # sunk 0.05 flat: two ground points
    ids, table, count = _table(s)
    slop, percent = 0.01, 0.2
    first = percent * (0.05 - slop)
    second = percent * (0.05 - first - slop)  # the second point sees what the first already undid
    assert correct_positions(s.x[0], s.y[0], s.inv_mass[0], ids, table, count, slop, percent, np.zeros((1, 2)))
    assert count == 2
    assert s.y[0, 0] == pytest.approx(0.45 + first + second, abs=1e-15)
    assert s.x[0, 0] == 0.0 and s.angle[0, 0] == 0.0


def test_the_lab_correction_says_whether_it_moved_and_passes_over_points_still_apart() -> None:
    """Sunk within slop: nothing moves and it says so. A point still apart (from a speculative margin) is
    passed over even where the pushes before it closed its gap past the slop: it is not in the table with no
    margin that the stage is defined on."""
    s = world([{"x": 0.0, "y": 0.495}])
    ids, table, count = _table(s)
    assert count == 2 and not correct_positions(s.x[0], s.y[0], s.inv_mass[0], ids, table, count, 0.01, 0.2,
                                                np.zeros((1, 2)))
    assert s.y[0, 0] == 0.495
    s = world([{"x": 0.0, "y": 0.45}])
    ids, table, count = _table(s)
    table[0, DEPTH] = 0.2  # a first push that moves the box up by 3.8 cm
    table[1, DEPTH] = -0.001  # the second point apart, along a normal that push closes it by
    table[1, NX], table[1, NY] = 0.0, -1.0
    assert correct_positions(s.x[0], s.y[0], s.inv_mass[0], ids, table, count, 0.01, 0.2, np.zeros((1, 2)))
    assert s.y[0, 0] == 0.45 + 0.2 * (0.2 - 0.01)  # the first push only


def test_memory_finds_each_point_by_its_bodies_and_feature() -> None:
    s = world(SCENE)
    ids, table, count = _table(s)
    table[:count, PN] = np.arange(count) + 1.0
    table[:count, PT] = -np.arange(count) - 1.0
    keys, carried = np.zeros((64, 3), np.int64), np.zeros((64, 2))
    held = remember(ids, table, count, keys, carried)
    assert held == count
    drop = 1  # forget one point: it must come back as 0, the others unchanged
    keys = np.delete(keys, drop, axis=0)
    carried = np.delete(carried, drop, axis=0)
    table[:count, PN] = table[:count, PT] = np.nan  # whatever a table held before: recall writes every point
    recall(ids, table, count, keys, carried, held - 1)
    memory = {tuple(keys[i]): tuple(carried[i]) for i in range(held - 1)}
    for k in range(count):
        key = (ids[k, A], ids[k, B], ids[k, FEATURE])
        assert (table[k, PN], table[k, PT]) == memory.get(key, (0.0, 0.0))
    assert table[drop, PN] == 0.0 and table[0, PN] == 1.0
    assert np.copysign(1.0, table[drop, PN]) == 1.0 and np.copysign(1.0, table[drop, PT]) == 1.0  # +0, as cleared


def test_memory_finds_corners_that_swapped_places_in_the_list() -> None:
    s = world(SCENE)
    ids, table, count = _table(s)
    keys = np.array([[ids[k, A], ids[k, B], ids[k, FEATURE]] for k in range(count)], np.int64)
    carried = np.stack([np.arange(count) + 1.0, -np.arange(count) - 1.0], axis=1)
    two = next(k for k in range(count - 1) if tuple(keys[k, :2]) == tuple(keys[k + 1, :2]))
    keys[[two, two + 1]] = keys[[two + 1, two]]  # a manifold's two corners listed the other way round last step
    carried[[two, two + 1]] = carried[[two + 1, two]]
    table[:count, PN] = table[:count, PT] = np.nan
    recall(ids, table, count, keys, carried, count)
    for k in range(count):  # every point gets its own impulses back, the swapped pair included
        assert (table[k, PN], table[k, PT]) == (k + 1.0, -k - 1.0)


def test_recalling_tells_whether_the_points_are_between_the_last_steps_pairs() -> None:
    """``recall_impulses`` says, on the way, what ``same_pairs`` says: yes for the same pairs (features may
    differ), no for a point between other bodies, one point more or fewer; the impulses are ``recall``'s."""
    s = world(SCENE)
    ids, table, count = _table(s)
    keys = np.array([[ids[k, A], ids[k, B], ids[k, FEATURE]] for k in range(count)], np.int64)
    carried = np.stack([np.arange(count) + 1.0, -np.arange(count) - 1.0], axis=1)
    other = keys.copy()
    other[count - 1, 1] = other[count - 1, 1] + 1  # its last point between other bodies
    turned = keys.copy()
    turned[0, 2] = turned[0, 2] + 1  # the same pairs, a corner's feature changed
    for memory, held in ((keys, count), (turned, count), (other, count), (keys, count - 1)):
        impulses = np.full((count, 2), np.nan)
        table[:count, PN] = table[:count, PT] = np.nan
        same = recall_impulses(ids, count, memory, carried, held, impulses)
        assert same == same_pairs(ids, count, memory, held)
        recall(ids, table, count, memory, carried, held)
        assert impulses.tobytes() == np.ascontiguousarray(table[:count, PN:PT + 1]).tobytes()
    assert recall_impulses(ids, count, turned, carried, count, np.empty((count, 2)))
    assert not recall_impulses(ids, count, other, carried, count, np.empty((count, 2)))


def test_the_position_pass_measures_the_depth_where_the_box_has_turned_to() -> None:
    s = world([{"x": 0.0, "y": 0.49, "angle": 0.0}])
    ids, table, count = _table(s, margin=0.05)
    anchor_locals(s.x[0], s.y[0], s.angle[0], ids, table, count)
    s.x[0, 0], s.y[0, 0], s.angle[0, 0] = 0.3, 0.47, 0.04  # moved and turned after the contacts were found
    deepest = separation_push(s.x[0], s.y[0], s.angle[0], s.inv_mass[0], s.inv_inertia[0], ids, table, count,
                              1.0, 0.2, 0.2)  # slop 1 m: measure only, push nothing
    assert deepest == pytest.approx(-lowest_corner(0.3, 0.47, 0.04, 0.5, 0.5), abs=1e-12)
    assert (s.x[0, 0], s.y[0, 0], s.angle[0, 0]) == (0.3, 0.47, 0.04)
    for _ in range(30):
        deepest = separation_push(s.x[0], s.y[0], s.angle[0], s.inv_mass[0], s.inv_inertia[0], ids, table,
                                  count, 0.0, 1.0, 0.2)
    assert -lowest_corner(s.x[0, 0], s.y[0, 0], s.angle[0, 0], 0.5, 0.5) == pytest.approx(0.0, abs=1e-9)
    assert abs(s.angle[0, 0]) < 0.04  # the deeper corner was pushed out, turning the box back


def test_a_point_records_its_depth_and_the_normal_of_its_face() -> None:
    s = world([{"x": 0.0, "y": 0.45}])
    ids, table, count = _table(s)
    assert [(ids[k, A], table[k, NX], table[k, NY], table[k, DEPTH]) for k in range(count)] == \
        [(-1, 0.0, 1.0, pytest.approx(0.05, abs=1e-15))] * 2
    assert table[:count, PN].tolist() == [0.0, 0.0] and table[:count, PT].tolist() == [0.0, 0.0]


@pytest.mark.parametrize("compiled", [False, True])
def test_a_pass_in_manifold_order_gives_the_numbers_of_a_table_order_sweep(compiled: bool) -> None:
    """``manifold_order`` only swaps manifolds that share no body: every body meets its manifolds in table
    order, so a pass (accumulated or the lab's) gives the velocities and impulses of visiting the table from
    top to bottom, bit for bit; and on a pile it does reorder (that is what it is for)."""
    from stackx import kernel
    from stackx.scenes.planar import Planar, PlanarParams, Pyramid
    from stackx.solvers.planar.contacts import accumulated_iteration, set_targets
    from stackx.solvers.planar.wavefront import manifold_end, manifold_order
    from tests.planar.lab_table import lab_table_pass
    from tests.planar.worlds import run

    s = Planar(PlanarParams(pyramid=Pyramid(rows=6, gap=0.0, friction=0.5))).build()
    s.inv_mass[0, 3], s.inv_inertia[0, 3] = 0.0, 0.0  # a static box in the middle of the bottom row
    run("planar-warm-start", s, 5, {"iterations": 3})  # moving, not at rest
    s.vx[0] += np.linspace(-0.3, 0.3, s.bodies)  # and pushed about, so every visit acts
    s.w[0] += np.linspace(0.2, -0.2, s.bodies)
    ids, table, count = _table(s, 0.02)
    with kernel.compiled(compiled):
        set_targets(table, count, 1 / 60)
        order = manifold_order(ids, count, s.bodies)
    starts = [0]
    while manifold_end(ids, starts[-1], count) < count:
        starts.append(manifold_end(ids, starts[-1], count))
    assert sorted(order) == starts and list(order) != starts
    for body in range(s.bodies):  # each body's manifolds keep their table order
        mine = [k for k in order if body in (ids[k, A], ids[k, B])]
        assert mine == sorted(mine)
    table_order = np.array(starts, np.int64)
    for visit in ("lab", "block", "points"):
        got, want = s.copy(), s.copy()
        got_table, want_table = table.copy(), table.copy()
        with kernel.compiled(compiled):
            for t, st, o in ((got_table, got, order), (want_table, want, table_order)):
                for _ in range(4):
                    args = (st.vx[0], st.vy[0], st.w[0], st.inv_mass[0], st.inv_inertia[0], ids, t, count, o)
                    if visit == "lab":
                        lab_table_pass(*args)
                    else:
                        accumulated_iteration(*args, visit == "block", 1.3)
        assert got_table.tobytes() == want_table.tobytes(), visit
        for field in ("vx", "vy", "w"):
            assert getattr(got, field).tobytes() == getattr(want, field).tobytes(), (visit, field)
        assert not np.array_equal(want.vx, s.vx)  # the passes did act
