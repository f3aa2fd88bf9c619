"""``--set solver.name=OTHER`` switches solver: the keys the new solver takes are kept, the others dropped
and named, so comparing solvers on a config needs no hand edit."""

from __future__ import annotations

import json
from pathlib import Path

from tests.conftest import CONFIGS, Cli


def test_switching_solver_keeps_what_the_new_one_takes_and_names_what_it_drops(cli: Cli, tmp_path: Path) -> None:
    done = cli("run", CONFIGS / "06-stack.yaml", "--set", "solver.name=baumgarte", "--out", tmp_path, "-q")
    assert done.returncode == 0, done.stderr
    assert done.stderr.strip() == ("note: --set solver.name=baumgarte: dropped correction ('baumgarte' does not "
                                   "take them)")
    resolved = json.loads((tmp_path / "manifest.json").read_text())["experiments"]["06-stack"]["resolved"]
    solver = resolved["runs"][0]["solver"]
    assert solver["name"] == "baumgarte" and solver["iterations"] == 15  # kept from the config
    assert "correction" not in solver


def test_switching_to_an_unknown_solver_says_so_at_the_override(cli: Cli, tmp_path: Path) -> None:
    done = cli("run", CONFIGS / "06-stack.yaml", "--set", "solver.name=baumgart", "--out", tmp_path)
    assert done.returncode == 2
    assert done.stderr.startswith("error: --set solver.name=baumgart: unknown solver 'baumgart'; did you mean "
                                  "'baumgarte'?")
    assert not any(tmp_path.iterdir())
