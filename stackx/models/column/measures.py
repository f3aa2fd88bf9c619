"""Measures of finished runs, computed from the recorded states of their batch.

Every measure is deterministic (no clocks), so files built from them are byte-identical from run to run.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from stackx.models.column.state import ColumnState
from stackx.models.touch import TOUCH_GAP

if TYPE_CHECKING:
    from stackx.run.results import RunResult

MOTION_WINDOW = 60  # steps over which the final motion is measured

SCALARS = {
    "max_depth": "largest contact penetration in the final state (m)",
    "peak_depth": "largest contact depth after any step of the run (m)",
    "reach": "largest depth after any step as a share of the thinner box's half-height (>1: passed half-way)",
    "launch": "fastest upward velocity of a box after it first touched something (overlapping, at zero depth "
              "or at most 2 cm apart) (m/s)",
    "rms_motion": f"RMS of the boxes' actual motion (y_now - y_prev)/dt over the last {MOTION_WINDOW} steps (m/s)",
}
VECTORS = {
    "y": "final centre heights, bottom box first (m)",
    "v": "final velocities (m/s)",
    "depth": "final penetration of each contact, 0 = floor, k = boxes k-1 and k (m, 0 when apart)",
}


def motion_steps(steps: int) -> range:
    """The steps whose states ``rms_motion`` needs: the last ``MOTION_WINDOW`` + 1."""
    return range(max(0, steps - MOTION_WINDOW), steps + 1)


def rms_motion(frames: Mapping[int, ColumnState], steps: int, dt: np.ndarray) -> np.ndarray:
    """Per batch row, the RMS over boxes and steps of ``(y_k - y_{k-1})/dt`` for the last steps (stored velocities
    do not count); ``frames`` are the batch's recorded states and ``dt`` its rows' step sizes.

    Each row's values are laid out contiguously before averaging, so a row is summed exactly as its own array
    would be: a run gives the same bits in a batch of thousands as alone.
    """
    window = motion_steps(steps)
    ys = np.stack([frames[k].y for k in window])  # (window, batch, boxes)
    if len(window) < 2:
        return np.zeros(ys.shape[1])
    speeds = np.diff(ys, axis=0) / np.asarray(dt, dtype=np.float64)[None, :, None]
    rows = np.ascontiguousarray(speeds.transpose(1, 0, 2)).reshape(ys.shape[1], -1)
    return np.sqrt(np.mean(rows ** 2, axis=1))  # type: ignore[no-any-return]


def state_measures(state: ColumnState) -> dict[str, float | list[float]]:
    """The measures one state gives on its own (a batch of one): all but ``rms_motion``, which needs a window."""
    depth = state.penetration()[0]
    return {
        "y": state.y[0].tolist(),
        "v": state.v[0].tolist(),
        "depth": depth.tolist(),
        "max_depth": float(depth.max()),
        "peak_depth": float(max(state.peak_depth[0], 0.0)),
        "reach": float(max(state.reach[0], 0.0)),
        "launch": float(max(state.launch[0], 0.0)),
    }


def measure(frames: Mapping[int, ColumnState], steps: int, dt: np.ndarray) -> list[dict[str, float | list[float]]]:
    """Every named measure of every row of a batch, from its recorded states (``frames[steps]`` the final one)."""
    motion = rms_motion(frames, steps, dt)
    final = frames[steps]
    return [{**state_measures(final.row(b)), "rms_motion": float(motion[b])} for b in range(final.batch)]

def extra_measures(result: RunResult) -> dict[str, float]:
    """Where the top box ends, how much it still moves at the end, and the largest gap left.

    - ``max_gap``: the largest gap in the final state between neighbouring boxes, or the bottom box and the
      floor (m, 0 when every contact touches);
    - ``top_rest_error``: final height of the top box minus where it rests on a rigid column (the sum of
      the heights below it plus its half-height); negative when the column has sunk (m);
    - ``top_p2p``: peak-to-peak height of the top box over the final motion window (m), the size of an
      oscillation or jitter that the RMS motion averages away;
    - ``boxes``: boxes left at the end.
    """
    final, steps = result.final, result.spec.steps
    half = final.half[0]
    rest = float(2.0 * half[:-1].sum() + half[-1])
    tops = [result.frames[k].y[0, -1] for k in motion_steps(steps)]
    return {"max_gap": float(max(0.0, -final.depths()[0].min())), "top_rest_error": float(final.y[0, -1]) - rest,
            "top_p2p": float(max(tops) - min(tops)),
            "boxes": float(final.boxes)}


STILL = 1e-9  # m: a step of the top box shorter than this is standing still, not a change of direction


def top_motion(result: RunResult) -> dict[str, float]:
    """How the top box moves over the whole run once it touches what is under it (``stackx.models.touch``; needs
    the state before every step).

    - ``top_reversals``: how many times its step-to-step motion changes direction (steps shorter than
      ``STILL`` skipped), the count of a bounce or an oscillation;
    - ``top_rise``: its fastest upward motion, ``(y_next - y)/dt`` (m/s), from positions: a position
      correction that throws a box up shows here although it never touches a velocity.

    Steps before the last scene event are left out (the top box may be another one then).
    """
    steps, dt = result.spec.steps, result.spec.dt
    start = max([0, *(e.step for e in result.spec.scene.events())])
    tops, touching = [], False
    for k in range(start, steps + 1):
        f = result.frames[k]
        y, half = f.y[0], f.half[0]
        gap = (y[-1] - y[-2]) - (half[-1] + half[-2]) if f.boxes > 1 else y[0] - half[0]
        touching = touching or gap < TOUCH_GAP
        if touching:
            tops.append(float(y[-1]))
    moves = [b - a for a, b in zip(tops, tops[1:]) if abs(b - a) > STILL]
    reversals = sum(1 for a, b in zip(moves, moves[1:]) if (a > 0) != (b > 0))
    rise = max([0.0, *(m / dt for m in moves)])
    return {"top_reversals": float(reversals), "top_rise": rise}
