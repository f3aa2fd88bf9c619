"""Measures the bench adds to a run's own (``stackx.metrics``): where the top box ends and how it moves."""

from __future__ import annotations

from stackx.metrics import motion_steps
from stackx.results import RunResult


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
    """How the top box moves over the whole run once it rests on something (needs the state before every step).

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
        touching = touching or gap < 0.0
        if touching:
            tops.append(float(y[-1]))
    moves = [b - a for a, b in zip(tops, tops[1:]) if abs(b - a) > STILL]
    reversals = sum(1 for a, b in zip(moves, moves[1:]) if (a > 0) != (b > 0))
    rise = max([0.0, *(m / dt for m in moves)])
    return {"top_reversals": float(reversals), "top_rise": rise}
