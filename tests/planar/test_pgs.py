"""planar-pgs: the lab's rules on planar boxes, against hand-worked answers."""

from __future__ import annotations

import numpy as np
import pytest

from stackx import kernel
from stackx.solvers.planar import passes as laid
from stackx.solvers.planar.contacts import KN, MU, contact_workspace, find_contacts, prepare
from stackx.solvers.planar.pgs import PlanarPGSParams
from tests.planar.worlds import DT, G, deepest, laid_step, run, world

MIXED = [{"x": 0.0, "y": 0.48, "angle": 0.05}, {"x": 0.3, "y": 1.5, "angle": -0.1, "vx": 0.5},
         {"x": 2.0, "y": 1.0, "angle": 0.7, "w": 2.0, "mu": 0.9}]


@pytest.mark.skipif(not kernel.available(), reason="numba not installed")
def test_plain_and_compiled_give_the_same_numbers() -> None:
    plain = run("planar-pgs", world(MIXED), 60, compiled=False)
    fast = run("planar-pgs", world(MIXED), 60, compiled=True)
    for name in plain.FIELDS:
        assert np.array_equal(getattr(plain, name), getattr(fast, name)), name
    assert plain.touched.all()


def test_a_box_dropped_flat_rests_at_about_slop_without_turning() -> None:
    # falling 0.1 m, it lands overlapping; the lab's correction undoes the overlap down to slop and no
    # further, and a resting box's approach is stopped each step, so it stays between 0 and slop deep
    s = run("planar-pgs", world([{"x": 0.0, "y": 0.6}]), 180)
    slop = PlanarPGSParams().correction.slop
    assert 0.5 * slop < deepest(s) <= slop + 1e-12
    assert abs(s.angle[0, 0]) < 1e-5 and abs(s.x[0, 0]) < 1e-4
    assert abs(s.vy[0, 0]) < 1e-3


def test_only_overlapping_points_push_so_a_box_lands_with_the_overlap_of_its_last_free_step() -> None:
    # the lab's rule: a point acts once it overlaps, so the step that takes the box below the ground is a
    # free-fall step, worked out here by hand
    y, v, steps = 0.505, 0.0, 0
    while y - 0.5 >= 0.0:
        v += G * DT
        y += v * DT
        steps += 1
    s = run("planar-pgs", world([{"x": 0.0, "y": 0.505}]), steps, {"correction": "off"})
    assert deepest(s) == pytest.approx(0.5 - y, abs=1e-12)
    assert s.vy[0, 0] == pytest.approx(v, abs=1e-12)


def _lab_passes(s, ids: np.ndarray, table: np.ndarray, count: int, passes: int) -> list[np.ndarray]:
    """``passes`` of ``planar-pgs``'s own velocity pass (the lab's visits on the laid-out step) on row 0 of ``s``,
    in place: after each pass, the visits' summed normal and tangent impulses per point, ``(count, 2)`` in table
    order."""
    m, groups, tally, links, rows, bodies = laid_step(s, ids, table, count, False)
    sums = []
    for _ in range(passes):
        laid.laid_pass(bodies, links, rows, groups, tally, 1.0, True)
        keys, carried = np.zeros((count, 3), np.int64), np.zeros((count, 2))
        laid.laid_remember(ids, links, rows, m, count, keys, carried)
        sums.append(carried)
    laid.give_velocities(bodies, s.vx[0], s.vy[0], s.w[0])
    return sums


def test_friction_per_visit_never_exceeds_mu_times_that_visits_normal_impulse() -> None:
    s = world([{"x": 0.0, "y": 0.49, "vx": 3.0, "vy": -1.0, "mu": 0.4}])
    ids, table = contact_workspace(8)
    ids, table, count = find_contacts(s.x[0], s.y[0], s.angle[0], s.hx[0], s.hy[0], s.inv_mass[0], 0.0, ids, table)
    prepare(s.x[0], s.y[0], s.inv_mass[0], s.inv_inertia[0], s.friction[0], ids, table, count)
    assert count == 2
    first = -(-1.0) * table[0, KN]  # the first visit stops the first corner's approach of 1 m/s
    sums = _lab_passes(s, ids, table, count, 21)
    assert sums[0][0, 0] == pytest.approx(first, rel=1e-12)
    for k in range(count):  # sliding fast: each visit's friction is at its bound, against the motion (the
        assert sums[0][k, 1] == pytest.approx(table[k, MU] * sums[0][k, 0], rel=1e-12)  # tangent is -x here)
    for before, after in zip(sums, sums[1:]):  # later visits: each bounded by its own normal impulse
        gave = after - before
        assert all(abs(gave[k, 1]) <= table[k, MU] * gave[k, 0] * (1 + 1e-12) + 1e-15 for k in range(count))
    assert s.vx[0, 0] > 0.0  # friction slowed the box, never reversed it


def test_the_column_only_correction_stages_are_refused() -> None:
    with pytest.raises(ValueError, match="sequential"):
        PlanarPGSParams(correction={"stage": "global"})
    with pytest.raises(ValueError, match="max_push"):
        PlanarPGSParams(correction={"max_push": 1.0})
    assert PlanarPGSParams(correction="off").correction is None
