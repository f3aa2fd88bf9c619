"""``stackx bench`` end to end on tiny cases: bench.json, report.html and its plots, the matrix, bad input."""

from __future__ import annotations

import base64
import dataclasses
import hashlib
import html
import json
import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import pytest

from stackx import registry
from stackx.bench import plots as plots_module
from stackx.bench.sweep import Record
from tests.conftest import REPO, Cli
from tests.lab.reference import png_header
from tests.limits import hang_limit

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
                          cwd=REPO, capture_output=True, text=True, timeout=hang_limit(600))


@pytest.fixture(scope="module")
def bench_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One bench of the tiny cases with every built-in solver."""
    tmp = tmp_path_factory.mktemp("bench")
    _write_cases(tmp / "cases")
    done = _bench(tmp / "cases", tmp / "out", "--plugins", str(REPO / "plugins"), "--wide")  # 'sor' is loaded
    assert done.returncode == 0, done.stderr
    assert "stability matrix" in done.stdout
    return tmp


@pytest.fixture(scope="module")
def doc(bench_out: Path) -> dict:
    return json.loads((bench_out / "out" / "bench.json").read_text())


def builtin_solvers() -> set[str]:
    """What a bench of column cases runs by default: the built-in solvers that step the column, but the
    engines, which join when named."""
    return {e.name for e in registry.solvers.entries()
            if e.origin == "built-in" and getattr(e.plugin, "bench_by_default", True)
            and "column" in e.plugin.models}


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
    """The page stands alone: two pictures per case embedded as data: URIs, nothing beside it, no network."""
    out = bench_out / "out"
    assert sorted(p.name for p in out.iterdir()) == ["bench.json", "report.html"]
    page = (out / "report.html").read_text()
    images = re.findall(r'<img src="([^"]+)"', page)
    assert len(images) == 2 * len(CASES) and all(src.startswith("data:image/png;base64,") for src in images)
    for src in images:
        header = png_header(base64.b64decode(src.split(",", 1)[1]))
        assert header.width > 300 and header.height > 200
    assert "http://" not in page.replace("http://www.w3.org", "") and "https://" not in page
    assert not re.findall(r'(?:src|href)="(?!data:|#)', page), "a link to a file beside the page"
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


class _Tables(HTMLParser):
    """Every table of a page as rows of (text, attributes) cells, and the order of headings and sections."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: list[list[list[tuple[str, dict[str, str]]]]] = []
        self.order: list[str] = []
        self._cell: tuple[list[str], dict[str, str]] | None = None
        self._heading: list[str] | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = {k: v or "" for k, v in attrs}
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = ([], a)
        elif tag in ("h1", "h2"):
            self._heading = []
        elif tag == "details":
            self.order.append(f"details#{a.get('id', '')}.{a.get('class', '')}")

    def handle_endtag(self, tag: str) -> None:
        if tag in ("td", "th") and self._cell is not None:
            self.tables[-1][-1].append(("".join(self._cell[0]).strip(), self._cell[1]))
            self._cell = None
        elif tag in ("h1", "h2") and self._heading is not None:
            self.order.append(f"{tag}:{''.join(self._heading).strip()}")
            self._heading = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell[0].append(data)
        if self._heading is not None:
            self._heading.append(data)


def _parsed(bench_out: Path) -> _Tables:
    parser = _Tables()
    parser.feed((bench_out / "out" / "report.html").read_text())
    return parser


def _own(case: dict) -> dict[str, list[dict]]:
    by: dict[str, list[dict]] = {}
    for r in case["records"]:
        if r["variant"] == "case":
            by.setdefault(r["solver"], []).append(r)
    return {s: sorted(rs, key=lambda r: r["value"] or 0) for s, rs in by.items()}


