"""verify runs only what the user names: a tampered manifest imports nothing and writes nothing.

Every case starts from a self-contained folder made by ``stackx run DIR/configs --out DIR`` (its configs and their
empty ``plugins/`` folder, ``DIR/configs/plugins``, inside it), then edits its manifest the way someone sending it
could. A planted
plugin file writes a marker file when imported; verify runs in a subprocess, so an import anywhere shows as
the marker, and every file under the test's temporary folder is compared before and after.
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from typer.testing import CliRunner

from stackx.cli import app
from tests.conftest import CONFIGS, Cli

CONFIG = "03-sink.yaml"


@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding its configs, their (empty) plugin folder and what ``stackx run`` made from them."""
    bundle = tmp_path_factory.mktemp("made") / "bundle"
    (bundle / "configs" / "plugins").mkdir(parents=True)
    shutil.copy(CONFIGS / CONFIG, bundle / "configs" / CONFIG)
    result = CliRunner().invoke(app, ["run", str(bundle / "configs"), "--out", str(bundle), "-q"])
    assert result.exit_code == 0, result.output
    entry = json.loads((bundle / "manifest.json").read_text())["experiments"]["03-sink"]
    assert (entry["config"], entry["plugins"]) == ("configs/03-sink.yaml", "configs/plugins")
    return bundle


def _planted(folder: Path, marker: Path) -> Path:
    """A plugin file that writes ``marker`` when it is imported."""
    folder.mkdir(parents=True, exist_ok=True)
    plugin = folder / "planted.py"
    plugin.write_text(f"from pathlib import Path\nPath({str(marker)!r}).write_text('imported')\n")
    return plugin


def _tree(root: Path) -> dict[str, tuple[int, int]]:
    """Every file and link under ``root``: size and modification time, to see that nothing was written."""
    out = {}
    for folder, dirs, files in os.walk(root):
        for name in dirs + files:
            stat = (Path(folder) / name).lstat()
            out[os.path.relpath(Path(folder) / name, root)] = (stat.st_size, stat.st_mtime_ns)
    return out


@pytest.fixture
def place(made: Path, tmp_path: Path) -> tuple[Path, Path, Path]:
    """A copy of the made folder, and beside it ``elsewhere/``: a config and a plugin folder with a planted
    plugin, as someone would leave them for a tampered manifest to name; and where the marker would go."""
    bundle = tmp_path / "bundle"
    shutil.copytree(made, bundle)
    elsewhere = tmp_path / "elsewhere"
    _planted(elsewhere / "plugins", tmp_path / "imported")
    shutil.copy(CONFIGS / CONFIG, elsewhere / CONFIG)
    return bundle, elsewhere, tmp_path / "imported"


def _tamper(bundle: Path, **fields: str) -> None:
    path = bundle / "manifest.json"
    doc = json.loads(path.read_text())
    doc["experiments"]["03-sink"].update(fields)
    path.write_text(json.dumps(doc))


def _link_configs_elsewhere(bundle: Path, elsewhere: Path) -> None:
    shutil.rmtree(bundle / "configs")
    (bundle / "configs").symlink_to(elsewhere, target_is_directory=True)


TAMPERED: dict[str, tuple[str, Callable[[Path, Path], None], str]] = {
    "absolute config": ("config", lambda b, e: _tamper(b, config=str(e / CONFIG)), "is an absolute path"),
    "escaping config": ("config", lambda b, e: _tamper(b, config=f"../elsewhere/{CONFIG}"), "climbs out with '..'"),
    "config through a link": ("config", _link_configs_elsewhere, "leads out through a link, to "),
    "plugin folder elsewhere": ("plugins", lambda b, e: _tamper(b, plugins=str(e / "plugins")),
                                "is an absolute path"),
    "escaping plugin folder": ("plugins", lambda b, e: _tamper(b, plugins="../elsewhere/plugins"),
                               "climbs out with '..'"),
}


@pytest.mark.parametrize("case", TAMPERED)
def test_trust_refuses_a_path_leading_out_before_importing_anything(cli: Cli, place: tuple[Path, Path, Path],
                                                                    case: str) -> None:
    bundle, elsewhere, marker = place
    field, tamper, why = TAMPERED[case]
    tamper(bundle, elsewhere)
    before = _tree(bundle.parent)
    done = cli("verify", "bundle", "--trust", cwd=bundle.parent)  # named short: the line is not cut to fit
    assert done.returncode == 2, done.stdout + done.stderr
    assert done.stdout == ""  # nothing listed, nothing run
    assert done.stderr.count("\n") == 1
    assert done.stderr.startswith(f"error: bundle/manifest.json: experiments.03-sink.{field}: "), done.stderr
    assert why in done.stderr  # the line may be cut in its middle to fit: its end is kept
    assert done.stderr.endswith("name the configs instead (stackx verify bundle CONFIG...)\n"), done.stderr
    assert not marker.exists()
    assert _tree(bundle.parent) == before


