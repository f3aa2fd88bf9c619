"""The column model's state: boxes stacked on a floor, moving only vertically.

Box ``i`` rests on box ``i - 1`` and box 0 on the floor (the line y = 0, inverse mass 0). Arrays carry a
leading batch axis so that variants of the same shape step together; a single run is a batch of one.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class ColumnState:
    """Heights, velocities, inverse masses and half-heights, each shaped ``(batch, boxes)``.

    ``peak_depth`` (shape ``(batch,)``) is the largest contact depth seen after any step so far; solvers
    update it through ``stackx.monitor.observe`` so that a compiled run does not return to Python per step.
    """

    y: np.ndarray
    v: np.ndarray
    inv_mass: np.ndarray
    half: np.ndarray
    peak_depth: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        for name in ("y", "v", "inv_mass", "half"):
            setattr(self, name, np.ascontiguousarray(getattr(self, name), dtype=np.float64))
        if self.peak_depth is None:
            self.peak_depth = np.maximum(self.depths().max(axis=1), 0.0)

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

    def copy(self) -> ColumnState:
        return ColumnState(self.y.copy(), self.v.copy(), self.inv_mass.copy(), self.half.copy(),
                           self.peak_depth.copy())

    @staticmethod
    def concat(states: list[ColumnState]) -> ColumnState:
        """Stack same-shaped states along the batch axis."""
        return ColumnState(*(np.concatenate([getattr(s, k) for s in states])
                             for k in ("y", "v", "inv_mass", "half", "peak_depth")))
