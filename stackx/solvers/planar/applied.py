"""What a substepping step applied at each contact point: its impulses summed over the substeps.

A solver that takes substeps with each point's anchors and normal fixed for the step (the soft step) changes
every body's velocity over the step by ``M^-1 J^T p`` with ``J`` the step's contact Jacobian and ``p`` the sum
of what each substep applied: with Box2D v3's warm start, a substep applies each point's accumulated total
anew, so what substep ``i`` gives the velocities is that total at its end, and the step's impulse is the sum
of the totals. That sum is the one impulse that takes the step's free velocities (gravity for ``dt``) to the
velocities the solver stored, on the same contact problem the reference solves: the step's own answer.

What it cannot show: within the step the substeps met the points at other positions (a soft contact pushes an
overlap apart, a gap closes), so a step that was right substep by substep can read as a point pushing while
it separates (complementarity) or a gap closed faster than the step's target allows; the figure says how
far the step as a whole is from one rigid step, not where a substep went wrong.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import leaf


@leaf
def clear_applied(applied: np.ndarray, count: int) -> None:
    """Start a step: nothing applied yet at the first ``count`` points (as many as ``applied`` has room for)."""
    for k in range(min(count, applied.shape[0])):
        applied[k, 0], applied[k, 1] = 0.0, 0.0


@leaf
def add_applied(rows: np.ndarray, pn: np.ndarray, pt: np.ndarray, count: int, applied: np.ndarray) -> None:
    """End of a substep: add each of ``count`` points' accumulated impulses (``pn``, ``pt``), which the substep
    applied, to ``applied`` at the point's table row (``rows``)."""
    for p in range(count):
        k = int(rows[p])
        if k < applied.shape[0]:
            applied[k, 0] += pn[p]
            applied[k, 1] += pt[p]