def test_named_configs_ignore_every_path_the_manifest_names(cli: Cli, place: tuple[Path, Path, Path]) -> None:
    """Absolute config, plugin folder elsewhere, a plugin planted in the folder's configs/plugins/: verify of a
    named config imports none of them, writes nothing, finds every artifact identical, and names the files
    in the folder that the manifest no longer accounts for."""
    bundle, elsewhere, marker = place
    _tamper(bundle, config=str(elsewhere / CONFIG), plugins=str(elsewhere / "plugins"))
    _planted(bundle / "configs" / "plugins", marker)
    mine = bundle.parent / "mine"
    mine.mkdir()
    shutil.copy(CONFIGS / CONFIG, mine / CONFIG)
    before = _tree(bundle.parent)
    done = cli("verify", bundle, mine / CONFIG, cwd=bundle.parent)
    assert f"run  03-sink: {mine / CONFIG} (no local plugins)" in done.stdout
    assert "ok   03-sink: 2 artifact(s) identical" in done.stdout
    # the folder's own config and the planted plugin are files its (tampered) manifest no longer knows
    assert [line.split(":")[1].strip() for line in done.stdout.splitlines() if line.startswith("DIFF")] == \
           ["configs/03-sink.yaml", "configs/plugins/planted.py"]
    assert done.returncode == 1 and f"verify: 2 difference(s) in {bundle}" in done.stdout
    assert not marker.exists()
    assert _tree(bundle.parent) == before


def test_a_named_config_inside_the_folder_does_not_import_its_plugins(cli: Cli,
                                                                       place: tuple[Path, Path, Path]) -> None:
    bundle, _, marker = place
    _planted(bundle / "configs" / "plugins", marker)
    before = _tree(bundle.parent)
    done = cli("verify", "bundle", "bundle/configs", cwd=bundle.parent)
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr == (f"error: bundle/configs/{CONFIG}: its plugins/ folder, {bundle / 'configs' / 'plugins'}, "
                           "lies inside bundle, the folder being verified: name it with --plugins to import it, or "
                           "use --trust\n")
    assert not marker.exists()
    assert _tree(bundle.parent) == before


def test_trust_lists_what_it_imports_then_imports_it(cli: Cli, place: tuple[Path, Path, Path]) -> None:
    """The planted plugin works (it writes its marker when imported), and --trust names it before it runs."""
    bundle, _, marker = place
    _planted(bundle / "configs" / "plugins", marker)
    done = cli("verify", bundle, "--trust", cwd=bundle.parent)
    assert done.returncode == 0, done.stdout + done.stderr
    lines = done.stdout.splitlines()
    folder = bundle / "configs" / "plugins"
    listed = f"run  03-sink: {bundle / 'configs' / CONFIG} (local plugins {folder}: planted.py)"
    assert lines[:2] == [f"trust: running what {bundle}/manifest.json records inside {bundle}:", listed]
    assert "every byte identical" in lines[-1]
    assert done.stderr == f"plugins: imported planted.py from {folder}\n"
    assert marker.read_text() == "imported"


def test_trust_neither_imports_nor_refuses_a_plugins_folder_above_the_configs(cli: Cli,
                                                                             place: tuple[Path, Path, Path]) -> None:
    """``plugins/`` beside ``configs/`` (above the configs' own folder) is not where their plugins come from: not
    imported, not a reason to refuse; it is a file the manifest does not know, the one difference."""
    bundle, _, marker = place
    _planted(bundle / "plugins", marker)
    done = cli("verify", bundle, "--trust", cwd=bundle.parent)
    assert f"(local plugins {bundle / 'configs' / 'plugins'}: no *.py files)" in done.stdout
    assert [line for line in done.stdout.splitlines() if line.startswith("DIFF")] == \
           [f"DIFF stray: plugins/planted.py: in {bundle} but not in its manifest (left by another run, or put there)"]
    assert done.returncode == 1 and done.stderr == ""
    assert not marker.exists()


def test_a_named_config_below_a_planted_plugins_folder_does_not_import_it(cli: Cli,
                                                                          place: tuple[Path, Path, Path]) -> None:
    """A config three folders below a ``plugins/`` folder someone left: verify runs it without importing it."""
    bundle, _, marker = place
    _planted(bundle.parent / "shared" / "plugins", marker)
    deep = bundle.parent / "shared" / "a" / "b" / "c"
    deep.mkdir(parents=True)
    shutil.copy(CONFIGS / CONFIG, deep / CONFIG)
    done = cli("verify", bundle, deep / CONFIG, cwd=deep)
    assert f"run  03-sink: {deep / CONFIG} (no local plugins)" in done.stdout
    assert "ok   03-sink: 2 artifact(s) identical" in done.stdout
    assert done.returncode == 0 and done.stderr == "" and not marker.exists()
