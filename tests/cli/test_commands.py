"""The commands besides ``run``: version, help, validate, plugins, schema, serve."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

from tests.conftest import CONFIGS, REPO, Cli


def test_version(cli: Cli) -> None:
    import stackx

    done = cli("--version")
    assert done.returncode == 0
    assert done.stdout.strip() == f"stackx {stackx.__version__}"


def test_help_does_not_import_numpy() -> None:
    code = ("import sys; from stackx.cli import app\n"
            "try:\n    app(['--help'])\nexcept SystemExit:\n    pass\n"
            "heavy = [m for m in ('numpy', 'numba', 'pydantic') if m in sys.modules]\n"
            "print('HEAVY', heavy)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO)
    assert "Usage" in done.stdout
    assert done.stdout.strip().splitlines()[-1] == "HEAVY []"


def test_validate_names_runs_and_outputs(cli: Cli) -> None:
    done = cli("validate", CONFIGS)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.strip().splitlines()
    assert [ln.split()[1].rstrip(":") for ln in lines] == [str(p) for p in sorted(CONFIGS.glob("*.yaml"))]
    assert any("05-iters.yaml: 3 run(s)" in ln for ln in lines)


def test_plugins_table_lists_kinds_and_sources(cli: Cli) -> None:
    done = cli("plugins", env={"COLUMNS": "200"})
    assert done.returncode == 0, done.stderr
    rows = {tuple(cell.strip() for cell in ln.split("│")[1:4]) for ln in done.stdout.splitlines() if "│" in ln}
    for row in [("scene", "column", "built-in"), ("solver", "pgs", "built-in"), ("renderer", "frames", "built-in"),
                ("sink", "keyvalue", "built-in"), ("solver", "sor", "plugins/sor.py")]:
        assert row in rows, rows


def test_schema_includes_plugin_parameters(cli: Cli, tmp_path: Path) -> None:
    target = tmp_path / "schema.json"
    done = cli("schema", "--plugins", REPO / "plugins", "--out", target)
    assert done.returncode == 0, done.stderr
    schema = json.loads(target.read_text())
    solvers = {s["properties"]["name"]["const"]: s for s in schema["properties"]["solver"]["oneOf"]}
    assert {"pgs", "sor"} <= set(solvers)
    assert "iterations" in solvers["pgs"]["properties"]
    assert "omega" in solvers["sor"]["properties"]
    outputs = schema["properties"]["outputs"]["items"]["oneOf"]
    kinds = {("sink" if "sink" in o["properties"] else "render",
              (o["properties"].get("sink") or o["properties"]["render"])["const"]) for o in outputs}
    assert {("sink", "keyvalue"), ("render", "frames"), ("render", "drawing")} <= kinds
    assert schema["additionalProperties"] is False


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_serve_shows_the_player(cli: Cli, tmp_path: Path) -> None:
    out = tmp_path / "out"
    assert cli("run", CONFIGS / "06-stack.yaml", "--out", out, "-q").returncode == 0
    port = _free_port()
    server = subprocess.Popen([sys.executable, "-m", "stackx", "serve", str(out), "--port", str(port)],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for _ in range(100):
            try:
                page = urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=2).read().decode()
                break
            except OSError:
                time.sleep(0.1)
        else:
            raise AssertionError("server did not answer")
        assert page == (out / "index.html").read_text()
        png = urllib.request.urlopen(f"http://127.0.0.1:{port}/f11.png", timeout=2).read()
        assert png == (out / "f11.png").read_bytes()
    finally:
        server.terminate()
        server.wait(timeout=10)


def test_serve_refuses_a_missing_folder(cli: Cli, tmp_path: Path) -> None:
    done = cli("serve", tmp_path / "nowhere")
    assert done.returncode == 2
    assert "no such folder" in done.stderr


@pytest.mark.parametrize("command", ["plugins", "schema", "validate"])
def test_a_missing_plugins_folder_is_refused(cli: Cli, tmp_path: Path, command: str) -> None:
    """``--plugins DIR`` that is not a folder stops every command that takes it (it used to list built-ins)."""
    args = [CONFIGS / "03-sink.yaml"] if command == "validate" else []
    done = cli(command, *args, "--plugins", tmp_path / "nowhere")
    assert done.returncode == 2, done.stdout
    assert done.stderr.strip() == f"error: {tmp_path / 'nowhere'}: --plugins: no such folder"


def _commands() -> list[str]:
    import typer.main

    from stackx.cli import app

    return sorted(typer.main.get_command(app).commands)  # type: ignore[attr-defined]


def _example(args: list[str]) -> list[list[str]]:
    """The example invocations printed by ``stackx ARGS``'s help, each split into its words."""
    import re
    import shlex

    from typer.testing import CliRunner

    from stackx.cli import app

    done = CliRunner().invoke(app, args, prog_name="stackx", env={"COLUMNS": "80"})
    assert done.exit_code == 0, done.output
    examples = [m.group(1) for m in re.finditer(r"Example: (stackx .*?)\s*$", done.output, re.MULTILINE)]
    assert len(examples) == 1, done.output
    return [shlex.split(part) for part in examples[0].split("&&")]


@pytest.mark.parametrize("command", [None, *_commands()])
@pytest.mark.parametrize("flag", ["-h", "--help"])
def test_every_help_shows_an_example_that_parses(command: str | None, flag: str) -> None:
    """``-h`` is ``--help`` everywhere, and each help ends on an invocation of that command that its own
    parser accepts (options that exist, values of the right type)."""
    import typer.main

    from stackx.cli import app

    group = typer.main.get_command(app)
    invocations = _example([flag] if command is None else [command, flag])
    assert all(words[0] == "stackx" for words in invocations)
    if command is not None:
        assert invocations[0][1] == command
    for words in invocations:
        root = group.make_context("stackx", words[1:])
        name, sub, rest = group.resolve_command(root, words[1:])  # type: ignore[attr-defined]
        assert sub is not None and name in _commands()
        sub.make_context(name, rest, parent=root)  # raises click.UsageError on an unknown option or bad value


def test_shell_completion_completes_commands_and_options() -> None:
    """The completion a shell asks for (``stackx --install-completion`` sets it up) names commands and options."""
    from typer.testing import CliRunner

    from stackx.cli import app

    def complete(line: str) -> list[str]:
        words = line.split(" ")
        done = CliRunner().invoke(app, [], prog_name="stackx", env={
            "_STACKX_COMPLETE": "complete_bash", "COMP_WORDS": line, "COMP_CWORD": str(len(words) - 1)})
        assert done.exit_code == 0, done.output
        return done.output.split()

    assert complete("stackx in") == ["init"]
    assert set(complete("stackx ")) == set(_commands())
    assert "--solvers" in complete("stackx bench --so")
