"""Each step's contacts are found once, where the last step ended, and serve that step's monitors and the next
step's solve. Finding them again at the start of every step (a call of one step finds them afresh) must give
the same trajectories and monitors, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from stackx.models.planar.state import PlanarState
from tests.planar.worlds import run, world

SOLVERS = ["planar-pgs", "planar-warm-start", "planar-ngs", "planar-soft-step", "planar-xpbd", "planar-jacobi",
           "planar-pgs-soft", "planar-tgs-soft", "planar-tgs-sticky", "planar-tgs-ngs", "planar-shock",
           "planar-avbd"]


def tumbling() -> PlanarState:
    """Boxes dropped tilted onto a static ledge and each other: contacts appear, vanish and change partner."""
    boxes = [{"x": 0.0, "y": 1.0, "hx": 2.0, "hy": 0.2, "static": True, "angle": 0.1}]
    boxes += [{"x": 0.3 * k - 0.6, "y": 1.6 + 0.9 * k, "angle": 0.4 * k, "vy": -1.0, "hx": 0.3 + 0.05 * k}
              for k in range(5)]
    boxes += [{"x": 2.5, "y": 0.5}, {"x": 2.6, "y": 1.5, "angle": 0.2}]
    return world(boxes)


@pytest.mark.parametrize("name", SOLVERS)
def test_one_call_of_many_steps_equals_many_calls_of_one_step(name: str) -> None:
    together, apart = tumbling(), tumbling()
    run(name, together, 40, compiled=False)
    from tests.planar.worlds import solver

    s = solver(name)
    from stackx import kernel

    with kernel.compiled(False):
        for _ in range(40):
            s.advance(apart, 1)
    assert together.touched.sum() >= 6  # the boxes met the ledge, the ground and each other
    for field in PlanarState.FIELDS:
        np.testing.assert_array_equal(getattr(together, field), getattr(apart, field), err_msg=field)
