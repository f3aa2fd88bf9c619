"""``stackx bench`` end to end on tiny cases: bench.json, report.html and its plots, the matrix, bad input."""

from __future__ import annotations

import hashlib
import html
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from stackx import registry
from tests.conftest import REPO, Cli
from tests.lab.reference import png_header

CASES = {
    "tall-6": """
description: six equal boxes resting on each other
scene: {name: column, stack: {count: 6, y0: 0.501, spacing: 1.0}}
solver: {name: pgs, iterations: 15, correction: {slop: 0.01, percent: 0.2}}
steps: 240
""",
    "ratio-20": """
description: four light boxes under a box of mass 20
scene:
  name: column
  boxes: [{y: 0.501}, {y: 1.501}, {y: 2.501}, {y: 3.501}, {y: 4.501, mass: 20}]
solver: {name: pgs, iterations: 15}
steps: 240
""",
    "lift": """
description: ratio-20 with the heavy box lifted off at step 120
scene:
  name: column
  boxes: [{y: 0.501}, {y: 1.501}, {y: 2.501}, {y: 3.501}, {y: 4.501, mass: 20}]
  remove: [{step: 120}]
solver: {name: pgs, iterations: 15}
steps: 240
""",
    "full-push": """
description: the lab stack with percent 1.0
scene: {name: column, stack: {count: 5, y0: 2.5, spacing: 1.6}}
solver: {name: pgs, iterations: 15, correction: {slop: 0.01, percent: 1.0}}
steps: 300
bench:
  set: {correction.percent: 1.0}
  claim: {text: "percent 1.0 oscillates", baseline: {correction.percent: 0.2}}
""",
}
BENCH = "\nbench: {knob: [2, 16], timing: {steps: 30, repeats: 2}}\n"
TIMED = {"us_per_step", "us_per_call", "timing"}  # the only record fields allowed to differ between two benches


def _write_cases(folder: Path) -> None:
    folder.mkdir()
    for name, text in CASES.items():
        if "bench:" in text:  # the case's own section gets the tiny settings too
            text = text.replace("bench:\n", "bench:\n  knob: [2, 16]\n  timing: {steps: 30, repeats: 2}\n")
        else:
            text += BENCH
        (folder / f"{name}.yaml").write_text(text)


def _bench(folder: Path, out: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "stackx", "bench", str(folder), "--out", str(out), *extra],
                          cwd=REPO, capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def bench_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One bench of the tiny cases with every built-in solver."""
    tmp = tmp_path_factory.mktemp("bench")
    _write_cases(tmp / "cases")
    done = _bench(tmp / "cases", tmp / "out", "--plugins", str(REPO / "plugins"))  # the example 'sor' is loaded
    assert done.returncode == 0, done.stderr
    assert "stability matrix" in done.stdout
    return tmp


@pytest.fixture(scope="module")
def doc(bench_out: Path) -> dict:
    return json.loads((bench_out / "out" / "bench.json").read_text())


def builtin_solvers() -> set[str]:
    """What a bench runs by default: the built-in solvers but the engines, which join when named."""
    return {e.name for e in registry.solvers.entries()
            if e.origin == "built-in" and getattr(e.plugin, "bench_by_default", True)}


def test_every_builtin_solver_runs_every_case(doc: dict) -> None:
    """By default every built-in solver, not the local plugin 'sor' that was loaded (it joins when named)."""
    assert [c["name"] for c in doc["cases"]] == sorted(CASES)
    for case in doc["cases"]:
        assert set(case["solvers"]) == builtin_solvers()
        for solver, plan in case["solvers"].items():
            records = [r for r in case["records"] if r["solver"] == solver and r["variant"] == "case"]
            values = [2, 16] if plan["knob"] else [None]
            if solver == "pgs":  # the config's own setting joins the sweep
                values = [2, 15, 16]
            assert sorted(r["value"] for r in records) == sorted(values, key=lambda v: v or 0)
            assert plan["values"] == [v for v in values if v is not None]


def test_records_carry_what_the_report_promises(bench_out: Path, doc: dict) -> None:
    assert {"platform", "cpus", "python"} <= set(doc["machine"])
    assert doc["versions"]["numpy"] and doc["versions"]["stackx"]
    for case in doc["cases"]:
        file = Path(case["file"])
        assert case["config_sha256"] == hashlib.sha256(file.read_bytes()).hexdigest()
        for r in case["records"]:
            assert r["us_per_step"] > 0 and len(r["timing"]["repeats"]) == 2
            assert r["us_per_call"] > 0 and len(r["timing"]["call_repeats"]) == 2
            assert set(r["measures"]) >= {"max_depth", "peak_depth", "reach", "launch", "rms_motion", "top_rest_error",
                                          "top_p2p"}
            measured = r["crushed_at"] - 1 if r["crushed"] else case["steps"]  # every step before the crushing one
            assert r["error"]["steps"] == measured and (r["error"]["rms"] is None or r["error"]["rms"] >= 0)
            assert set(r["criteria"]) == {"holds", "settled", "never_launched"}


def _judged(m: dict) -> bool:
    """The hard cases' definitions, written out: 2 x slop 0.01, reach 1, motion below 1e-4, launch 1 m/s."""
    return (m["max_depth"] <= 0.02 and m["max_gap"] <= 0.02 and abs(m["top_rest_error"]) <= 0.015 * m["boxes"]
            and m["reach"] <= 1.0 and m["rms_motion"] < 1e-4 and m["launch"] <= 1.0)


