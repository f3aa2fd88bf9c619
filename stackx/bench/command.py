"""``stackx bench``: load every case first, run them with a progress bar, write the report, print tables.

Every config and every solver's settings are validated before anything runs, so a bad file or an unknown
solver stops the command with exit code 2 and nothing written. The output folder is locked and its staging
folder made before the first case runs (a folder that cannot be written is refused then, not after the
bench), and it is switched in whole at the end, as ``stackx run`` switches its folder
(``stackx.output.folder``): a second bench into it waits, and a killed one leaves the old files or the new.
"""

from __future__ import annotations

import time
from contextlib import nullcontext
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from stackx.bench.plan import Case, load_case
from stackx.bench.report import write
from stackx.bench.result import CaseResult
from stackx.bench.sweep import bench_plan, plan_work, work
from stackx.bench.tables import print_all
from stackx.config.experiment import config_files, load
from stackx.errors import ConfigError
from stackx.run.executor import Choice, open_executor
from stackx.run.lines import Finished
from stackx.output.folder import FolderUpdate
from stackx.output.outdir import OutputDir
from stackx.output.screen import screen


def load_cases(paths: list[str], solvers: list[str] | None, plugins: Path | None,
               sets: list[str] | None = None) -> list[tuple[Case, dict[str, str]]]:
    """Every config made a bench case (validated, ``--set`` applied, solvers planned), in command-line order."""
    cases = [load_case(load(f, sets, plugins), solvers) for f in config_files(paths)]
    seen: dict[str, str] = {}
    for case, _ in cases:
        if case.name in seen:
            raise ConfigError(f"two cases are named {case.name!r} ({seen[case.name]} and {case.spec.file}); "
                              "rename one file", file=case.spec.file)
        seen[case.name] = case.spec.file
    return cases


def bench(paths: list[str], solvers: list[str] | None, out: Path | None, plugins: Path | None = None,
          quiet: bool = False, command: str = "stackx bench", sets: list[str] | None = None,
          choice: Choice | None = None, wide: bool = False) -> list[CaseResult]:
    """Bench ``paths`` with ``solvers`` (None: every built-in and installed one); write into ``out`` (None:
    nothing is written, the results are returned). Each solver on each case is one job for the executor
    ``choice`` names (this process by default). The terminal gets a summary that fits 80 columns, or with
    ``wide`` every run's figures and the stability matrix."""
    cases = load_cases(paths, solvers, plugins, sets)
    console = Console(stderr=True)
    say = lambda line: console.print(line, markup=False, highlight=False, soft_wrap=True)  # noqa: E731
    with FolderUpdate(out, say=say) if out is not None else nullcontext() as folder:
        start = time.perf_counter()
        results = []
        columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
        with open_executor(choice or Choice()) as executor, \
                Progress(*columns, console=console, transient=True, disable=quiet) as bar:
            task = bar.add_task("bench", total=sum(work(c) for c, _ in cases) or 1)
            jobs = [executor.calls(bench_plan, [(case, plan) for plan in case.plans],
                                   [plan_work(case, plan) for plan in case.plans]) for case, _ in cases]
            finished = Finished(console, "bench", sum(len(case.plans) for case, _ in cases), quiet)
            for (case, left_out), case_jobs in zip(cases, jobs):
                bar.update(task, description=case.name)
                records = []
                for plan, job in zip(case.plans, case_jobs):
                    records += job.result(lambda n: bar.advance(task, n))
                    finished.done(f"{case.name} {plan.solver}")  # a line each where no bar is drawn
                results.append(CaseResult.build(case, records, left_out))
        wall = time.perf_counter() - start
        if folder is not None:
            _switch_in(folder, results, command, wall)
    if not quiet:
        console = screen()
        print_all(results, console, wide)
        if out is not None:
            console.print(f"wrote {out / 'bench.json'} and {out / 'report.html'} in {wall:.1f} s")
    return results


def _switch_in(folder: FolderUpdate, results: list[CaseResult], command: str, wall: float) -> None:
    """Stage the bench's files and switch its folder to them; the files a bench writes are its own to replace
    (every other entry of the folder is carried over untouched)."""
    staged = OutputDir(folder.shown)
    write(results, staged, command, wall)
    folder.ours = set(staged.staged)
    folder.write(staged.staged)
    folder.commit()
