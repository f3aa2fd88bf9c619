"""The engine solvers on the lab's scenes and hard cases, from the configs with only the solver changed, against
each engine driven directly (``tests.engines.drivers``): same final heights and velocities, and the measures
stackx takes from the engine's heights are those of the driver's trajectory."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from stackx.config.experiment import load
from stackx.run.runner import run_experiment
from tests.conftest import CONFIGS
from tests.engines.drivers import DRIVERS, peak_depth, read_column
from tests.engines.need import engine_params
from tests.engines.planar_drivers import PLANAR_DRIVERS, read_scene

# Box2D computes in float32: the same column with the floor placed another way (another body origin) rounds
# differently, a few ulps of a height (1e-7 m at 5 m), which 900 steps grow to about 1e-6 m
TOLERANCE = {"pymunk": 1e-9, "mujoco": 1e-9, "box2d": 1e-5, "box2d-v3": 1e-5}

CASES = [CONFIGS / "06-stack.yaml", CONFIGS / "hard" / "tall-20.yaml", CONFIGS / "hard" / "ratio-100.yaml",
         CONFIGS / "hard" / "load-removal.yaml"]


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # pybox2d's SWIG types, on import
@pytest.mark.parametrize("engine", engine_params())
@pytest.mark.parametrize("config", CASES, ids=[p.stem for p in CASES])
def test_engine_agrees_with_driving_it_directly(engine: str, config: Path) -> None:
    spec = load(str(config), [f"solver={{name: {engine}}}"])
    result = run_experiment(spec).runs[0]
    column = read_column(config)
    assert result.spec.steps == column.steps and result.spec.dt == column.dt
    direct = DRIVERS[engine](column)
    assert result.final.y.shape == (1, len(column.y) - len(column.removals))
    tol = TOLERANCE[engine]
    np.testing.assert_allclose(result.final.y[0], direct.y, rtol=0, atol=tol)
    np.testing.assert_allclose(result.final.v[0], direct.v, rtol=0, atol=10 * tol)
    # the depths are stackx's, from the engine's heights: the final ones and the deepest along the way
    half, y = direct.halves[-1], direct.y
    final = np.concatenate([[half[0] - y[0]], (half[:-1] + half[1:]) - (y[1:] - y[:-1])])
    assert result.measures["max_depth"] == pytest.approx(max(float(final.max()), 0.0), abs=2 * tol)
    assert result.measures["peak_depth"] == pytest.approx(peak_depth(direct), abs=2 * tol)


PLANAR_STEPS = 40  # enough for every contact to load and the ramp's box to start sliding, few enough to stay fast
# Box2D computes in float32; Box2D v3's own angle (b2Rot_GetAngle, what the driver reads) is an approximation of
# atan2 within about 1e-4 rad, where stackx takes atan2 of the engine's rotation
PLANAR_TOLERANCE = {"pymunk": 1e-9, "mujoco": 1e-9, "box2d": 1e-5, "box2d-v3": 1e-4}
PLANAR = [CONFIGS / "planar" / f"{name}.yaml" for name in ("pyramid-10", "card-house", "ramp-stick", "ramp-slide")]


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # pybox2d's SWIG types, on import
@pytest.mark.parametrize("engine", engine_params())
@pytest.mark.parametrize("config", PLANAR, ids=[p.stem for p in PLANAR])
def test_planar_engine_agrees_with_driving_it_directly(engine: str, config: Path) -> None:
    """The shipped planar configs with only the solver changed (and the run shortened, outputs off): the poses
    and velocities stackx holds after the run are the engine's own, driven directly."""
    spec = load(str(config), [f"solver={{name: {engine}}}", f"steps={PLANAR_STEPS}", "outputs=[]"])
    final = run_experiment(spec).runs[0].final
    direct = PLANAR_DRIVERS[engine](read_scene(config, PLANAR_STEPS))
    movable = final.inv_mass[0] != 0.0
    ours = np.stack([getattr(final, k)[0, movable] for k in ("x", "y", "angle", "vx", "vy", "w")], axis=1)
    assert ours.shape == direct.shape
    tol = PLANAR_TOLERANCE[engine]
    np.testing.assert_allclose(ours[:, :3], direct[:, :3], rtol=0, atol=tol)
    np.testing.assert_allclose(ours[:, 3:], direct[:, 3:], rtol=0, atol=10 * tol)
    # the run did move the boxes (a pile settles into its contacts, the ramp's box slides or sinks in)
    start = spec.runs[0].scene.build()
    assert np.abs(final.y[0, movable] - start.y[0, movable]).max() > 1e-6
