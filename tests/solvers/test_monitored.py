"""A solver must update its model's monitors after every step: one that leaves ``observe(...)`` out is refused
with one line naming its file before any result is written, and every registered solver passes the check."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from stackx import api, kernel, registry
from stackx.errors import RunError
from stackx.run import monitored
from stackx.solvers.base import Solver
from stackx.solvers.column.pgs import PGS
from tests.conftest import REPO, Cli
from tests.solvers.columns import resting, solver, solver_names

CASE = """\
scene: {name: column, stack: {count: 5, y0: 2.5, spacing: 1.6}}
solver: {name: sor-blind, iterations: 4}
steps: 300
outputs: [{sink: metrics, path: case.json}]
"""


def _blind_sor() -> str:
    """``plugins/sor.py`` with its ``observe`` left out (the import and the call), registered as ``sor-blind``."""
    text = (REPO / "plugins" / "sor.py").read_text()
    kept = [line for line in text.splitlines() if not re.search(r"\bobserve\b", line)]
    assert len(kept) == len(text.splitlines()) - 2, "sor.py imports and calls observe once each"
    return "\n".join(kept).replace('register("sor")', 'register("sor-blind")') + "\n"


def test_a_plugin_that_forgets_observe_is_refused_naming_its_file(cli: Cli, tmp_path: Path) -> None:
    """Without the check this run passes with peak depth, reach and launch all 0."""
    (tmp_path / "plugins").mkdir()
    (tmp_path / "plugins" / "blind.py").write_text(_blind_sor())
    (tmp_path / "case.yaml").write_text(CASE)
    done = cli("run", "case.yaml", "--out", "out", env={"STACKX_JIT": "0"}, cwd=tmp_path)
    assert done.returncode == 1, (done.stdout, done.stderr)
    assert "Traceback" not in done.stderr
    [line] = [ln for ln in done.stderr.splitlines() if ln.startswith("error:")]
    assert line == (f"error: case.yaml: solver 'sor-blind' ({tmp_path / 'plugins' / 'blind.py'}) did not call "
                    "stackx.models.column.monitor.observe(...) in its first step (run(s) 'main'): advance must call "
                    "it for every row after every step, or depths and launches go unmeasured"), line
    assert not (tmp_path / "out").exists()


def _planar_state(rows: int = 2) -> Any:
    spec = api.load({"scene": {"name": "planar", "stack": {"count": 3, "offset": 0.05, "seed": 1}},
                     "solver": {"name": "planar-pgs"}, "steps": 2})
    start = spec.runs[0].scene.build()
    return spec.runs[0].model.concat([start] * rows)


def _planar_names() -> list[Any]:
    return [pytest.param(e.name, marks=pytest.mark.skip(reason=why)) if (why := registry.unavailable(e.plugin))
            else e.name for e in registry.solvers.entries() if "planar" in getattr(e.plugin, "models", ())]


@pytest.mark.parametrize("name", solver_names())
def test_every_column_solver_updates_the_monitors(name: str) -> None:
    """Two rows, so that a solver observing only its first row would be caught too."""
    state = resting(4)
    state = type(state).concat([state, resting(4)])
    assert monitored.seen_heights(state) is not None  # the check has a monitor to read
    with kernel.compiled(False):
        assert monitored.first_step("case.yaml", ["a", "b"], state, solver(name, [{}, {}]))


@pytest.mark.parametrize("name", _planar_names())
def test_every_planar_solver_updates_the_monitors(name: str) -> None:
    state = _planar_state()
    cls = registry.solvers.get(name)
    stepper = cls([cls.Params(), cls.Params()], np.full(2, -9.8), np.full(2, 1 / 60))
    assert monitored.seen_heights(state) is not None
    with kernel.compiled(False):
        assert monitored.first_step("case.yaml", ["a", "b"], state, stepper)


def test_a_planar_solver_that_leaves_its_monitors_is_refused() -> None:
    """The planar check reads the same monitor: a planar solver whose step leaves ``last_y`` as it was."""
    cls = registry.solvers.get("planar-pgs")

    class Unseen(cls):  # type: ignore[misc, valid-type]
        plugin_name, plugin_origin = "planar-unseen", "test"

        def advance(self, state: Any, steps: int) -> None:
            kept = state.last_y.copy()
            super().advance(state, steps)
            state.last_y[...] = kept

    stepper = Unseen([cls.Params(), cls.Params()], np.full(2, -9.8), np.full(2, 1 / 60))
    with kernel.compiled(False), pytest.raises(RunError, match="'planar-unseen' \\(test\\) did not call "
                                               "stackx.models.planar.monitor.observe"):
        monitored.first_step("case.yaml", ["a", "b"], _planar_state(), stepper)


class FirstRowOnly(PGS):
    """The lab solver stepping both rows and observing the first: the second row's monitors stay."""

    plugin_name, plugin_origin = "first-row", "test"

    def advance(self, state: Any, steps: int) -> None:
        seen = state.last.copy()
        super().advance(state, steps)
        state.last[1] = seen[1]


