"""planar-avbd against a transcription of the AVBD rules in plain Python (floats and dicts, written from the
paper's steps; contact points from the model's collision test), and what resting loads must do under it."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from stackx.kernel import compiled
from stackx.models.planar.layout import A, B, DEPTH, FEATURE, NX, NY, PX, PY
from stackx.models.planar.state import PlanarState
from stackx.solvers.planar.avbd import PlanarAVBD, PlanarAVBDParams
from stackx.solvers.planar.contacts import contact_workspace, find_contacts
from stackx.solvers.planar.reach import contact_margin
from tests.planar.hand_states import boxes, ramp

DT = 1 / 60
G = 9.8
DEMO = dict(iterations=10, beta=1e5, alpha=0.99, gamma=0.99, k_min=1e3, k_max=1e9, max_spin=50.0,
            speculative=0.02)


def _avbd(**params: Any) -> PlanarAVBD:
    return PlanarAVBD([PlanarAVBDParams(**params)], np.array([-G]), np.array([DT]))


def points(s: PlanarState, margin: float) -> list[dict[str, Any]]:
    """The model's contact points within ``margin``: bodies, feature, normal (A to B), point, depth."""
    ids, table = contact_workspace(64)
    ids, table, count = find_contacts(s.x[0], s.y[0], s.angle[0], s.hx[0], s.hy[0], s.inv_mass[0], margin, ids,
                                      table)
    return [dict(a=int(ids[k, A]), b=int(ids[k, B]), key=(int(ids[k, A]), int(ids[k, B]), int(ids[k, FEATURE])),
                 n=(table[k, NX], table[k, NY]), p=(table[k, PX], table[k, PY]), depth=table[k, DEPTH])
            for k in range(count)]


