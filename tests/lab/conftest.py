"""Fixtures that run the stackx CLI on the lab configs, each run into its own fresh folder."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _run_lab(out: Path) -> Path:
    command = [sys.executable, "-m", "stackx", "run", str(REPO / "configs"), "--out", str(out)]
    subprocess.run(command, check=True, cwd=REPO)
    return out


@pytest.fixture(scope="session")
def lab_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The output folder of one full lab run, shared by every artifact test."""
    return _run_lab(tmp_path_factory.mktemp("lab-out"))


@pytest.fixture(scope="session")
def lab_out_again(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A second, separate lab run, to show the output does not depend on the run."""
    return _run_lab(tmp_path_factory.mktemp("lab-out-again"))
