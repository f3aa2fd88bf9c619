"""Each run's µs/step is its own: a batch's time is shared out by what each row did, the table says how a time
was obtained, and whether a batch steps compiled follows the work its steps do (passes times contacts), for a
whole run and for a Dask chunk alike.

No figure here comes from a clock: the runner's clock is replaced by one that moves a fixed time per reading,
so an order or a share is the runner's arithmetic, never the machine's load.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
import yaml

from stackx import kernel
from stackx.config.experiment import ExperimentSpec, load
from stackx.output.screen import ENGINE_MARK, TIMING_CAPTION, timing_cell
from stackx.run import chunks, runner
from stackx.run.executor import Local
from stackx.run.results import ExperimentResult
from stackx.solvers.base import Solver

ITERATIONS = [4, 16, 64, 256]
BOXES = 5


def _config(folder: Path, solver: dict[str, object], steps: int, grid: dict[str, list[object]] | None) -> Path:
    doc: dict[str, object] = {
        "description": "A short column of five boxes.",
        "scene": {"name": "column", "stack": {"count": BOXES, "y0": 0.5, "spacing": 1.0}},
        "solver": solver, "dt": "1/60", "steps": steps, "outputs": [],
    }
    if grid is not None:
        doc["sweep"] = {"name": "v{index}", "grid": grid}
    path = folder / "timed.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def _sweep(folder: Path, steps: int = 30) -> ExperimentSpec:
    grid = {"solver.iterations": ITERATIONS, "solver.correction.percent": [0.2, 0.8]}
    return load(str(_config(folder, {"name": "pgs"}, steps, grid)))


def fixed_clock(seconds: float) -> Iterator[float]:
    """A clock that reads ``seconds`` later at every reading: each timed stretch of steps takes exactly that."""
    return (seconds * k for k in itertools.count())


@pytest.fixture
def ticks(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every stretch of steps the runner times takes one second."""
    clock = fixed_clock(1.0)
    monkeypatch.setattr(runner, "CLOCK", lambda: next(clock), raising=False)


