"""verify reads the folder's own JSON as untrusted data, and names every file its manifest does not know."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from tests.conftest import CONFIGS, Cli

CONFIG = CONFIGS / "06-stack.yaml"


@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from tests.conftest import run_cli

    out = tmp_path_factory.mktemp("made") / "out"
    done = run_cli("run", CONFIG, "--out", out, "-q")
    assert done.returncode == 0, done.stderr
    return out


@pytest.fixture
def copy(made: Path, tmp_path: Path) -> Path:
    out = tmp_path / "out"
    shutil.copytree(made, out)
    return out


def test_stray_files_are_listed_and_count_as_differences(cli: Cli, copy: Path) -> None:
    done = cli("verify", copy, CONFIG)
    assert done.returncode == 0, done.stdout + done.stderr
    frames = sorted(p.name for p in copy.iterdir() if p.name.startswith("f") and p.suffix == ".png")
    assert frames
    extra = [f"f{len(frames) + i:02d}.png" for i in range(3)]  # frames an older, longer run left behind
    for name in extra:
        shutil.copy(copy / frames[0], copy / name)
    (copy / "old").mkdir()
    (copy / "old" / "notes.txt").write_text("kept by hand")
    (copy / "06-stack.failed.json").write_text("{}")  # a failed run's record is the folder's own, not a stray
    done = cli("verify", copy, CONFIG)
    assert done.returncode == 1
    listed = [line for line in done.stdout.splitlines() if line.startswith("DIFF stray: ")]
    assert listed == [f"DIFF stray: {name}: in {copy} but not in its manifest (left by another run, or put there)"
                      for name in [*extra, "old/notes.txt"]]
    assert f"verify: 4 difference(s) in {copy}" in done.stdout


@pytest.mark.parametrize("name", ["manifest.json", "timing.json"])
@pytest.mark.parametrize("depth", [100_000, 500])
def test_deeply_nested_json_is_one_line(cli: Cli, copy: Path, name: str, depth: int) -> None:
    (copy / name).write_text("[" * depth + "]" * depth)
    verified = cli("verify", copy, CONFIG)
    again = cli("run", CONFIG, "--out", copy, "-q")
    for done in (verified, again):
        assert "Traceback" not in done.stderr and "RecursionError" not in done.stderr
    if name == "manifest.json":
        for done in (verified, again):
            assert done.returncode == 2
            assert done.stderr.strip() == f"error: {copy / name}: not a readable stackx manifest (nested deeper " \
                                          f"than 64 levels); move it away to start a new one"
    else:  # wall-clock times are not verified; a run rebuilds a timing file it cannot read
        assert verified.returncode == 0, verified.stdout
        assert again.returncode == 0, again.stderr
        assert (copy / name).read_text().startswith('{\n  "06-stack"')
