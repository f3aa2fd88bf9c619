"""Engines as plugins: listed without importing them, refused with the install command when they are missing,
run from the command line like any solver, and timed one step per call in the bench."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest

from stackx import registry
from tests.conftest import CONFIGS, REPO, Cli
from tests.engines.need import ENGINES, missing
from tests.limits import hang_limit

PACKAGES = ("pymunk", "Box2D", "pyb2d3", "mujoco")  # what the engines import
HIDE = ("import sys\n"
        "for name in sys.argv[1].split(','):\n"
        "    sys.modules[name] = None  # as if not installed: found by no import\n"
        "sys.argv = ['stackx', *sys.argv[2:]]\n"
        "from stackx.cli import main\n"
        "main()\n")


def without(packages: tuple[str, ...], *args: str | Path, cwd: Path = REPO) -> subprocess.CompletedProcess[str]:
    """``stackx ARGS`` from this checkout in a process where ``packages`` cannot be imported."""
    env = {**os.environ, "PYTHONPATH": str(REPO), "COLUMNS": "300"}
    return subprocess.run([sys.executable, "-c", HIDE, ",".join(packages), *map(str, args)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=hang_limit(300))


def test_listing_and_validating_import_no_engine() -> None:
    code = ("import json, sys\n"
            "from stackx import registry\n"
            "from stackx.config.experiment import load\n"
            "names = [e.name for e in registry.solvers.entries()]\n"
            "load(sys.argv[1])\n"
            "print(json.dumps([names, [m for m in sys.argv[2:] if m in sys.modules]]))\n")
    done = subprocess.run([sys.executable, "-c", code, str(CONFIGS / "06-stack.yaml"), *PACKAGES], cwd=REPO,
                          capture_output=True, text=True, timeout=hang_limit(120))
    assert done.returncode == 0, done.stderr
    names, imported = json.loads(done.stdout)
    assert set(ENGINES) <= set(names) and imported == []


def test_a_missing_engine_is_listed_with_its_install_command() -> None:
    done = without(PACKAGES, "plugins")
    assert done.returncode == 0, done.stderr
    rows = {line.split("│")[2].strip(): line for line in done.stdout.splitlines() if line.count("│") > 3}
    for name, package in zip(ENGINES, ("pymunk", "box2d", "pyb2d3", "mujoco")):
        assert "unavailable" in rows[name] and "pip install 'stackx[engines]'" in rows[name], rows[name]
        assert f"pip install {package}" in rows[name]
    assert "unavailable" not in rows["pgs"]


@pytest.mark.parametrize("engine", ENGINES)
def test_a_config_naming_a_missing_engine_stops_at_load(engine: str, tmp_path: Path) -> None:
    out = tmp_path / "out"
    done = without(PACKAGES, "run", CONFIGS / "06-stack.yaml", "--set", f"solver={{name: {engine}}}", "--out", out)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "solver.name" in lines[0], done.stderr
    assert f"solver '{engine}' cannot run here" in lines[0] and "pip install 'stackx[engines]'" in lines[0]
    assert not out.exists()


def test_the_bench_refuses_a_missing_engine_by_name(tmp_path: Path) -> None:
    done = without(("pymunk",), "bench", CONFIGS / "hard" / "tall-20.yaml", "--solvers", "exact,pymunk", "--out",
                   tmp_path / "out")
    assert done.returncode == 2 and "pip install pymunk" in done.stderr, done.stderr
    assert not (tmp_path / "out").exists()


def test_an_engine_runs_a_lab_config_from_the_command_line(cli: Cli, tmp_path: Path) -> None:
    engine = next((e for e in ENGINES if not missing(e)), None)
    if engine is None:
        pytest.skip(missing(ENGINES[0]) or "")
    done = cli("run", CONFIGS / "06-stack.yaml", "--set", f"solver={{name: {engine}}}", "--out", tmp_path, "-q")
    assert done.returncode == 0, done.stderr
    values = dict(line.split("=", 1) for line in (tmp_path / "06-stack.txt").read_text().splitlines())
    run = json.loads((tmp_path / "06-stack.metrics.json").read_text())["runs"]["main"]
    assert run["solver"] == engine
    assert [float(values[f"y{i}"]) for i in range(1, 6)] == run["y"]
    assert 0.4 < run["y"][0] < 0.5 and run["y"] == sorted(run["y"])  # a stack on the floor, in order
    assert (tmp_path / "stack.png").is_file() and (tmp_path / "index.html").is_file()


def test_the_bench_times_an_engine_per_call_and_says_so(tmp_path: Path) -> None:
    engine = next((e for e in ENGINES if not missing(e)), None)
    if engine is None:
        pytest.skip(missing(ENGINES[0]) or "")
    config = tmp_path / "five.yaml"
    config.write_text("scene: {name: column, stack: {count: 5, y0: 0.501, spacing: 1.0}}\n"
                      "solver: {name: pgs}\nsteps: 60\n"
                      "bench: {knob: [2], timing: {steps: 5, repeats: 2}}\n")
    done = subprocess.run([sys.executable, "-m", "stackx", "bench", str(config), "--solvers", f"{engine},pgs",
                           "--out", str(tmp_path / "out")], cwd=REPO, capture_output=True, text=True, timeout=hang_limit(300),
                          env={**os.environ, "COLUMNS": "200"})
    assert done.returncode == 0, done.stderr
    doc = json.loads((tmp_path / "out" / "bench.json").read_text())
    records = {r["solver"]: r for r in doc["cases"][0]["records"]}
    assert set(records) == {engine, "pgs"} and set(doc["matrix"]) == {engine, "pgs"}
    distribution = registry.solvers.get(engine).distribution
    assert doc["versions"][distribution] == metadata.version(distribution)
    mine, lab = records[engine], records["pgs"]
    assert mine["timing"]["one_step_per_call"] is True
    assert mine["us_per_step"] == mine["us_per_call"] > 0
    assert mine["timing"]["repeats"] == mine["timing"]["call_repeats"]
    assert "one_step_per_call" not in lab["timing"] and lab["us_per_step"] > 0 and lab["us_per_call"] > 0
    shown = {name: re.escape(f"{r['us_per_step']:.3g} +{100 * r['timing']['spread']:.0f}%") + "!?"
             for name, r in (("mine", mine), ("lab", lab))}  # the fastest repeat, its spread, '!' if unstable
    assert re.search(shown["mine"] + r"\*", done.stdout) and not re.search(shown["lab"] + r"\*", done.stdout)
    report = (tmp_path / "out" / "report.html").read_text()
    assert re.search(shown["mine"] + r"\*", report) and "stepped once per Python call" in report
