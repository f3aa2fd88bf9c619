"""How the bench shows an error beside its uncertainty and beside the steps the reference left unsolved, from
records given here (no clock, no run): the error's text, fronts and winners that tie errors the uncertainty
cannot tell apart, runs with unsolved steps kept (and named) in fronts, winners and the speed plot, broken runs
kept out."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from stackx.bench.compare import equal_cost, measured, pareto
from stackx.bench.criteria import Criteria
from stackx.bench.figures import error_text
from stackx.bench.report import bench_json
from stackx.bench.result import shown
from stackx.bench.sweep import Record
from stackx.bench.tables import answers
from tests.bench.test_terminal_summary import _case, _run, _screen


@pytest.fixture(autouse=True)
def _compiled(monkeypatch: pytest.MonkeyPatch) -> None:
    """Compiled kernels on, as ``stackx bench`` sets them."""
    monkeypatch.setenv("STACKX_JIT", "1")


def _planar(solver: str, value: int, us: float, rms: float, spread: float = 0.0, unsolved: int = 0,
            residual: float = 0.0) -> Record:
    """A passing run whose error carries what a planar step log gives: its uncertainty and unsolved steps."""
    rec = _run(solver, value, us, rms)
    rec.error.update(spread=spread, spread_max=2 * spread, unsolved=unsolved, unsolved_residual=residual)
    return rec


def _front(records: list[Record]) -> list[tuple[str, int | None]]:
    return [(r.solver, r.value) for r in pareto(records)]


def _winners(records: list[Record]) -> dict[float, str | None]:
    return {row["target"]: row["winner"] for row in equal_cost(records)}


def _text(items: list[Any]) -> str:
    """What the terminal shows, its lines joined and its wrapping undone."""
    return " ".join(" ".join(_screen(*items)).split())


def test_an_error_with_unsolved_steps_says_how_many_and_the_residual_left() -> None:
    """Three steps the reference could not solve, the worst left at 2.4e-6 m/s: both are said, in every table
    (the terminal's and the report's every-run table)."""
    rec = _planar("planar-xpbd", 4, 1.0, 0.0124, unsolved=3, residual=2.4e-6)
    assert error_text(rec) == "0.0124 (3 steps unsolved, residual <= 2.4e-6 m/s)"
    assert shown(rec)["error"] == "0.0124 (3 steps unsolved, residual <= 2.4e-6 m/s)"
    one = _planar("planar-xpbd", 4, 1.0, 0.0124, unsolved=1, residual=3e-7)
    assert error_text(one) == "0.0124 (1 step unsolved, residual <= 3e-7 m/s)"


def test_an_error_within_its_uncertainty_reads_as_a_bound() -> None:
    """0.0011 m/s measured where the exact answers found lie 0.0024 apart: the error cannot be told from zero
    and reads '<= 0.0024', never as the number; at the uncertainty itself the same; above it, the number and
    its uncertainty; a column run without one, the number alone."""
    assert error_text(_planar("planar-pgs", 4, 1.0, 0.0011, spread=0.0024)) == "<= 0.0024"
    assert error_text(_planar("planar-pgs", 4, 1.0, 0.0024, spread=0.0024)) == "<= 0.0024"
    assert error_text(_planar("planar-pgs", 4, 1.0, 0.0124, spread=0.0004)) == "0.0124 ± 0.0004"
    assert error_text(_run("pgs", 4, 1.0, 0.0124)) == "0.0124"
    assert shown(_planar("planar-pgs", 4, 1.0, 0.0011, spread=0.0024))["error"] == "<= 0.0024"


def test_a_run_with_unsolved_steps_stays_in_fronts_and_winners_and_is_named() -> None:
    """planar-xpbd is the fastest and the most accurate run that passed, with 3 steps the reference left
    unsolved: it is drawn, it is the front and it wins every level it reaches, and the front's and the
    winners' headings name it, its line giving the steps and the residual."""
    xpbd = _planar("planar-xpbd", 4, 1.0, 0.005, unsolved=3, residual=2e-6)
    pgs = _planar("planar-pgs", 8, 3.0, 0.02)
    records = [xpbd, pgs]
    assert xpbd in measured(records)
    assert _front(records) == [("planar-xpbd", 4)]
    assert _winners(records)[1e-2] == "planar-xpbd" and _winners(records)[1e-1] == "planar-xpbd"
    row = next(row for row in equal_cost(records) if row["target"] == 1e-2)
    assert row["unsolved"] == ["planar-xpbd"] and row["solvers"][0]["unsolved"] == 3
    text = _text(answers(_case(records)))
    front = text.split("front (")[1].split("fastest to reach")[0]
    assert "1 with steps unsolved by the reference: planar-xpbd it 4" in front
    assert "0.005 m/s (3 steps unsolved, residual <= 2e-6 m/s)" in front
    assert "1 with steps unsolved by the reference: planar-xpbd it 4" in text.split("fastest to reach")[1]


def test_a_broken_run_stays_out_whatever_its_error() -> None:
    """A crushed run and one that blew up, both faster and more accurate than the others (and the crushed one
    with unsolved steps): neither is drawn, on a front or a winner; a sound run with unsolved steps is."""
    crushed = _planar("planar-xpbd", 4, 0.1, 1e-6, unsolved=2, residual=1e-7)
    crushed.crushed_at = 12
    blown = _planar("planar-jacobi", 4, 0.1, 1e-6)
    blown.blew_up = "run 'x' blew up at step 3"
    sound = _planar("planar-xpbd", 8, 2.0, 0.01, unsolved=2, residual=1e-7)
    pgs = _planar("planar-pgs", 8, 3.0, 0.02)
    records = [crushed, blown, sound, pgs]
    assert measured(records) == [sound, pgs]
    assert _front(records) == [("planar-xpbd", 8)]
    assert {row["winner"] for row in equal_cost(records)} == {None, "planar-xpbd"}


