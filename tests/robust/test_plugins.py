"""Plugins that fail: each error names the plugin and its file; a broken file does not stop other configs.

Every case runs the real command in a subprocess: a plugin file that fails to import is remembered for the
rest of a process, which must not leak into other tests.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from tests.conftest import Cli

HEADER = """\
import numpy as np
from pydantic import BaseModel, ConfigDict
from stackx.models.column.monitor import observe
from stackx.registry import solvers
from stackx.solvers.base import Solver


class P(BaseModel):
    model_config = ConfigDict(extra="forbid")
"""

SOLVERS = {
    "raises": '''
@solvers.register("raises")
class Raises(Solver):
    """Fails on its first call."""
    Params = P
    def advance(self, state, steps):
        return 1 / 0
''',
    "reshapes": '''
@solvers.register("reshapes")
class Reshapes(Solver):
    """Replaces the heights with an array one box short."""
    Params = P
    def advance(self, state, steps):
        state.y = np.ascontiguousarray(state.y[:, 1:])
''',
    "returns": '''
@solvers.register("returns")
class Returns(Solver):
    """Returns new arrays instead of stepping in place."""
    Params = P
    def advance(self, state, steps):
        return state.y + 1.0
''',
    "no-advance": '''
@solvers.register("no-advance")
class NoAdvance(Solver):
    """Forgot to write advance."""
    Params = P
''',
    "no-params": '''
@solvers.register("no-params")
class NoParams(Solver):
    """Forgot its params model."""
    def advance(self, state, steps):
        pass
''',
    "not-a-solver": '''
@solvers.register("not-a-solver")
class Loose:
    """Does not derive from Solver."""
    Params = P
    def advance(self, state, steps):
        pass
''',
}

CONFIG = """\
scene: {{name: column, boxes: [{{y: 0.5}}, {{y: 1.5}}, {{y: 2.5}}]}}
solver: {{name: {solver}}}
steps: 60
outputs: [{{sink: metrics, path: {stem}.json}}]
"""


def _after_imports(stderr: str, project: Path, names: str) -> list[str]:
    """The lines of ``stderr`` after the first, which must name the plugin files imported (``names``)."""
    first, *rest = stderr.strip().splitlines()
    assert first == f"plugins: imported {names} from {project / 'plugins'}", stderr
    return rest


def _project(tmp_path: Path, files: dict[str, str], configs: dict[str, str]) -> Path:
    (tmp_path / "plugins").mkdir()
    for name, text in files.items():
        (tmp_path / "plugins" / name).write_text(text)
    for stem, solver in configs.items():
        (tmp_path / f"{stem}.yaml").write_text(CONFIG.format(solver=solver, stem=stem))
    return tmp_path


@pytest.mark.parametrize("name, code, words", [
    ("raises", 1, ["raised in steps 1..", "ZeroDivisionError: division by zero"]),
    ("reshapes", 1, ["left state.y as (1, 2) float64", "it must stay (1, 3) float64"]),
    ("returns", 1, ["advance must change the state in place and return None; it returned ndarray"]),
    ("no-advance", 2, ["does not define 'advance'"]),
    ("no-params", 2, ["has no 'Params'"]),
    ("not-a-solver", 2, ["is not a subclass of stackx.solvers.base.Solver"]),
])
def test_broken_solver_is_named_with_its_file(cli: Cli, tmp_path: Path, name: str, code: int,
                                              words: list[str]) -> None:
    project = _project(tmp_path, {"mine.py": HEADER + SOLVERS[name]}, {"case": name})
    done = cli("run", "case.yaml", "--out", "out", "-q", cwd=project)
    assert done.returncode == code, done.stderr
    assert "Traceback" not in done.stderr
    [line] = _after_imports(done.stderr, project, "mine.py")
    assert f"'{name}'" in line and "plugins/mine.py" in line, line
    for word in words:
        assert word in line, line
    assert not (project / "out" / "case.json").exists()


BROKEN = HEADER + '''
raise RuntimeError("half-written plugin")


@solvers.register("broken")
class Broken(Solver):
    Params = P
'''


def test_broken_plugin_file_does_not_stop_unrelated_configs(cli: Cli, tmp_path: Path) -> None:
    project = _project(tmp_path, {"broken.py": BROKEN, "fine.py": HEADER + SOLVERS["raises"]},
                       {"lab": "pgs", "wants": "broken"})
    done = cli("run", "lab.yaml", "--out", "out", "-q", cwd=project)
    assert done.returncode == 0, done.stderr
    assert (project / "out" / "lab.json").is_file()
    [warning] = _after_imports(done.stderr, project, "broken.py, fine.py")
    line = BROKEN.splitlines().index('raise RuntimeError("half-written plugin")') + 1
    assert warning.startswith(f"warning: {project / 'plugins' / 'broken.py'}: local plugin failed to import")
    assert f"line {line}: RuntimeError: half-written plugin" in warning

    done = cli("run", "wants.yaml", "--out", "out2", "-q", cwd=project)
    assert done.returncode == 2
    error = done.stderr.strip().splitlines()[-1]
    assert error.startswith("error: wants.yaml:2:"), error
    assert f"solver.name: solver 'broken' is defined in {project / 'plugins' / 'broken.py'}, which failed to " \
           f"import: line {line}: RuntimeError: half-written plugin" in error
    assert not (project / "out2").exists()


def test_unreadable_plugin_file_is_suspected_only_for_unknown_names(cli: Cli, tmp_path: Path) -> None:
    project = _project(tmp_path, {"typo.py": "def oops(:\n"}, {"lab": "pgs", "other": "nowhere"})
    assert cli("run", "lab.yaml", "--out", "out", "-q", cwd=project).returncode == 0
    done = cli("validate", "other.yaml", cwd=project)
    assert done.returncode == 2
    error = done.stderr.strip().splitlines()[-1]
    assert "unknown solver 'nowhere'" in error
    # the known names make the line long: its middle may be cut, so only its end is asserted
    assert "SyntaxError" in error and error.endswith("and may define it")


def test_plugins_listing_reports_the_broken_file(cli: Cli, tmp_path: Path) -> None:
    project = _project(tmp_path, {"broken.py": BROKEN}, {})
    done = cli("plugins", cwd=project)
    assert done.returncode == 0
    assert "plugins/broken.py: local plugin failed to import" in done.stderr


def test_output_plugin_failure_names_it_and_writes_nothing(cli: Cli, tmp_path: Path) -> None:
    sink = textwrap.dedent('''\
        from pydantic import BaseModel, ConfigDict
        from stackx.outputs import Sink
        from stackx.registry import sinks


        class P(BaseModel):
            model_config = ConfigDict(extra="forbid")
            path: str


        @sinks.register("bad-sink")
        class BadSink(Sink):
            """Writes a number where bytes belong."""
            Params = P
            def write(self, result, out):
                out.write_bytes(self.params.path, 42)
        ''')
    project = _project(tmp_path, {"sink.py": sink}, {"case": "pgs"})
    config = project / "case.yaml"
    config.write_text(config.read_text().replace("case.json}]", "case.json}, {sink: bad-sink, path: bad.bin}]"))
    done = cli("run", "case.yaml", "--out", "out", "-q", cwd=project)
    assert done.returncode == 1
    [line] = _after_imports(done.stderr, project, "sink.py")
    assert (f"output 'bad-sink' ({project / 'plugins' / 'sink.py'}) failed: TypeError: 'bad.bin': an output "
            "writes bytes, not int") in line
    assert not (project / "out" / "case.json").exists()  # the experiment's other file is not written either
