"""Plugin code runs only from where the user said: ``--plugins DIR``, else the config's own ``plugins/`` folder.

A folder above the config is never imported (it is named in an unknown name's error instead), a plugin folder
or file that another user could have written is refused before any of it runs, every command that imports
plugin files names them in one line on stderr, and no config can write a file that a later command imports.
Every planted file writes a marker when it runs, and every case runs the real command in a subprocess.
"""

from __future__ import annotations

import os
import shutil
import textwrap
from pathlib import Path

import pytest

from tests.conftest import CONFIGS, Cli

CONFIG = "03-sink.yaml"


def _planted(folder: Path, marker: Path, name: str = "evil.py") -> Path:
    """A plugin file that writes ``marker`` when it is imported."""
    folder.mkdir(parents=True, exist_ok=True)
    plugin = folder / name
    plugin.write_text(f"from pathlib import Path\nPath({str(marker)!r}).write_text('imported')\n")
    return plugin


def _imported_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("plugins:")]


@pytest.fixture
def deep(tmp_path: Path) -> Path:
    """A config three folders below a shared folder whose ``plugins/evil.py`` someone planted."""
    _planted(tmp_path / "shared" / "plugins", tmp_path / "imported")
    folder = tmp_path / "shared" / "a" / "b" / "c"
    folder.mkdir(parents=True)
    shutil.copy(CONFIGS / CONFIG, folder / CONFIG)
    return folder


# ------------------------------------------------------------------------------------- folders above the config


@pytest.mark.parametrize("command", ["run", "validate"])
def test_a_plugins_folder_above_the_config_is_not_imported(cli: Cli, deep: Path, command: str) -> None:
    args = ["--out", "out", "-q"] if command == "run" else []
    done = cli(command, CONFIG, *args, cwd=deep)
    assert done.returncode == 0, done.stderr
    assert not (deep.parents[3] / "imported").exists()
    assert _imported_lines(done.stderr) == []
    if command == "run":
        assert (deep / "out" / "03-sink.txt").is_file()


def test_an_unknown_name_points_at_the_folder_above_without_importing_it(cli: Cli, deep: Path) -> None:
    config = deep / CONFIG
    config.write_text(config.read_text().replace("name: pgs", "name: planted"))
    done = cli("validate", CONFIG, cwd=deep)
    assert done.returncode == 2
    [line] = done.stderr.splitlines()
    assert line.startswith(f"error: {CONFIG}:7:9: solver.name: unknown solver 'planted'; plugins/ folders above "
                           "the config are not imported: name one with --plugins ../../../plugins; known: "), line
    assert not (deep.parents[3] / "imported").exists()

    named = cli("validate", CONFIG, "--plugins", "../../../plugins", cwd=deep)  # the hint, followed
    assert (deep.parents[3] / "imported").read_text() == "imported"
    assert _imported_lines(named.stderr) == [f"plugins: imported evil.py from {deep.parents[2] / 'plugins'}"]


def test_an_unknown_name_given_with_set_points_at_the_folder_above_too(cli: Cli, deep: Path) -> None:
    done = cli("validate", CONFIG, "--set", "solver.name=planted", cwd=deep)
    assert done.returncode == 2
    [line] = done.stderr.splitlines()
    assert line.startswith("error: --set solver.name=planted: unknown solver 'planted'; plugins/ folders above the "
                           "config are not imported: name one with --plugins ../../../plugins; known: "), line
    assert not (deep.parents[3] / "imported").exists()


def test_a_solver_named_to_bench_points_at_the_folder_above_too(cli: Cli, deep: Path) -> None:
    done = cli("bench", CONFIG, "--solvers", "planted", "--out", "out", cwd=deep)
    assert done.returncode == 2
    [line] = done.stderr.splitlines()
    assert line.startswith(f"error: {CONFIG}: --solvers: unknown solver 'planted'; plugins/ folders above the "
                           "config are not imported: name one with --plugins ../../../plugins; known: "), line
    assert not (deep.parents[3] / "imported").exists() and not (deep / "out").exists()


# ------------------------------------------------------------------------------------ what may be imported


def _link_out(folder: Path, marker: Path) -> Path:
    outside = _planted(folder.parent / "elsewhere", marker)
    (folder / "evil.py").unlink()
    (folder / "evil.py").symlink_to(outside)
    return folder / "evil.py"


def _folder_link(folder: Path, marker: Path) -> Path:
    real = folder.parent / "real-plugins"
    folder.rename(real)
    folder.symlink_to(real, target_is_directory=True)
    return folder


def _open_folder(folder: Path, marker: Path) -> Path:
    folder.chmod(0o777)
    return folder


def _open_file(folder: Path, marker: Path) -> Path:
    (folder / "evil.py").chmod(0o666)
    return folder / "evil.py"