def test_report_opens_on_speed_against_error_then_the_summary(bench_out: Path) -> None:
    """The page opens on every case's speed-against-error plot, in a section that is open, each linked to its
    case; the summary follows, then the cases, each a collapsible section (closed) that links back to its plot."""
    parsed = _parsed(bench_out)
    assert parsed.order[:4] == ["h1:stackx bench", "details#.speed", "h2:Speed against error", "h2:Summary"]
    page = (bench_out / "out" / "report.html").read_text()
    opening = page[page.index("<details open class=speed>"):page.index("<h2 id=summary>")]
    plots = re.findall(r'<figure class="speed" id="speed:([\w-]+)"><img src="data:image/png;base64,[^"]+" '
                       r'alt="speed against error, ([\w-]+)"><figcaption><a href="#([\w-]+)">', opening)
    assert [p[0] for p in plots] == sorted(CASES) and all(len(set(p)) == 1 for p in plots)
    cases = [o for o in parsed.order if o.endswith(".case")]
    assert cases == [f"details#{name}.case" for name in sorted(CASES)], "each case is a collapsible section"
    for name in CASES:
        assert f'<a href="#speed:{name}">speed against error, {name}</a>' in page


def test_report_summary_gives_the_cheapest_pass_its_time_error_and_the_reasons(bench_out: Path, doc: dict) -> None:
    """Each case row of the summary names the cheapest solver that passes (each solver at its smallest passing
    knob value, the fastest of those), its time and its error, and, for every solver that failed everywhere,
    the failed checks at its largest knob value (in the cell's hover text). Worked out here from bench.json."""
    parsed = _parsed(bench_out)
    summary = parsed.tables[0]
    head = [text for text, _ in summary[0]]
    assert head[:4] == ["case", "cheapest that passes", "µs per step", "error (m/s)"]
    rows = {row[0][0]: row for row in summary[1:]}
    assert sorted(rows) == sorted(CASES)
    for case in doc["cases"]:
        own = _own(case)
        smallest = {s: next(r for r in rs if r["passed"]) for s, rs in own.items() if any(r["passed"] for r in rs)}
        row = rows[case["name"]]
        cells = dict(zip(head, row))
        if smallest:
            best = min(smallest.values(), key=lambda r: r["us_per_step"])
            assert cells["cheapest that passes"][0].startswith(best["solver"])
            figure, spread = cells["µs per step"][0].rstrip("!").split(" +")  # '0.51 +5%': the fastest repeat, spread
            assert float(figure) == pytest.approx(best["us_per_step"], rel=5e-3)  # 3 figures
            assert spread == f"{100 * best['timing']['spread']:.0f}%"
            error = "reference" if best["reference"] else format(best["error"]["rms"], ".3g")
            assert cells["error (m/s)"][0] == error
        else:
            assert cells["cheapest that passes"][0] == "none passes"
        for solver, recs in own.items():
            text, attrs = cells[solver]
            if solver in smallest:
                assert text == "pass" + (f" {smallest[solver]['value']}" if recs[0]["knob"] else "")
                continue
            last = recs[-1]
            assert "fail" in attrs["class"]
            if last["blew_up"]:
                assert text.startswith("blew up")
            elif last["crushed"]:
                assert text == f"crushed at step {last['crushed_at']}"
            else:
                failed = [c for v in last["criteria"].values() for c in v["checks"] if not c["passed"]]
                assert failed and len(text.split(", ")) <= len(failed)
                for c in failed:
                    assert f"{c['measure']} {c['value']:.3g}" in attrs["title"], (case["name"], solver, attrs)


def _on_front(runs: list[dict]) -> set[tuple[str, int | None]]:
    """Brute force, from the definition: a run is off the front when another is at least as accurate and more
    than 20% faster, or more accurate and not more than 20% slower (times within 20% are the same cost), with
    both times moved in the run's favour by their noise (the spread, at least 5%)."""
    def beats(o: dict, r: dict) -> bool:
        t = o["us_per_step"] * (1 + max(0.05, o["timing"]["spread"]))
        u = r["us_per_step"] * (1 - max(0.05, r["timing"]["spread"]))
        e, f = o["error"]["rms"], r["error"]["rms"]
        return (e <= f and 1.2 * t < u) or (e < f and not 1.2 * u < t)
    return {(r["solver"], r["value"]) for r in runs if not any(o is not r and beats(o, r) for o in runs)}


