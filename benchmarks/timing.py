"""Timing on a noisy machine: implementations take turns, every one is repeated, medians are compared.

Each round runs every implementation once, in an order that rotates from round to round, so that a burst
of load from elsewhere hits them alike; set-up (fresh state) is outside the timed span. Figures are the
median over rounds, and ratios are taken between medians of the same run.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass, field

Prepared = Callable[[], None]
"""A run ready to go: calling it is what is timed."""


@dataclass
class Sample:
    """Seconds per repeat of one implementation, and how many units (steps, scene-steps) one repeat does."""

    units: int
    seconds: list[float] = field(default_factory=list)

    @property
    def median(self) -> float:
        return statistics.median(self.seconds)

    @property
    def per_unit(self) -> float:
        """Median seconds per unit."""
        return self.median / self.units

    def as_dict(self, scale: float = 1e6) -> dict[str, object]:
        """Per-unit figures scaled (default: microseconds), and the raw seconds."""
        return {"per_unit": self.per_unit * scale, "min_per_unit": min(self.seconds) / self.units * scale,
                "units": self.units, "repeats": len(self.seconds), "seconds": self.seconds}


def interleaved(setups: dict[str, tuple[Callable[[], Prepared], int]], repeats: int,
                clock: Callable[[], float] = time.perf_counter) -> dict[str, Sample]:
    """Time every ``name: (setup, units)`` ``repeats`` times, taking turns; ``setup()`` is not timed.
    ``clock``: wall time by default; ``time.process_time`` counts only this process's CPU time, which other
    processes' load does not inflate, and is fair only between implementations that each use one thread."""
    samples = {name: Sample(units) for name, (_, units) in setups.items()}
    names = list(setups)
    for r in range(repeats):
        for name in names[r % len(names):] + names[:r % len(names)]:
            run = setups[name][0]()
            t0 = clock()
            run()
            samples[name].seconds.append(clock() - t0)
    return samples


def fitted_exponent(sizes: list[int], costs: list[float]) -> float:
    """Least-squares slope of log(cost) against log(size): 1 is linear."""
    import math

    xs, ys = [math.log(s) for s in sizes], [math.log(c) for c in costs]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)
