"""Solver colours: fixed by name, the same in every process (plots of two benches read alike)."""

from __future__ import annotations

import os
import subprocess
import sys

from stackx import registry
from stackx.bench.palette import BUILT_IN, OTHERS, colour
from tests.conftest import REPO


def test_built_in_solvers_have_colours_of_their_own() -> None:
    assert len(set(BUILT_IN.values())) == len(BUILT_IN)
    assert not set(BUILT_IN.values()) & set(OTHERS)


def test_every_built_in_solver_has_a_colour_no_other_built_in_has() -> None:
    built_in = [e.name for e in registry.solvers.entries() if e.origin == "built-in"]
    colours = {name: colour(name) for name in built_in}
    assert len(set(colours.values())) == len(colours), colours
    assert not set(colours.values()) & set(OTHERS), colours


def test_a_plugin_keeps_its_colour_from_process_to_process() -> None:
    """Python's own string hash changes with PYTHONHASHSEED; the colour must not."""
    code = "from stackx.bench.palette import colour; print(colour('sor'), colour('my-solver'))"
    seen = {subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True,
                           env={**os.environ, "PYTHONHASHSEED": seed}).stdout for seed in ("1", "2", "3")}
    assert len(seen) == 1
    assert seen.pop().split() == [colour("sor"), colour("my-solver")]
    assert colour("sor") in OTHERS