def _foreign_file(folder: Path, marker: Path) -> Path:
    os.chown(folder / "evil.py", 4242, 4242)
    return folder / "evil.py"


PLANTED = {
    "file writable by all": (_open_file, "the plugin file is writable by every user (mode 0666)"),
    "folder writable by all": (_open_folder, "the plugin folder is writable by every user (mode 0777)"),
    "file of another user": (_foreign_file, "the plugin file is owned by user 4242"),
    "file linking out": (_link_out, "the plugin file is a link to "),
    "folder that is a link": (_folder_link, "the plugin folder is a link to "),
}


@pytest.mark.parametrize("case", PLANTED)
def test_a_plugin_someone_else_could_have_written_is_refused(cli: Cli, tmp_path: Path, case: str) -> None:
    if case == "file of another user" and os.geteuid() != 0:
        pytest.skip("giving a file to another user needs root")
    marker = tmp_path / "imported"
    project = tmp_path / "project"
    project.mkdir()
    shutil.copy(CONFIGS / CONFIG, project / CONFIG)
    _planted(project / "plugins", marker)
    make, why = PLANTED[case]
    where = make(project / "plugins", marker)
    done = cli("validate", CONFIG, cwd=project)
    assert done.returncode == 2, done.stderr
    [line] = done.stderr.splitlines()
    assert line.startswith(f"error: {where}: {why}"), line
    assert "not imported" in line
    assert not marker.exists()


