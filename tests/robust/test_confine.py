"""Output paths stay inside the output folder; links and files in the way are refused before anything runs."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from stackx.cli import app

CONFIG = """\
scene: {{name: column, boxes: [{{y: 0.5}}]}}
solver: {{name: pgs}}
steps: 60
outputs:
  - sink: metrics
    path: {path}
"""


def _run(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, ["run", *args, "-q"])
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exc_info
    return result.exit_code, result.stderr


def _write(folder: Path, name: str, path: str) -> Path:
    config = folder / name
    config.write_text(CONFIG.format(path=path))
    return config


@pytest.mark.parametrize("path", ["../up.json", "/tmp/abs.json", "a/../../up.json", ".hidden.json",
                                  "manifest.json"])
def test_paths_leaving_the_folder_are_refused_at_load(tmp_path: Path, path: str) -> None:
    config = _write(tmp_path, "bad.yaml", path)
    code, err = _run(str(config), "--out", str(tmp_path / "out"))
    assert code == 2
    assert err.startswith(f"error: {config}:6:11: outputs[0].path: "), err  # line 6, column of the value
    assert not (tmp_path / "out").exists() and not (tmp_path / "up.json").exists()


def test_a_link_in_the_output_folder_is_refused_before_any_experiment_runs(tmp_path: Path) -> None:
    outside, out = tmp_path / "outside", tmp_path / "out"
    outside.mkdir()
    out.mkdir()
    (out / "sub").symlink_to(outside, target_is_directory=True)
    first = _write(tmp_path, "a.yaml", "a.json")  # would run first and write, if the check came late
    second = _write(tmp_path, "b.yaml", "sub/b.json")
    code, err = _run(str(first), str(second), "--out", str(out))
    assert code == 2
    assert re.match(rf"error: {re.escape(str(second))}:6:11: outputs\[0\]\.path: 'sub/b.json': .*sub is a link", err)
    assert sorted(p.name for p in out.iterdir()) == ["sub"] and not any(outside.iterdir())


def test_a_linked_file_is_not_written_through(tmp_path: Path) -> None:
    target, out = tmp_path / "precious.json", tmp_path / "out"
    target.write_text("keep me")
    out.mkdir()
    (out / "a.json").symlink_to(target)
    code, err = _run(str(_write(tmp_path, "a.yaml", "a.json")), "--out", str(out))
    assert code == 2 and "is a link" in err
    assert target.read_text() == "keep me"


def test_an_output_folder_that_is_a_file_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.write_text("not a folder")
    code, err = _run(str(_write(tmp_path, "a.yaml", "a.json")), "--out", str(out))
    assert code == 2 and err.strip() == f"error: {out}: the output folder is a file"
    assert out.read_text() == "not a folder"
