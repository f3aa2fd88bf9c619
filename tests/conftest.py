"""Shared fixtures: the repository root and a way to run the real ``stackx`` command."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
CONFIGS = REPO / "configs"

Cli = Callable[..., subprocess.CompletedProcess[str]]


def run_cli(*args: object, cwd: Path = REPO, env: dict[str, str] | None = None,
            timeout: float = 120) -> subprocess.CompletedProcess[str]:
    """Run ``python -m stackx ARGS`` in a subprocess and return the completed process (text output). The
    package is this checkout's, from any working folder (not whichever copy is installed)."""
    path = os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p)
    return subprocess.run([sys.executable, "-m", "stackx", *map(str, args)], cwd=cwd, capture_output=True,
                          text=True, timeout=timeout, env={**os.environ, "PYTHONPATH": path, **(env or {})})


@pytest.fixture
def cli() -> Cli:
    """``run_cli`` as a fixture."""
    return run_cli
