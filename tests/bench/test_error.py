"""The error against the exact solver, recomputed from scratch: the lab step and a brute-force exact solve."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from tests.bench import reference as ref
from tests.conftest import Cli
from tests.limits import hang_limit

BOXES = [{"y": 0.501}, {"y": 1.3}, {"y": 2.6, "mass": 3.0}, {"y": 3.9}]  # boxes landing on each other
STEPS = 150


@pytest.fixture(scope="module")
def doc(tmp_path_factory: pytest.TempPathFactory) -> dict:
    import subprocess
    import sys

    from tests.conftest import REPO

    tmp = tmp_path_factory.mktemp("error")
    boxes = "\n".join(f"    - {{{', '.join(f'{k}: {v}' for k, v in b.items())}}}" for b in BOXES)
    (tmp / "landing.yaml").write_text(f"""
scene:
  name: column
  boxes:
{boxes}
solver: {{name: pgs, iterations: 15}}
dt: 1/60
steps: {STEPS}
bench:
  knob: [1, 3, 30]
  timing: {{steps: 20, repeats: 1}}
""")
    done = subprocess.run([sys.executable, "-m", "stackx", "bench", str(tmp / "landing.yaml"), "--solvers",
                           "pgs,exact", "--out", str(tmp / "out"), "-q"], cwd=REPO, capture_output=True, text=True,
                          timeout=hang_limit(300))
    assert done.returncode == 0, done.stderr
    return json.loads((tmp / "out" / "bench.json").read_text())


def _record(doc: dict, solver: str, value: int | None) -> dict:
    (case,) = doc["cases"]
    return next(r for r in case["records"] if r["solver"] == solver and r["value"] == value)


def _every_step(history: list[tuple[list[float], list[float]]], inv: list[float], half: list[float],
                speculative: float) -> dict:
    """RMS, largest difference and its step, over every step of a run given as the (y, v) before each step
    and after the last, against the brute-force exact step; the steps stop before the first one after which a
    box is more than half-way into its neighbour (the run is crushed there)."""
    diffs, worst, worst_step, crushed_at = [], -1.0, None, None
    for k in range(len(history) - 1):
        y, v = history[k]
        after = history[k + 1][0]
        depth = [half[0] - after[0]] + [half[i] + half[i + 1] - (after[i + 1] - after[i]) for i in range(len(y) - 1)]
        thinner = [half[0]] + [min(half[i], half[i + 1]) for i in range(len(y) - 1)]
        if any(d / h > 1.0 for d, h in zip(depth, thinner)):
            crushed_at = k + 1
            break
        exact = ref.exact_velocities(y, v, inv, half, -9.8, 1 / 60, speculative)
        step = [abs(a - b) for a, b in zip(history[k + 1][1], exact)]
        diffs += step
        if max(step) > worst:
            worst, worst_step = max(step), k
    return {"rms": math.sqrt(sum(d * d for d in diffs) / len(diffs)), "max": worst, "worst_step": worst_step,
            "steps": len(diffs) // len(history[0][0]), "crushed_at": crushed_at}


@pytest.mark.parametrize("iterations", [1, 3, 30])
def test_error_is_the_rms_distance_to_the_exact_step_at_every_step_of_the_solvers_own_path(
        doc: dict, iterations: int) -> None:
    rec = _record(doc, "pgs", iterations)
    run = ref.lab_run(BOXES, STEPS, iterations)
    want = _every_step(run.history + [(run.y, run.v)], run.inv, run.half, 0.0)
    assert rec["crushed_at"] == want["crushed_at"]
    assert (want["crushed_at"] is not None) is (iterations == 1)  # one pass lets the heavy box through
    assert rec["error"]["steps"] == want["steps"] == (STEPS if want["crushed_at"] is None else want["crushed_at"] - 1)
    assert rec["error"]["worst_step"] == want["worst_step"]
    assert rec["error"]["rms"] == pytest.approx(want["rms"], rel=1e-9, abs=1e-12)
    assert rec["error"]["max"] == pytest.approx(want["max"], rel=1e-9, abs=1e-12)


DROP = [{"y": 2.5}, {"y": 4.1}, {"y": 5.7}, {"y": 7.3}, {"y": 8.9, "v": -50.0}]  # configs/hard/drop-fast.yaml
DROP_STEPS = 60


def test_the_error_of_a_fast_drop_includes_its_impact(tmp_path: Path) -> None:
    """drop-fast, shortened: warm-start at 16 iterations, measured by the bench and recomputed here from its
    recorded path with the brute-force exact step (its own 0.02 m speculative margin). The impact, a few steps
    of the run, is the worst step and carries most of the error."""
    import subprocess
    import sys

    from stackx.config.experiment import load
    from stackx.run.runner import run_experiment
    from tests.conftest import REPO

    boxes = "\n".join(f"    - {{{', '.join(f'{k}: {v}' for k, v in b.items())}}}" for b in DROP)
    config = tmp_path / "drop.yaml"
    config.write_text(f"""
scene:
  name: column
  boxes:
{boxes}
solver: {{name: warm-start, iterations: 16}}
dt: 1/60
steps: {DROP_STEPS}
bench: {{knob: [16], timing: {{steps: 5, repeats: 1}}}}
""")
    done = subprocess.run([sys.executable, "-m", "stackx", "bench", str(config), "--solvers", "warm-start",
                           "--out", str(tmp_path / "out"), "-q"], cwd=REPO, capture_output=True, text=True,
                          timeout=hang_limit(300))
    assert done.returncode == 0, done.stderr
    (rec,) = json.loads((tmp_path / "out" / "bench.json").read_text())["cases"][0]["records"]
    result = run_experiment(load(str(config)), record=set(range(DROP_STEPS + 1))).runs[0]
    history = [(result.frames[k].y[0].tolist(), result.frames[k].v[0].tolist()) for k in range(DROP_STEPS + 1)]
    inv, half = result.final.inv_mass[0].tolist(), result.final.half[0].tolist()
    want = _every_step(history, inv, half, 0.02)
    assert rec["error"]["worst_step"] == want["worst_step"]
    assert rec["error"]["rms"] == pytest.approx(want["rms"], rel=1e-9)
    assert rec["error"]["max"] == pytest.approx(want["max"], rel=1e-9)
    assert want["max"] > 1.0 and want["rms"] > 0.05  # the impact: metres per second, not microns


def test_error_falls_with_iterations_and_exact_has_none(doc: dict) -> None:
    errors = [_record(doc, "pgs", n)["error"]["rms"] for n in (1, 3, 30)]
    assert errors[0] > errors[1] > errors[2]
    assert _record(doc, "exact", None)["error"]["rms"] < 1e-12
