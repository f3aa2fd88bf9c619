"""Every registered solver (built in, installed or local) through the same checks.

The scenes are the lab's: the configs 03 to 06 are loaded as they are, and each of their scenes is stepped by
every solver at its default parameters.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from stackx import kernel, registry
from stackx.config.experiment import load
from stackx.errors import ConfigError
from stackx.run.runner import run_experiment
from stackx.models.column.state import ColumnState
from tests.conftest import CONFIGS
from tests.solvers.columns import solver, solver_names

LAB_CONFIGS = ["03-sink.yaml", "04-fixed.yaml", "05-iters.yaml", "06-stack.yaml"]
STACK = CONFIGS / "06-stack.yaml"
NAMES = solver_names()


def lab_scenes() -> list[tuple[str, Any, float, float, int]]:
    """(label, scene, gravity, dt, steps) of every distinct run setting in the lab configs."""
    out, seen = [], set()
    for name in LAB_CONFIGS:
        for r in load(str(CONFIGS / name)).runs:
            key = (repr(r.scene.params.model_dump()), r.gravity, r.dt, r.steps)
            if key not in seen:
                seen.add(key)
                out.append((f"{name}:{r.name}", r.scene, r.gravity, r.dt, r.steps))
    return out


SCENES = lab_scenes()


def step(name: str, rows: list[dict[str, Any]], state: ColumnState, chunks: list[int], g: float = -9.8,
         dt: float = 1 / 60) -> ColumnState:
    stepper = solver(name, rows, dt=dt, g=g)
    for n in chunks:
        stepper.advance(state, n)
    return state


def assert_same(a: ColumnState, b: ColumnState) -> None:
    for field in ColumnState.FIELDS:
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)


def test_the_lab_scenes_are_found() -> None:
    assert len(SCENES) == 3  # one box (03 and 04), three boxes (05), five boxes (06)


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("label, scene, g, dt, steps", SCENES, ids=[s[0] for s in SCENES])
def test_lab_scene_stays_finite_and_observed(name: str, label: str, scene: Any, g: float, dt: float,
                                            steps: int) -> None:
    state = step(name, [{}], scene.build(), [steps], g, dt)
    assert np.isfinite(state.y).all() and np.isfinite(state.v).all()
    # observe ran after the steps: the peak covers the final depth, and touching boxes set the launch monitor
    # (a lone box that a position projection leaves exactly touching the floor after every step never
    # counts as touching, so that part is checked where boxes stack)
    assert state.peak_depth[0] >= state.penetration().max()
    if state.boxes > 1:
        assert state.touched[0].any()
        assert np.isfinite(state.launch[0])
    # and the boxes ended on the floor, not below it or far above it
    assert 0.0 < state.y[0, 0] < 1.0


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("config", ["03-sink.yaml", "06-stack.yaml"])
def test_runs_from_a_lab_config(name: str, config: str) -> None:
    spec = load(str(CONFIGS / config), [f"solver={{name: {name}}}"])
    result = run_experiment(spec)
    measures = result.runs[0].measures
    assert all(np.isfinite(measures[k]) for k in ("max_depth", "peak_depth", "rms_motion", "launch"))
    assert measures["peak_depth"] >= measures["max_depth"]


@pytest.mark.parametrize("name", NAMES)
def test_deterministic(name: str) -> None:
    scene = load(str(STACK)).runs[0].scene
    assert_same(step(name, [{}], scene.build(), [300]), step(name, [{}], scene.build(), [300]))


@pytest.mark.parametrize("name", NAMES)
def test_steps_in_chunks_equal_one_call(name: str) -> None:
    """What a solver remembers between steps survives between calls (the runner steps in chunks)."""
    scene = load(str(STACK)).runs[0].scene
    assert_same(step(name, [{}], scene.build(), [100, 1, 199]), step(name, [{}], scene.build(), [300]))


@pytest.mark.parametrize("name", NAMES)
def test_unknown_key_is_refused(name: str) -> None:
    with pytest.raises(ConfigError) as err:
        load(str(STACK), [f"solver={{name: {name}, no_such_knob: 1}}"])
    assert "solver.no_such_knob" in str(err.value) and "unknown key" in str(err.value)


@pytest.mark.parametrize("name", NAMES)
def test_bad_values_are_refused(name: str) -> None:
    fields = registry.solvers.get(name).Params.model_fields
    checked = [f for f, info in fields.items() if info.annotation is not str]
    assert checked, "a solver with parameters"
    for field in checked:
        with pytest.raises(ConfigError) as err:
            load(str(STACK), [f"solver={{name: {name}, {field}: not-a-value}}"])
        assert f"solver.{field}" in str(err.value)


def variants(name: str) -> list[dict[str, Any]]:
    """The defaults and up to two valid variants, each changing one number of the params."""
    params = registry.solvers.get(name).Params
    out: list[dict[str, Any]] = [{}]
    for field, info in params.model_fields.items():
        default = info.get_default(call_default_factory=True)
        if isinstance(default, bool) or not isinstance(default, (int, float)):
            continue
        for value in ((default + 1,) if isinstance(default, int) else (default * 0.5, default * 2) if default
                      else (0.1,)):
            try:
                params.model_validate({field: value})
            except ValueError:
                continue
            out.append({field: value})
            break
        if len(out) == 3:
            break
    return out


@pytest.mark.parametrize("name", NAMES)
def test_batch_rows_equal_single_runs(name: str) -> None:
    scene = load(str(STACK)).runs[0].scene
    rows = variants(name)
    assert len(rows) >= 2, "no numeric knob to vary"
    batch = step(name, rows, ColumnState.concat([scene.build() for _ in rows]), [300])
    for b, row in enumerate(rows):
        assert_same(batch.row(b), step(name, [row], scene.build(), [300]))
    assert any(not np.array_equal(batch.y[0], batch.y[b]) for b in range(1, len(rows))), \
        "the variants should change something"


@pytest.mark.skipif(not kernel.available() or kernel.mode() == kernel.PLAIN, reason="numba not in use")
@pytest.mark.parametrize("name", NAMES)
def test_compiled_and_plain_give_the_same_numbers(name: str) -> None:
    scene = load(str(STACK)).runs[0].scene
    with kernel.compiled(False):
        plain = step(name, [{}], scene.build(), [300])
    with kernel.compiled(True):
        fast = step(name, [{}], scene.build(), [300])
    assert_same(plain, fast)
