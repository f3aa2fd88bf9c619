"""How a solver steps, read from its code: every built-in solver reaches compiled kernels, the README's plugin
(a subclass that hands over to ``super().advance``) too, a plugin written as Python loops does not, and an
engine is an engine."""

from __future__ import annotations

from typing import Any

import numpy as np

from stackx import registry
from stackx.bench.stepping import COMPILED, ENGINE, PLAIN, reaches_kernel, stepping
from stackx.solvers.base import Solver
from stackx.solvers.column.pgs import PGS


class TallPGS(PGS):
    """The README's plugin: more passes, then the lab solver's own stepping."""

    def advance(self, state: Any, steps: int) -> None:
        self.iterations = np.maximum(self.iterations, state.y.shape[1] ** 2)
        super().advance(state, steps)


class LoopSolver(Solver):
    """A plugin whose step is Python loops over the column, calling no kernel."""

    def advance(self, state: Any, steps: int) -> None:
        for _ in range(steps):
            self._gravity(state)

    def _gravity(self, state: Any) -> None:
        for b in range(state.v.shape[0]):
            state.v[b] += self.gravity[b] * self.dt[b]


class RewrittenPGS(PGS):
    """A subclass that replaces the lab's step with its own loop and never calls the one it inherits."""

    def advance(self, state: Any, steps: int) -> None:
        for _ in range(steps):
            state.v += self.gravity[:, None] * self.dt[:, None]


def test_every_builtin_solver_steps_compiled_or_is_an_engine() -> None:
    for entry in registry.solvers.entries():
        if entry.origin != "built-in" or entry.plugin is None:
            continue
        want = ENGINE if getattr(entry.plugin, "one_step_per_call", False) else COMPILED
        assert stepping(entry.plugin, kernels_on=True) == want, entry.name


def test_a_subclass_that_hands_over_to_super_is_compiled() -> None:
    assert reaches_kernel(TallPGS) and stepping(TallPGS, kernels_on=True) == COMPILED


def test_a_plugin_of_python_loops_is_plain() -> None:
    assert not reaches_kernel(LoopSolver) and stepping(LoopSolver, kernels_on=True) == PLAIN
    assert not reaches_kernel(RewrittenPGS), "its advance never reaches the kernels it inherits"


def test_with_kernels_off_everything_but_an_engine_is_plain() -> None:
    assert stepping(PGS, kernels_on=False) == PLAIN and stepping(TallPGS, kernels_on=False) == PLAIN
    class Engine(Solver):
        one_step_per_call = True

    assert stepping(Engine, kernels_on=False) == ENGINE
