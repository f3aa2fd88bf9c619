"""The API page's example prints what its comments say, and the API's arrays are the runner's numbers."""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
from pathlib import Path

import numpy as np
import pytest

from stackx import api
from stackx.errors import ConfigError
from tests.conftest import CONFIGS, REPO, Cli


def _example() -> str:
    text = (REPO / "docs" / "api.md").read_text()
    return re.search(r"```python run\n(.*?)```", text, re.S).group(1)  # type: ignore[union-attr]


def test_the_api_example_prints_what_it_says(tmp_path: Path) -> None:
    (tmp_path / "configs").symlink_to(CONFIGS)
    here = os.getcwd()
    printed = io.StringIO()
    os.chdir(tmp_path)
    try:
        with contextlib.redirect_stdout(printed):
            exec(compile(_example(), "docs/api.md", "exec"), {})
    finally:
        os.chdir(here)
    lines = printed.getvalue().splitlines()
    assert lines[0] == "(91, 5) 15.0"
    assert set(json.loads(lines[2].replace("'", '"'))) == {"it1", "it4", "it16"}
    assert lines[3] == "['exact', 'warm-start']"


def test_arrays_are_the_states_the_command_line_writes(cli: Cli, tmp_path: Path) -> None:
    """The final heights of the API's run equal those of ``stackx run``'s metrics file, bit for bit."""
    spec = api.load(CONFIGS / "06-stack.yaml")
    result = api.run(spec, steps=[0, 450, 900])
    done = cli("run", CONFIGS / "06-stack.yaml", "--out", tmp_path, "-q")
    assert done.returncode == 0, done.stderr
    metrics = json.loads((tmp_path / "06-stack.metrics.json").read_text())["runs"]["main"]
    main = result["main"]
    assert main.heights.shape == (3, 5) and list(main.steps) == [0, 450, 900]
    assert main.heights[-1].tolist() == metrics["y"] and main.velocities[-1].tolist() == metrics["v"]
    assert main.heights[0].tolist() == [2.5 + 1.6 * i for i in range(5)]
    assert np.allclose(main.time, [0.0, 7.5, 15.0])
    written = api.write(spec, result, tmp_path / "again")
    assert sorted(p.name for p in written) == sorted(p.name for p in tmp_path.iterdir()
                                                     if p.is_file() and p.name not in ("manifest.json", "timing.json"))
    for path in written:
        assert path.read_bytes() == (tmp_path / path.name).read_bytes()


def test_bad_input_from_a_dict_is_the_usual_error() -> None:
    with pytest.raises(ConfigError) as err:
        api.load({"scene": {"name": "column", "stack": {"count": 2, "y0": 0.5, "spacing": 1}},
                  "solver": {"name": "pgs", "iteratons": 3}, "steps": 10})
    assert str(err.value) == ("notebook: solver.iteratons: unknown key 'iteratons'; allowed: correction, "
                              "iterations")
