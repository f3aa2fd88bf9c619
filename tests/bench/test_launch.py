""""Never launched", recomputed here from every step's positions for every solver, and shown to fail for each.

The transcription below is written from the criterion's definition alone (plain Python, no stackx code): a
box has touched something once a contact of it is overlapping or at most 2 cm apart (the floor's included);
from then on, every step's rise ``(y_now - y_prev) / dt`` counts, and the fastest is the launch. On the
column a contact is two neighbours' heights against their half-heights; on the planar model it is the
separating-axis gap of two turned boxes (or a box's lowest corner against the ground).

- On ``drop-fast`` and the planar drop cases (a box thrown at a pile), every solver at every knob value the
  bench runs: the launch each run reports equals the one recomputed from its recorded positions, and the
  bench's verdict is the one the recomputed launch gives.
- A box resting on the floor at exactly zero depth, thrown up at 5 m/s at the start: every solver, column and
  planar, must report it launched (a criterion no solver can fail would judge nothing).
"""

from __future__ import annotations

import dataclasses
import math

import pytest

from stackx import registry
from stackx.bench.plan import CASE, load_case
from stackx.config.experiment import load
from stackx.bench.criteria import Criteria, judge
from stackx.errors import BlowUp
from stackx.run.runner import run_experiment
from tests.conftest import REPO
from stackx.config.spec import Plan
from tests.conftest import CONFIGS

GAP = 0.02  # m: touching, as the criterion defines it
DROPS = {"column": [CONFIGS / "hard" / "drop-fast.yaml"], "planar": [CONFIGS / "planar" / "fast-into-stack.yaml"]}


def _solvers(model: str) -> list[str]:
    """Every solver of ``model`` that can run here, engines included."""
    return [e.name for e in registry.solvers.entries()
            if model in (cls := registry.solvers.get(e.name)).models and not registry.unavailable(cls)]


def _column_launch(ys: list[list[float]], half: list[float], dt: float) -> float:
    """The launch of a column run from its heights at every step (bottom box first)."""
    n = len(half)
    touched = [False] * n
    best = 0.0
    for k, y in enumerate(ys):
        if y[0] - half[0] < GAP:  # on the floor
            touched[0] = True
        for i in range(n - 1):
            if (y[i + 1] - y[i]) - (half[i] + half[i + 1]) < GAP:
                touched[i] = touched[i + 1] = True
        if k:
            best = max([best] + [(y[i] - ys[k - 1][i]) / dt for i in range(n) if touched[i]])
    return best


def _corners(x: float, y: float, a: float, hx: float, hy: float) -> list[tuple[float, float]]:
    c, s = math.cos(a), math.sin(a)
    return [(x + c * px - s * py, y + s * px + c * py) for px, py in ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy))]


def _gap(p: list[tuple[float, float]], q: list[tuple[float, float]]) -> float:
    """The separating-axis gap of two convex quadrilaterals: the largest, over the edge normals of both, of the
    space between their projections (negative when they overlap on every axis)."""
    best = -math.inf
    for poly in (p, q):
        for k in range(4):
            (x0, y0), (x1, y1) = poly[k], poly[(k + 1) % 4]
            nx, ny = y1 - y0, x0 - x1
            length = math.hypot(nx, ny)
            nx, ny = nx / length, ny / length
            pp = [nx * px + ny * py for px, py in p]
            qq = [nx * qx + ny * qy for qx, qy in q]
            best = max(best, min(qq) - max(pp), min(pp) - max(qq))
    return best


def _planar_launch(frames: list[dict[str, list[float]]], dt: float) -> float:
    """The launch of a planar run from its poses at every step (the movable boxes only)."""
    n = len(frames[0]["x"])
    movable = [m != 0.0 for m in frames[0]["inv_mass"]]
    touched = [False] * n
    best = 0.0
    for k, f in enumerate(frames):
        boxes = [_corners(f["x"][i], f["y"][i], f["angle"][i], f["hx"][i], f["hy"][i]) for i in range(n)]
        for i in range(n):
            if movable[i] and min(py for _, py in boxes[i]) < GAP:
                touched[i] = True
            for j in range(i + 1, n):
                reach = math.hypot(f["hx"][i], f["hy"][i]) + math.hypot(f["hx"][j], f["hy"][j]) + GAP
                if math.hypot(f["x"][i] - f["x"][j], f["y"][i] - f["y"][j]) >= reach:
                    continue  # their circumscribed circles are more than the gap apart
                if (movable[i] or movable[j]) and _gap(boxes[i], boxes[j]) < GAP:
                    touched[i] = touched[j] = True
        if k:
            best = max([best] + [(f["y"][i] - frames[k - 1]["y"][i]) / dt for i in range(n)
                                 if touched[i] and movable[i]])
    return best