def transcribed_steps(s: PlanarState, steps: int, post: bool = True) -> None:
    """AVBD on planar boxes, rule by rule, on row 0 of ``s`` in place. Per contact point a normal row (error:
    the gap) and a friction row (error: slip along t = (-ny, nx), from the slip carried while the point
    sticks), each with force clamp(k C + lambda)."""
    p = DEMO
    n = s.bodies
    q = [[s.x[0, i], s.y[0, i], s.angle[0, i]] for i in range(n)]
    v = [[s.vx[0, i], s.vy[0, i], s.w[0, i]] for i in range(n)]
    inv = [[s.inv_mass[0, i], s.inv_mass[0, i], s.inv_inertia[0, i]] for i in range(n)]
    mu = [s.friction[0, i] for i in range(n)]
    memory: dict[tuple[int, int, int], list[float]] = {}
    vy_before = [v[i][1] for i in range(n)]
    g, h = -G, DT
    for _ in range(steps):
        margin = contact_margin(p["speculative"], s.vx[0], s.vy[0], s.w[0], s.inv_mass[0], s.hx[0], s.hy[0], g, h)
        found = points(s, margin)
        for c in found:
            lam_n, lam_t, k_n, k_t, slip, stuck = memory.get(c["key"], [0.0] * 6)
            c["slip"] = slip if stuck else 0.0  # the tangent offset a sticking point carries (its kept anchors)
            decay = 1.0 if post else p["alpha"] * p["gamma"]
            c["spring"] = c["depth"] >= -0.01  # further apart: not a spring until it first pushes in this step
            c["lam"] = [lam_n * decay, lam_t * decay] if c["spring"] else [0.0, 0.0]
            c["k"] = [min(max(k_n * p["gamma"], p["k_min"]), p["k_max"]),
                      min(max(k_t * p["gamma"], p["k_min"]), p["k_max"])]
            c["rb"] = (c["p"][0] - q[c["b"]][0], c["p"][1] - q[c["b"]][1])
            c["ra"] = (c["p"][0] - q[c["a"]][0], c["p"][1] - q[c["a"]][1]) if c["a"] >= 0 else (0.0, 0.0)
            c["mu"] = math.sqrt(mu[c["a"]] * mu[c["b"]]) if c["a"] >= 0 else mu[c["b"]]
        q0 = [list(qi) for qi in q]
        free = [list(qi) for qi in q]
        for i in range(n):
            if inv[i][0] > 0:
                v[i][2] = min(max(v[i][2], -p["max_spin"]), p["max_spin"])
                felt = min(max(((v[i][1] - vy_before[i]) / h) * math.copysign(1.0, g) / abs(g), 0.0), 1.0)
                free[i] = [q[i][0] + v[i][0] * h, q[i][1] + v[i][1] * h + g * h * h, q[i][2] + v[i][2] * h]
                q[i] = [free[i][0], q[i][1] + v[i][1] * h + g * felt * h * h, free[i][2]]

        def errors(c: dict[str, Any], share: float) -> tuple[float, float]:
            """J dq of both bodies along n and t (anchors fixed where found), plus the kept gap share."""
            def moved(body: int, r: tuple[float, float]) -> tuple[float, float]:
                turn = q[body][2] - q0[body][2]
                return q[body][0] - q0[body][0] - turn * r[1], q[body][1] - q0[body][1] + turn * r[0]
            ux, uy = moved(c["b"], c["rb"])
            if c["a"] >= 0:
                ax, ay = moved(c["a"], c["ra"])
                ux, uy = ux - ax, uy - ay
            nx, ny = c["n"]
            start_gap = -c["depth"] if c["depth"] < 0.0 else (1.0 - share) * -c["depth"]
            return start_gap + ux * nx + uy * ny, (1.0 - share) * c["slip"] + (-ux * ny + uy * nx)

        def newton(share: float) -> None:
            for i in range(n):
                if inv[i][0] == 0:
                    continue
                m = [1.0 / (inv[i][j] * h * h) for j in range(3)]
                hess = [[m[0], 0.0, 0.0], [0.0, m[1], 0.0], [0.0, 0.0, m[2]]]
                grad = [m[j] * (q[i][j] - free[i][j]) for j in range(3)]
                for c in found:
                    if i not in (c["a"], c["b"]):
                        continue
                    side, (rx, ry) = (1.0, c["rb"]) if c["b"] == i else (-1.0, c["ra"])
                    nx, ny = c["n"]
                    cn, ct = errors(c, share)
                    bound = c["mu"] * abs(c["lam"][0])
                    if not c["spring"]:
                        if min(c["k"][0] * cn + c["lam"][0], 0.0) == 0.0:
                            continue
                        c["spring"] = True
                    for jac, f, k in (((side * nx, side * ny, side * (rx * ny - ry * nx)),
                                       min(c["k"][0] * cn + c["lam"][0], 0.0), c["k"][0]),
                                      ((-side * ny, side * nx, side * (rx * nx + ry * ny)),
                                       min(max(c["k"][1] * ct + c["lam"][1], -bound), bound), c["k"][1])):
                        for r in range(3):
                            grad[r] += jac[r] * f
                            for col in range(3):
                                hess[r][col] += k * jac[r] * jac[col]
                step = np.linalg.solve(np.array(hess), np.array(grad))
                q[i] = [q[i][j] - step[j] for j in range(3)]
                s.x[0, i], s.y[0, i], s.angle[0, i] = q[i]

        keep = 1.0 if post else p["alpha"]
        for _ in range(p["iterations"]):
            newton(keep)
            for c in found:
                cn, ct = errors(c, keep)
                bound = c["mu"] * abs(c["lam"][0])
                c["lam"][0] = min(c["k"][0] * cn + c["lam"][0], 0.0)
                if c["lam"][0] < 0.0:
                    c["k"][0] = min(c["k"][0] + p["beta"] * abs(cn), p["k_max"])
                c["lam"][1] = min(max(c["k"][1] * ct + c["lam"][1], -bound), bound)
                if -bound < c["lam"][1] < bound:
                    c["k"][1] = min(c["k"][1] + p["beta"] * abs(ct), p["k_max"])
        vy_before = [v[i][1] for i in range(n)]
        for i in range(n):
            if inv[i][0] > 0:
                v[i] = [(q[i][j] - q0[i][j]) / h for j in range(3)]
        if post:
            newton(0.0)
        for c in found:  # sticking: friction inside its bound, slipped less than 1 cm (the demo's threshold)
            stuck = abs(c["lam"][1]) < c["mu"] * abs(c["lam"][0]) and abs(c["slip"]) < 0.01
            c["slip"], c["stuck"] = (errors(c, 0.0)[1], 1.0) if stuck else (0.0, 0.0)
        memory = {c["key"]: c["lam"] + c["k"] + [c["slip"], c["stuck"]] for c in found}
        for i in range(n):
            s.x[0, i], s.y[0, i], s.angle[0, i] = q[i]
            s.vx[0, i], s.vy[0, i], s.w[0, i] = v[i]


