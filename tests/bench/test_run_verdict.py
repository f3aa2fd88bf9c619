"""``stackx run`` says whether a scene held what it states, as the bench judges it.

fast-into-stack throws a box at a stack of five placed at rest: under its default solver the stack ends
toppled. The verdict is checked here against the run's own metrics file: the boxes' final angles, against the
0.05 rad the criteria allow, say it was destroyed. A lab config states nothing and gets no verdict.
"""

from __future__ import annotations

import json
from pathlib import Path

from tests.conftest import CONFIGS, Cli


def test_the_run_table_says_a_stated_outcome_failed(cli: Cli, tmp_path: Path) -> None:
    done = cli("run", CONFIGS / "planar" / "fast-into-stack.yaml", CONFIGS / "03-sink.yaml", "--out", tmp_path,
               env={"COLUMNS": "200"})
    assert done.returncode == 0, done.stderr
    final = json.loads((tmp_path / "fast-into-stack.metrics.json").read_text())["runs"]["main"]
    turned = max(abs(a) for a in final["angle"][:5])  # the stack's five boxes started upright
    assert turned > 1.0  # toppled: the scene's stack is destroyed
    rows = {line.split()[0]: line for line in done.stdout.splitlines() if line[:1].strip()
            and line.split()[0].endswith("/main")}
    assert rows["fast-into-stack/main"].rstrip().endswith("FAIL")
    assert rows["03-sink/main"].rstrip().endswith("-")
    flat = " ".join(done.stdout.split())  # the lines under the table, unwrapped
    failed = flat[flat.index("FAIL fast-into-stack/main:"):]
    failed = failed[:failed.index(")")]
    assert "turned" in failed.split("(")[0] and f"launch {final['launch']:.3g} > 1" in failed
    assert "03-sink/main:" not in flat
