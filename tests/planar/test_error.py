"""The planar step log: the every-step error against the reference, worked by hand on a free box, and on
real runs: the reference's own run measures no error, each iterative solver's error falls as its knob grows
(XPBD's only where nothing lands: see its test)."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from stackx.config.experiment import load
from stackx.bench.criteria import Criteria
from stackx.bench.error_planar import BatchLog, RowLog, StepLog, log_step
from stackx.registry import solvers
from stackx.run.runner import run_experiment
from tests.planar.hand_states import boxes

DT = 1 / 60


def _free_box_and_a_plank():
    """A box high in the air (no contact) and a static plank far away, at rest."""
    return boxes([0.0, 30.0], [10.0, 0.5], [0.0, 0.0], [(0.5, 0.25), (5.0, 0.5)], [1.0, 0.0], [0.5, 0.5])


def _after(before, dvx: float, dw: float):
    """The state after a step whose solver got the free fall right but for ``dvx`` and ``dw``."""
    after = before.copy()
    after.vx[0, 0] += dvx
    after.vy[0, 0] += -9.8 * DT
    after.w[0, 0] += dw
    after.y[0, 0] += after.vy[0, 0] * DT
    return after


def test_the_error_is_the_speed_difference_of_the_box_rotation_at_its_corners() -> None:
    before = _free_box_and_a_plank()
    log = BatchLog(1, 2)
    criteria = Criteria()
    g, dt, spec = np.array([-9.8]), np.array([DT]), np.array([0.02])
    r = math.hypot(0.5, 0.25)
    log_step(log, 0, before, _after(before, 0.3, 2.0), g, dt, spec, criteria)
    second = _after(before, 0.0, 0.5)
    log_step(log, 1, before, second, g, dt, spec, criteria)
    log.steps = 2
    first, other = math.sqrt(0.09 + (2.0 * r) ** 2), 0.5 * r  # the plank is static: not counted
    got = RowLog(log, 0).error()
    assert got["rms"] == pytest.approx(math.sqrt((first ** 2 + other ** 2) / 2), rel=1e-9)
    assert got["max"] == pytest.approx(first, rel=1e-9)
    assert (got["worst_step"], got["steps"], got["unsolved"]) == (0, 2, 0)
    assert RowLog(log, 0).crushed_at is None


def test_a_crushed_run_stops_being_measured_and_an_overlap_delays_recovery() -> None:
    before = _free_box_and_a_plank()
    log = BatchLog(1, 2)
    criteria = Criteria()
    g, dt, spec = np.array([-9.8]), np.array([DT]), np.array([0.0])
    sunk = _after(before, 0.0, 0.0)
    sunk.y[0, 0] = 0.2  # 5 cm into the ground: over the depth limit
    log_step(log, 0, before, sunk, g, dt, spec, criteria)
    crushed = _after(before, 1.0, 0.0)
    crushed.reach[0] = 2.0
    log_step(log, 1, before, crushed, g, dt, spec, criteria)
    log_step(log, 2, before, _after(before, 0.0, 0.0), g, dt, spec, criteria)
    log.steps = 3
    row = RowLog(log, 0)
    assert row.crushed_at == 2
    assert row.error()["steps"] == 1 and row.error()["max"] == pytest.approx(0.0, abs=1e-12)
    assert row.timeline()["steps_to_recover"] == 1
    assert row.timeline()["steps_to_settle"] is None  # the box is still falling at the end


@pytest.fixture(scope="module")
def pyramid_errors(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict]:
    """Every step of a 4-row pyramid settling under its weight, by planar-pgs at 1, 4 and 32 iterations and
    by planar-exact, measured by the planar step log."""
    folder = tmp_path_factory.mktemp("planar-error")
    path = folder / "pyramid.yaml"
    path.write_text("""
scene:
  name: planar
  pyramid: {rows: 4, gap: 0.02, friction: 0.5}