def test_a_link_to_a_file_of_the_same_folder_is_imported_once(cli: Cli, tmp_path: Path) -> None:
    counter = tmp_path / "count"
    (tmp_path / "plugins").mkdir()
    (tmp_path / "plugins" / "one.py").write_text(
        f"with open({str(counter)!r}, 'a') as f:\n    f.write('x')\n")
    (tmp_path / "plugins" / "two.py").symlink_to("one.py")
    shutil.copy(CONFIGS / CONFIG, tmp_path / CONFIG)
    done = cli("validate", CONFIG, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert counter.read_text() == "x"
    assert _imported_lines(done.stderr) == [f"plugins: imported one.py from {tmp_path / 'plugins'}"]


# --------------------------------------------------------------------------- every command names what it ran

TWIN = '''\
from stackx.registry import solvers
from stackx.solvers.column.pgs import PGS


@solvers.register("twin")
class Twin(PGS):
    """The lab solver under another name."""
'''


@pytest.fixture
def project(tmp_path: Path) -> Path:
    """``lab/configs/``: a config naming the local solver 'twin' from its own plugins/ folder, which holds a
    second file."""
    configs = tmp_path / "lab" / "configs"
    (configs / "plugins").mkdir(parents=True)
    (configs / "plugins" / "twin.py").write_text(TWIN)
    (configs / "plugins" / "aside.py").write_text("SEEN = True\n")
    (configs / CONFIG).write_text((CONFIGS / CONFIG).read_text().replace("name: pgs", "name: twin"))
    return configs


COMMANDS = {  # the command, and the run that makes the folder it checks (from the lab's parent folder)
    "run": (["run", CONFIG, "--out", "out", "-q"], None),
    "validate": (["validate", CONFIG], None),
    "bench": (["bench", CONFIG, "--solvers", "twin", "--out", "bench", "-q"], None),
    "plugins": (["plugins"], None),
    "schema": (["schema", "--out", "schema.json"], None),
    "verify": (["verify", "../../made", CONFIG], ["run", "lab/configs", "--out", "made", "-q"]),
    "verify --trust": (["verify", "..", "--trust"], ["run", "lab/configs", "--out", "lab", "-q"]),
}


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_names_the_plugin_files_it_imports_in_one_line(cli: Cli, project: Path, command: str) -> None:
    args, setup = COMMANDS[command]
    if setup is not None:
        made = cli(*setup, cwd=project.parents[1])
        assert made.returncode == 0, made.stderr
    done = cli(*args, cwd=project)
    assert done.returncode == 0, done.stdout + done.stderr
    assert _imported_lines(done.stderr) == [f"plugins: imported aside.py, twin.py from {project / 'plugins'}"]


def test_validate_says_it_imports_plugin_files(cli: Cli) -> None:
    done = cli("validate", "--help", env={"COLUMNS": "200"})
    assert done.returncode == 0
    text = " ".join(done.stdout.split())
    assert "imports the local plugin files the configs use" in text


# ------------------------------------------------------------------------------- outputs never become code

ATTACK = """\
scene: {{name: column, boxes: [{{y: 0.5}}]}}
solver: {{name: pgs}}
steps: 60
outputs:
  - sink: keyvalue
    path: {path}
    values:
      {key}: depth[0]
"""


def _attack(folder: Path, marker: Path, path: str = "plugins/zz_notes.py", key: str | None = None) -> Path:
    """``folder/configs/attack.yaml``: a keyvalue sink whose file would be a plugin that writes ``marker``."""
    (folder / "configs").mkdir(parents=True, exist_ok=True)
    key = key if key is not None else f'"import os; os.system(\'touch {marker}\'); depth"'
    config = folder / "configs" / "attack.yaml"
    config.write_text(ATTACK.format(path=path, key=key))
    return config


def test_a_config_cannot_write_the_plugin_the_next_command_imports(cli: Cli, tmp_path: Path) -> None:
    """The layout docs/outputs.md suggests, ``stackx run DIR/configs --out DIR``, with a keyvalue sink writing
    ``plugins/zz_notes.py`` whose key is code: refused at load, nothing written, nothing imported later."""
    marker = tmp_path / "PWNED"
    folder = tmp_path / "lab"
    _attack(folder, marker)
    done = cli("run", "lab/configs", "--out", "lab", "-q", cwd=tmp_path)
    assert done.returncode == 2
    [line] = done.stderr.splitlines()
    assert line.startswith("error: lab/configs/attack.yaml:8:"), line
    assert line.endswith("is not an identifier: letters, digits and _, not starting with a digit (e.g. max_depth)")
    assert sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*")) == ["configs", "configs/attack.yaml"]
    for command in (["validate", "configs"], ["run", "configs", "--out", ".", "-q"], ["plugins"], ["schema"]):
        cli(*command, cwd=folder)
    assert not marker.exists()


REFUSED_PATHS = {
    "plugins/zz_notes.py": "ends in '.py'",
    "notes.PY": "ends in '.py'",
    "deep/er/notes.pyc": "ends in '.pyc'",
    "zz.pth": "ends in '.pth'",
    "plugins/notes.txt": "is inside plugins/",
    "Plugins/notes.txt": "is inside plugins/",
}


@pytest.mark.parametrize("path", REFUSED_PATHS)
def test_an_output_path_that_could_be_code_is_refused_at_load(cli: Cli, tmp_path: Path, path: str) -> None:
    config = _attack(tmp_path, tmp_path / "PWNED", path=path, key="depth")
    done = cli("validate", config)
    assert done.returncode == 2
    assert done.stderr.startswith(f"error: {config}:6:11: outputs[0].path: {path!r} {REFUSED_PATHS[path]}")
    assert done.stderr.count("\n") == 1


def test_file_name_templates_are_checked_as_expanded(cli: Cli, tmp_path: Path) -> None:
    config = tmp_path / "frames.yaml"
    config.write_text(textwrap.dedent("""\
        scene: {name: column, boxes: [{y: 0.5}]}
        solver: {name: pgs}
        steps: 60
        outputs:
          - {render: frames, path: "f{index:02d}.pY", every: 15, count: 2}
        """))
    done = cli("validate", config)
    assert done.returncode == 2
    assert done.stderr.startswith(f"error: {config}:5:") and "'f00.pY' ends in '.py'" in done.stderr


def test_an_output_landing_in_a_plugin_folder_is_refused_before_anything_runs(cli: Cli, tmp_path: Path) -> None:
    """Checked against the real output folder: the configs' own plugins/ (which need not exist yet), and a
    folder named with --plugins."""
    config = _attack(tmp_path, tmp_path / "PWNED", path="configs/plugins/notes.txt", key="depth")
    done = cli("run", config, "--out", tmp_path, "-q")
    assert done.returncode == 2
    assert done.stderr.startswith(f"error: {config}:6:11: outputs[0].path: 'configs/plugins/notes.txt' would "
                                  f"land in {tmp_path / 'configs' / 'plugins'}, a plugin folder"), done.stderr
    assert not (tmp_path / "configs" / "plugins").exists()

    (tmp_path / "mine").mkdir()
    config.write_text(config.read_text().replace("configs/plugins/notes.txt", "notes.txt"))
    done = cli("run", config, "--plugins", tmp_path / "mine", "--out", tmp_path / "mine", "-q")
    assert done.returncode == 2
    assert "'notes.txt' would land in " + str(tmp_path / "mine") in done.stderr
    assert list((tmp_path / "mine").iterdir()) == []


def test_keyvalue_keys_are_identifiers(cli: Cli, tmp_path: Path) -> None:
    config = _attack(tmp_path, tmp_path / "PWNED", path="notes.txt", key='"2nd depth"')
    done = cli("validate", config)
    assert done.returncode == 2
    assert done.stderr == (f"error: {config}:8:20: outputs[0].values.2nd depth: key '2nd depth' is not an "
                           "identifier: letters, digits and _, not starting with a digit (e.g. max_depth)\n")