def three_boxes() -> PlanarState:
    """A box landing tilted on a box resting on a wider one on the ground, moving sideways: every row kind
    (ground, box on box, sticking and sliding friction, a new contact) within 60 steps."""
    s = boxes([0.0, 0.1, 0.3], [0.3, 1.0, 2.2], [0.0, 0.0, 0.25], [(1.0, 0.3), (0.4, 0.4), (0.5, 0.3)],
              [1.0, 2.0, 1.0], [0.6, 0.4, 0.5])
    s.vx[0, 2], s.vy[0, 2], s.w[0, 2] = 0.5, -1.0, 1.0
    return s


@pytest.mark.parametrize("post", [True, False], ids=["post-stabilized", "alpha"])
def test_the_kernel_is_the_transcribed_rules(post: bool) -> None:
    """To 1e-12 m, not to the bit: the transcription solves each body's 3 x 3 system with numpy's LU where the
    kernel uses LDL^T, which rounds differently in the last bits."""
    want, got = three_boxes(), three_boxes()
    transcribed_steps(want, 60, post=post)
    with compiled(False):
        _avbd(post_stabilize=post).advance(got, 60)
    for name in ("x", "y", "angle"):
        np.testing.assert_allclose(getattr(got, name), getattr(want, name), rtol=0, atol=1e-12, err_msg=name)
    for name in ("vx", "vy", "w"):
        np.testing.assert_allclose(getattr(got, name), getattr(want, name), rtol=0, atol=1e-10, err_msg=name)
    assert got.touched[0, 2] and abs(got.angle[0, 2] - 0.25) > 0.1  # the top box landed and turned


def test_a_box_resting_on_the_ground_stays() -> None:
    state = boxes([0.0], [0.5], [0.0], [(0.5, 0.5)], [1.0], [0.6])
    with compiled(False):
        _avbd().advance(state, 120)
    assert math.hypot(state.x[0, 0], state.y[0, 0] - 0.5) < 1e-4 and abs(state.angle[0, 0]) < 1e-6


def test_a_heavy_box_on_a_light_one_stays_up_at_mass_ratio_100() -> None:
    state = boxes([0.0, 0.0], [0.5, 1.5], [0.0, 0.0], [(0.5, 0.5)] * 2, [1.0, 100.0], [0.6, 0.6])
    with compiled(False):
        _avbd().advance(state, 120)
    assert abs(state.y[0, 1] - 1.5) < 2e-3 and abs(state.y[0, 0] - 0.5) < 2e-3
    assert np.abs(state.x[0]).max() < 1e-6 and np.abs(state.angle[0]).max() < 1e-6


@pytest.mark.parametrize("degrees, slides", [(20.0, False), (35.0, True)])
def test_a_box_on_a_ramp_sticks_below_atan_mu_and_slides_above(degrees: float, slides: bool) -> None:
    """atan(0.5) = 26.6 degrees; sliding, the box gains g (sin a - mu cos a) t^2 / 2 along the ramp."""
    a = math.radians(degrees)
    state, start = ramp(a, 0.5), ramp(a, 0.5)
    with compiled(False):
        _avbd().advance(state, 60)
    along = math.hypot(state.x[0, 1] - start.x[0, 1], state.y[0, 1] - start.y[0, 1])
    coulomb = 0.5 * G * (math.sin(a) - 0.5 * math.cos(a)) * 1.0 ** 2
    if slides:
        assert along == pytest.approx(coulomb, rel=0.05)
    else:
        assert along < 1e-3


