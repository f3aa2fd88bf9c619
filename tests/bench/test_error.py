"""The error against the exact solver, recomputed from scratch: the lab step and a brute-force exact solve."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from tests.bench import reference as ref
from tests.conftest import Cli

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
  samples: 12
  timing: {{steps: 20, repeats: 1}}
""")
    done = subprocess.run([sys.executable, "-m", "stackx", "bench", str(tmp / "landing.yaml"), "--solvers",
                           "pgs,exact", "--out", str(tmp / "out"), "-q"], cwd=REPO, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    return json.loads((tmp / "out" / "bench.json").read_text())


def _record(doc: dict, solver: str, value: int | None) -> dict:
    (case,) = doc["cases"]
    return next(r for r in case["records"] if r["solver"] == solver and r["value"] == value)


@pytest.mark.parametrize("iterations", [1, 3, 30])
def test_error_is_the_rms_distance_to_the_exact_step_along_the_solvers_own_path(doc: dict, iterations: int) -> None:
    rec = _record(doc, "pgs", iterations)
    steps = rec["error"]["steps"]
    assert len(steps) == 12 and steps[0] == 0 and steps[-1] == STEPS - 1
    run = ref.lab_run(BOXES, STEPS, iterations)
    history = run.history + [(run.y, run.v)]
    diffs = []
    for k in steps:
        y, v = history[k]
        exact = ref.exact_velocities(y, v, run.inv, run.half, -9.8, 1 / 60)
        diffs += [a - b for a, b in zip(history[k + 1][1], exact)]
    rms = math.sqrt(sum(d * d for d in diffs) / len(diffs))
    assert rec["error"]["rms"] == pytest.approx(rms, rel=1e-9, abs=1e-12)
    assert rec["error"]["max"] == pytest.approx(max(abs(d) for d in diffs), rel=1e-9, abs=1e-12)


def test_error_falls_with_iterations_and_exact_has_none(doc: dict) -> None:
    errors = [_record(doc, "pgs", n)["error"]["rms"] for n in (1, 3, 30)]
    assert errors[0] > errors[1] > errors[2]
    assert _record(doc, "exact", None)["error"]["rms"] < 1e-12