def test_pass_and_matrix_follow_the_measures(doc: dict) -> None:
    for case in doc["cases"]:
        for r in case["records"]:
            assert r["passed"] is _judged(r["measures"]), (case["name"], r["solver"], r["value"])
        for solver in case["solvers"]:
            cell = doc["matrix"][solver][case["name"]]
            own = [r for r in case["records"] if r["solver"] == solver and r["variant"] == "case"]
            assert cell["passing"] == [r["value"] for r in own if r["passed"]]
            assert cell["passed"] is any(r["passed"] for r in own)
            if not cell["passed"]:
                assert cell["failing"] and cell["text"].startswith("FAIL")


def test_removal_case_ends_with_one_box_less(doc: dict) -> None:
    lift = next(c for c in doc["cases"] if c["name"] == "lift")
    assert lift["events"] and all(r["measures"]["boxes"] == 4 for r in lift["records"])


def test_top_rest_error_is_the_sinking_of_the_column(doc: dict) -> None:
    """On a rigid column of six unit boxes the top rests at 5.5: a held column is low by at most the sum of its
    six contact depths; the lab solver at 2 iterations lets it sink by much more."""
    tall = next(c for c in doc["cases"] if c["name"] == "tall-6")
    exact = next(r for r in tall["records"] if r["solver"] == "exact")["measures"]
    assert -6 * exact["max_depth"] - 1e-12 <= exact["top_rest_error"] <= 0.0
    lab = next(r for r in tall["records"] if r["solver"] == "pgs" and r["value"] == 2)["measures"]
    assert lab["top_rest_error"] < -0.1 and lab["max_depth"] > 0.02


def test_claim_is_measured_pair_by_pair(doc: dict) -> None:
    case = next(c for c in doc["cases"] if c["name"] == "full-push")
    claim = case["claim"]
    with_setting = {s for s, p in case["solvers"].items() if p["applied"]}
    assert "pgs" in with_setting and {s for s, p in case["solvers"].items() if p["claim_baseline"]} == with_setting
    rows = claim["rows"]
    assert {r["solver"] for r in rows} == with_setting
    assert claim["pairs"] == len(rows)
    borne = sum(1 for r in rows if r["case"]["rms_motion"] >= 1e-4 > r["baseline"]["rms_motion"])
    assert claim["borne_out"] == borne
    assert claim["text"].startswith("The lab says: percent 1.0 oscillates.")
    assert claim["verdict"] in claim["text"]


def test_report_page_shows_plots_matrix_and_findings(bench_out: Path, doc: dict) -> None:
    page = (bench_out / "out" / "report.html").read_text()
    images = re.findall(r'<img src="([^"]+)"', page)
    assert sorted(images) == sorted(f"plots/{name}.png" for name in CASES)
    for src in images:
        header = png_header((bench_out / "out" / src).read_bytes())
        assert header.width > 300 and header.height > 200
    assert "http://" not in page.replace("http://www.w3.org", "") and "https://" not in page
    matrix = page[page.index("<h2>Stability matrix</h2>"):page.index("</table>", page.index("Stability matrix"))]
    for solver in builtin_solvers():
        assert f">{solver}<" in matrix
    for name in CASES:
        assert f">{name}<" in matrix
    full_push = next(c for c in doc["cases"] if c["name"] == "full-push")
    assert html.escape(full_push["claim"]["verdict"]) in page
    for row in next(c for c in doc["cases"] if c["name"] == "tall-6")["equal_cost"]:
        if row["winner"]:
            assert row["winner"] in page