def test_runs_within_their_uncertainty_are_tied_on_error_and_cost_decides() -> None:
    """Both errors are within the 0.003 m/s the exact answers lie apart: planar-ngs's 0.0001 is no better
    than planar-pgs's 0.002, so the cheaper, planar-pgs, is the front alone; neither reaches 1e-3 (their
    uncertainty does not), and planar-pgs is the cheaper to reach 1e-2."""
    pgs = _planar("planar-pgs", 4, 1.0, 0.002, spread=0.003)
    ngs = _planar("planar-ngs", 4, 2.0, 0.0001, spread=0.003)
    records = [pgs, ngs]
    assert _front(records) == [("planar-pgs", 4)]
    winners = _winners(records)
    assert winners[1e-3] is None and winners[1e-2] == "planar-pgs"
    text = _text(answers(_case(records)))
    assert "<=: 1 within its uncertainty, tied on error" in text.split("front (")[1].split("fastest to reach")[0]


def test_an_error_above_its_uncertainty_compares_by_its_number() -> None:
    """0.005 ± 0.001 is below 0.02 ± 0.001 beyond both uncertainties: the slower, more accurate run stays on
    the front beside the faster one. 0.010 ± 0.001 and 0.0105 ± 0.001 overlap: tied, the cheaper alone."""
    fast, accurate = _planar("planar-pgs", 4, 1.0, 0.02, spread=0.001), _planar("planar-ngs", 4, 2.0, 0.005,
                                                                                  spread=0.001)
    assert _front([fast, accurate]) == [("planar-pgs", 4), ("planar-ngs", 4)]
    assert _winners([fast, accurate])[1e-2] == "planar-ngs"
    near_fast = _planar("planar-pgs", 8, 1.0, 0.0105, spread=0.001)
    near_accurate = _planar("planar-ngs", 8, 2.0, 0.010, spread=0.001)
    assert _front([near_fast, near_accurate]) == [("planar-pgs", 8)]


def test_the_speed_plot_draws_unsolved_runs_marked_and_bounds_at_their_uncertainty() -> None:
    """planar-xpbd's run with unsolved steps is drawn, as a diamond, at its error; planar-ngs's error within
    its uncertainty is drawn at the uncertainty (not at its 1e-4) with an arrow down from it; the crushed run
    is not drawn; the legend names both marks."""
    pytest.importorskip("matplotlib")
    from stackx.bench.plots import _pyplot, speed_error_figure

    xpbd = _planar("planar-xpbd", 4, 1.5, 0.005, unsolved=3, residual=2e-6)
    ngs = _planar("planar-ngs", 4, 2.0, 1e-4, spread=0.003)
    pgs = _planar("planar-pgs", 4, 1.0, 0.02, spread=0.001)
    crushed = _planar("planar-jacobi", 4, 0.7, 1e-5)
    crushed.crushed_at = 5
    fig = speed_error_figure("pile", [xpbd, ngs, pgs, crushed])
    try:
        lines = fig.axes[0].get_lines()

        def at(x: float) -> list[Any]:
            return [ln for ln in lines if list(ln.get_xdata()) == [x] and ln.get_marker() != "None"]

        assert [ln.get_marker() for ln in at(1.5)] == ["D"]
        assert list(at(1.5)[0].get_ydata()) == [0.005]
        assert [(ln.get_marker(), list(ln.get_ydata())) for ln in at(1.0)] == [("o", [0.02])]  # as any run
        ngs_marks = sorted(at(2.0), key=lambda ln: -ln.get_ydata()[0])
        assert ngs_marks[0].get_ydata()[0] == 0.003 and ngs_marks[0].get_marker() == "o"
        assert len(ngs_marks) == 2 and ngs_marks[1].get_ydata()[0] < 0.003  # the arrow's head, below
        arrow = next(ln for ln in lines if list(ln.get_xdata()) == [2.0, 2.0])
        assert max(arrow.get_ydata()) == 0.003 and min(arrow.get_ydata()) < 0.003
        assert not any(0.7 in list(ln.get_xdata()) for ln in lines)
        labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
        assert any("unsolved" in t for t in labels) and any("<=" in t for t in labels)
    finally:
        _pyplot().close(fig)



def test_bench_json_carries_each_front_runs_uncertainty_and_unsolved_steps(tmp_path: Path) -> None:
    """bench.json keeps each record's error whole (its spread too), and each run on the front says its error,
    its uncertainty and its unsolved steps, so a reader of the file alone can tell a bound from a number."""
    config = tmp_path / "pile.yaml"
    config.write_text("steps: 10\n")
    xpbd = _planar("planar-xpbd", 4, 0.5, 0.005, spread=0.001, unsolved=3, residual=2e-6)
    pgs = _planar("planar-pgs", 4, 1.0, 0.0005, spread=0.001)
    res = _case([xpbd, pgs])
    res.case.spec = SimpleNamespace(file=str(config), description="a pile")
    res.case.run.scene.events = list
    res.case.run.dt, res.case.run.gravity = 0.01, -9.8
    res.case.section = SimpleNamespace(criteria=Criteria())
    res.case.plans = []
    doc = json.loads(bench_json([res], "stackx bench pile.yaml", 1.0))["cases"][0]
    assert [r["error"]["spread"] for r in doc["records"]] == [0.001, 0.001]
    front = {p["solver"]: p for p in doc["pareto"]}
    assert (front["planar-xpbd"]["error_spread"], front["planar-xpbd"]["unsolved"]) == (0.001, 3)
    assert (front["planar-pgs"]["error_spread"], front["planar-pgs"]["unsolved"]) == (0.001, 0)