def test_removing_a_box_keeps_the_other_rows_and_the_step_impulses_hold_the_load() -> None:
    state = boxes([0.0, 0.0, 0.0], [0.5, 1.5, 2.5], [0.0] * 3, [(0.5, 0.5)] * 3, [1.0] * 3, [0.6] * 3)
    solver = _avbd()
    with compiled(False):
        solver.advance(state, 30)
        impulses = solver.step_impulses(0)
        assert impulses is not None
        ground = impulses.keys[:, 0] == -1
        weight = 3 * 1.0 * G * DT  # three unit boxes of density 1
        assert impulses.pn[ground].sum() == pytest.approx(weight, rel=1e-3)
        solver.remove_box(state, 1)
        assert set(map(int, solver.keys[0, :solver.held[0], 1])) <= {0, 1}
        state = PlanarState.concat([state.row(0)])  # the state the scene's event leaves: box 1 taken out
        for name in state.FIELDS:
            value = getattr(state, name)
            if value.ndim == 2 and value.shape[1] == 3:
                setattr(state, name, np.ascontiguousarray(np.delete(value, 1, axis=1)))
        solver.advance(state, 60)
    assert state.y[0, 1] == pytest.approx(1.5, abs=2e-3)  # the top box fell onto the bottom one and rests


def test_points_found_ahead_of_a_falling_box_do_not_turn_it() -> None:
    """Contacts are looked for as far as a fast box closes in a step, so a tilted box thrown down has the
    ground's points in its rows while it is still 12 cm up; a row that does not push must not act on the
    box's Newton step either (its stiffness, through the lever arm, would turn it): the box falls as if alone.
    The first step starts from where the box would coast (it has felt no gravity yet), so the Newton step
    has gravity to add."""
    tilt = 0.3
    lowest = 0.5 * (math.cos(tilt) + math.sin(tilt))  # the centre's height when the lowest corner touches
    state = boxes([0.0], [lowest + 0.12], [tilt], [(0.5, 0.5)], [1.0], [0.6])
    state.vy[0, 0] = -5.0
    solver = _avbd()
    with compiled(False):
        solver.advance(state, 1)
    assert solver.held[0] > 0  # the ground's points were in its rows
    assert state.angle[0, 0] == tilt and state.w[0, 0] == 0.0 and state.vx[0, 0] == 0.0
    assert state.vy[0, 0] == pytest.approx(-5.0 - G * DT, abs=1e-12)


def test_a_box_dropped_on_its_corner_comes_to_rest_flat() -> None:
    """configs/planar/tilted-drop: a box tilted 30 degrees lands on its corner at 6 m/s; it must tip onto a
    face and stop there, not hover or keep a speed its position does not show."""
    state = boxes([0.0], [2.5], [math.radians(30)], [(0.5, 0.5)], [1.0], [0.6])
    with compiled(False):
        _avbd().advance(state, 180)
    quarter = state.angle[0, 0] / (math.pi / 2)
    assert abs(quarter - round(quarter)) * math.pi / 2 < 0.05
    assert state.y[0, 0] == pytest.approx(0.5, abs=2e-3)
    assert max(abs(state.vx[0, 0]), abs(state.vy[0, 0]), abs(state.w[0, 0])) < 1e-2


def test_plain_and_compiled_steps_agree_to_the_bit() -> None:
    out = []
    for on in (False, True):
        state = three_boxes()
        with compiled(on):
            _avbd(iterations=4).advance(state, 40)
        out.append(state)
    for name in out[0].FIELDS:
        assert np.array_equal(getattr(out[0], name), getattr(out[1], name)), name
