"""The compiled and the plain path give the same numbers: on every lab artifact, on the hard cases with every
registered solver, and between a parallel batch and its rows stepped one by one.

The plain path is the readable reference (``STACKX_JIT=0``: the kernels run as the Python they are written
in); the compiled path is numba's build of the same source (``STACKX_JIT=1``). Nothing here is compared with
a stored value: each path is the other's yardstick.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from stackx import kernel, registry
from stackx.config.experiment import load
from stackx.errors import StackxError
from stackx.run.results import ExperimentResult
from stackx.run.runner import run_experiment
from stackx.run.session import run_all
from stackx.models.column.state import ColumnState
from tests.conftest import CONFIGS, REPO
from tests.solvers.columns import solver_names
from tests.speed.artifacts import differences
from tests.limits import hang_limit

HARD = sorted((CONFIGS / "hard").glob("*.yaml"))
SMALL_STEPS = 240  # steps of a shrunk hard case (more when a scene event comes later)
SMALL_BOXES = 30  # boxes of a shrunk tall column

registry.load_local_plugins(REPO / "plugins")
SOLVERS = solver_names()  # engines that are not installed are skipped, with the command that installs them


# --------------------------------------------------------------------------------- the lab, as a user runs it


@pytest.fixture(scope="module")
def lab_by_path(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """``stackx run configs/`` in a subprocess with each path."""
    outs = {}
    for jit in ("1", "0"):
        out = tmp_path_factory.mktemp(f"lab-jit{jit}")
        subprocess.run([sys.executable, "-m", "stackx", "run", str(CONFIGS), "--out", str(out), "-q"], cwd=REPO,
                       check=True, env={**os.environ, "STACKX_JIT": jit}, timeout=hang_limit(300))
        outs[jit] = out
    return outs


def test_lab_artifacts_are_the_same_compiled_and_plain(lab_by_path: dict[str, Path]) -> None:
    compiled, plain = lab_by_path["1"], lab_by_path["0"]
    assert (compiled / "06-stack.txt").is_file() and (compiled / "f11.png").is_file()
    assert differences(compiled, plain) == []


def test_the_comparison_sees_a_changed_number(lab_by_path: dict[str, Path], tmp_path: Path) -> None:
    """The yardstick can fail: one height moved by 1e-9 in a copy is reported."""
    copy = tmp_path / "copy"
    shutil.copytree(lab_by_path["1"], copy)
    text = (copy / "06-stack.txt").read_text().splitlines()
    key, _, value = text[0].partition("=")
    text[0] = f"{key}={float(value) + 1e-9!r}"
    (copy / "06-stack.txt").write_text("\n".join(text) + "\n")
    assert any("06-stack.txt" in d for d in differences(lab_by_path["1"], copy))


# --------------------------------------------------------------------------------- the hard cases, small


def small_case(path: Path, solver: str | None, folder: Path) -> Path:
    """A copy of a hard case with fewer steps and boxes, optionally stepped by ``solver`` at its defaults."""
    doc = yaml.safe_load(path.read_text())
    events = [r["step"] for r in doc.get("scene", {}).get("remove", [])]
    doc["steps"] = min(doc["steps"], max([SMALL_STEPS, *[s + 60 for s in events]]))
    stack = doc["scene"].get("stack")
    if stack and stack["count"] > SMALL_BOXES:
        stack["count"] = SMALL_BOXES
    if solver is not None:
        doc["solver"] = {"name": solver}
    doc.pop("bench", None)
    out = folder / path.name
    out.write_text(yaml.safe_dump(doc, sort_keys=False))
    return out


def run_path(config: Path, jit: str, out: Path, monkeypatch: pytest.MonkeyPatch) -> list[Any] | str:
    """The results of ``stackx run`` on one path, or the error it stopped with (a blow-up is an outcome too)."""
    monkeypatch.setenv("STACKX_JIT", jit)
    try:
        return run_all([load(str(config))], out, quiet=True)
    except StackxError as exc:
        return f"{type(exc).__name__}: {exc}"


def assert_same_runs(a: list[Any] | str, b: list[Any] | str) -> None:
    """Every recorded state of every run bit-identical, field by field (or the same error on both paths)."""
    if isinstance(a, str) or isinstance(b, str):
        assert a == b
        return
    for ra, rb in zip(a[0].runs, b[0].runs, strict=True):
        assert ra.frames.keys() == rb.frames.keys()
        for k in ra.frames:
            for field in ColumnState.FIELDS:
                np.testing.assert_array_equal(getattr(ra.frames[k], field), getattr(rb.frames[k], field),
                                              err_msg=f"{ra.name} before step {k}: {field}")


@pytest.mark.skipif(not HARD, reason="no configs/hard/*.yaml in this tree")
@pytest.mark.parametrize("case", HARD, ids=[p.stem for p in HARD])
def test_hard_cases_as_configured(case: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    config = small_case(case, None, tmp_path)
    compiled = run_path(config, "1", tmp_path / "jit1", monkeypatch)
    plain = run_path(config, "0", tmp_path / "jit0", monkeypatch)
    assert_same_runs(compiled, plain)
    assert differences(tmp_path / "jit1", tmp_path / "jit0") == []


@pytest.mark.skipif(not HARD, reason="no configs/hard/*.yaml in this tree")
@pytest.mark.parametrize("solver", SOLVERS)
def test_every_solver_on_the_hard_cases(solver: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each registered solver at its defaults, on every shrunk hard case, compiled against plain."""
    for case in HARD:
        config = small_case(case, solver, tmp_path)
        compiled = run_path(config, "1", tmp_path / f"{case.stem}-jit1", monkeypatch)
        plain = run_path(config, "0", tmp_path / f"{case.stem}-jit0", monkeypatch)
        assert_same_runs(compiled, plain)


