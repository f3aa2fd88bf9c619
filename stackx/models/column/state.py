"""The column model's state: boxes stacked on a floor, moving only vertically.

Box ``i`` rests on box ``i - 1`` and box 0 on the floor (the line y = 0, inverse mass 0). Arrays carry a
leading batch axis so that variants of the same shape step together; a single run is a batch of one.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from stackx.models.touch import TOUCH_GAP


@dataclass
class ColumnState:
    """Heights, velocities, inverse masses and half-heights, each shaped ``(batch, boxes)``.

    The monitors (see ``stackx.models.column.monitor.observe``) are updated by solvers after every step, so a compiled run
    does not return to Python per step: ``last`` (the heights after the previous step, from which
    ``launch`` measures motion) and ``touched`` ``(batch, boxes)``, ``peak_depth``, ``reach`` and ``launch``
    ``(batch,)``.
    """

    y: np.ndarray
    v: np.ndarray
    inv_mass: np.ndarray
    half: np.ndarray
    last: np.ndarray = field(default=None)  # type: ignore[assignment]
    peak_depth: np.ndarray = field(default=None)  # type: ignore[assignment]
    reach: np.ndarray = field(default=None)  # type: ignore[assignment]
    touched: np.ndarray = field(default=None)  # type: ignore[assignment]
    launch: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        for name in ("y", "v", "inv_mass", "half"):
            setattr(self, name, np.ascontiguousarray(getattr(self, name), dtype=np.float64))
        if all(getattr(self, k) is not None for k in self.MONITORS):
            return  # a copy: nothing to derive (this runs for every recorded state and solver call)
        d = self.depths()
        if self.last is None:
            self.last = self.y.copy()
        if self.peak_depth is None:
            self.peak_depth = np.maximum(d.max(axis=1), 0.0)
        if self.reach is None:
            thinner = np.concatenate([self.half[:, :1], np.minimum(self.half[:, :-1], self.half[:, 1:])], axis=1)
            self.reach = np.maximum((d / thinner).max(axis=1), 0.0)
        if self.touched is None:
            self.touched = np.zeros(self.y.shape, dtype=np.bool_)
            self.touched[:, :] = d > -TOUCH_GAP  # as ``touching`` judges (stackx.models.touch)
            self.touched[:, :-1] |= d[:, 1:] > -TOUCH_GAP
        if self.launch is None:
            self.launch = np.full(self.batch, -np.inf)

    MONITORS = ("last", "peak_depth", "reach", "touched", "launch")
    FIELDS = ("y", "v", "inv_mass", "half", *MONITORS)

    @property
    def batch(self) -> int:
        return self.y.shape[0]

    @property
    def boxes(self) -> int:
        return self.y.shape[1]

    def depths(self) -> np.ndarray:
        """Signed contact depths ``(batch, boxes)``: column 0 is the floor contact, column k the pair (k-1, k).

        Positive means overlap. Floor: ``h0 - y0``; pair: ``(h_i + h_{i+1}) - (y_{i+1} - y_i)``.
        """
        d = np.empty_like(self.y)
        d[:, 0] = self.half[:, 0] - self.y[:, 0]
        d[:, 1:] = (self.half[:, :-1] + self.half[:, 1:]) - (self.y[:, 1:] - self.y[:, :-1])
        return d

    def penetration(self) -> np.ndarray:
        """Contact depths clipped at zero: a separated contact has no penetration."""
        return np.maximum(self.depths(), 0.0)

    def monitors(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The arguments ``observe`` takes after ``y, half, dt``."""
        return self.last, self.peak_depth, self.reach, self.touched, self.launch

    def remove_box(self, box: int) -> None:
        """Take box ``box`` out of every row in place; the per-run monitors keep their history."""
        for name in ("y", "v", "inv_mass", "half", "last", "touched"):
            setattr(self, name, np.ascontiguousarray(np.delete(getattr(self, name), box, axis=1)))

    def copy(self) -> ColumnState:
        return ColumnState(*(getattr(self, k).copy() for k in self.FIELDS))

    def row(self, b: int) -> ColumnState:
        """Batch row ``b`` as a batch of one (views, not copies). Made for each run of a batch and each state
        looked at, so it skips what building a state checks and derives: its arrays are already right."""
        out = object.__new__(ColumnState)
        out.__dict__.update((k, getattr(self, k)[b:b + 1]) for k in self.FIELDS)
        return out

    @staticmethod
    def concat(states: list[ColumnState]) -> ColumnState:
        """Stack same-shaped states along the batch axis."""
        return ColumnState(*(np.concatenate([getattr(s, k) for s in states]) for k in ColumnState.FIELDS))
