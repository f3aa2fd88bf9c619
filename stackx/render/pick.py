"""Choosing which run and which recorded state a renderer draws."""

from __future__ import annotations

from stackx.config.spec import Plan
from stackx.errors import Fail


def run_name(spec: Plan, wanted: str | None, fail: Fail) -> str:
    """``wanted``, or the only run; an experiment with several runs must name one."""
    names = [r.name for r in spec.runs]
    if wanted is None:
        if len(names) != 1:
            raise fail(("run",), f"this experiment has several runs; name one: {', '.join(names)}")
        return names[0]
    if wanted not in names:
        raise fail(("run",), f"unknown run {wanted!r}; runs: {', '.join(names)}")
    return wanted