def test_same_configs_give_the_same_records_apart_from_timings(bench_out: Path, doc: dict, tmp_path: Path) -> None:
    done = _bench(bench_out / "cases" / "lift.yaml", tmp_path / "again", "--solvers", "pgs,warm-start", "-q")
    assert done.returncode == 0, done.stderr
    again = json.loads((tmp_path / "again" / "bench.json").read_text())["cases"][0]["records"]
    first = [r for r in next(c for c in doc["cases"] if c["name"] == "lift")["records"]
             if r["solver"] in ("pgs", "warm-start")]
    strip = lambda rs: [{k: v for k, v in r.items() if k not in TIMED} for r in rs]  # noqa: E731
    assert strip(again) == strip(first)


@pytest.mark.parametrize("args, message", [
    (["--solvers", "pgz"], "unknown solver 'pgz'; did you mean 'pgs'?"),
    (["--solvers", " , "], "--solvers needs at least one solver name"),
    (["--set", "bench.knobs={nosuch: [1]}"], "bench.knobs.nosuch: unknown solver 'nosuch'"),
    (["--set", "bench.knob=[0]"], "bench.knob[0]: Input should be greater than 0"),
    (["--set", "bench.set={correction.percent: 2.0}"],
     "bench.set.correction.percent: solver 'exact' refuses correction.percent = 2.0: Input should be less than or "
     "equal to 1"),
    (["--set", "bench.knobs={pgs: [200000]}"], "bench.knobs.pgs: solver 'pgs' refuses iterations = 200000"),
])
def test_bad_input_stops_before_anything_runs(cli: Cli, tmp_path: Path, args: list[str], message: str) -> None:
    config = tmp_path / "tall-6.yaml"
    config.write_text(CASES["tall-6"] + BENCH)
    done = cli("bench", config, "--out", tmp_path / "out", *args)
    assert done.returncode == 2, done.stderr
    assert message in done.stderr and done.stderr.startswith("error: ") and done.stderr.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_a_local_plugin_joins_when_named(tmp_path: Path) -> None:
    (tmp_path / "cases").mkdir()
    (tmp_path / "cases" / "tall-6.yaml").write_text(CASES["tall-6"].replace("steps: 240", "steps: 90") + BENCH)
    done = _bench(tmp_path / "cases", tmp_path / "out", "--plugins", str(REPO / "plugins"), "--solvers", "sor,pgs",
                  "-q")
    assert done.returncode == 0, done.stderr
    (case,) = json.loads((tmp_path / "out" / "bench.json").read_text())["cases"]
    assert list(case["solvers"]) == ["sor", "pgs"]
    assert case["solvers"]["sor"]["knob"] == "iterations" and case["solvers"]["sor"]["values"] == [2, 16]


def test_a_run_that_blows_up_is_a_failing_record(tmp_path: Path) -> None:
    """A box dropped from 30 m passes limits.max_speed = 5 m/s within a second of falling (it lands after
    2.4 s): every run blows up and is a record that failed, saying where; the bench goes on and the matrix
    shows it."""
    config = tmp_path / "drop.yaml"
    config.write_text("""
scene: {name: column, boxes: [{y: 0.5}, {y: 30.0}]}
solver: {name: pgs}
steps: 120
limits: {max_speed: 5}
""" + BENCH)
    done = _bench(config, tmp_path / "out", "--solvers", "pgs,exact", "-q")
    assert done.returncode == 0, done.stderr
    doc = json.loads((tmp_path / "out" / "bench.json").read_text())
    records = doc["cases"][0]["records"]
    assert len(records) == 4 and all(r["blew_up"] and not r["passed"] for r in records)
    assert all("max_speed = 5 m/s" in r["blew_up"] for r in records)
    assert doc["matrix"]["pgs"]["drop"]["text"].startswith("FAIL at iterations 16: blew up")
    assert "Runs that blew up: pgs (iterations 2) on drop" in (tmp_path / "out" / "report.html").read_text()


def test_a_bench_case_is_one_run(cli: Cli, tmp_path: Path) -> None:
    config = tmp_path / "two.yaml"
    config.write_text(CASES["tall-6"] + "runs: {a: {}, b: {solver.iterations: 4}}\n")
    done = cli("bench", config, "--out", tmp_path / "out")
    assert done.returncode == 2 and "a bench case has one run" in done.stderr


def test_hard_configs_validate_and_name_every_case(cli: Cli) -> None:
    names = {p.stem for p in (REPO / "configs" / "hard").glob("*.yaml")}
    assert names == {"tall-20", "tall-100", "tall-1000", "ratio-100", "ratio-1000", "light-on-heavy", "overlap-25",
                     "load-removal", "drop-fast", "big-dt", "long-rest", "percent-1", "slop-0", "gap-200", "gap-1000",
                     "drop-200", "recovery-10", "recovery-100", "recovery-1000"}
    done = cli("validate", REPO / "configs" / "hard")
    assert done.returncode == 0, done.stderr