def test_fronts_and_winners_come_from_runs_that_passed(doc: dict) -> None:
    for case in doc["cases"]:
        passing = [r for rs in _own(case).values() for r in rs if r["passed"] and not r["reference"]
                   and not r["crushed"] and not r["blew_up"] and r["error"]["rms"] is not None]
        assert {(p["solver"], p["value"]) for p in case["pareto"]} == _on_front(passing), case["name"]
        for row in case["equal_cost"]:
            reach = [r for r in passing if r["error"]["rms"] <= row["target"]]
            fastest = min(reach, key=lambda r: r["us_per_step"]) if reach else None
            assert row["winner"] == (fastest["solver"] if fastest else None)
            assert {s["solver"] for s in row["solvers"]} == {r["solver"] for r in reach}


def test_each_solver_is_drawn_against_time_at_the_run_the_summary_shows(doc: dict) -> None:
    """tall-6: six unit boxes from y = 0.501 + k. Each solver's series starts from the initial state (top at
    5.501, no overlap), ends on the run's final measures (top = 5.5 + top_rest_error on a rigid column of six
    unit boxes, depth = max_depth), at evenly spaced steps from 0 to the end; a crushed run stops before."""
    case = next(c for c in doc["cases"] if c["name"] == "tall-6")
    own = _own(case)
    shown = {s["solver"]: s for s in case["shown"]}
    assert set(shown) == set(own)
    for solver, recs in own.items():
        want = next((r for r in recs if r["passed"]), recs[-1])
        got = shown[solver]
        assert (got["value"], got["passed"]) == (want["value"], want["passed"])
        series = got["series"]
        if want["blew_up"]:
            assert series is None
            continue
        steps = series["steps"]
        assert steps[0] == 0 and steps == sorted(set(steps)) and len(steps) >= 100
        gaps = {b - a for a, b in zip(steps, steps[1:])}
        assert max(gaps) - min(gaps) <= 1, "evenly spaced"
        assert series["top"][0] == pytest.approx(5.501, abs=1e-12) and abs(series["max_depth"][0]) <= 1e-12
        if want["crushed"]:
            assert steps[-1] < want["crushed_at"]
            continue
        assert steps[-1] == case["steps"]
        assert series["top"][-1] == pytest.approx(5.5 + want["measures"]["top_rest_error"], abs=1e-12)
        assert series["max_depth"][-1] == want["measures"]["max_depth"]


def _records(case: dict) -> list[Record]:
    """A case's records from bench.json, as the bench holds them."""
    fields = {f.name for f in dataclasses.fields(Record)}
    return [Record(**{k: v for k, v in r.items() if k in fields}) for r in case["records"]]