@pytest.fixture
def plain(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("STACKX_JIT", "0")
    monkeypatch.delenv("STACKX_JIT_WORK", raising=False)


def _by_iterations(result: ExperimentResult, percent: float) -> list[float]:
    rows = [r for r in result.runs if r.spec.solver_params.correction.percent == percent]
    return [r.us_per_step for r in sorted(rows, key=lambda r: r.spec.solver_params.iterations)]


# ------------------------------------------------------------------------------------- a batch's time, shared


def test_a_sweep_over_iterations_charges_each_run_by_its_work(tmp_path: Path, plain: None, ticks: None) -> None:
    """One batch of 8 rows: the more velocity passes a row makes, the more of the batch's time it is charged;
    the shares add up to the batch's time."""
    result = runner.run_experiment(_sweep(tmp_path))
    assert len({r.spec.solver_params.iterations for r in result.runs}) == len(ITERATIONS)
    for percent in (0.2, 0.8):
        times = _by_iterations(result, percent)
        assert times == sorted(times) and len(set(times)) == len(times), times
    alone = runner.run_experiment(load(str(_config(tmp_path, {"name": "pgs"}, 30, None))))
    segments = alone.runs[0].wall_seconds  # one second per timed stretch: the batch has as many stretches
    assert sum(r.wall_seconds for r in result.runs) == pytest.approx(segments)


def test_each_row_is_charged_in_proportion_to_the_work_counted_for_it(tmp_path: Path, plain: None,
                                                                      ticks: None) -> None:
    """The work counted for a row grows with its iterations and covers at least its velocity passes (one visit
    of each contact per pass); its share of the time is its share of the work."""
    result = runner.run_experiment(_sweep(tmp_path))
    total_wall = sum(r.wall_seconds for r in result.runs)
    total_work = sum(r.work for r in result.runs)
    for r in result.runs:
        assert r.work >= r.spec.solver_params.iterations * BOXES * r.spec.steps
        assert r.wall_seconds / total_wall == pytest.approx(r.work / total_work)
    works = [r.work for r in sorted(result.runs, key=lambda r: r.spec.solver_params.iterations)]
    assert works == sorted(works)


def test_a_run_says_whether_its_time_is_its_own_or_a_share(tmp_path: Path, plain: None) -> None:
    sweep = runner.run_experiment(_sweep(tmp_path))
    assert {r.timed for r in sweep.runs} == {"share"}
    alone = runner.run_experiment(load(str(_config(tmp_path, {"name": "pgs"}, 30, None))))
    assert alone.runs[0].timed == "own"
    record = sweep.runs[0].timing_record()  # what timing.json says of a run
    assert record["timed"] == "share" and record["us_per_step"] == sweep.runs[0].us_per_step
    assert alone.runs[0].timing_record()["timed"] == "own"


def test_the_table_cell_and_caption_say_how_a_time_was_obtained(tmp_path: Path, plain: None) -> None:
    sweep = runner.run_experiment(_sweep(tmp_path))
    alone = runner.run_experiment(load(str(_config(tmp_path, {"name": "pgs"}, 30, None))))
    shared, own = timing_cell(sweep.runs[0], ".3g"), timing_cell(alone.runs[0], ".3g")
    assert shared.split()[-1] == own.split()[-1] == "py"  # STACKX_JIT=0
    assert format(sweep.runs[0].us_per_step, ".3g") in shared and format(alone.runs[0].us_per_step, ".3g") in own
    marker = shared.replace(format(sweep.runs[0].us_per_step, ".3g"), "").split()[0]
    assert marker not in own and marker in TIMING_CAPTION and "share" in TIMING_CAPTION


class Loops(Solver):
    """A plugin whose step is Python loops over the rows, calling no compiled kernel."""

    def advance(self, state: Any, steps: int) -> None:
        for _ in range(steps):
            for b in range(state.v.shape[0]):
                state.v[b] += self.gravity[b] * self.dt[b]


def test_the_cell_marks_an_engine_and_a_plain_plugin_apart_from_compiled_kernels(tmp_path: Path,
                                                                                plain: None) -> None:
    """How a run stepped is read from its solver as well as from its batch's compiled flag: an engine (pymunk:
    its own compiled code, one step per Python call) is marked as one whether the batch's kernels were on or
    off, a plugin of Python loops is plain even in a compiled batch, and only a solver that reaches the
    kernels is ``jit``, in a compiled batch. Each mark is explained in the caption."""
    engine = runner.run_experiment(load(str(_config(tmp_path, {"name": "pymunk"}, 5, None)))).runs[0]
    builtin = runner.run_experiment(load(str(_config(tmp_path, {"name": "pgs"}, 5, None)))).runs[0]
    loops = replace(builtin, spec=replace(builtin.spec, solver_cls=Loops))

    def mark(run: Any, compiled: bool) -> str:
        return timing_cell(replace(run, compiled=compiled), ".3g").split()[-1]

    assert [mark(engine, True), mark(engine, False)] == [ENGINE_MARK, ENGINE_MARK]
    assert [mark(builtin, True), mark(builtin, False)] == ["jit", "py"]
    assert [mark(loops, True), mark(loops, False)] == ["py", "py"]
    assert ENGINE_MARK not in ("jit", "py")
    for word in (ENGINE_MARK, "jit", "py"):
        assert f"{word} = " in TIMING_CAPTION, word
    assert "engine" in TIMING_CAPTION.split(f"{ENGINE_MARK} = ")[1].split(",")[0]


def test_chunks_keep_each_rows_share_and_how_it_stepped(tmp_path: Path, plain: None, ticks: None) -> None:
    """A sweep cut into chunks of two (as Dask steps it): each row keeps its own share of its chunk's time, the
    rows of a chunk ordered by iterations, and its compiled flag; a chunk of one row is timed on its own."""
    spec = _sweep(tmp_path)
    for rows in (2, 1):
        parts = chunks.split(spec, rows)
        merged = chunks.merge(spec, parts, [chunks.run_chunk(p) for p in parts])  # type: ignore[misc]
        by_name = {r.name: r for r in merged.runs}
        for part in parts:
            got = [by_name[n] for n in part.names]
            assert {r.timed for r in got} == {"own" if rows == 1 else "share"}
            if rows == 2 and got[0].spec.solver_params.iterations != got[1].spec.solver_params.iterations:
                low, high = sorted(got, key=lambda r: r.spec.solver_params.iterations)
                assert low.us_per_step < high.us_per_step
        assert not any(r.compiled for r in merged.runs)


# ------------------------------------------------------------------------------------- the compile decision


needs_numba = pytest.mark.skipif(not kernel.available(), reason="numba is not installed")


@needs_numba
def test_a_batch_is_compiled_by_the_passes_its_steps_make(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Five boxes for 20 steps are 100 box-steps either way; 200 velocity passes a step are 20 times the
    lab solver's 10, and that work, not the box-steps, decides."""
    monkeypatch.setenv("STACKX_JIT", "auto")
    monkeypatch.setenv("STACKX_JIT_WORK", "1000")
    few = runner.run_experiment(load(str(_config(tmp_path, {"name": "pgs", "iterations": 1}, 20, None))))
    many = runner.run_experiment(load(str(_config(tmp_path, {"name": "pgs", "iterations": 200}, 20, None))))
    assert not few.runs[0].compiled
    assert many.runs[0].compiled


RAISES_ITS_PASSES = '''
import numpy as np

from stackx.registry import solvers
from stackx.solvers.column.pgs import PGS


@solvers.register("pgs-raised")
class RaisedPGS(PGS):
    """As many velocity passes as boxes squared times eight, set when it steps."""

    def advance(self, state, steps):
        self.iterations = np.maximum(self.iterations, 8 * state.y.shape[1] ** 2)
        super().advance(state, steps)
'''


@needs_numba
def test_a_plugin_that_sets_its_passes_when_it_steps_is_compiled(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """As the README's plugin does: its params say 1 pass, its steps make 200."""
    (tmp_path / "plugins").mkdir()
    (tmp_path / "plugins" / "raised.py").write_text(RAISES_ITS_PASSES)
    monkeypatch.setenv("STACKX_JIT", "auto")
    monkeypatch.setenv("STACKX_JIT_WORK", "1000")
    result = runner.run_experiment(load(str(_config(tmp_path, {"name": "pgs-raised", "iterations": 1}, 20, None))))
    assert result.runs[0].compiled
    assert result.runs[0].work >= 200 * BOXES * 20


@needs_numba
def test_a_chunk_is_compiled_when_its_whole_batch_would_be(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The sweep's batch does more work than the threshold, each of its chunks of one row less: every chunk
    compiles, as the whole run does."""
    spec = _sweep(tmp_path)
    monkeypatch.setenv("STACKX_JIT", "auto")
    parts = chunks.split(spec, 1)
    single = min((runner.planned_work(p.plan.runs) for p in parts))
    whole = runner.planned_work(spec.runs)
    assert len(parts) > 1 and whole > 2 * single
    monkeypatch.setenv("STACKX_JIT_WORK", str(int(whole / 2)))
    assert all(runner.planned_work(p.plan.runs) < whole / 2 for p in parts)
    assert all(r.compiled for r in runner.run_experiment(spec).runs)
    outcomes = [chunks.run_chunk(p) for p in parts]
    merged = chunks.merge(spec, parts, outcomes)  # type: ignore[arg-type]
    assert all(r.compiled for r in merged.runs)


# ----------------------------------------------------------------------------------- a plain run that dragged


@needs_numba
def test_a_long_plain_run_says_so_with_the_switch(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """A batch judged small that still stepped a minute as plain Python says so in one line naming
    ``STACKX_JIT=1``, on standard error; one that stepped briefly says nothing."""
    monkeypatch.setenv("STACKX_JIT", "auto")
    monkeypatch.delenv("STACKX_JIT_WORK", raising=False)
    spec = load(str(_config(tmp_path, {"name": "pgs"}, 30, None)))
    for seconds, said in ((60.0, True), (1e-6, False)):
        clock = fixed_clock(seconds)
        monkeypatch.setattr(runner, "CLOCK", lambda clock=clock: next(clock), raising=False)
        (job,) = Local().experiments([spec])
        result = job.result()
        assert not result.runs[0].compiled
        err = capsys.readouterr().err
        if said:
            assert len(result.notes) == 1 and "STACKX_JIT=1" in result.notes[0]
            assert err.strip().splitlines() == [result.notes[0]]
        else:
            assert result.notes == [] and err == ""


def test_a_long_run_plain_by_choice_is_not_second_guessed(tmp_path: Path, plain: None,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    clock = fixed_clock(60.0)
    monkeypatch.setattr(runner, "CLOCK", lambda: next(clock), raising=False)
    result = runner.run_experiment(load(str(_config(tmp_path, {"name": "pgs"}, 30, None))))
    assert result.notes == []