def test_a_row_left_unobserved_is_named() -> None:
    state = type(resting(3)).concat([resting(3), resting(3)])
    stepper = FirstRowOnly([PGS.Params(), PGS.Params()], np.full(2, -9.8), np.full(2, 1 / 60))
    with kernel.compiled(False), pytest.raises(RunError) as err:
        monitored.first_step("case.yaml", ["a", "b"], state, stepper)
    assert ("'first-row' (test) did not call stackx.models.column.monitor.observe(...) in its first step "
            "(run(s) 'b')") in str(err.value)


class Uncopied(Solver):
    """Free fall, with a ``__copy__`` that fails: the check waits for its first real call."""

    Params = PGS.Params
    plugin_name, plugin_origin = "uncopied", "test"
    sees = False

    def __copy__(self) -> Uncopied:
        raise TypeError("cannot be copied")

    def advance(self, state: Any, steps: int) -> None:
        for _ in range(steps):
            state.v += self.gravity[:, None] * self.dt[:, None]
            state.y += state.v * self.dt[:, None]
            if self.sees:
                state.last[...] = state.y


@pytest.mark.parametrize("sees", [False, True])
def test_a_solver_that_cannot_be_copied_is_checked_on_its_first_call(sees: bool) -> None:
    state = resting(3)
    stepper = Uncopied([PGS.Params()], np.full(1, -9.8), np.full(1, 1 / 60))
    stepper.sees = sees
    assert not monitored.first_step("case.yaml", ["main"], state, stepper)
    before = state.copy()
    stepper.advance(state, 10)
    if sees:
        monitored.observed("case.yaml", ["main"], stepper, before, state)
    else:
        with pytest.raises(RunError, match="'uncopied' \\(test\\) did not call .* \\(run\\(s\\) 'main'\\)"):
            monitored.observed("case.yaml", ["main"], stepper, before, state)


def test_the_runner_checks_a_solver_it_cannot_copy_on_its_first_call(tmp_path: Path,
                                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    from stackx.run.runner import run_experiment

    (tmp_path / "plugins").mkdir()
    (tmp_path / "plugins" / "blind_uncopied.py").write_text(_blind_sor().replace('"sor-blind"', '"sor-blind-2"'))
    (tmp_path / "case.yaml").write_text(CASE.replace("sor-blind", "sor-blind-2"))
    spec = api.load(tmp_path / "case.yaml")
    monkeypatch.setattr(monitored, "snapshot", lambda solver: None)
    monkeypatch.setenv("STACKX_JIT", "0")
    try:
        with pytest.raises(RunError, match="'sor-blind-2' .* did not call .*observe.* \\(run\\(s\\) 'main'\\)"):
            run_experiment(spec)
    finally:  # tests that bench every registered solver share this process: the blind one must not stay
        from stackx import registry
        registry.solvers.forget(str(tmp_path / "plugins" / "blind_uncopied.py"))
