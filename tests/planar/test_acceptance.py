"""The planar model's standing test: the shipped 20-row pyramid and 40-box stack, each with the solver and
settings its config names, stand for 10 s at 60 Hz. Every figure is computed here from the recorded states,
against the scene's own start: no box moves sideways more than the bench's drift limit or turns more than its
turn limit, none ever overlaps another by more than twice the lab's slop, and the top box ends where a rigid
pile would hold it, within the lab's depth allowance per contact."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stackx import api, kernel
from tests.conftest import CONFIGS

DRIFT = 0.05  # m: criteria.drift, the bench's limit on a resting box's sideways motion
TURN = 0.05  # rad: criteria.turn
SLOP = 0.01  # m: the lab's slop


@pytest.mark.parametrize("case, boxes, rows", [("pyramid-20", 210, 20), ("stack-40", 40, 40)])
def test_the_shipped_pile_stands_for_ten_seconds(case: str, boxes: int, rows: int) -> None:
    spec = api.load(CONFIGS / "planar" / f"{case}.yaml")
    steps = spec.runs[0].steps
    assert steps * spec.runs[0].dt == pytest.approx(10.0)  # 600 steps at 60 Hz
    with kernel.compiled(True):
        run = api.run(spec, steps=[0, steps])["main"]
    x, y, angle = run.states["x"], run.states["y"], run.states["angle"]
    assert x.shape == (2, boxes)
    drift = np.abs(x[1] - x[0]).max()
    turn = np.abs(angle[1] - angle[0]).max()
    assert drift < DRIFT and turn < TURN, (drift, turn)
    # unit boxes: the highest rests on `rows` contacts (the ground's included), each at most 2 x slop deep
    top = y[1].max()
    assert rows - 0.5 - rows * 2 * SLOP <= top <= rows - 0.5 + 1e-9, top
    assert run.measures["peak_depth"] < 2 * SLOP and math.isfinite(run.measures["rms_motion"])
