"""The planar model plugin: registered with its scene, its health check naming the body that went wrong, runs
from YAML, and the same numbers plain and compiled."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from stackx import api, registry
from stackx.errors import ConfigError
from stackx.models.planar.state import PlanarState
from tests.conftest import Cli

CONFIG = """description: three boxes, the top one shifted, settling under the lab's rules
scene:
  name: planar
  stack: {count: 3, offset: 0.1, seed: 5, gap: 0.002}
solver: {name: planar-pgs, iterations: 10}
dt: 1/60
steps: 90
outputs:
  - {sink: metrics, path: three.metrics.json}
"""


def _state(n: int = 3) -> PlanarState:
    row = lambda values: np.array([values], dtype=np.float64)  # noqa: E731
    zeros = row([0.0] * n)
    return PlanarState(row([float(i) * 2 for i in range(n)]), row([0.5] * n), zeros, zeros.copy(), zeros.copy(),
                       zeros.copy(), row([1.0] * n), row([6.0] * n), row([0.3] * n), row([0.4] * n), row([0.5] * n))


def test_the_planar_scene_builds_the_planar_model_whose_reference_is_planar_exact() -> None:
    model = registry.models.get("planar")
    assert registry.scenes.get("planar").model == "planar"
    assert model.reference == "planar-exact" and model.State is PlanarState
    assert {"x", "y", "angle", "vx", "vy", "w"} == set(model.VECTORS)
    assert {"max_depth", "peak_depth", "reach", "launch", "rms_motion", "unsolved_steps", "first_unsolved",
            "worst_unsolved"} == set(model.SCALARS)


def test_offender_names_the_first_non_finite_body() -> None:
    model = registry.models.get("planar")
    s = _state()
    assert model.offender(s, 1000.0) is None
    s.w[0, 2] = np.nan
    s.angle[0, 1] = np.inf
    row, body, cause, detail = model.offender(s, 1000.0)
    assert (row, body, cause) == (0, 1, "non-finite") and "angle = inf" in detail


def test_offender_counts_rotation_in_a_body_speed() -> None:
    model = registry.models.get("planar")
    s = _state()
    s.vx[0, 0], s.vy[0, 0] = 3.0, 4.0  # 5 m/s
    s.w[0, 0] = 10.0  # its corners, 0.5 m from the centre (0.3, 0.4 half-sizes), add 5 m/s
    assert model.offender(s, 10.0) is None
    s.w[0, 0] = 10.1
    row, body, cause, detail = model.offender(s, 10.0)
    assert (row, body, cause) == (0, 0, "speed") and "10.05 m/s" in detail
    assert model.motion(s, 0)["w"] == [10.1, 0.0, 0.0]


def test_a_column_solver_is_refused_on_a_planar_scene(tmp_path: Path) -> None:
    config = tmp_path / "three.yaml"
    config.write_text(CONFIG.replace("name: planar-pgs", "name: pgs"))
    with pytest.raises(ConfigError) as caught:
        api.load(config)
    assert "solver 'pgs' steps column scenes, not 'planar' (scene 'planar')" in str(caught.value)


def test_a_planar_run_writes_its_measures_the_same_plain_and_compiled(cli: Cli, tmp_path: Path) -> None:
    config = tmp_path / "three.yaml"
    config.write_text(CONFIG)
    docs = []
    for jit in ("0", "1"):
        done = cli("run", config, "--out", tmp_path / jit, "-q", env={"STACKX_JIT": jit})
        assert done.returncode == 0, done.stderr
        docs.append((tmp_path / jit / "three.metrics.json").read_bytes())
    assert docs[0] == docs[1]
    run = json.loads(docs[0])["runs"]["main"]
    assert run["boxes"] == 3 and run["steps"] == 90
    assert len(run["x"]) == len(run["angle"]) == 3
    # the three boxes came to rest on each other: from the top box's height down, within the lab's depths
    assert run["y"][2] == pytest.approx(2.5 + 3 * 0.002, abs=3 * 0.02)
    assert max(abs(a) for a in run["angle"]) < 0.05 and run["max_depth"] < 0.02  # none toppled
    assert math.isfinite(run["rms_motion"])


def test_a_planar_scene_starting_faster_than_max_speed_is_refused_at_load(tmp_path: Path) -> None:
    config = tmp_path / "fast.yaml"
    config.write_text(CONFIG.replace("stack: {count: 3, offset: 0.1, seed: 5, gap: 0.002}",
                                     "boxes: [{y: 3.0, vx: 30.0, vy: 40.0, w: 4.0}]")
                      + "limits: {max_speed: 52}\n")
    with pytest.raises(ConfigError) as caught:
        api.load(config)  # 50 m/s at the centre, 4 rad/s x 0.707 m at the corners: 52.83 m/s
    assert (f"run 'main' starts with box 0 that moves at {50 + 4 * math.sqrt(0.5):.4g} m/s (centre and rotation), "
            "over limits.max_speed = 52") in str(caught.value)
    config.write_text(config.read_text().replace("max_speed: 52", "max_speed: 53"))
    api.load(config)
