"""The solver x case matrix of docs/planar.md (``python -m benchmarks.planar_outcomes``): the cheapest knob value
that holds is found by trying 1, 2, 4, ... and stopping at the first that passes; every run's outcome is cached
as it ends, so a rerun makes only the missing runs; the markdown goes between its marks and nowhere else."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import pytest

from benchmarks import planar_outcomes as po
from tests.conftest import CONFIGS


def _case(tmp_path: Path, name: str = "tiny", text: str = "steps: 1\n") -> po.Case:
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return po.Case.read(path)


def holds_from(least: int, us_per_pass: float = 10.0):  # type: ignore[no-untyped-def]
    """A fake run: fails at its defaults and below ``least``, passes from it; µs grow with the knob."""
    def run(t: po.Trial) -> po.Outcome:
        v = t.value
        if v is None:
            return po.Outcome(False, "drifted", 5.0)
        return po.Outcome(v >= least, "" if v >= least else "turned", us_per_pass * v)
    return run


class Counting:
    def __init__(self, run) -> None:  # type: ignore[no-untyped-def]
        self.run, self.made = run, []

    def __call__(self, t: po.Trial) -> po.Outcome:
        self.made.append(t.value)
        return self.run(t)  # type: ignore[no-any-return]


def fake_pass_at_4(t: po.Trial) -> po.Outcome:
    """Module level, so processes can run it: passes from knob value 4."""
    return holds_from(4)(t)  # type: ignore[no-any-return]


def test_ladder_doubles_to_the_cap_and_ends_on_it() -> None:
    assert po.ladder(256) == [1, 2, 4, 8, 16, 32, 64, 128, 256]
    assert po.ladder(6) == [1, 2, 4, 6] and po.ladder(1) == [1]
    assert po.cap_of("substeps") == 64 and po.cap_of("iterations") == 256 and po.cap_of(None) == 256


def test_the_search_stops_at_the_first_knob_value_that_holds(tmp_path: Path) -> None:
    case, run = _case(tmp_path), Counting(holds_from(8))
    cache = po.Cache(None)
    assert po.fill([(case, "s", "iterations")], cache, run) == 5
    assert run.made == [None, 1, 2, 4, 8]
    c = po.cell(case, "s", "iterations", cache.outcomes)
    assert c.complete and c.holds_at == 8 and c.holds is not None and c.holds.us == 80.0
    assert po.show(c) == "drifted 5 µs · 8: 80 µs"


def test_a_solver_that_never_holds_is_tried_up_to_its_cap(tmp_path: Path) -> None:
    case, run = _case(tmp_path), Counting(holds_from(10_000))
    cache = po.Cache(None)
    po.fill([(case, "s", "substeps")], cache, run)
    assert run.made == [None, 1, 2, 4, 8, 16, 32, 64]
    assert po.show(po.cell(case, "s", "substeps", cache.outcomes)) == "drifted 5 µs · none to 64"


def test_a_solver_without_a_knob_runs_once(tmp_path: Path) -> None:
    case, run = _case(tmp_path), Counting(holds_from(1))
    cache = po.Cache(None)
    po.fill([(case, "engine", None)], cache, run)
    assert run.made == [None]
    assert po.show(po.cell(case, "engine", None, cache.outcomes)) == "drifted 5 µs"


def test_without_the_search_a_cell_is_its_defaults_alone(tmp_path: Path) -> None:
    case, run = _case(tmp_path), Counting(holds_from(1))
    cache = po.Cache(None)
    po.fill([(case, "s", "iterations")], cache, run, search=False)
    assert run.made == [None]
    assert po.show(po.cell(case, "s", "iterations", cache.outcomes, search=False)) == "drifted 5 µs"


def test_an_interrupted_run_resumes_with_only_the_missing_runs(tmp_path: Path) -> None:
    case, file = _case(tmp_path), tmp_path / "cells.json"
    calls = {"n": 0}

    def breaks_on_the_fourth(t: po.Trial) -> po.Outcome:
        calls["n"] += 1
        if calls["n"] == 4:
            raise KeyboardInterrupt
        return holds_from(16)(t)  # type: ignore[no-any-return]

    with pytest.raises(KeyboardInterrupt):
        po.fill([(case, "s", "iterations")], po.Cache(file), breaks_on_the_fourth)
    kept = json.loads(file.read_text())["outcomes"]
    assert len(kept) == 3  # the defaults, 1 and 2: each kept as it ended
    again = Counting(holds_from(16))
    po.fill([(case, "s", "iterations")], po.Cache(file), again)
    assert again.made == [4, 8, 16]
    rerun = Counting(holds_from(16))
    assert po.fill([(case, "s", "iterations")], po.Cache(file), rerun) == 0 and rerun.made == []


def test_an_edited_config_or_a_forgotten_solver_runs_again_a_reworded_one_does_not(tmp_path: Path) -> None:
    file = tmp_path / "cells.json"
    case = _case(tmp_path)
    po.fill([(case, "s", None), (case, "t", None)], po.Cache(file), holds_from(1))
    reworded = _case(tmp_path, text="description: the same case, said otherwise\nsteps: 1\n")
    run = Counting(holds_from(1))
    po.fill([(reworded, "s", None)], po.Cache(file), run)
    assert run.made == []
    edited = _case(tmp_path, text="steps: 2\n")
    po.fill([(edited, "s", None)], po.Cache(file), run)
    assert run.made == [None]
    cache = po.Cache(file)
    assert cache.forget(["t"]) == 1
    run = Counting(holds_from(1))
    po.fill([(case, "s", None), (case, "t", None)], po.Cache(file), run)
    assert run.made == [None]  # only t's


def test_a_cache_of_another_layout_is_refused(tmp_path: Path) -> None:
    file = tmp_path / "cells.json"
    file.write_text(json.dumps({"version": 0, "outcomes": {}}))
    with pytest.raises(po.Refusal, match="cells.json"):
        po.Cache(file)


def test_two_jobs_fill_the_same_cells_as_one(tmp_path: Path) -> None:
    cases = [_case(tmp_path, f"c{i}") for i in range(2)]
    cells = [(c, s, "iterations") for c in cases for s in ("a", "b")]
    one, two = po.Cache(None), po.Cache(tmp_path / "two.json")
    po.fill(cells, one, fake_pass_at_4)
    assert po.fill(cells, two, fake_pass_at_4, jobs=2) == 16
    assert two.outcomes == one.outcomes
    assert po.Cache(tmp_path / "two.json").outcomes == one.outcomes


def test_the_matrix_has_the_reference_apart_and_the_cheapest_run_per_case(tmp_path: Path) -> None:
    case = _case(tmp_path)
    done: dict[str, po.Outcome] = {}
    for solver, run in (("planar-exact", holds_from(1)), ("planar-a", holds_from(2, 10.0)),
                        ("planar-b", holds_from(4, 1.0))):
        cache = po.Cache(None)
        po.fill([(case, solver, None if solver == "planar-exact" else "iterations")], cache, run)
        done.update(cache.outcomes)
    lines = po.matrix([case], [("planar-exact", None), ("planar-a", "iterations"), ("planar-b", "iterations")], done)
    assert lines[0] == "| case | `planar-exact` | `a` (iterations) | `b` (iterations) | cheapest that holds |"
    assert lines[2] == ("| `tiny` | drifted 5 µs | drifted 5 µs · 2: 20 µs | drifted 5 µs · 4: 4 µs "
                        "| b 4 (4 µs) |")


def test_a_cell_not_yet_run_shows_a_dash_and_nothing_holds_shows_a_dash(tmp_path: Path) -> None:
    case = _case(tmp_path)
    lines = po.matrix([case], [("planar-a", "iterations")], {}, reference=None)
    assert lines[2] == "| `tiny` | - | - |"
    assert po.show(po.Cell("s", None, 256, po.Outcome(False, "blew up", math.nan), None, None, True)) == "blew up -"


def test_the_matrix_goes_between_its_marks_and_nowhere_else(tmp_path: Path) -> None:
    doc = tmp_path / "planar.md"
    doc.write_text(f"# Title\n\nbefore\n{po.BEGIN}\nold table\n{po.END}\nafter\n")
    po.write_between(doc, ["| new |", "| --- |"])
    assert doc.read_text() == f"# Title\n\nbefore\n{po.BEGIN}\n| new |\n| --- |\n{po.END}\nafter\n"
    po.write_between(doc, ["| newer |"])  # again: the marks are still there, the old lines gone
    assert doc.read_text() == f"# Title\n\nbefore\n{po.BEGIN}\n| newer |\n{po.END}\nafter\n"


def test_a_file_without_both_marks_is_refused_unchanged(tmp_path: Path) -> None:
    doc = tmp_path / "planar.md"
    for text in ("no marks\n", f"{po.END}\n{po.BEGIN}\n", f"{po.BEGIN}\nonly the start\n"):
        doc.write_text(text)
        with pytest.raises(po.Refusal, match="planar.md"):
            po.write_between(doc, ["| x |"])
        assert doc.read_text() == text


def test_bad_input_is_one_line_and_exit_code_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    jit = os.environ.get("STACKX_JIT")
    doc = tmp_path / "planar.md"
    doc.write_text("no marks\n")
    skid = str(CONFIGS / "planar" / "skid.yaml")
    for argv in (["--solvers", "pgs", skid], ["--solvers", "planar-nonesuch", skid], [str(tmp_path / "missing.yaml")],
                 ["--solvers", "planar-pgs", skid]):  # the last: a run that would work, into a file without marks
        with pytest.raises(SystemExit) as exit_:
            po.main(argv + ["--write", str(doc)])
        assert exit_.value.code == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("error: ") and len(err.splitlines()) == 1, err
    assert doc.read_text() == "no marks\n"
    assert "STACKX_JIT" not in os.environ or os.environ["STACKX_JIT"] == jit  # refused before anything ran


def test_the_solvers_are_every_planar_one_registered_the_reference_first() -> None:
    from stackx import registry

    found = po.planar_solvers()
    names = [s for s, _ in found]
    assert names[0] == "planar-exact" and dict(found)["planar-exact"] is None
    for name in names:
        cls = registry.solvers.get(name)
        assert "planar" in cls.models and not registry.unavailable(cls)
    assert {"planar-pgs", "planar-ngs", "planar-soft-step"} <= set(names) and "pgs" not in names
    assert dict(found)["planar-soft-step"] == "substeps"


def test_a_real_run_fills_the_cache_and_writes_the_doc(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("STACKX_JIT", "1")
    monkeypatch.setattr(po.signal, "signal", lambda *a: None)
    doc, file = tmp_path / "planar.md", tmp_path / "cells.json"
    doc.write_text(f"intro\n{po.BEGIN}\n{po.END}\n")
    config = CONFIGS / "planar" / "ramp-stick.yaml"
    po.main([str(config), "--solvers", "planar-ngs", "--no-search", "--cache", str(file), "--write", str(doc)])
    text = doc.read_text()
    assert "| `ramp-stick` | pass " in text
    assert f"Made by `python -m benchmarks.planar_outcomes {config} --solvers planar-ngs --no-search` on " in text
    assert text.startswith("intro\n") and text.endswith(f"{po.END}\n")
    (outcome,) = json.loads(file.read_text())["outcomes"].values()
    assert outcome["passed"] and outcome["us"] > 0