# --------------------------------------------------------------------------------- a parallel batch


def sweep_config(folder: Path, solver: dict[str, Any], grid: dict[str, list[Any]]) -> Path:
    doc = yaml.safe_load((CONFIGS / "06-stack.yaml").read_text())
    doc.update(solver=solver, steps=300, outputs=[], sweep={"name": "v{index}", "grid": grid})
    path = folder / "sweep.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


PARALLEL_SWEEPS = {
    "pgs": ({"name": "pgs"}, {"solver.iterations": [1, 4, 15], "solver.correction.percent": [0.1, 0.2, 0.5, 1.0],
                              "solver.correction.slop": [0.0, 0.002, 0.005, 0.008, 0.01, 0.015, 0.02, 0.03, 0.04]}),
    "warm-start": ({"name": "warm-start"}, {"solver.iterations": [1, 4, 15],
                                            "solver.correction.percent": [0.1, 0.2, 0.5, 1.0],
                                            "solver.speculative": [0.0, 0.005, 0.01, 0.015, 0.02, 0.03, 0.05, 0.07, 0.1]}),
}


@pytest.mark.parametrize("name", [n for n in PARALLEL_SWEEPS if n in SOLVERS])
def test_a_parallel_batch_equals_its_rows_alone_and_the_plain_path(name: str, tmp_path: Path) -> None:
    """108 variants x 5 boxes (above twice the parallel grain): one batch over the threads, each row alone, and
    the plain path."""
    solver, grid = PARALLEL_SWEEPS[name]
    spec = load(str(sweep_config(tmp_path, solver, grid)))
    rows = len(spec.runs)
    assert rows * 5 >= 2 * kernel.GRAIN  # big enough to be split over two threads when there are two
    runs = spec.runs

    def step(batch: list[Any], compiled: bool) -> ColumnState:
        state = ColumnState.concat([r.scene.build() for r in batch])
        stepper = batch[0].solver_cls([r.solver_params for r in batch], np.array([r.gravity for r in batch]),
                                      np.array([r.dt for r in batch]))
        with kernel.compiled(compiled):
            for chunk in (1, 99, 200):
                stepper.advance(state, chunk)
        return state

    together = step(runs, True)
    plain = step(runs, False)
    for field in ColumnState.FIELDS:
        np.testing.assert_array_equal(getattr(together, field), getattr(plain, field), err_msg=field)
    for b in range(0, rows, 7):
        alone = step([runs[b]], True)
        for field in ColumnState.FIELDS:
            np.testing.assert_array_equal(getattr(together, field)[b:b + 1], getattr(alone, field),
                                          err_msg=f"row {b}: {field}")


def test_the_runner_steps_a_sweep_the_same_compiled_and_plain(tmp_path: Path,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    path = sweep_config(tmp_path, *PARALLEL_SWEEPS["pgs"])
    monkeypatch.setenv("STACKX_JIT", "1")
    compiled = run_experiment(load(str(path)))
    monkeypatch.setenv("STACKX_JIT", "0")
    plain = run_experiment(load(str(path)))
    assert_same_runs([compiled], [plain])
    assert [r.measures for r in compiled.runs] == [r.measures for r in plain.runs]


def test_each_run_of_a_batch_is_measured_as_if_alone(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The runner measures a batch at once (the final motion of every row together, each row with its own step
    size): each run's measures and recorded states are bit for bit those of the run stepped alone."""
    monkeypatch.setenv("STACKX_JIT", "0")
    grid = {"dt": [1 / 60, 1 / 45], "solver.iterations": [2, 9], "solver.correction.percent": [0.2, 0.7]}
    sweep = run_experiment(load(str(sweep_config(tmp_path, {"name": "pgs"}, grid))))
    assert len({(r.spec.solver_cls, r.spec.steps, r.spec.scene.size()) for r in sweep.runs}) == 1  # one batch
    for run in sweep.runs:
        doc = yaml.safe_load((tmp_path / "sweep.yaml").read_text())
        del doc["sweep"]
        doc["dt"] = run.spec.dt
        doc["solver"]["iterations"] = run.spec.solver_params.iterations
        doc["solver"]["correction"] = {"percent": run.spec.solver_params.correction.percent}  # as the grid sets it
        alone_path = tmp_path / f"{run.name}.yaml"
        alone_path.write_text(yaml.safe_dump(doc, sort_keys=False))
        alone = run_experiment(load(str(alone_path)))
        assert alone.runs[0].measures == run.measures, run.name
        assert_same_runs([alone], [ExperimentResult(sweep.spec, [run])])
