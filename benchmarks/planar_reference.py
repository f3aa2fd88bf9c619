"""``python -m benchmarks.planar_reference``: what the planar reference solve costs per step of a pyramid.

The bench solves one reference problem per step of every planar run (``stackx.models.planar.error``), so its
cost decides how long a planar bench takes. For pyramids of 10 and 20 rows (the scene's ``pyramid``
generator), two runs of ``steps`` steps: ``planar-exact`` (a pile held at rest: the reference's own path) and
``planar-pgs`` at 10 iterations (a pile that sags and slides: the hard path), each watched by the planar step
log. Printed per case: the median and the largest time per reference solve, Newton rounds and sweeps per
solve, and steps the reference could not solve; per pyramid, the ratio of the median solve on the sagging
path to that on the held path, both measured in this one run.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from stackx.config import load
from stackx.criteria import Criteria
from stackx.kernel import compiled
from stackx.models.planar import step_problem
from stackx.models.planar.error import StepLog
from stackx.registry import solvers
from stackx.runner import run_experiment


def measure(rows: int, steps: int, solver: str) -> dict[str, float]:
    """Time every reference solve of a ``solver`` run of a ``rows``-row pyramid, and the run's own steps."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "pyramid.yaml"
        path.write_text(f"scene: {{name: planar, pyramid: {{rows: {rows}}}}}\nsolver: {{name: {solver}}}\n"
                        f"dt: 1/60\nsteps: {steps}\n")
        spec = load(str(path))
    cls = solvers.get(solver)
    params = cls.Params(iterations=10) if solver == "planar-pgs" else cls.Params()
    spec.runs = [replace(spec.runs[0], solver_params=params)]
    solves: list[float] = []
    work: list[tuple[int, int]] = []
    plain = step_problem.ReferenceStep._solve

    def timed(self: step_problem.ReferenceStep, *args: object) -> object:
        t0 = time.perf_counter()
        found = plain(self, *args)  # type: ignore[arg-type]
        solves.append(time.perf_counter() - t0)
        work.append((found.rounds, found.sweeps))
        return found

    step_problem.ReferenceStep._solve = timed  # type: ignore[method-assign]
    try:
        log = StepLog(Criteria())
        t0 = time.perf_counter()
        with compiled(True):
            run_experiment(spec, None, log)
        total = time.perf_counter() - t0
    finally:
        step_problem.ReferenceStep._solve = plain  # type: ignore[method-assign]
    (row,) = log.rows.values()
    timed_solves = solves[1:] or solves  # the first includes loading compiled code
    return {"median_ms": 1e3 * statistics.median(timed_solves), "max_ms": 1e3 * max(timed_solves),
            "rounds": statistics.mean(r for r, _ in work), "sweeps": statistics.mean(s for _, s in work),
            "unsolved": row.error()["unsolved"], "solves": len(solves), "run_s": total}


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.planar_reference", description=__doc__)
    parser.add_argument("--steps", type=int, default=60, help="steps per run")
    parser.add_argument("--rows", type=int, nargs="+", default=[10, 20], help="pyramid sizes")
    args = parser.parse_args()
    print(f"{'case':<28}{'ms/solve':>10}{'max ms':>10}{'rounds':>8}{'sweeps':>8}{'unsolved':>10}"
          )
    for rows in args.rows:
        medians = []
        for solver in ("planar-exact", "planar-pgs"):
            m = measure(rows, args.steps, solver)
            medians.append(m["median_ms"])
            print(f"{f'pyramid-{rows} {solver}':<28}{m['median_ms']:>10.1f}{m['max_ms']:>10.1f}"
                  f"{m['rounds']:>8.1f}{m['sweeps']:>8.0f}{m['unsolved']:>10d}")
        print(f"pyramid-{rows}: a solve on the sagging path costs {medians[1] / medians[0]:.0f}x one on the held path")


if __name__ == "__main__":
    main()
