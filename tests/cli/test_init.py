"""``stackx init``: the shipped configs and plugin written into a folder, never over anything."""

from __future__ import annotations

from pathlib import Path

from tests.conftest import REPO, Cli


def _repository_files() -> dict[str, bytes]:
    """What a folder made by init must hold: every config and plugin of the repository, found by globbing."""
    paths = [*REPO.glob("configs/**/*.yaml"), *REPO.glob("plugins/*.py")]
    return {p.relative_to(REPO).as_posix(): p.read_bytes() for p in paths}


def _tree(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in root.rglob("*") if p.is_file()}


def test_init_writes_the_repository_configs_and_plugin(cli: Cli, tmp_path: Path) -> None:
    done = cli("init", "lab", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    expected = _repository_files()
    assert {"configs/06-stack.yaml", "configs/hard/tall-20.yaml", "configs/examples/sor-stack.yaml",
            "plugins/sor.py"} <= set(expected)
    assert _tree(tmp_path / "lab") == expected
    assert done.stdout.splitlines()[0] == f"wrote {len(expected)} files into lab:"
    assert done.stdout.splitlines()[-1] == "run the lab: stackx run lab/configs/"


def test_the_example_finds_its_plugin_in_the_new_folder(cli: Cli, tmp_path: Path) -> None:
    """``configs/examples/sor-stack.yaml`` names the local solver 'sor': init ships it in ``plugins/``, which the
    example's documented command names with ``--plugins`` (a folder above a config is never imported by itself)."""
    assert cli("init", cwd=tmp_path).returncode == 0
    done = cli("validate", "configs/examples/", "--plugins", "plugins", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok  configs/examples/sor-stack.yaml: 2 run(s), 2 output(s)"


def test_init_refuses_to_overwrite_and_writes_nothing(cli: Cli, tmp_path: Path) -> None:
    mine = tmp_path / "lab" / "configs" / "06-stack.yaml"
    mine.parent.mkdir(parents=True)
    mine.write_text("my own stack\n")
    done = cli("init", "lab", cwd=tmp_path)
    assert done.returncode == 2
    assert done.stdout == ""
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("error: lab: lab/configs/06-stack.yaml already exists;")
    assert "never overwrites" in lines[0]
    assert _tree(tmp_path / "lab") == {"configs/06-stack.yaml": b"my own stack\n"}


def test_a_second_init_counts_what_is_in_the_way(cli: Cli, tmp_path: Path) -> None:
    assert cli("init", "lab", cwd=tmp_path).returncode == 0
    before = _tree(tmp_path / "lab")
    done = cli("init", "lab", cwd=tmp_path)
    assert done.returncode == 2
    assert f"(and {len(before) - 1} more)" in done.stderr
    assert _tree(tmp_path / "lab") == before


def test_init_refuses_a_file_in_the_way(cli: Cli, tmp_path: Path) -> None:
    (tmp_path / "lab").mkdir()
    (tmp_path / "lab" / "plugins").write_text("not a folder\n")
    done = cli("init", "lab", cwd=tmp_path)
    assert done.returncode == 2
    assert "lab/plugins is a file, not a folder" in done.stderr
    assert _tree(tmp_path / "lab") == {"plugins": b"not a folder\n"}

    (tmp_path / "taken").write_text("x\n")
    done = cli("init", "taken", cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr.strip() == ("error: taken: not a folder: stackx init writes configs/ and plugins/ "
                                   "into a folder")
