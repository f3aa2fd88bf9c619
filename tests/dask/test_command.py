"""The executor options on the command line: Dask stays unimported until chosen, and a choice that cannot work
stops before anything runs (exit code 2, one line, nothing written). None of this needs Dask installed."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from stackx.errors import ConfigError
from stackx.run.executor import Choice
from tests.conftest import CONFIGS, REPO, Cli
from tests.limits import hang_limit


def test_help_imports_no_dask() -> None:
    code = ("import sys; from stackx.cli import app\n"
            "for command in ([], ['run'], ['bench']):\n"
            "    try:\n        app([*command, '--help'])\n    except SystemExit:\n        pass\n"
            "print('HEAVY', [m for m in ('dask', 'distributed', 'numpy') if m in sys.modules])")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, timeout=hang_limit(60))
    assert done.stdout.count("Usage") == 3 and done.stdout.count("--scheduler") == 2
    assert done.stdout.strip().splitlines()[-1] == "HEAVY []"


@pytest.mark.parametrize("choice, message", [
    (Choice("spark"), "--executor: unknown executor 'spark'; allowed: local, dask"),
    (Choice("local", "tcp://127.0.0.1:8786"), "--scheduler needs --executor dask"),
    (Choice("local", chunk=10), "--chunk needs --executor dask"),
    (Choice("dask", chunk=0), "--chunk: must be at least 1 run per task, not 0"),
])
def test_a_choice_that_cannot_work_is_refused(choice: Choice, message: str) -> None:
    with pytest.raises(ConfigError) as caught:
        choice.check()
    assert caught.value.message.startswith(message) and caught.value.exit_code == 2


def test_the_command_refuses_it_before_anything_runs(cli: Cli, tmp_path: Path) -> None:
    done = cli("run", CONFIGS / "03-sink.yaml", "--out", tmp_path / "out", "--executor", "spark")
    assert done.returncode == 2 and done.stderr == ("error: <input>: --executor: unknown executor 'spark'; "
                                                    "allowed: local, dask\n")
    assert not (tmp_path / "out").exists()


def test_without_dask_the_error_says_how_to_install_it(tmp_path: Path) -> None:
    """Dask made unimportable (as where it is not installed): the command says what to install."""
    code = ("import sys; sys.modules['distributed'] = None\nfrom stackx.cli import app\n"
            f"app(['bench', {str(CONFIGS / '03-sink.yaml')!r}, '--out', {str(tmp_path / 'out')!r}, "
            "'--executor', 'dask'])")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, timeout=hang_limit(60))
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith("error: <input>: --executor dask needs Dask's distributed scheduler: python3 -m "
                                  "pip install 'dask[distributed]'")
    assert not (tmp_path / "out").exists()
