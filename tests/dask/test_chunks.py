"""A sweep cut into chunks, each stepped on its own and sent through pickle as to a worker, then merged, writes
what the runner writes stepping the whole plan; a chunked run that fails says what the whole run says.

No cluster here: chunks run one after another in this process (``tests/dask/test_cluster.py`` runs them on
Dask workers). The yardstick is always the runner on the whole plan, in this process.
"""

from __future__ import annotations

import dataclasses
import json
import pickle
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from stackx.run import chunks
from stackx.config.experiment import ExperimentSpec, load
from stackx.errors import BlowUp, RunError
from stackx.run.runner import run_experiment
from stackx.run.session import stage
from stackx.solvers.column.pgs import PGS
from tests.conftest import REPO
from tests.dask.configs import BLOWS, SWEEP, write
from tests.limits import hang_limit


def _wire(obj: Any) -> Any:
    """What a worker receives or sends back: a pickled copy."""
    return pickle.loads(pickle.dumps(obj))


def _chunked(spec: ExperimentSpec, rows: int) -> tuple[list[chunks.Chunk], list[chunks.Stepped | chunks.Failed]]:
    parts = chunks.split(spec, rows)
    return parts, [_wire(chunks.run_chunk(_wire(part))) for part in parts]


def _rerun(work: list[tuple[chunks.Chunk, int]]) -> list[list[dict[str, Any]]]:
    return [_wire(chunks.states_at(_wire(chunk), step)) for chunk, step in work]


@pytest.fixture(scope="module")
def sweep(tmp_path_factory: pytest.TempPathFactory) -> ExperimentSpec:
    return load(str(write(tmp_path_factory.mktemp("sweep"), "sweep", SWEEP)))


@pytest.mark.parametrize("rows", [1, 4, 5, 100])
def test_chunks_merge_into_the_artifacts_of_one_batch(sweep: ExperimentSpec, tmp_path: Path, rows: int) -> None:
    whole = stage(sweep, run_experiment(sweep), tmp_path).staged
    parts, outcomes = _chunked(sweep, rows)
    merged = chunks.merge(sweep, parts, outcomes)  # type: ignore[arg-type]
    assert [r.name for r in merged.runs] == [r.name for r in sweep.runs]
    again = stage(sweep, merged, tmp_path).staged
    assert sorted(again) == sorted(whole) and "f05.png" in whole and "stack.png" in whole
    assert [name for name in whole if again[name] != whole[name]] == []


def test_chunks_hold_consecutive_rows_of_one_batch(sweep: ExperimentSpec) -> None:
    """Two batches of 6 (240 and 300 steps) in chunks of 4: 4 + 2 rows each, none straddling a batch; the
    progress they report adds up to the steps of every run."""
    parts = chunks.split(sweep, 4)
    assert [(p.batch, p.first, len(p.plan.runs)) for p in parts] == [(0, 0, 4), (0, 4, 2), (1, 0, 4), (1, 4, 2)]
    assert [{r.steps for r in p.plan.runs} for p in parts] == [{240}, {240}, {300}, {300}]
    assert sum(p.weight for p in parts) == 6 * 240 + 6 * 300
    assert all(p.frames == {0, 20, 40, 60, 80, 100, 240} for p in parts)  # the frames, and r3's final state


def test_a_chunk_sends_back_only_the_states_outputs_draw(sweep: ExperimentSpec) -> None:
    """The frames (every 20 steps to 100), the stack picture's state (240) and the final state; the motion window
    stays on the worker."""
    (part,) = [p for p in chunks.split(sweep, 6) if p.batch == 1]
    got = chunks.run_chunk(part)
    assert isinstance(got, chunks.Stepped)
    assert sorted(got.frames) == [0, 20, 40, 60, 80, 100, 240, 300]


def test_chunk_rows_spread_a_sweep_and_bound_its_memory(sweep: ExperimentSpec) -> None:
    assert [len(p.plan.runs) for p in chunks.split(sweep, None, 1)] == [2, 2, 2, 2, 2, 2]  # 4 per thread: 6 / 4
    assert [len(p.plan.runs) for p in chunks.split(sweep, None, 100)] == [1] * 12
    frames = sweep.frame_steps()
    many = [[sweep.runs[0]] * 100_000]  # a batch of 100,000 rows of 240 steps
    per_run = (61 + 6 + 2) * 5 * 40  # 61 states of the motion window, 6 frames, 2 working states; 5 boxes
    assert chunks.CHUNK_BYTES // per_run < 100_000 // 4  # memory, not spreading, bounds the chunks here
    assert chunks.chunk_rows(many, frames, 1) == chunks.CHUNK_BYTES // per_run
    assert chunks.chunk_rows(many, frames, 1000) == 25  # 100,000 / (4 x 1,000)


