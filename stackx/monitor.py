"""Measures taken inside the stepping loop, after every step.

Written as plain loops over one batch row so that the same function runs in the readable Python path and
inside a compiled stepping loop.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import kernel


@kernel
def observe(y: np.ndarray, half: np.ndarray, peak: np.ndarray, b: int) -> None:
    """Raise ``peak[b]`` to the largest contact depth of row ``y`` (floor contact and every pair)."""
    worst = half[0] - y[0]
    for i in range(y.shape[0] - 1):
        d = (half[i] + half[i + 1]) - (y[i + 1] - y[i])
        if d > worst:
            worst = d
    if worst > peak[b]:
        peak[b] = worst
