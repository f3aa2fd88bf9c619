"""The ``stackx`` command line.

Heavy modules (numpy, pydantic, the solvers) are imported inside the commands, so ``stackx --help`` stays
fast. Every expected failure is a ``StackxError``: one or two lines on stderr and exit code 2 (bad input) or
1 (a run failed); ``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Optional

import typer

from stackx import __version__

if TYPE_CHECKING:
    from stackx.config.experiment import ExperimentSpec

app = typer.Typer(no_args_is_help=True, pretty_exceptions_enable=False,
                  context_settings={"help_option_names": ["-h", "--help"]},  # every command, inherited
                  help="Run, compare and stress-test rigid-body contact solvers from YAML configs.",
                  epilog="Example: stackx init lab && stackx run lab/configs/")

Paths = Annotated[list[str], typer.Argument(help="YAML config files, or folders whose *.yaml files run in name order")]
Sets = Annotated[Optional[list[str]], typer.Option("--set", help="override a config value: key.path=value (YAML)")]
Plugins = Annotated[Optional[Path], typer.Option("--plugins", help="folder of local plugin *.py files to import "
                                                 "(default: the plugins/ folder in each config's own folder, "
                                                 "never one above; for 'plugins' and 'schema': ./plugins)")]
Debug = Annotated[bool, typer.Option("--debug", help="show tracebacks")]
Executor = Annotated[str, typer.Option("--executor", metavar="local|dask",
                                       help="where runs step: this process (local), or the workers of a Dask "
                                            "cluster (dask: needs stackx's optional dask extra)")]
Scheduler = Annotated[Optional[str], typer.Option(
    "--scheduler", metavar="ADDRESS", help="the Dask scheduler, e.g. tcp://10.0.0.5:8786 (default: "
                                           "$DASK_SCHEDULER_ADDRESS, else a local cluster of one worker per core)")]
Chunk = Annotated[Optional[int], typer.Option(
    "--chunk", metavar="RUNS", help="runs of a sweep per Dask task (default: about four tasks per worker thread, "
                                    "at most 256 MiB of recorded states each)")]


def _version(value: bool) -> None:
    if value:
        typer.echo(f"stackx {__version__}")
        raise typer.Exit()


@app.callback()
def _root(version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True,
                                                help="print the version and exit")] = False) -> None:
    """Run, compare and stress-test rigid-body contact solvers from YAML configs."""


@contextmanager
def _guard(debug: bool) -> Iterator[None]:
    """Report ``StackxError`` as one readable line (long values cut: ``errors.readable``) with its exit code."""
    from stackx.errors import StackxError, readable

    try:
        yield
    except StackxError as exc:
        if debug:
            raise
        typer.echo(readable(f"error: {exc}"), err=True)  # one line, whatever a plugin said
        raise typer.Exit(exc.exit_code) from None


def _import_plugins(paths: list[str], plugins: Path | None) -> None:
    """Import the local plugin files the configs use (``--plugins DIR``, else each config's own ``plugins/``)
    and name them in one line on stderr, also when a folder is refused half-way."""
    from stackx.config.experiment import config_files, local_plugins, own_plugins

    with _naming_imports():
        for file in config_files(paths):
            local_plugins(plugins, own_plugins(file) if plugins is None else None)


@contextmanager
def _naming_imports() -> Iterator[None]:
    """On the way out, one line on stderr naming every local plugin file this command imported (none: no line)."""
    from stackx.registry import imported_count, imported_line

    before = imported_count()
    try:
        yield
    finally:
        line = imported_line(before)
        if line is not None:
            typer.echo(line, err=True)


def _load_all(paths: list[str], sets: list[str] | None, plugins: Path | None) -> list[ExperimentSpec]:
    """Validate every config before anything runs, so one bad file stops the whole command cleanly."""
    from stackx.config.experiment import config_files, load
    from stackx.errors import ConfigError

    _import_plugins(paths, plugins)
    notes: list[str] = []
    specs = [load(f, sets, plugins, notes) for f in config_files(paths)]
    for note in dict.fromkeys(notes):  # once each, though every config repeats it
        typer.echo(f"note: {note}", err=True)
    _warn_failed_plugins()
    owner: dict[str, str] = {}
    for spec in specs:
        for output in spec.outputs:
            for name in output.files():
                if name in owner and owner[name] != spec.file:
                    raise ConfigError(f"{name!r} is written by both {owner[name]} and {spec.file}", file=spec.file)
                owner[name] = spec.file
    return specs


def _warn_failed_plugins() -> None:
    """One line per local plugin file that failed to import: configs not using it still run."""
    from stackx.registry import local_failures

    for failure in local_failures():
        typer.echo(f"warning: {failure.file}: local plugin failed to import, its plugins are unavailable: "
                   f"{failure.message}", err=True)


@app.command(epilog="Example: stackx init lab && stackx run lab/configs/")
def init(folder: Annotated[Path, typer.Argument(help="folder to write configs/ and plugins/ into (made if "
                                                    "missing)")] = Path("."),
         debug: Debug = False) -> None:
    """Copy the lab, hard-case and example configs and the example plugin into a folder; never overwrites."""
    with _guard(debug):
        from stackx.config.starter import init_folder, summary

        for line in summary(folder, init_folder(folder)):
            typer.echo(line)


@app.command(epilog="Example: stackx run configs/ --out out --set solver.iterations=20")
def run(paths: Paths, out: Annotated[Path, typer.Option("--out", "-o", help="output folder")] = Path("out"),
        sets: Sets = None, plugins: Plugins = None, debug: Debug = False,
        quiet: Annotated[bool, typer.Option("--quiet", "-q", help="no progress bar or table")] = False,
        wide: Annotated[bool, typer.Option("--wide", help="a wider table: launch, reach, full precision")] = False,
        executor: Executor = "local", scheduler: Scheduler = None, chunk: Chunk = None,
        check: Annotated[bool, typer.Option("--check", help="exit 1 when a run's verdict is FAIL (default: the "
                                                            "table says FAIL and the command exits 0); the "
                                                            "artifacts are written either way")] = False) -> None:
    """Run experiments and write their artifacts into the output folder."""
    with _guard(debug):
        from stackx.run.executor import Choice
        from stackx.run.session import run_all

        choice = Choice(executor, scheduler, chunk)
        choice.check()
        results = run_all(_load_all(paths, sets, plugins), out, quiet=quiet, wide=wide, choice=choice)
        if check:
            from stackx.run.check import check as check_verdicts

            note = check_verdicts(results)
            if note:
                typer.echo(f"note: {note}", err=True)


@app.command(epilog="Example: stackx bench configs/hard/tall-20.yaml --solvers pgs,exact")
def bench(paths: Paths,
          solvers: Annotated[Optional[str], typer.Option(
              "--solvers", help="comma-separated solver names (default: every built-in and installed solver; "
                                "local plugins join when named)")] = None,
          out: Annotated[Path, typer.Option("--out", "-o", help="output folder")] = Path("out/bench"),
          sets: Sets = None, plugins: Plugins = None, debug: Debug = False,
          quiet: Annotated[bool, typer.Option("--quiet", "-q", help="no progress bar or tables")] = False,
          wide: Annotated[bool, typer.Option("--wide", help="every run's figures and the stability matrix, as "
                                                            "wide as they need (default: 80 columns)")] = False,
          executor: Executor = "local", scheduler: Scheduler = None) -> None:
    """Run every chosen solver over the configs and a range of its cost knob; write bench.json and report.html."""
    os.environ.setdefault("STACKX_JIT", "1")  # a bench measures compiled solvers, small batches too
    with _guard(debug):
        from stackx.bench.command import bench as run_bench
        from stackx.errors import ConfigError
        from stackx.run.executor import Choice

        choice = Choice(executor, scheduler)
        choice.check()
        _import_plugins(paths, plugins)
        names = None
        if solvers is not None:
            names = [n.strip() for n in solvers.split(",") if n.strip()]
            if not names:
                raise ConfigError("--solvers needs at least one solver name, e.g. --solvers pgs,warm-start")
        run_bench(paths, names, out, plugins, quiet, command=" ".join(["stackx", *sys.argv[1:]]), sets=sets,
                  choice=choice, wide=wide)


@app.command(epilog="Example: stackx validate configs/ configs/hard/")
def validate(paths: Paths, sets: Sets = None, plugins: Plugins = None, debug: Debug = False) -> None:
    """Check configs (and the plugins they name) without running a simulation or writing a file.

    It imports the local plugin files the configs use, as 'stackx run' would, and names them: their code runs.
    """
    with _guard(debug):
        for spec in _load_all(paths, sets, plugins):
            typer.echo(f"ok  {spec.file}: {len(spec.runs)} run(s), {len(spec.outputs)} output(s)")


@app.command(epilog="Example: stackx plugins --plugins plugins/")
def plugins(plugins: Plugins = None, debug: Debug = False) -> None:
    """List every plugin: its kind, its name and where it came from (and why one cannot run here)."""
    with _guard(debug):
        from rich.markup import escape
        from rich.table import Table

        from stackx import registry
        from stackx.config.experiment import local_plugins
        from stackx.output.screen import screen
        from stackx.output.summary_text import first_sentence

        with _naming_imports():
            local_plugins(plugins, Path("plugins"))
        _warn_failed_plugins()
        table = Table(title="stackx plugins")
        for col in ("kind", "name", "source", "about"):
            table.add_column(col)
        for kind, reg in registry.ALL.items():
            for entry in reg.entries():
                doc = first_sentence(entry.plugin.__doc__) if entry.plugin else "(not loaded)"
                why = registry.unavailable(entry.plugin)
                if why:
                    doc = f"unavailable: {why}"
                table.add_row(kind, entry.name, entry.origin, escape(doc))
        screen().print(table)


@app.command(epilog="Example: stackx schema --out stackx.schema.json")
def schema(plugins: Plugins = None, debug: Debug = False,
           out: Annotated[Optional[Path], typer.Option("--out", "-o", help="write to a file")] = None) -> None:
    """Print the JSON Schema of a config, with every installed plugin's parameters (for YAML editors)."""
    with _guard(debug):
        import json

        from stackx.config.experiment import local_plugins
        from stackx.config.schema import config_schema

        with _naming_imports():
            local_plugins(plugins, Path("plugins"))
        text = json.dumps(config_schema(), indent=2, sort_keys=True) + "\n"
        if out is None:
            sys.stdout.write(text)
        else:
            out.write_text(text)


@app.command(epilog="Example: stackx verify out configs/")
def verify(folder: Annotated[Path, typer.Argument(help="output folder holding a manifest.json")] = Path("out"),
           configs: Annotated[Optional[list[str]], typer.Argument(
               help="the configs to run again (files, or folders of *.yaml), each for the experiment of its name",
               show_default=False)] = None,
           plugins: Plugins = None,
           trust: Annotated[bool, typer.Option(
               "--trust", help="instead of named configs, run the configs and plugin folder the manifest records "
                               "inside FOLDER (listed first; a path leading outside it is refused)")] = False,
           debug: Debug = False) -> None:
    """Run configs again and report every artifact whose bytes differ from FOLDER's manifest.

    Only what you name runs: the CONFIGS (with the plugins 'stackx run CONFIGS' would import), or with --trust
    what the folder itself holds.
    """
    with _guard(debug):
        from stackx.output.verify import verify as verify_folder

        if verify_folder(folder, typer.echo, configs, plugins, trust, notice=lambda line: typer.echo(line, err=True)):
            raise typer.Exit(1)


@app.command(epilog="Example: stackx serve out --port 8080")
def serve(folder: Annotated[Path, typer.Argument(help="folder to serve")] = Path("out"),
          port: Annotated[int, typer.Option(help="TCP port")] = 8080,
          host: Annotated[str, typer.Option(help="address to listen on")] = "127.0.0.1",
          debug: Debug = False) -> None:
    """Serve an output folder over HTTP to watch its players; prints the URL of each HTML page in it."""
    with _guard(debug):
        from stackx.errors import ConfigError
        from stackx.output.serve import serve_folder

        if not folder.is_dir():
            raise ConfigError("no such folder", file=str(folder))
        serve_folder(folder, host, port)


def main() -> None:
    app()
