"""The measures the bench adds to a run's own: the top box's rest-height error, its end and whole-run motion."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from stackx.models.column.measures import extra_measures, top_motion
from stackx.config.experiment import load
from stackx.run.results import RunResult
from stackx.models.column.state import ColumnState

DT = 0.1
TOP = [3.0, 2.0, 1.2, 1.4, 1.45, 1.3, 1.3, 1.35]  # falls, touches at 1.2 (box 0 at 0.5), bounces, rests


def _result(tmp: Path, tops: list[float]) -> RunResult:
    config = tmp / "two.yaml"
    config.write_text(f"""
scene: {{name: column, boxes: [{{y: 0.5}}, {{y: {tops[0]}}}]}}
solver: {{name: pgs}}
dt: {DT}
steps: {len(tops) - 1}
""")
    run = load(str(config)).runs[0]
    frames = {k: ColumnState(np.array([[0.5, y]]), np.zeros((1, 2)), np.ones((1, 2)), np.full((1, 2), 0.5))
              for k, y in enumerate(tops)}
    return RunResult(run, frames[len(tops) - 1], frames, {})


def test_top_motion_counts_direction_changes_after_touching(tmp_path: Path) -> None:
    """From the first overlap (1.2: moves +0.2, +0.05, -0.15, 0, +0.05): up, down, up again is 2 changes of
    direction; the standing-still step is skipped; the fastest rise is 0.2 m in one step of 0.1 s."""
    got = top_motion(_result(tmp_path, TOP))
    assert got["top_reversals"] == 2
    assert got["top_rise"] == pytest.approx(2.0)


def test_a_box_that_never_lands_has_no_motion_counted(tmp_path: Path) -> None:
    got = top_motion(_result(tmp_path, [5.0, 4.0, 5.0, 4.0]))
    assert got == {"top_reversals": 0.0, "top_rise": 0.0}


def test_rest_height_error_and_final_peak_to_peak(tmp_path: Path) -> None:
    """Two boxes of half-height 0.5: the top rests at 1.5 on a rigid column. The run is shorter than the
    motion window, so the peak-to-peak spans the whole fall, 3.0 down to 1.2."""
    got = extra_measures(_result(tmp_path, TOP))
    assert got["top_rest_error"] == pytest.approx(1.35 - 1.5)
    assert got["top_p2p"] == pytest.approx(3.0 - 1.2)
    assert got["boxes"] == 2
