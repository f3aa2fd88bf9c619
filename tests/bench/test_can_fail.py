"""Every criterion can fail, on a real run through ``stackx bench``, with the failing value recomputed here.

- holds, by gap: boxes floating 5 cm apart with no gravity (a column resting on air, as an engine's contact
  skin leaves it): every depth is 0, the gap is the scene's own 0.05 m;
- settled: one box still falling at the end, its motion over the last 60 steps from the integration rule
  (v += g dt, y += v dt) written out here;
- never launched, from positions: a box spawned 0.25 m into the floor, the lab solver with percent 1.0: its
  velocity stays 0 while the correction lifts it by depth - slop in one step.
(A crushed run is checked against the lab's plain transcription in ``test_error``.)
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import REPO
from tests.limits import hang_limit

G, DT = -9.8, 1 / 60
CASES = {
    "floating": f"""
scene: {{name: column, stack: {{count: 3, y0: 0.55, spacing: 1.05}}}}
solver: {{name: exact}}
gravity: 0.0
steps: 120
""",
    "falling": f"""
scene: {{name: column, boxes: [{{y: 1000.0}}]}}
solver: {{name: exact}}
steps: 120
""",
    "thrown": f"""
scene: {{name: column, boxes: [{{y: 0.25}}]}}
solver: {{name: pgs, iterations: 15, correction: {{slop: 0.01, percent: 1.0}}}}
steps: 120
""",
}


@pytest.fixture(scope="module")
def records(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict]:
    tmp = tmp_path_factory.mktemp("fail")
    for name, text in CASES.items():
        (tmp / f"{name}.yaml").write_text(text + "dt: 1/60\nbench: {timing: {steps: 5, repeats: 1}}\n")
    done = subprocess.run([sys.executable, "-m", "stackx", "bench", str(tmp), "--solvers", "exact,pgs", "--out",
                           str(tmp / "out"), "-q"], cwd=REPO, capture_output=True, text=True, timeout=hang_limit(300))
    assert done.returncode == 0, done.stderr
    doc = json.loads((tmp / "out" / "bench.json").read_text())
    return {c["name"]: next(r for r in c["records"] if r["solver"] == ("pgs" if c["name"] == "thrown" else "exact")
                            and r["value"] in (None, 15)) for c in doc["cases"]}


def _failing(rec: dict) -> set[str]:
    return {name for name, v in rec["criteria"].items() if not v["passed"]}


def test_a_column_resting_on_air_fails_holds_by_its_gap(records: dict[str, dict]) -> None:
    rec = records["floating"]
    assert rec["measures"]["max_gap"] == pytest.approx(0.05, abs=1e-12)  # 1.05 - 2 x 0.5, and 0.55 - 0.5
    assert rec["measures"]["max_depth"] == 0.0
    assert _failing(rec) == {"holds"}
    assert rec["measures"]["top_rest_error"] == pytest.approx(3 * 0.05, abs=1e-12)  # three gaps under the top
    assert rec["criteria"]["holds"]["failing"] == "max_gap 0.05 > 0.02; |top_rest_error| 0.15 > 0.045"


def test_a_box_still_falling_is_not_settled(records: dict[str, dict]) -> None:
    v, heights = 0.0, [1000.0]
    for _ in range(120):
        v += G * DT
        heights.append(heights[-1] + v * DT)
    window = heights[-61:]
    motion = math.sqrt(sum(((b - a) / DT) ** 2 for a, b in zip(window, window[1:])) / 60)
    rec = records["falling"]
    assert rec["measures"]["rms_motion"] == pytest.approx(motion, rel=1e-12)
    assert "settled" in _failing(rec)
    assert rec["measures"]["steps_to_settle"] is None


def test_a_position_correction_that_throws_a_box_up_launches_it(records: dict[str, dict]) -> None:
    """Stored velocity 0 throughout, yet the box rose (0.25 - 0.01) m in the first step: 14.4 m/s."""
    rec = records["thrown"]
    assert rec["measures"]["launch"] == pytest.approx((0.25 - 0.01) / DT, rel=1e-9)
    assert "never_launched" in _failing(rec)
    assert rec["criteria"]["never_launched"]["failing"] == "launch 14.4 > 1"