solver: {name: planar-pgs, iterations: 10}
dt: 1/60
steps: 40
""")
    spec = load(str(path))
    base = spec.runs[0]
    runs = [replace(base, name=f"pgs{n}", solver_params=base.solver_cls.Params(iterations=n)) for n in (1, 4, 32)]
    exact = solvers.get("planar-exact")
    runs.append(replace(base, name="exact", solver_cls=exact, solver_params=exact.Params(speculative=0.0)))
    spec.runs = runs
    log = StepLog(Criteria())
    run_experiment(spec, None, log)
    return {name: row.error() for name, row in log.rows.items()}


def test_the_reference_run_measures_no_error(pyramid_errors: dict[str, dict]) -> None:
    assert pyramid_errors["exact"]["max"] < 1e-9
    assert pyramid_errors["exact"]["steps"] == 40 and pyramid_errors["exact"]["unsolved"] == 0


def test_the_lab_solver_error_falls_as_its_iterations_grow(pyramid_errors: dict[str, dict]) -> None:
    rms = [pyramid_errors[name]["rms"] for name in ("pgs1", "pgs4", "pgs32")]
    assert rms[0] > rms[1] > rms[2] > 0.0
    assert all(pyramid_errors[name]["unsolved"] == 0 for name in ("pgs1", "pgs4", "pgs32"))


LANDING = """
scene:
  name: planar
  pyramid: {rows: 3, gap: 0.02, friction: 0.5}
  boxes: [{x: 0.2, y: 3.8, angle: 10, mass: 2.0}]
solver: {name: planar-pgs}
dt: 1/60
steps: 20
"""

CARD_HOUSE = """
scene:
  name: planar
  card_house: {}
solver: {name: planar-pgs}
dt: 1/60
steps: 60
"""


def knob_errors(folder, text: str, name: str, knob: str, values: tuple[int, ...]) -> list[dict]:
    """The planar step log's error of solver ``name`` on the scene ``text``, at each of ``values`` of its
    cost knob."""
    path = folder / "scene.yaml"
    path.write_text(text)
    spec = load(str(path))
    cls = solvers.get(name)
    spec.runs = [replace(spec.runs[0], name=f"{name}/{v}", solver_cls=cls, solver_params=cls.Params(**{knob: v}))
                 for v in values]
    log = StepLog(Criteria())
    run_experiment(spec, None, log)
    return [row.error() for row in log.rows.values()]


KNOBS = [("planar-pgs", "iterations"), ("planar-warm-start", "iterations"), ("planar-ngs", "iterations"),
         ("planar-soft-step", "substeps")]


@pytest.mark.parametrize(("solver", "knob"), KNOBS)
def test_every_iterative_solver_comes_closer_to_the_reference_as_its_knob_grows(
        tmp_path: Path, solver: str, knob: str) -> None:
    # a heavy box landing tilted on a 3-row pyramid, the knob at 2 and at 32
    low, high = knob_errors(tmp_path, LANDING, solver, knob, (2, 32))
    assert low["rms"] > high["rms"] > 0.0
    # every step measured: the reference solved each one (an unsolved step may be the worst)
    assert (low["steps"], low["unsolved"], high["steps"], high["unsolved"]) == (20, 0, 20, 0)


def test_small_steps_come_closer_to_the_reference_without_impacts_and_not_on_one(tmp_path: Path) -> None:
    """XPBD's substeps approach the motion of ever smaller steps, not the answer of one step's contact
    problem: where nothing hits anything (a card house settling) the two agree and its error falls a
    hundredfold from 2 to 32 substeps; where a box lands, the one-step problem sees the impact at the start
    of the step and the substeps see it when it comes, so past a few substeps the error grows again."""
    low, high = knob_errors(tmp_path, CARD_HOUSE, "planar-xpbd", "substeps", (2, 32))
    assert high["rms"] < 0.01 * low["rms"]
    few, many = knob_errors(tmp_path, LANDING, "planar-xpbd", "substeps", (4, 32))
    assert many["rms"] > 1.2 * few["rms"]
    assert (few["unsolved"], many["unsolved"]) == (0, 0)


def test_beside_the_error_each_step_logs_how_fast_the_solver_lets_a_point_sink() -> None:
    # a box resting flat on the ground (two touching points, target 0): a solver that only applied gravity lets
    # both points sink at g dt; one that held it, not at all; the step log keeps the worst and the RMS over steps
    before = boxes([0.0], [0.5], [0.0], [(0.5, 0.5)], [1.0], [0.5])
    g, dt, spec = np.array([-9.8]), np.array([DT]), np.array([0.02])  # touching points are within the margin
    log = BatchLog(1, 1)
    fell = before.copy()
    fell.vy[0, 0] = -9.8 * DT
    log_step(log, 0, before, fell, g, dt, spec, Criteria())
    log_step(log, 1, before, before.copy(), g, dt, spec, Criteria())
    log.steps = 2
    got = RowLog(log, 0).error()
    assert got["approach_max"] == pytest.approx(9.8 * DT, rel=1e-12)
    assert got["approach_rms"] == pytest.approx(9.8 * DT / math.sqrt(2), rel=1e-12)
    assert BatchLog(1, 1) and RowLog(BatchLog(1, 1), 0).error()["approach_max"] is None  # no step logged
