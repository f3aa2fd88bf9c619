"""Blow-ups stop with exit 1 naming step, run, box and solver; partial measures are kept; good files stay."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

from tests.conftest import Cli

G, DT = -9.8, 1 / 60

FAST = """\
scene:
  name: column
  boxes: [{y: 1000.0, v: -50.0}, {y: 1010.0}]
solver: {name: pgs}
dt: 1/60
steps: 600
limits: {max_speed: LIMIT}
outputs:
  - {sink: keyvalue, path: fast.txt, values: {bottom: "y[0]"}}
  - {sink: metrics, path: fast.metrics.json}
"""

# a solver that falls freely and puts NaN into one box at a chosen step: memory in an array attribute
NAN_AT = '''
import numpy as np
from pydantic import BaseModel, ConfigDict
from stackx.models.column.monitor import observe
from stackx.registry import solvers
from stackx.solvers.base import Solver


class NanAtParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    at: int
    box: int


@solvers.register("nan-at")
class NanAt(Solver):
    """Free fall, then NaN in box ``box`` at step ``at``."""
    Params = NanAtParams

    def __init__(self, params, gravity, dt):
        super().__init__(params, gravity, dt)
        self.count = np.zeros(1, dtype=np.int64)

    def advance(self, state, steps):
        for _ in range(steps):
            self.count[0] += 1
            for b, p in enumerate(self.params):
                state.v[b] += self.gravity[b] * self.dt[b]
                state.y[b] += state.v[b] * self.dt[b]
                if self.count[0] == p.at:
                    state.y[b, p.box] = np.nan
                observe(state.y[b], state.half[b], self.dt[b], *state.monitors(), b)
'''


def _free_fall(v0: float, steps: int) -> float:
    """Velocity after ``steps`` lab steps of free fall (v += g*dt each step), by plain repetition."""
    v = v0
    for _ in range(steps):
        v += G * DT
    return v


def _first_step_over(v0: float, limit: float) -> int:
    k = 0
    v = v0
    while abs(v) <= limit:
        k += 1
        v += G * DT
    return k


def test_speed_limit_names_the_step_and_keeps_good_files(cli: Cli, tmp_path: Path) -> None:
    config, out = tmp_path / "fast.yaml", tmp_path / "out"
    config.write_text(FAST.replace("LIMIT", "1000"))
    assert cli("run", config, "--out", out, "-q").returncode == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    config.write_text(FAST.replace("LIMIT", "60"))
    done = cli("run", config, "--out", out, "-q")
    step = _first_step_over(-50.0, 60.0)
    assert step == 62  # (60 - 50) / (9.8 / 60) = 61.2 steps
    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr
    [line] = done.stderr.strip().splitlines()
    assert f"run 'main' blew up at step {step} of 600: box 0 moves at" in line
    assert "over limits.max_speed = 60 m/s" in line and "solver 'pgs' (built-in)" in line
    assert line.startswith(f"error: {config}: ")

    failed = out / "fast.failed.json"
    assert str(failed) in line
    report = json.loads(failed.read_text())
    assert (report["status"], report["step"], report["run"], report["box"], report["solver"], report["cause"]) == (
        "FAILED", step, "main", 0, "pgs", "speed")
    main = report["runs"]["main"]
    assert main["steps_done"] == step - 1
    assert abs(main["measures"]["v"][0] - _free_fall(-50.0, step - 1)) < 1e-9
    assert abs(main["after_failing_step"]["v"][0] - _free_fall(-50.0, step)) < 1e-9

    after = {p.name: p.read_bytes() for p in out.iterdir() if p.name != failed.name}
    assert after == before  # artifacts, manifest and timing of the good run untouched

    config.write_text(FAST.replace("LIMIT", "1000"))
    assert cli("run", config, "--out", out, "-q").returncode == 0
    assert not failed.exists()  # a later good run clears the failure mark


def test_nan_is_traced_to_its_step_inside_a_long_call(cli: Cli, tmp_path: Path) -> None:
    plugins = tmp_path / "plugins"
    plugins.mkdir()
    (plugins / "nan_at.py").write_text(NAN_AT)
    config = tmp_path / "nan.yaml"
    config.write_text(textwrap.dedent("""\
        scene: {name: column, stack: {count: 3, y0: 5000.0, spacing: 2.0}}
        solver: {name: nan-at, at: 437, box: 1}
        steps: 700
        limits: {max_speed: 100000}
        outputs: [{sink: metrics, path: nan.metrics.json}]
        """))
    out = tmp_path / "out"
    done = cli("run", config, "--out", out, "-q")
    assert done.returncode == 1, done.stderr
    imported, line = done.stderr.strip().splitlines()
    assert imported == f"plugins: imported nan_at.py from {plugins}"
    # step 437 lies inside the first call (steps 1..500): found by replaying that call step by step
    assert "run 'main' blew up at step 437 of 700: box 1 is not finite (y = nan" in line
    assert f"solver 'nan-at' ({plugins / 'nan_at.py'})" in line
    report = json.loads((out / "nan.failed.json").read_text())
    assert report["runs"]["main"]["steps_done"] == 436
    assert report["runs"]["main"]["after_failing_step"]["y"][1] == "nan"
    assert not (out / "nan.metrics.json").exists()
