"""Which solver passes which hard case, pinned: a change that breaks a passing case (or mends a failing one)
fails here until the table below is updated on purpose.

Small versions of the cases (configs/hard/*.yaml with fewer boxes or steps where a case is big) run through
``stackx bench`` with every built-in solver at knob values 4, 16 and 64 (the lab solver also at its own 15);
the table holds, per case and solver, the knob values at which all three criteria passed. The lab solver's
failures are part of the table, as the report shows them.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from stackx import registry
from tests.conftest import CONFIGS, REPO

SMALL = {  # what makes a big case small: dotted key -> value
    "tall-1000": {"scene.stack.count": 200, "steps": 600},
    "long-rest": {"steps": 5000},
    "gap-200": {"steps": 900},
    "drop-200": {"steps": 900},
    "gap-1000": {"scene.stack.count": 300, "steps": 600},
    "recovery-1000": {"scene.stack.count": 200, "steps": 2400},
}
KNOB = [4, 16, 64]

PINNED: dict[str, dict[str, list[int | None]]] = {
    "big-dt": {
        "avbd": [], "baumgarte": [], "exact": [None], "jacobi": [64], "ngs": [], "pgs": [64], "soft-step": [],
        "split-impulse": [], "warm-start": [16, 64], "xpbd": []},
    "drop-200": {
        "avbd": [], "baumgarte": [], "exact": [None], "jacobi": [], "ngs": [], "pgs": [], "soft-step": [], "split-impulse": [],
        "warm-start": [], "xpbd": []},
    "drop-fast": {
        "avbd": [16, 64], "baumgarte": [], "exact": [], "jacobi": [], "ngs": [64], "pgs": [], "soft-step": [], "split-impulse": [64],
        "warm-start": [], "xpbd": []},
    "gap-1000": {
        "avbd": [], "baumgarte": [], "exact": [None], "jacobi": [], "ngs": [], "pgs": [], "soft-step": [], "split-impulse": [],
        "warm-start": [], "xpbd": []},
    "gap-200": {
        "avbd": [], "baumgarte": [], "exact": [None], "jacobi": [], "ngs": [], "pgs": [], "soft-step": [], "split-impulse": [],
        "warm-start": [], "xpbd": []},
    "light-on-heavy": {
        "avbd": [16, 64], "baumgarte": [4, 16, 64], "exact": [None], "jacobi": [4, 16, 64], "ngs": [4, 16, 64], "pgs": [15, 16, 64],
        "soft-step": [4, 16, 64], "split-impulse": [4, 16, 64], "warm-start": [4, 16, 64], "xpbd": [4, 16, 64]},
    "load-removal": {
        "avbd": [16, 64], "baumgarte": [64], "exact": [None], "jacobi": [64], "ngs": [16, 64], "pgs": [], "soft-step": [16, 64],
        "split-impulse": [16, 64], "warm-start": [16, 64], "xpbd": [16, 64]},
    "long-rest": {
        "avbd": [4, 16, 64], "baumgarte": [4, 16, 64], "exact": [None], "jacobi": [4, 16, 64], "ngs": [4, 16, 64], "pgs": [],
        "soft-step": [4, 16, 64], "split-impulse": [4, 16, 64], "warm-start": [4, 16, 64], "xpbd": [4, 16, 64]},
    "overlap-25": {
        "avbd": [], "baumgarte": [], "exact": [], "jacobi": [], "ngs": [], "pgs": [], "soft-step": [], "split-impulse": [],
        "warm-start": [], "xpbd": []},
    "percent-1": {
        "avbd": [4, 16, 64], "baumgarte": [], "exact": [], "jacobi": [], "ngs": [16, 64], "pgs": [], "soft-step": [64],
        "split-impulse": [], "warm-start": [], "xpbd": []},
    "ratio-100": {
        "avbd": [64], "baumgarte": [64], "exact": [None], "jacobi": [], "ngs": [64], "pgs": [], "soft-step": [],
        "split-impulse": [64], "warm-start": [64], "xpbd": [16, 64]},
    "ratio-1000": {
        "avbd": [64], "baumgarte": [], "exact": [None], "jacobi": [], "ngs": [], "pgs": [], "soft-step": [], "split-impulse": [],
        "warm-start": [], "xpbd": []},
    "recovery-10": {
        "avbd": [], "baumgarte": [], "exact": [None], "jacobi": [], "ngs": [], "pgs": [], "soft-step": [], "split-impulse": [],
        "warm-start": [], "xpbd": []},
    "recovery-100": {
        "avbd": [], "baumgarte": [], "exact": [None], "jacobi": [], "ngs": [], "pgs": [], "soft-step": [], "split-impulse": [],
        "warm-start": [], "xpbd": []},
    "recovery-1000": {
        "avbd": [], "baumgarte": [], "exact": [None], "jacobi": [], "ngs": [], "pgs": [], "soft-step": [], "split-impulse": [],
        "warm-start": [], "xpbd": []},
    "slop-0": {
        "avbd": [4, 16, 64], "baumgarte": [], "exact": [None], "jacobi": [64], "ngs": [16, 64], "pgs": [64], "soft-step": [64],
        "split-impulse": [], "warm-start": [16, 64], "xpbd": []},
    "tall-100": {
        "avbd": [], "baumgarte": [], "exact": [None], "jacobi": [], "ngs": [], "pgs": [], "soft-step": [], "split-impulse": [],
        "warm-start": [], "xpbd": [64]},
    "tall-1000": {
        "avbd": [], "baumgarte": [], "exact": [None], "jacobi": [], "ngs": [], "pgs": [], "soft-step": [], "split-impulse": [],
        "warm-start": [], "xpbd": []},
    "tall-20": {
        "avbd": [], "baumgarte": [], "exact": [None], "jacobi": [64], "ngs": [], "pgs": [], "soft-step": [4, 16, 64],
        "split-impulse": [], "warm-start": [16, 64], "xpbd": [16, 64]},
}


def _small_configs(folder: Path) -> None:
    folder.mkdir()
    for path in sorted((CONFIGS / "hard").glob("*.yaml")):
        data = yaml.safe_load(path.read_text())
        for key, value in SMALL.get(path.stem, {}).items():
            node = data
            *parents, last = key.split(".")
            for part in parents:
                node = node[part]
            node[last] = value
        data["bench"] = {**data.get("bench", {}), "knob": KNOB, "timing": {"steps": 1, "repeats": 1}}
        (folder / path.name).write_text(yaml.safe_dump(data, sort_keys=False))


@pytest.fixture(scope="module")
def matrix(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, dict]]:
    tmp = tmp_path_factory.mktemp("pins")
    _small_configs(tmp / "hard")
    # no time limit: the bench cannot hang, only take long (minutes alone, several times that under load)
    done = subprocess.run([sys.executable, "-m", "stackx", "bench", str(tmp / "hard"), "--out", str(tmp / "out"), "-q"],
                          cwd=REPO, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return json.loads((tmp / "out" / "bench.json").read_text())["matrix"]


def test_every_case_and_builtin_solver_is_pinned(matrix: dict[str, dict[str, dict]]) -> None:
    solvers = {e.name for e in registry.solvers.entries()  # the engines join a bench when named
               if e.origin == "built-in" and getattr(e.plugin, "bench_by_default", True)
               and "column" in e.plugin.models}  # the hard cases are column cases
    assert set(matrix) == solvers
    assert {s for row in PINNED.values() for s in row} == solvers, "pin the new solver in PINNED"
    assert set(PINNED) == {p.stem for p in (CONFIGS / "hard").glob("*.yaml")}


@pytest.mark.parametrize("case", sorted(PINNED))
def test_passing_knob_values_are_pinned(matrix: dict[str, dict[str, dict]], case: str) -> None:
    got = {solver: row[case]["passing"] for solver, row in matrix.items()}
    changed = {solver: row[case]["text"] for solver, row in matrix.items() if got[solver] != PINNED[case].get(solver)}
    assert got == PINNED[case], f"{case}: {changed}; now {got}"