# ------------------------------------------------------------------------------------------------ failures


@pytest.fixture(scope="module")
def blows(tmp_path_factory: pytest.TempPathFactory) -> ExperimentSpec:
    return load(str(write(tmp_path_factory.mktemp("blows"), "blows", BLOWS)))


def _local_failure(spec: ExperimentSpec) -> RunError:
    with pytest.raises(RunError) as caught:
        run_experiment(spec)
    return caught.value


def _chunked_failure(spec: ExperimentSpec, rows: int) -> RunError:
    parts, outcomes = _chunked(spec, rows)
    assert any(isinstance(o, chunks.Failed) for o in outcomes)
    return chunks.failure(spec, parts, dict(enumerate(outcomes)), _rerun)


@pytest.mark.parametrize("rows", [1, 2, 3, 6])
def test_a_chunked_blow_up_says_and_keeps_what_the_whole_run_does(blows: ExperimentSpec, rows: int) -> None:
    """Chunks of 1 put 'fast' and 'fast2' (both bad at step 31) apart, the first row winning the tie; chunks of
    2 and 3 fail at steps 31 and 76 in different chunks; rows that did not fail are stepped again to step 30."""
    local = _local_failure(blows)
    assert isinstance(local, BlowUp) and "run 'fast' blew up at step 31 of 120" in str(local)
    got = _chunked_failure(blows, rows)
    assert isinstance(got, BlowUp)
    assert str(got) == str(local)
    assert json.dumps(got.report) == json.dumps(local.report)  # the same keys, in the same order
    statuses = {name: row["status"] for name, row in got.report["runs"].items()}
    assert statuses == {"slow": "stopped with its batch", "late": "stopped with its batch",
                        "calm": "stopped with its batch", "fast": "blew up", "fast2": "stopped with its batch",
                        "mild": "stopped with its batch", "early": "finished", "after": "not run"}
    assert {row.get("steps_done") for row in got.report["runs"].values()} == {30, 100, None}


class Raising(PGS):
    """The lab solver, but its stepping raises: a plugin that fails while running."""

    plugin_name = "raising"
    plugin_origin = __file__

    def advance(self, state: Any, steps: int) -> None:
        raise ValueError("no stepping today")


@pytest.mark.parametrize("rows", [1, 4])
def test_a_chunked_plugin_failure_names_every_run_of_its_batch(sweep: ExperimentSpec, rows: int) -> None:
    raising = dataclasses.replace(sweep, runs=[dataclasses.replace(r, solver_cls=Raising) for r in sweep.runs])
    local = _local_failure(raising)
    assert "'r0', 'r1', 'r2', 'r3', 'r4', 'r5': ValueError: no stepping today" in str(local)
    got = _chunked_failure(raising, rows)
    assert type(got) is RunError and str(got) == str(local)


# ------------------------------------------------------------------------------------------------ plugins


def test_a_worker_imports_local_plugins_under_the_senders_names(tmp_path: Path) -> None:
    """In a fresh process, as on a worker: the example plugin file, shipped with its source to a path where it
    is not, is imported under its module name, its runs unpickle, the built-in solver it imports keeps its
    own origin, and the worker's registry keeps nothing of it."""
    spec = load(str(REPO / "configs" / "examples" / "sor-stack.yaml"), plugins=REPO / "plugins")
    from stackx import registry

    (module,) = [m for m in registry.local_modules() if m.path == str(REPO / "plugins" / "sor.py")]
    elsewhere = dataclasses.replace(module, path=str(tmp_path / "gone" / "sor.py"))
    code = """
import pickle, sys
from pathlib import Path
from stackx import registry
module, runs = pickle.loads(sys.stdin.buffer.read())
registry.import_local(module, Path(sys.argv[1]))
run = pickle.loads(runs)[0]
from stackx.solvers.column.pgs import PGS
try:
    registry.solvers.get("sor")
    kept = True
except Exception:
    kept = False
print(run.solver_cls.__module__, run.solver_cls.plugin_origin, PGS.plugin_origin, kept, run.solver_params.omega)
"""
    payload = pickle.dumps((elsewhere, pickle.dumps(spec.runs)))
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "spare")], input=payload, cwd=REPO,
                          capture_output=True, timeout=hang_limit(120))
    assert done.returncode == 0, done.stderr.decode()
    name, origin, pgs_origin, kept, omega = done.stdout.decode().split()
    assert name == module.name and origin == module.origin and pgs_origin == "built-in" and kept == "False"
    assert float(omega) == spec.runs[0].solver_params.omega
    copied = tmp_path / "spare" / module.name.rpartition(".")[2] / "sor.py"
    assert copied.read_bytes() == (REPO / "plugins" / "sor.py").read_bytes()