def _runs(path: object, model: str) -> tuple[object, list[tuple[str, int | None, object]]]:
    """The bench's runs of the case at ``path`` for every solver of ``model`` (the shipped local
    plugins included) at every knob value, stepped with every state kept: the case and (solver, knob value, result)."""
    spec = load(str(path), plugins=REPO / "plugins")
    case, left_out = load_case(spec, _solvers(model))
    assert not left_out, left_out
    specs = [(p.solver, value if p.knob else None,
              dataclasses.replace(case.run, name=f"{p.solver}/{value}", solver_cls=p.solver_cls, solver_params=params,
                                  overrides={}))
             for p in case.plans for value, params in p.params[CASE].items()]
    def run(runs: list[object]) -> dict[str, object]:
        plan = Plan(case.spec.file, case.name, "", runs, case.spec.limits)
        return {r.name: r for r in run_experiment(plan, record=set(range(case.run.steps + 1))).runs}

    try:
        done = run([s for *_, s in specs])
    except BlowUp:  # as the bench does: each run alone, and those that blow up have no launch to check
        done = {}
        for *_, spec in specs:
            try:
                done.update(run([spec]))
            except BlowUp:
                pass
    return case, [(solver, value, done[spec.name]) for solver, value, spec in specs if spec.name in done]


def _recomputed(model: str, result: object) -> float:
    frames = [result.frames[k] for k in range(result.spec.steps + 1)]  # type: ignore[attr-defined]
    dt = result.spec.dt  # type: ignore[attr-defined]
    if model == "column":
        return _column_launch([f.y[0].tolist() for f in frames], frames[0].half[0].tolist(), dt)
    keys = ("x", "y", "angle", "hx", "hy", "inv_mass")
    return _planar_launch([{k: getattr(f, k)[0].tolist() for k in keys} for f in frames], dt)


@pytest.mark.parametrize("model,path", [(m, p) for m, paths in DROPS.items() for p in paths],
                         ids=lambda v: getattr(v, "stem", v))
def test_every_solver_launches_as_its_positions_say(model: str, path: object, monkeypatch: pytest.MonkeyPatch) -> None:
    # compiled however small the batch: the plain path would step the 64-iteration rows in Python for most of a
    # minute, to the same numbers (tests/speed)
    monkeypatch.setenv("STACKX_JIT", "1")
    case, runs = _runs(path, model)
    limit = case.section.criteria.launch
    seen = set()
    for solver, value, result in runs:
        expected = _recomputed(model, result)
        reported = float(result.measures["launch"])
        assert reported == pytest.approx(expected, rel=1e-9, abs=1e-12), (solver, value)
        verdict = judge({"launch": reported}, case.section.criteria)["never_launched"]
        assert verdict.passed == (expected <= limit), (solver, value, expected)
        seen.add(verdict.passed)
    assert {solver for solver, *_ in runs} == set(_solvers(model))  # every solver, at least where it did not blow up
    if path.stem == "drop-fast":  # type: ignore[attr-defined]
        assert seen == {True, False}  # some pass, some throw the pile up: the criterion tells them apart
        xpbd = next(r for s, v, r in runs if s == "xpbd" and v == 64)
        heights = [xpbd.frames[k].y[0].tolist() for k in range(xpbd.spec.steps + 1)]
        rise = max((b[i] - a[i]) / xpbd.spec.dt for a, b in zip(heights, heights[1:]) for i in range(5))
        assert rise > 5.0  # a box rises at about 5 m/s after the impact, on contacts it leaves at zero depth
        assert xpbd.measures["launch"] == pytest.approx(rise, rel=1e-12)
        assert not judge({"launch": rise}, Criteria())["never_launched"].passed


THROWN_UP = {
    "column": "scene: {name: column, boxes: [{y: 0.5, v: 5.0}, {y: 1.5}]}\nsolver: {name: exact}\n",
    "planar": "scene: {name: planar, boxes: [{y: 0.5, vy: 5.0}, {x: 3.0, y: 0.5}]}\nsolver: {name: planar-exact}\n",
}


@pytest.mark.parametrize("model", sorted(THROWN_UP))
def test_launch_can_fail_for_every_solver(model: str, tmp_path: object) -> None:
    """A box at rest on the floor at zero depth, given 5 m/s upward: no contact pulls it back, so every solver
    lets it rise (about 5 - 9.8/60 m/s in its first step), and each must say it launched."""
    path = tmp_path / f"up-{model}.yaml"  # type: ignore[operator]
    path.write_text(THROWN_UP[model] + "dt: 1/60\nsteps: 30\nbench: {knob: [1, 8]}\n")
    case, runs = _runs(path, model)
    assert {s for s, *_ in runs} == set(_solvers(model))
    for solver, value, result in runs:
        launch = float(result.measures["launch"])
        assert launch == pytest.approx(_recomputed(model, result), rel=1e-9), (solver, value)
        assert launch > 2.0, (solver, value)  # Box2D 2.3 lets it go at 2.3 m/s, the others at about 4.8
        assert not judge(result.measures, case.section.criteria)["never_launched"].passed, (solver, value)

