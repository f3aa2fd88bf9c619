"""``python -m benchmarks.planar_outcomes``: every planar case against every solver at its defaults, judged by
the bench's criteria, without the reference solve.

``stackx bench configs/planar/`` also solves every step's reference problem and times every knob value, which
takes an hour on the planar cases with pyramid-20; this asks only what the matrix's cells ask, whether each
solver at its default settings meets the case's outcome (holds, settled, never launched, and where the case
says so: slides at g (sin a - mu cos a), lands on a face, topples), in seconds to minutes. Each config runs
with its solver section replaced by ``{name: SOLVER}`` (so a config's own tuning and its ``bench.set`` are not
applied) and without outputs. Printed: a markdown table, one row per case, ``pass`` or the failing measures.
"""

from __future__ import annotations

import argparse
import re
import warnings
from pathlib import Path

from stackx.config.experiment import load
from stackx.bench.criteria import Criteria, judge
from stackx.models.planar import measures
from stackx.run.runner import run_experiment

SOLVERS = ("pymunk", "box2d", "box2d-v3", "mujoco", "planar-pgs", "planar-warm-start", "planar-ngs",
           "planar-soft-step", "planar-xpbd")


def outcome(config: Path, solver: str) -> str:
    """``pass``, or ``FAIL`` and the measures that failed, for ``solver`` at its defaults on ``config``."""
    result = run_experiment(load(str(config), [f"solver={{name: {solver}}}", "outputs=[]"])).runs[0]
    found = {**result.measures, **measures.bench_measures(result)}
    verdicts = judge(found, Criteria(), measures.unjudged(result.spec.scene))
    failed = [c.measure.strip("|") for v in verdicts.values() for c in v.checks if not c.passed]
    return "pass" if not failed else "FAIL " + ", ".join(failed)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("configs", nargs="*", default=["configs/planar"], help="configs or folders of them")
    parser.add_argument("--solvers", default=",".join(SOLVERS), help="comma-separated solver names")
    args = parser.parse_args()
    paths = [p for c in map(Path, args.configs) for p in (sorted(c.glob("*.yaml")) if c.is_dir() else [c])]
    solvers = args.solvers.split(",")
    print("| case | " + " | ".join(re.sub("^planar-", "", s) for s in solvers) + " |")
    print("|---" * (len(solvers) + 1) + "|")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # pybox2d's SWIG types, on import
        for path in paths:
            print(f"| {path.stem} | " + " | ".join(outcome(path, s) for s in solvers) + " |", flush=True)


if __name__ == "__main__":
    main()
