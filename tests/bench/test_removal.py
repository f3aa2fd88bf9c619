"""Taking a box away during a run: the scene's ``remove`` events, the runner's split, the solver's memory."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from stackx.config.experiment import load
from stackx.run.runner import run_experiment
from tests.bench import reference as ref
from tests.conftest import Cli

HEAVY_TOP = [{"y": 0.501}, {"y": 1.501}, {"y": 2.501}, {"y": 3.501, "mass": 10.0}]


def _boxes_yaml(boxes: list[dict[str, float]]) -> str:
    return "\n".join(f"    - {{{', '.join(f'{k}: {v}' for k, v in b.items())}}}" for b in boxes)


def _config(tmp: Path, remove: str, steps: int = 200, runs: str = "", solver: str = "pgs") -> Path:
    path = tmp / "removal.yaml"
    path.write_text(f"""
scene:
  name: column
  boxes:
{_boxes_yaml(HEAVY_TOP)}
  remove: {remove}
solver: {{name: {solver}, iterations: 15}}
dt: 1/60
steps: {steps}
{runs}
outputs:
  - sink: metrics
    path: removal.json
""")
    return path


@pytest.mark.parametrize("box, index", [(-1, 3), (1, 1)])
def test_run_with_removal_matches_the_plain_lab_step(cli: Cli, tmp_path: Path, box: int, index: int) -> None:
    """The top box (or a middle one, after which its neighbours face each other) vanishes before step 100."""
    config = _config(tmp_path, f"[{{step: 100, box: {box}}}]")
    done = cli("run", config, "--out", tmp_path / "out", "-q")
    assert done.returncode == 0, done.stderr
    got = json.loads((tmp_path / "out" / "removal.json").read_text())["runs"]["main"]
    want = ref.lab_run(HEAVY_TOP, 200, 15, removals={100: index})
    assert len(got["y"]) == 3
    assert got["y"] == pytest.approx(want.y, abs=1e-12)
    assert got["v"] == pytest.approx(want.v, abs=1e-12)


def test_runs_with_and_without_removal_are_not_batched_together(tmp_path: Path) -> None:
    spec = load(str(_config(tmp_path, "[{step: 100}]", runs="runs: {kept: {scene.remove: []}, lifted: {}}")))
    result = run_experiment(spec)
    kept, lifted = result.run("kept"), result.run("lifted")
    assert kept.final.boxes == 4 and lifted.final.boxes == 3
    assert kept.final.y[0].tolist() == pytest.approx(ref.lab_run(HEAVY_TOP, 200, 15).y, abs=1e-12)
    assert lifted.final.y[0].tolist() == pytest.approx(ref.lab_run(HEAVY_TOP, 200, 15, removals={100: 3}).y,
                                                       abs=1e-12)
    assert lifted.frames[100].boxes == 3  # the state kept before step 100 is the one after the removal


def test_solver_memory_follows_the_removed_box(tmp_path: Path) -> None:
    """Warm-started impulses: the contact under the removed box goes, the one above it becomes the contact
    between the two neighbours and keeps its impulse (it carried the same load); the others keep theirs."""
    spec = load(str(_config(tmp_path, "[{step: 100, box: 1}]", solver="warm-start")))
    run = spec.runs[0]
    state = run.scene.build()
    solver = run.solver_cls([run.solver_params], np.array([run.gravity]), np.array([run.dt]))
    solver.advance(state, 100)
    impulse = solver.impulse.copy()
    assert (impulse[0] > 0).all()  # a resting column: every contact carries load
    peak, launch = state.peak_depth.copy(), state.launch.copy()
    (event,) = run.scene.events()
    event.apply(state, solver)
    assert solver.impulse[0].tolist() == [impulse[0, 0], impulse[0, 2], impulse[0, 3]]
    assert state.boxes == 3 and state.touched.shape == (1, 3)
    assert state.inv_mass[0].tolist() == [1.0, 1.0, 0.1]
    assert state.peak_depth.tolist() == peak.tolist() and state.launch.tolist() == launch.tolist()
    solver.advance(state, 10)  # steps on with the remembered impulses, shapes agreeing
    assert np.isfinite(state.y).all()


@pytest.mark.parametrize("remove, key, message", [
    ("[{step: 150}]", "scene.remove[0].step", "too late"),
    ("[{step: 50, box: 4}]", "scene.remove", "box 4 does not exist"),
    ("[{step: 50}, {step: 50}]", "scene.remove", "steps must increase"),
    ("[{step: 10}, {step: 20}, {step: 30}, {step: 40}]", "scene.remove", "cannot take away the last box"),
])
def test_bad_removals_are_refused_before_running(cli: Cli, tmp_path: Path, remove: str, key: str,
                                                 message: str) -> None:
    config = _config(tmp_path, remove)
    done = cli("run", config, "--out", tmp_path / "out", "-q")
    assert done.returncode == 2
    line = done.stderr.strip()
    assert line.startswith(f"error: {config}:") and f" {key}:" in line and message in line, line
    assert not (tmp_path / "out").exists()
