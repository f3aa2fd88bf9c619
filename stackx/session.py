"""One ``stackx run``: step every experiment with a progress bar, write its artifacts, summarise.

An experiment's files are staged and written only after all its runs and outputs succeeded, so a failure
leaves the output folder as it was for that experiment. Wall-clock times, the one thing that differs from
run to run, go to ``timing.json`` and nowhere else.
"""

from __future__ import annotations

import json
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from stackx.config import ExperimentSpec
from stackx.errors import RunError
from stackx.outdir import OutputDir, atomic_write
from stackx.results import ExperimentResult
from stackx.runner import run_experiment

TIMING_FILE = "timing.json"


def run_all(specs: list[ExperimentSpec], out: Path, quiet: bool = False) -> list[ExperimentResult]:
    console = Console(stderr=True)
    results = []
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    with Progress(*columns, console=console, transient=True, disable=quiet) as bar:
        for spec in specs:
            total = sum(r.steps for r in spec.runs)
            task = bar.add_task(spec.name, total=total or 1)
            result = run_experiment(spec, lambda n, task=task: bar.advance(task, n))
            _write(result, out)
            bar.update(task, completed=total or 1)
            results.append(result)
    _write_timing(results, out)
    if not quiet:
        Console().print(summary(results, out))
    return results


def _write(result: ExperimentResult, out: Path) -> None:
    staged = OutputDir(out)
    for output in result.spec.outputs:
        try:
            output.write(result, staged)
        except (RunError, OSError):
            raise
        except Exception as exc:
            raise RunError(f"{result.spec.file}: output {output.plugin_name!r} failed: "
                           f"{type(exc).__name__}: {exc}") from exc
    staged.commit()


def _write_timing(results: list[ExperimentResult], out: Path) -> None:
    """Merge this invocation's wall times into ``timing.json`` (microseconds per step, per run)."""
    path = out / TIMING_FILE
    try:
        doc = json.loads(path.read_text())
        if not isinstance(doc, dict):
            doc = {}
    except (OSError, ValueError):
        doc = {}
    for result in results:
        if result.runs:
            doc[result.spec.name] = {r.name: {"us_per_step": 1e6 * r.wall_seconds / r.spec.steps,
                                              "wall_seconds": r.wall_seconds} for r in result.runs}
    out.mkdir(parents=True, exist_ok=True)
    atomic_write(path, (json.dumps(doc, indent=2, sort_keys=True) + "\n").encode())


def summary(results: list[ExperimentResult], out: Path) -> Table:
    table = Table(title=f"stackx run -> {out}")
    for col, just in (("config", "left"), ("run", "left"), ("solver", "left"), ("boxes", "right"),
                      ("steps", "right"), ("max depth", "right"), ("peak depth", "right"),
                      ("rms motion", "right"), ("µs/step", "right")):
        table.add_column(col, justify=just)  # type: ignore[arg-type]
    for result in results:
        if not result.runs:
            table.add_row(result.spec.name, "-", "-", "-", "-", "-", "-", "-", "-")
        for r in result.runs:
            m = r.measures
            table.add_row(result.spec.name, r.name, r.spec.solver_cls.plugin_name, str(r.final.boxes),
                          str(r.spec.steps), f"{m['max_depth']:.5f}", f"{m['peak_depth']:.5f}",
                          f"{m['rms_motion']:.2e}", f"{1e6 * r.wall_seconds / r.spec.steps:.1f}")
    return table
