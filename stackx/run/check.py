"""``stackx run --check``: a run whose verdict is FAIL fails the command (exit code 1).

Without ``--check`` a verdict is a finding, not an error: the run table says FAIL and what failed, the
artifacts are written, and the command exits 0, as it does for a lab run that sinks on purpose. A CI job
that states what must hold (a ``bench:`` section, or a scene that places boxes at rest) asks for ``--check``
and gets exit code 1 when it does not hold. The artifacts are written either way: a failing run's numbers
are what a user needs to see why.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from stackx.errors import RunError


def verdicts(results: Iterable[Any]) -> dict[str, bool]:
    """``experiment/run`` -> passed, for every run whose config states what must hold (``session.verdict``)."""
    from stackx.run.session import verdict

    found = {}
    for result in results:
        bench = getattr(result.spec, "bench", None)
        for run in result.runs:
            judged = verdict(run, bench)
            if judged is not None:
                found[f"{result.spec.name}/{run.name}"] = judged[0]
    return found


def check(results: Iterable[Any]) -> str:
    """Raise ``RunError`` naming the runs whose verdict is FAIL; else return a note when no run was judged
    (``--check`` then checked nothing, which a CI user should hear), or an empty string."""
    found = verdicts(results)
    failed = [name for name, passed in found.items() if not passed]
    if failed:
        shown = ", ".join(failed[:5]) + (f" and {len(failed) - 5} more" if len(failed) > 5 else "")
        raise RunError(f"--check: verdict FAIL for {len(failed)} of {len(found)} judged run"
                       f"{'s' if len(found) > 1 else ''}: {shown} (the run table says what failed)")
    if not found:
        return ("--check: no run states what must hold (a bench: section, or a scene that places boxes at rest "
                "or on a ramp): nothing was judged")
    return ""
