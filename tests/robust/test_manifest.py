"""manifest.json: every artifact with its SHA-256; the same configs give the same manifest; verify re-runs it."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from stackx.cli import app
from tests.conftest import CONFIGS, REPO, Cli

VOLATILE = "timing.json"


def _cli(*args: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(app, list(args))
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exc_info
    return result.exit_code, result.stdout, result.stderr


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    outs = tmp_path_factory.mktemp("first") / "out", tmp_path_factory.mktemp("second") / "out"
    for out in outs:
        assert _cli("run", str(CONFIGS), "--out", str(out), "-q")[0] == 0
    return outs


def test_two_runs_give_the_same_manifest(two_runs: tuple[Path, Path]) -> None:
    first, second = (out / "manifest.json" for out in two_runs)
    assert hashlib.sha256(first.read_bytes()).hexdigest() == hashlib.sha256(second.read_bytes()).hexdigest()


def test_manifest_lists_every_artifact_with_its_hash(two_runs: tuple[Path, Path]) -> None:
    out = two_runs[0]
    doc = json.loads((out / "manifest.json").read_text())
    listed = {name: entry for exp in doc["experiments"].values() for name, entry in exp["artifacts"].items()}
    on_disk = {p.name for p in out.iterdir()} - {"manifest.json", VOLATILE}
    assert set(listed) == on_disk
    for name, entry in listed.items():
        data = (out / name).read_bytes()
        assert entry == {"sha256": hashlib.sha256(data).hexdigest(), "bytes": len(data)}, name
    assert VOLATILE in doc["volatile"]
    stack = doc["experiments"]["06-stack"]
    assert not Path(stack["config"]).is_absolute()  # as seen from the output folder: no checkout's place in it
    assert (out / stack["config"]).resolve() == (CONFIGS / "06-stack.yaml").resolve()
    assert stack["config_sha256"] == hashlib.sha256((CONFIGS / "06-stack.yaml").read_bytes()).hexdigest()
    run = stack["resolved"]["runs"][0]
    assert (run["solver"]["name"], run["solver"]["iterations"], run["steps"], run["dt"]) == ("pgs", 15, 900, 1 / 60)
    assert run["scene"]["stack"]["count"] == 5
    assert stack["plugins_used"]["solver:pgs"] == {"source": "built-in"}
    assert {"python", "numpy", "numba", "pydantic"} <= set(doc["versions"]) and doc["stackx"]


def test_verify_says_every_byte_is_identical(two_runs: tuple[Path, Path]) -> None:
    code, out, _ = _cli("verify", str(two_runs[0]), str(CONFIGS))
    assert code == 0, out
    digest = hashlib.sha256((two_runs[0] / "manifest.json").read_bytes()).hexdigest()
    assert f"every byte identical to {two_runs[0] / 'manifest.json'} (sha256 {digest})" in out


def test_verify_names_a_changed_byte(two_runs: tuple[Path, Path], tmp_path: Path) -> None:
    copy = tmp_path / "out"
    shutil.copytree(two_runs[1], copy)
    frame = bytearray((copy / "f05.png").read_bytes())
    frame[77] ^= 0x01
    (copy / "f05.png").write_bytes(bytes(frame))
    code, out, _ = _cli("verify", str(copy), str(CONFIGS))
    assert code == 1
    assert "DIFF 06-stack: f05.png: the file on disk differs from the manifest (changed after the run); against " \
           f"the re-run: first different byte at offset 77 ({len(frame)} bytes against {len(frame)})" in out
    assert "verify: 1 difference(s)" in out


def test_a_later_run_merges_into_the_manifest_and_verify_replays_its_overrides(two_runs: tuple[Path, Path],
                                                                               tmp_path: Path) -> None:
    out = tmp_path / "out"
    shutil.copytree(two_runs[0], out)
    before = json.loads((out / "manifest.json").read_text())["experiments"]
    code, _, err = _cli("run", str(CONFIGS / "06-stack.yaml"), "--out", str(out), "-q",
                        "--set", "solver.iterations=4")
    assert code == 0, err
    after = json.loads((out / "manifest.json").read_text())["experiments"]
    assert {k: v for k, v in after.items() if k != "06-stack"} == {k: v for k, v in before.items() if k != "06-stack"}
    assert after["06-stack"]["sets"] == ["solver.iterations=4"]
    assert after["06-stack"]["resolved"]["runs"][0]["solver"]["iterations"] == 4
    assert after["06-stack"]["artifacts"]["stack.png"] != before["06-stack"]["artifacts"]["stack.png"]
    code, text, _ = _cli("verify", str(out), str(CONFIGS))
    assert code == 0, text


def test_verify_reports_a_config_edited_since_the_run(tmp_path: Path) -> None:
    config = tmp_path / "sink.yaml"
    config.write_text((CONFIGS / "03-sink.yaml").read_text().replace("path: 03-sink", "path: sink"))
    out = tmp_path / "out"
    assert _cli("run", str(config), "--out", str(out), "-q")[0] == 0
    config.write_text(config.read_text().replace("steps: 600", "steps: 300"))
    code, text, _ = _cli("verify", str(out), str(config))
    assert code == 1
    assert f"note sink: {config} has changed since the run" in text
    # the metrics hold the number of steps, so they must differ (the final depth may not: the box has settled)
    assert "DIFF sink: sink.metrics.json: the re-run differs from the manifest; against the file on disk: first " \
           "different byte at offset" in text
    assert "DIFF sink: resolved: the re-run's differs from the manifest's" in text


def test_verify_without_a_manifest_is_a_usage_error(tmp_path: Path) -> None:
    code, _, err = _cli("verify", str(tmp_path))
    assert code == 2 and "no manifest.json here" in err


def test_two_checkouts_give_the_same_manifest_and_verify_from_anywhere(cli: Cli, tmp_path: Path) -> None:
    """Paths are recorded from the output folder: the same configs in two folders (at different depths) give
    the same manifest, byte for byte, and verify re-makes it from the named configs from any working folder,
    also after the whole checkout moved."""
    checkouts = [tmp_path / "one", tmp_path / "deeper" / "two"]
    for root in checkouts:
        (root / "configs").mkdir(parents=True)
        for name in ("03-sink.yaml", "06-stack.yaml"):
            shutil.copy(CONFIGS / name, root / "configs" / name)
        shutil.copytree(REPO / "plugins", root / "plugins")  # the nearest plugins/ folder is recorded too
        done = cli("run", "configs", "--out", "out", "-q", cwd=root)
        assert done.returncode == 0, done.stderr
    first, second = ((root / "out" / "manifest.json").read_bytes() for root in checkouts)
    assert first == second
    moved = tmp_path / "moved"
    checkouts[0].rename(moved)
    done = cli("verify", moved / "out", moved / "configs", cwd=tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "every byte identical" in done.stdout


def test_verify_runs_only_the_named_configs_and_checks_the_other_files_on_disk(two_runs: tuple[Path, Path],
                                                                               tmp_path: Path) -> None:
    out = tmp_path / "out"
    shutil.copytree(two_runs[0], out)
    code, _, err = _cli("verify", str(out))
    assert code == 2 and len(err.splitlines()) == 1, err  # a long folder name is cut in its later mentions
    assert err.startswith(f"error: {out}: name the configs to run again (e.g. 'stackx verify ") and "configs/'" in err
    code, text, _ = _cli("verify", str(out), str(CONFIGS / "06-stack.yaml"))
    assert code == 0, text
    assert "ok   06-stack: 16 artifact(s) identical" in text and text.count("ok   ") == 1
    recorded = json.loads((out / "manifest.json").read_text())["experiments"]["03-sink"]["config"]
    assert f'skip 03-sink: not run again, its config was not named (the manifest records "{recorded}"); 2 of 2 ' \
           "file(s) on disk as listed" in text
    assert "verify: 1 experiment(s) of 5 (4 not named), 16 artifact(s): every byte identical" in text
    (out / "03-sink.txt").write_text("depth_final=0\n")
    code, text, _ = _cli("verify", str(out), str(CONFIGS / "06-stack.yaml"))
    assert code == 1
    assert "DIFF 03-sink: 03-sink.txt: the file on disk differs from the manifest (changed after the run)" in text
