"""How far apart the planar solvers that find contacts once per step look for them.

A solver that finds its contact points at the start of a step, within a fixed ``speculative`` gap, sees a
contact a step late when two boxes close more than that gap in the step: a box falling at 12 m/s closes
0.2 m per step at 60 Hz, ten times a 2 cm margin, and is first found some 10 cm into what it hits. Whatever
then removes that overlap (a position pass, a soft contact's push-out speed, a projection) lifts the boxes
out as fast as it removes it, which reads as a launch. Looking as far as the fastest box can close in the
step finds the contact while it is still open, and the solve lets the point close its gap within the step
and no more, so the box stops touching instead of inside. On a pile at rest the margin stays ``speculative``.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import kernel


@kernel
def reach_in_step(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, hx: np.ndarray,
                  hy: np.ndarray, g: float, dt: float) -> float:
    """How far two points may close in one step (m): twice the fastest point of any movable box (its centre's
    speed plus ``|w|`` times its half-diagonal, plus what gravity adds in the step) times ``dt``. Contacts are
    found this far apart when it is more than ``speculative``, so the substeps see every contact a corner
    reaches within the step instead of finding it deep a step late."""
    fastest = 0.0
    for i in range(vx.shape[0]):
        if inv_mass[i] > 0.0:
            fastest = max(fastest, np.hypot(vx[i], vy[i]) + abs(w[i]) * np.hypot(hx[i], hy[i]))
    return 2.0 * (fastest + abs(g) * dt) * dt


@kernel
def contact_margin(speculative: float, vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray,
                   hx: np.ndarray, hy: np.ndarray, g: float, dt: float) -> float:
    """The gap within which the next step's contacts are found: ``speculative``, or what the fastest box can
    close in the step when that is more. It reads only the velocities the step begins with, so the contacts
    found where the last step ended are the ones the step would have found itself."""
    return max(speculative, reach_in_step(vx, vy, w, inv_mass, hx, hy, g, dt))
