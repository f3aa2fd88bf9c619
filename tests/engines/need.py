"""Which engines can run here: tests that need one that is not installed are skipped, saying how to install it."""

from __future__ import annotations

from typing import Any

import pytest

from stackx import registry

ENGINES = ("pymunk", "box2d", "box2d-v3", "mujoco")


def missing(name: str) -> str | None:
    """Why the engine solver ``name`` cannot run here (with the install command), or None."""
    return registry.unavailable(registry.solvers.get(name))


def engine_params() -> list[Any]:
    """The engines as pytest parameters, each skipped with its reason when it is not installed."""
    return [pytest.param(n, marks=pytest.mark.skip(reason=why)) if (why := missing(n)) else n for n in ENGINES]
