"""``avbd`` on the column against a transcription of the AVBD rules in plain Python (lists and floats, written
from the paper's steps, not from the kernel), and what a resting load must do under it."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from stackx.config.experiment import load
from stackx.kernel import compiled
from tests.conftest import CONFIGS
from tests.solvers.columns import column, run, solver

DEMO = dict(iterations=10, beta=1e5, alpha=0.99, gamma=0.99, k_min=1e3, k_max=1e9, margin=0.02)


def transcribed_steps(ys: list[float], vs: list[float], masses: list[float], half: list[float], g: float, h: float,
                      steps: int, post: bool = True, **knobs: Any) -> tuple[list[float], list[float]]:
    """AVBD on a column, rule by rule. Row r is the contact under box r (r = 0: the floor); its constraint is
    the gap, C = gap_at_start (an overlap's times 1 - alpha) + (dy_r - dy_below), and its force
    f = min(k C + lambda, 0)."""
    p = {**DEMO, **knobs}
    n = len(ys)
    y, v = list(ys), list(vs)
    lam, k = [0.0] * n, [0.0] * n
    v_before = list(vs)
    inverse = [0.0 if m == math.inf else 1.0 / m for m in masses]

    def gap(r: int, heights: list[float]) -> float:  # minus the lab's depth of contact r
        if r == 0:
            return -(half[0] - heights[0])
        return -((half[r - 1] + half[r]) - (heights[r] - heights[r - 1]))

    for _ in range(steps):
        keep = 1.0 if post else p["alpha"]
        gap0 = [gap(r, y) for r in range(n)]
        taking_part, spring = [], []
        for r in range(n):
            approach = v[r] - (v[r - 1] if r > 0 else 0.0)
            movable = inverse[r] > 0 or (r > 0 and inverse[r - 1] > 0)
            taking_part.append(movable and gap0[r] + min(approach, 0.0) * h < p["margin"])
            spring.append(taking_part[r] and gap0[r] <= 0.01)  # further apart: a spring only once it pushes
            if taking_part[r]:
                lam[r] = lam[r] * (1.0 if post else p["alpha"] * p["gamma"]) if spring[r] else 0.0
                k[r] = min(max(k[r] * p["gamma"], p["k_min"]), p["k_max"])
            else:
                lam[r], k[r] = 0.0, 0.0
        y0 = list(y)
        free = list(y)
        for i in range(n):
            if inverse[i] > 0:
                free[i] = y[i] + v[i] * h + g * h * h
                felt = min(max(((v[i] - v_before[i]) / h) * math.copysign(1.0, g) / abs(g), 0.0), 1.0)
                y[i] = y[i] + v[i] * h + g * felt * h * h

        def error(r: int, share: float) -> float:
            moved = y[r] - y0[r] - ((y[r - 1] - y0[r - 1]) if r > 0 else 0.0)
            return (gap0[r] if gap0[r] > 0.0 else (1.0 - share) * gap0[r]) + moved

        def newton(share: float) -> None:
            for i in range(n):
                if inverse[i] == 0:
                    continue
                inertia = 1.0 / (inverse[i] * h * h)
                hessian, gradient = inertia, inertia * (y[i] - free[i])
                for r, side in ((i, 1.0), (i + 1, -1.0)):
                    if r < n and taking_part[r]:
                        f = min(k[r] * error(r, share) + lam[r], 0.0)
                        if not spring[r] and f == 0.0:
                            continue
                        spring[r] = True
                        gradient += side * f
                        hessian += k[r]
                y[i] -= gradient / hessian

        for _ in range(p["iterations"]):
            newton(keep)
            for r in range(n):
                if taking_part[r]:
                    c = error(r, keep)
                    lam[r] = min(k[r] * c + lam[r], 0.0)
                    if lam[r] < 0.0:
                        k[r] = min(k[r] + p["beta"] * abs(c), p["k_max"])
        v_before = list(v)
        v = [(y[i] - y0[i]) / h if inverse[i] > 0 else v[i] for i in range(n)]
        if post:
            newton(0.0)
    return y, v


def lab_scenes() -> list[Any]:
    out = []
    for name in ("03-sink.yaml", "05-iters.yaml", "06-stack.yaml"):
        r = load(str(CONFIGS / name)).runs[0]
        out.append(pytest.param(r.scene, r.gravity, r.dt, min(r.steps, 400), id=name))
    return out


@pytest.mark.parametrize("post", [True, False], ids=["post-stabilized", "alpha"])
@pytest.mark.parametrize("scene, g, dt, steps", lab_scenes())
def test_the_kernel_is_the_transcribed_rules_to_the_bit(scene: Any, g: float, dt: float, steps: int,
                                                        post: bool) -> None:
    state = scene.build()
    masses = [1.0 / m if m > 0 else math.inf for m in state.inv_mass[0]]
    want_y, want_v = transcribed_steps(list(state.y[0]), list(state.v[0]), masses, list(state.half[0]), g, dt,
                                       steps, post=post)
    with compiled(False):
        solver("avbd", [{"post_stabilize": post}], dt=dt, g=g).advance(state, steps)
    assert state.y[0].tolist() == want_y
    assert state.v[0].tolist() == want_v


def test_a_landing_is_the_transcribed_rules_with_other_knobs() -> None:
    knobs = dict(iterations=4, beta=3e4, gamma=0.9, penalty_min=50.0, penalty_max=1e6, margin=0.05)
    state = column([0.6, 2.0, 3.2], masses=[2.0, 1.0, 5.0], vs=[0.0, -3.0, 1.0])
    want_y, want_v = transcribed_steps([0.6, 2.0, 3.2], [0.0, -3.0, 1.0], [2.0, 1.0, 5.0], [0.5] * 3, -9.8, 1 / 60,
                                       200, iterations=4, beta=3e4, gamma=0.9, k_min=50.0, k_max=1e6, margin=0.05)
    with compiled(False):
        run("avbd", state, 200, **knobs)
    assert state.y[0].tolist() == want_y and state.v[0].tolist() == want_v


def test_a_box_resting_on_the_floor_stays() -> None:
    state = column([0.5])
    run("avbd", state, 120)
    assert abs(state.y[0, 0] - 0.5) < 1e-4


def test_a_heavy_box_on_a_light_one_stays_up_at_mass_ratio_100() -> None:
    state = column([0.5, 1.5], masses=[1.0, 100.0])
    run("avbd", state, 600)
    assert abs(state.y[0, 1] - 1.5) < 2e-3 and abs(state.y[0, 0] - 0.5) < 2e-3
    assert np.abs(state.v[0]).max() < 1e-3


def test_without_post_stabilization_a_resting_load_sinks_as_its_force_decays() -> None:
    """The paper's alpha warm start carries alpha * gamma = 98% of each force, so each step the rest is found
    again by letting the box sink into its contact; post-stabilized, the whole force is carried."""
    kept, decayed = column([0.5, 1.5], masses=[1.0, 10.0]), column([0.5, 1.5], masses=[1.0, 10.0])
    run("avbd", kept, 120)
    run("avbd", decayed, 120, post_stabilize=False)
    assert 1.5 - decayed.y[0, 1] > 10 * (1.5 - kept.y[0, 1])
    assert 1.5 - decayed.y[0, 1] > 1e-3


def test_penalty_bounds_out_of_order_are_refused() -> None:
    from stackx.solvers.column.avbd import AVBDParams
    with pytest.raises(ValueError, match="penalty_min"):
        AVBDParams(penalty_min=1e6, penalty_max=1e3)
