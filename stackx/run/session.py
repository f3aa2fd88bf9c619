"""One ``stackx run``: step every experiment with a progress bar, write its artifacts, summarise.

Nothing is written into the output folder while the runs step: each finished experiment's files are staged beside
it, and when every experiment has finished the folder is switched to the staged one in a single step
(``stackx.output.folder``), with its ``manifest.json`` (see ``stackx.output.manifest``) and ``timing.json``. A run
killed or failing at any moment leaves the folder as it was; two runs into one folder take turns. A run that blows
up commits the experiments finished before it and its partial measures in ``NAME.failed.json``, a file that a
later successful run of the experiment removes. Wall-clock times, the one thing that differs from run to run, go
to ``timing.json`` and nowhere else. Where the runs step (this process, or a Dask cluster) is the executor's
business (``stackx.run.executor``); what is written does not depend on it.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from rich import box
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from stackx.output import manifest
from stackx.config.experiment import ExperimentSpec
from stackx.errors import BlowUp, ConfigError, RunError, first_line
from stackx.run.executor import Choice, open_executor
from stackx.output.folder import FolderUpdate
from stackx.output.outdir import MANIFEST, TIMING, OutputDir, failed_file, json_bytes, read_json
from stackx.outputs import confine
from stackx.run.lines import Finished
from stackx.run.results import ExperimentResult
from stackx.output.screen import TIMING_CAPTION, screen, timing_cell


def run_all(specs: list[ExperimentSpec], out: Path, quiet: bool = False, wide: bool = False,
            choice: Choice | None = None) -> list[ExperimentResult]:
    """Run ``specs`` where ``choice`` says (this process by default) and switch the output folder to their
    files in one step once they finished (see ``stackx.output.folder``); a failure leaves ``out`` as it was, except a
    blow-up, which keeps the experiments finished before it and the failed-run file."""
    console = Console(stderr=True)
    say = lambda line: console.print(line, markup=False, highlight=False, soft_wrap=True)  # noqa: E731
    with FolderUpdate(out, say=say) as folder:
        preflight(specs, out)
        book = manifest.read(out)
        own(folder, specs, book)
        results: list[ExperimentResult] = []
        blown: BlowUp | None = None
        columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
        finished = Finished(console, "run", len(specs), quiet)  # the bar's lines where no bar is drawn
        with open_executor(choice or Choice()) as executor, \
                Progress(*columns, console=console, transient=True,
                         disable=quiet or not console.is_terminal) as bar:  # no terminal: ``finished`` says it
            for spec, job in zip(specs, executor.experiments(specs)):
                total = sum(r.steps for r in spec.runs)
                task = bar.add_task(spec.name, total=total or 1)
                try:
                    result = job.result(lambda n, task=task: bar.advance(task, n))
                except BlowUp as exc:
                    kept = failed_file(spec.name)
                    folder.write_records({kept: json_bytes({**exc.report, "resolved": spec.resolved})})
                    blown = BlowUp(f"{exc}; partial measures in {out / kept}", exc.report)
                    break
                book = _stage(spec, result, folder, book)
                bar.update(task, completed=total or 1)
                finished.done(spec.name)
                results.append(result)
        if any(r.runs for r in results):
            _write_timing(results, folder)
        if book is not None:
            folder.write_records({MANIFEST: json_bytes(book)})
        folder.commit()
    if blown is not None:
        raise blown
    if not quiet:
        screen().print(summary(results, out, wide))
    return results


def preflight(specs: list[ExperimentSpec], out: Path) -> None:
    """Refuse, before anything steps, an output folder that cannot take the artifacts or has a bad manifest (or
    a record, manifest or timing, over the bound of ``manifest.read_record``)."""
    if out.exists() and not out.is_dir():
        raise ConfigError("the output folder is a file", file=str(out))
    for spec in specs:
        for i, output in enumerate(spec.outputs):
            confine(output, lambda path, msg, i=i, spec=spec: spec.source.error(("outputs", i, *path), msg), out)
    manifest.read(out)
    manifest.read_record(out / TIMING)  # merged into after the runs: refused now, not after them


def listed(book: dict[str, Any] | None) -> set[str]:
    """The files a manifest lists (its experiments' artifacts): the files of the folder that are stackx's."""
    experiments = book.get("experiments") if isinstance(book, dict) else None
    names: set[str] = set()
    for entry in (experiments.values() if isinstance(experiments, dict) else ()):
        artifacts = entry.get("artifacts") if isinstance(entry, dict) else None
        names.update(n for n in (artifacts if isinstance(artifacts, dict) else ()) if isinstance(n, str))
    return names


def own(folder: FolderUpdate, specs: list[ExperimentSpec], book: dict[str, Any] | None) -> None:
    """Tell ``folder`` which of its files the run may replace (those ``book``, the manifest before the run,
    lists) and refuse, before anything steps, an output whose file is there and is not one of them: a run
    replaces only stackx's own files."""
    folder.ours = listed(book)
    for spec in specs:
        for i, output in enumerate(spec.outputs):
            for name in output.files():
                if name not in folder.ours and os.path.lexists(folder.root / name):
                    raise spec.source.error(("outputs", i), f"{folder.shown / name} is not a file stackx wrote "
                                            f"({MANIFEST} does not list it), and a run replaces only its own "
                                            f"files: move it away or choose another path")


def stage(spec: ExperimentSpec, result: ExperimentResult, out: Path) -> OutputDir:
    """Every output of a finished experiment, held in memory; a plugin failing is named with its file."""
    staged = OutputDir(out)
    for output in spec.outputs:
        try:
            output.write(result, staged)
        except RunError:
            raise
        except Exception as exc:
            raise RunError(f"{spec.file}: output {output.plugin_name!r} "
                           f"({getattr(output, 'plugin_origin', '?')}) failed: {first_line(exc)}") from exc
    return staged


def _stage(spec: ExperimentSpec, result: ExperimentResult, folder: FolderUpdate,
           book: dict[str, Any] | None) -> dict[str, Any] | None:
    """Stage an experiment's files and drop its failed-run file; return the manifest with its entry merged."""
    staged = stage(spec, result, folder.shown).staged
    folder.write(staged)
    folder.remove(failed_file(spec.name))
    if not staged:
        return book
    return manifest.merged(book, spec.name, manifest.entry(spec, staged, folder.shown))


def write(spec: ExperimentSpec, result: ExperimentResult, out: Path) -> list[Path]:
    """Write one experiment's files and its manifest entry into ``out``, switched in whole, and drop a
    failed-run file it leaves behind. Return the files written."""
    with FolderUpdate(out) as folder:
        preflight([spec], out)
        book = manifest.read(out)
        own(folder, [spec], book)
        book = _stage(spec, result, folder, book)
        if book is not None:
            folder.write_records({MANIFEST: json_bytes(book)})
        written = [out / name for name in sorted(folder.added) if name != MANIFEST]
        folder.commit()
    return written


def _write_timing(results: list[ExperimentResult], folder: FolderUpdate) -> None:
    """Merge this invocation's wall times into ``timing.json``: per run, ``RunResult.timing_record`` (µs/step,
    seconds, how it stepped, whether the time is its own or a share of its batch's)."""
    doc = read_json(folder.read(TIMING))
    if not isinstance(doc, dict):
        doc = {}
    for result in results:
        if result.runs:
            doc[result.spec.name] = {r.name: r.timing_record() for r in result.runs}
    folder.write_records({TIMING: json_bytes(doc)})


MEASURED = (("max_depth", "depth m", "largest final penetration"), ("peak_depth", "peak m", "largest depth at any step"),
            ("rms_motion", "motion m/s", "RMS motion over the final window"))


def summary(results: list[ExperimentResult], out: Path, wide: bool = False) -> Table:
    """One row per run. The default fits 80 columns (3 significant figures, names folded, numbers never cut);
    ``wide`` adds the launch and reach monitors and full precision. µs/step says how the run was stepped
    and timed (``stackx.output.screen.timing_cell``: ``jit``/``py``/``engine``, and ``≈`` for a share of a
    batch's time)."""
    caption = TIMING_CAPTION
    if any(r.measures.get("unsolved_steps") for result in results for r in result.runs):
        caption += ("\nsteps N (K unsolved): K steps missed the solver's own tolerance and kept its closest answer "
                    "(measures unsolved_steps, first_unsolved, worst_unsolved)")
    table = Table(title=f"stackx run -> {out}", box=None if not wide else box.HEAVY_HEAD, pad_edge=False,
                  caption=caption if results else None)
    table.add_column("run", overflow="fold")
    table.add_column("solver", overflow="fold")
    for head in ("boxes", "steps", *(h for _, h, _ in MEASURED), *(("launch m/s", "reach") if wide else ()),
                 "µs/step"):
        table.add_column(head, justify="right", no_wrap=True)
    names = [k for k, _, _ in MEASURED] + (["launch", "reach"] if wide else [])
    form = ".6g" if wide else ".3g"
    verdicts = {id(r): verdict(r, getattr(result.spec, "bench", None)) for result in results for r in result.runs}
    judged = any(v is not None for v in verdicts.values())
    if judged:  # some scene states what must hold: say whether it did, and below the table what failed
        table.add_column("verdict", no_wrap=True)
        failed = [f"{result.spec.name}/{r.name}: {verdicts[id(r)][1]}" for result in results for r in result.runs
                  if verdicts[id(r)] and verdicts[id(r)][1]]  # type: ignore[index]
        table.caption = "\n".join([*(f"FAIL {line}" for line in failed), "verdict: judged as stackx bench judges "
                                    "it, where the config has a bench section or the scene states what must "
                                    "hold", table.caption or ""])
        table.caption_justify = "left"
    for result in results:
        if not result.runs:
            table.add_row(result.spec.name, "-", *["-"] * (3 + len(names) + judged))
        for r in result.runs:
            table.add_row(f"{result.spec.name}/{r.name}", r.spec.solver_cls.plugin_name, str(r.spec.scene.final_size()),
                          _steps(r.spec.steps, r.measures), *(_number(r.measures, k, form) for k in names),
                          timing_cell(r, form), *([_verdict_cell(verdicts[id(r)])] if judged else []))
    return table


def verdict(run: Any, bench: Any) -> tuple[bool, str] | None:
    """A run's verdict (``stackx.bench.criteria.run_verdicts``): (passed, what failed in the bench's words and
    with the values and limits); None for a run whose config states nothing to judge."""
    from stackx.bench.criteria import failed_words, passed, run_verdicts

    judged = run_verdicts(run, bench.criteria if bench is not None else None)
    if judged is None:
        return None
    found, measures = judged
    if passed(found):
        return True, ""
    detail = "; ".join(f"{name}: {v.failing}" for name, v in found.items() if not v.passed)
    return False, f"{failed_words(found, measures)} ({detail})"


def _verdict_cell(found: tuple[bool, str] | None) -> str:
    return "-" if found is None else "[green]pass[/]" if found[0] else "[red]FAIL[/]"


def _steps(steps: int, measures: dict[str, Any]) -> str:
    """The run's step count, flagged with how many of its steps the solver left unsolved, if any."""
    missed = measures.get("unsolved_steps")
    return f"{steps} ({missed} unsolved)" if missed else str(steps)


def _number(measures: dict[str, Any], name: str, form: str) -> str:
    """A measure as the table prints it; "-" for one the run's model does not measure."""
    value = measures.get(name)
    return "-" if value is None else format(value, form)
