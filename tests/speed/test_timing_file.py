"""``timing.json`` and the run table say of each run how its time was obtained: its own, or a share of its batch's."""

from __future__ import annotations

import json
from pathlib import Path

from stackx.output.screen import SHARED
from tests.conftest import Cli

SWEEP = """
description: a short column at two iteration counts, stepped as one batch
scene: {name: column, stack: {count: 4, y0: 0.5, spacing: 1.0}}
solver: {name: pgs}
steps: 5
sweep: {name: "it{solver.iterations}", grid: {solver.iterations: [4, 16]}}
"""

ALONE = """
description: a short column, one run
scene: {name: column, stack: {count: 4, y0: 0.5, spacing: 1.0}}
solver: {name: pgs}
steps: 5
"""


def test_timing_file_and_table_say_whether_a_time_is_a_share(cli: Cli, tmp_path: Path) -> None:
    (tmp_path / "sweep.yaml").write_text(SWEEP)
    (tmp_path / "alone.yaml").write_text(ALONE)
    out = tmp_path / "out"
    done = cli("run", tmp_path / "sweep.yaml", tmp_path / "alone.yaml", "--out", out,
               env={"COLUMNS": "120", "STACKX_JIT": "0"})
    assert done.returncode == 0, done.stderr
    timing = json.loads((out / "timing.json").read_text())
    assert {r["timed"] for r in timing["sweep"].values()} == {"share"}
    assert [r["timed"] for r in timing["alone"].values()] == ["own"]
    for record in (*timing["sweep"].values(), *timing["alone"].values()):
        assert record["contact_visits"] >= 0 and record["us_per_step"] > 0 and record["compiled"] is False
    rows = {cells[0]: cells for cells in map(str.split, done.stdout.splitlines()) if cells[:1] and "/" in cells[0]}
    assert rows["sweep/it4"][-2].startswith(SHARED) and rows["sweep/it16"][-2].startswith(SHARED), rows
    assert not rows["alone/main"][-2].startswith(SHARED), rows
    assert f"{SHARED} = " in " ".join(done.stdout.split())