def test_every_solver_has_one_colour_everywhere(bench_out: Path, doc: dict) -> None:
    """The swatches of the page give each solver one colour, a different one per built-in solver, and each
    case's speed plot draws every solver it shows in that exact colour: its line (labelled with its name) and
    each of its runs' markers. The plot is drawn here from the bench's records with fixed timings put in their
    place, and its drawn data read back, so nothing depends on how fast the machine was. That a run another
    solver's marker lands on stays in sight is ``tests/bench/test_plots.py``'s to check, where the pixels under
    each run are known."""
    page = (bench_out / "out" / "report.html").read_text()
    swatches = re.findall(r'<span class="sw" style="background:(#[0-9a-f]{6})"></span>([\w-]+)', page)
    colours: dict[str, set[str]] = {}
    for c, solver in swatches:
        colours.setdefault(solver, set()).add(c)
    assert set(colours) == builtin_solvers() and all(len(c) == 1 for c in colours.values())
    assert len({next(iter(c)) for c in colours.values()}) == len(colours)
    plots = re.findall(r'<img src="([^"]+)" alt="speed against error, ([\w-]+)"', page)
    assert sorted(name for _, name in plots) == sorted(CASES)
    from matplotlib.colors import to_hex

    for case in doc["cases"]:
        records = _records(case)
        for k, r in enumerate(records):
            r.us_per_step, r.timing = 10.0 + 3.0 * k, {"spread": 0.0}  # fixed, apart: no clock decides anything
        fig = plots_module.speed_error_figure(case["name"], records)
        try:
            lines = fig.axes[0].get_lines()
            shown = [r for r in records if r.variant == "case" and not r.reference and not r.crushed
                     and not r.blew_up and r.error.get("rms") is not None]
            drawn = {r.solver for r in shown}
            assert drawn
            for solver in drawn:
                c = next(iter(colours[solver]))
                line = next(ln for ln in lines if ln.get_label() == solver)
                assert to_hex(line.get_color()) == c, (case["name"], solver)
                runs = sorted((r for r in shown if r.solver == solver), key=lambda r: r.value or 0)
                assert list(line.get_xdata()) == [r.us_per_step for r in runs]
                for r in runs:  # each run's marker, at its time, edged in the solver's colour
                    assert any(list(ln.get_xdata()) == [r.us_per_step] and ln.get_marker() in ("o", "v", "D")
                               and to_hex(ln.get_markeredgecolor()) == c for ln in lines), (solver, r.value)
        finally:
            plots_module._pyplot().close(fig)


def test_table_headers_carry_units(bench_out: Path) -> None:
    parsed = _parsed(bench_out)
    runs = next(t for t in parsed.tables if t[0][0][0] == "solver")
    head = [text for text, _ in runs[0]]
    unitless = {"solver", "knob", "worst step", "holds", "settled", "never_launched"}
    for text in head:
        assert text in unitless or re.search(r"\((?:m|m/s|step|× half-height)\)$|^µs per", text), text


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


def test_the_terminal_output_fits_80_columns(bench_out: Path, tmp_path: Path) -> None:
    """By default each case is a short table (solver, knob, µs/step with its spread, error, verdict in the
    summary's words) and what it comes to, every line within 80 columns; ``--wide`` (the fixture's) adds the
    full tables and the matrix."""
    import os

    solvers = "pgs,warm-start,split-impulse,exact,soft-step"
    done = subprocess.run([sys.executable, "-m", "stackx", "bench", str(bench_out / "cases"), "--solvers", solvers,
                           "--out", str(tmp_path / "out")], cwd=REPO, capture_output=True, text=True, timeout=hang_limit(600),
                          env={**os.environ, "COLUMNS": "80"})
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert max(len(line) for line in lines) <= 80, max(lines, key=len)
    assert "stability matrix" not in done.stdout
    assert any(line.split() == ["solver", "knob", "µs/step", "error", "m/s", "verdict"] for line in lines)
    doc = json.loads((tmp_path / "out" / "bench.json").read_text())
    for case in doc["cases"]:
        assert f"{case['name']}: " in done.stdout
        for solver in solvers.split(","):
            assert any(line.split()[:1] == [solver] for line in lines), solver
        rows = [line.split() for line in done.stdout.split(f"{case['name']}: ", 1)[1].splitlines()]
        for rec in case["records"]:
            shown = next((s for s in case["shown"] if (s["solver"], s["value"]) == (rec["solver"], rec["value"])), None)
            if shown is None or rec["variant"] != "case" or rec["blew_up"] or rec["crushed"]:
                continue
            row = next(r for r in rows if r[:1] == [rec["solver"]])
            assert ("reference" if rec["reference"] else format(rec["error"]["rms"], ".3g")) in row, row
        for shown in case["shown"]:
            if not shown["passed"]:
                words = shown["why"].replace(",", " ").split()  # the summary's words, not the measures' names
                assert all(word in done.stdout for word in words), words  # (a long verdict wraps in its column)
