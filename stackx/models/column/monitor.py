"""Measures taken inside the stepping loop, after every step.

Written as plain loops over one batch row so that the same function runs in the readable Python path and
inside a compiled stepping loop. Solvers call ``observe`` for every batch row after every step (the runner
refuses one that does not: ``stackx.run.monitored``). Everything it measures comes
from positions, the same way for every solver: a velocity a solver stores is its own business, and a
position correction that throws a box up without touching its velocity must show as the launch it is.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import kernel
from stackx.models.touch import touching


@kernel
def observe(y: np.ndarray, half: np.ndarray, dt: float, last: np.ndarray, peak: np.ndarray, reach: np.ndarray,
            touched: np.ndarray, launch: np.ndarray, b: int) -> None:
    """Update the monitors of batch row ``b`` after a step of ``dt`` that left the heights ``y``.

    - ``last[b, i]``: the height of box ``i`` after the previous step (set here for the next one);
    - ``peak[b]``: the largest contact depth so far (m);
    - ``reach[b]``: the largest depth as a share of the thinner box's half-height; above 1 a box has passed
      half-way into its neighbour (or its centre is below the floor);
    - ``touched[b, i]``: box ``i`` has touched something at some step (a contact overlapping, at zero
      depth or a hair apart: ``stackx.models.touch``);
    - ``launch[b]``: the fastest upward motion ``(y - last)/dt`` of a box that had touched something (m/s):
      what the box actually did over the step, whatever moved it (impulse or position correction).
    """
    n = y.shape[0]
    d = half[0] - y[0]
    if d > peak[b]:
        peak[b] = d
    if d / half[0] > reach[b]:
        reach[b] = d / half[0]
    if touching(d):
        touched[b, 0] = True
    for i in range(n - 1):
        d = (half[i] + half[i + 1]) - (y[i + 1] - y[i])
        if d > peak[b]:
            peak[b] = d
        r = d / min(half[i], half[i + 1])
        if r > reach[b]:
            reach[b] = r
        if touching(d):
            touched[b, i] = True
            touched[b, i + 1] = True
    for i in range(n):
        if touched[b, i]:
            rise = (y[i] - last[b, i]) / dt
            if rise > launch[b]:
                launch[b] = rise
        last[b, i] = y[i]
