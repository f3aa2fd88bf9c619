"""What is timed: one stackx experiment (a scene and a solver, one or many variants), stepped by stackx and
by the transcriptions of the same algorithm.

stackx is driven the way its runner drives it: the experiment's runs as one batch (``ColumnState`` rows,
one params object per row) and ``solver.advance(state, steps)``, compiled or plain. The transcriptions get
the same initial arrays and the same parameters, read from the validated config, so all of them step
exactly the same thing.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from benchmarks import plain
from benchmarks.native import Native
from stackx import kernel
from stackx.config.experiment import ExperimentSpec, load
from stackx.models.column.state import ColumnState

TRANSCRIBED = ("pgs", "warm-start", "exact")
"""Solvers with a Python and a C transcription."""

Prepared = Callable[[], None]


def write_config(folder: Path, name: str, doc: dict[str, Any]) -> ExperimentSpec:
    """Save a config document as ``folder/name.yaml`` and load it as stackx does."""
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return load(str(path))


@dataclass
class Subject:
    """One experiment's runs as a batch: ``rows`` variants of one scene shape and one solver."""

    spec: ExperimentSpec

    @property
    def solver(self) -> str:
        return str(self.spec.runs[0].solver_cls.plugin_name)

    @property
    def rows(self) -> int:
        return len(self.spec.runs)

    @cached_property
    def initial(self) -> ColumnState:
        return ColumnState.concat([r.scene.build() for r in self.spec.runs])

    @property
    def boxes(self) -> int:
        return self.initial.boxes

    @cached_property
    def params(self) -> dict[str, np.ndarray]:
        """One value per row of everything the transcriptions take (0 where a solver has no such knob)."""
        ps = [r.solver_params for r in self.spec.runs]
        corr = [getattr(p, "correction", None) for p in ps]
        return {"g": np.array([r.gravity for r in self.spec.runs]), "dt": np.array([r.dt for r in self.spec.runs]),
                "iterations": np.array([getattr(p, "iterations", 0) for p in ps], dtype=np.int64),
                "carry": np.array([bool(getattr(p, "warm_start", True)) for p in ps], dtype=np.uint8),
                "corrects": np.array([c is not None for c in corr], dtype=np.uint8),
                "slop": np.array([c.slop if c is not None else 0.0 for c in corr]),
                "percent": np.array([c.percent if c is not None else 0.0 for c in corr]),
                "speculative": np.array([float(getattr(p, "speculative", 0.0)) for p in ps])}

    def stackx(self, steps: int, compiled: bool = True) -> tuple[Prepared, ColumnState]:
        """A fresh batch and its solver; running it steps every row ``steps`` times in one call."""
        runs = self.spec.runs
        state = self.initial.copy()
        solver = runs[0].solver_cls([r.solver_params for r in runs], self.params["g"], self.params["dt"])

        def run() -> None:
            with kernel.compiled(compiled):
                solver.advance(state, steps)

        return run, state

    def c(self, native: Native, steps: int) -> tuple[Prepared, np.ndarray]:
        """The C transcription of this solver on a fresh copy of every row; returns the heights it moves."""
        s = self.initial.copy()
        p = self.params
        if self.solver == "pgs":
            return lambda: native.lab(s.y, s.v, s.inv_mass, s.half, p, steps), s.y
        if self.solver == "exact":
            return lambda: native.exact(s.y, s.v, s.inv_mass, s.half, p, steps), s.y
        impulse = np.zeros_like(s.y)
        return lambda: native.warm_start(s.y, s.v, s.inv_mass, s.half, p, impulse, steps), s.y

    def c_lab(self, native: Native, steps: int, iterations: int = 15, slop: float = 0.01,
              percent: float = 0.2) -> Prepared:
        """The C lab step (the lab's settings by default) on this scene, whatever solver the config names."""
        s = self.initial.copy()
        p = {**self.params, "iterations": np.full(self.rows, iterations, dtype=np.int64),
             "corrects": np.ones(self.rows, dtype=np.uint8), "slop": np.full(self.rows, slop),
             "percent": np.full(self.rows, percent)}
        return lambda: native.lab(s.y, s.v, s.inv_mass, s.half, p, steps)

    def python(self, steps: int, rows: list[int] | None = None) -> tuple[Prepared, list[list[float]]]:
        """The plain-Python transcription, row after row (``rows``: a subset); returns the heights it moves."""
        s, p = self.initial, self.params
        picked = list(range(self.rows)) if rows is None else rows
        ys = [s.y[b].tolist() for b in picked]
        jobs = []
        for y, b in zip(ys, picked):
            column = [y, s.v[b].tolist(), s.inv_mass[b].tolist(), s.half[b].tolist(), float(p["g"][b]),
                      float(p["dt"][b])]
            correction = [bool(p["corrects"][b]), float(p["slop"][b]), float(p["percent"][b])]
            if self.solver == "pgs":
                jobs.append((plain.lab_run, [*column, int(p["iterations"][b]), *correction, steps]))
            elif self.solver == "exact":
                jobs.append((plain.exact_run, [*column, *correction, float(p["speculative"][b]), steps]))
            else:
                jobs.append((plain.warm_start_run, [*column, int(p["iterations"][b]), bool(p["carry"][b]),
                                                    *correction, float(p["speculative"][b]), [0.0] * len(y), steps]))

        def run() -> None:
            for fn, job in jobs:
                fn(*job)

        return run, ys


def largest_difference(a: Any, b: Any) -> float:
    """Largest absolute difference between two sets of heights (0.0 means bit-identical here)."""
    return float(np.max(np.abs(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64))))
