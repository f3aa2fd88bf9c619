"""``python -m benchmarks.planar_answers``: how often a planar step has several exact answers the reference can
land on, beside the error the bench measures against one of them.

With friction a step's contact problem can have more than one exact answer, with different velocities
(``tests/planar/test_answers.py``: three on a shaking 20-row pyramid, up to 3.6e-2 m/s apart). The bench's
reference gives the one its solve reaches from its own last answer. Per ``--run CONFIG SOLVER KNOB``
(repeatable; a run as ``stackx bench`` runs it, KNOB ``-`` the config's value), every step the step log
solves is solved a second time from zero impulses, and the two answers' velocities are compared as the error
is (each box's speed difference, its turn counted at the box's half diagonal; the largest box). Printed per
run: the steps compared (both solves landed), those whose two answers differ by more than 1e-6 and 1e-3
m/s, the largest difference, the steps the second solve missed, and the run's RMS error and unsolved steps
from the step log. Where the differences stay far below the error, the reference's choice among answers does
not move the run's figure.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

APART = (1e-6, 1e-3)  # m/s: the differences between two answers the table counts


def compare(path: str, steps: int, solver: str, knob: int | None) -> dict[str, Any]:
    """One run's steps solved twice (the step log's solve, then from zero impulses): the largest velocity
    difference per step compared, the second solves that missed, and the step log's error figures."""
    from benchmarks.planar_reference import load_run
    from stackx.bench.criteria import Criteria
    from stackx.kernel import compiled
    from stackx.solvers.planar import reference, step_problem
    from stackx.bench import error_planar
    from stackx.bench.error_planar import StepLog, box_speeds
    from stackx.models.planar.measures import half_diagonal
    from stackx.solvers.planar.problem import ContactProblem
    from stackx.run.runner import run_experiment

    spec = load_run(path, steps, solver, knob)
    plain = step_problem.solve
    apart: list[float] = []
    missed = 0
    radius = half_diagonal(spec.runs[0].scene.build())[0]  # each box's turn counted at its half diagonal

    def twice(problem: ContactProblem, pn: np.ndarray, pt: np.ndarray, **kwargs: Any) -> reference.Solution:
        nonlocal missed
        found = plain(problem, pn, pt, **kwargs)
        try:
            again = plain(problem, None, None)
        except reference.ReferenceFailure:
            missed += 1
            return found
        d = again.velocity - found.velocity
        if d.shape[0] != radius.shape[0]:  # a scene event took a box out: the boxes are renumbered
            return found
        moving = problem.inv_mass > 0.0
        apart.append(float(box_speeds(d[:, 0], d[:, 1], d[:, 2], radius)[moving].max(initial=0.0)))
        return found

    step_problem.solve = twice  # type: ignore[assignment]
    fraction = error_planar.FRACTION
    error_planar.FRACTION = np.inf  # both answers exact (1e-10), not stopped at the bench's e / FRACTION
    try:
        log = StepLog(Criteria())
        with compiled(True):
            run_experiment(spec, None, log)
    finally:
        step_problem.solve = plain  # type: ignore[assignment]
        error_planar.FRACTION = fraction
    (row,) = log.rows.values()
    error = row.error()
    gaps = np.array(apart)
    return {"compared": gaps.size, "apart": [int((gaps > a).sum()) for a in APART],
            "largest": float(gaps.max(initial=0.0)), "missed": missed, "rms": error["rms"],
            "unsolved": error["unsolved"]}


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.planar_answers", description=__doc__)
    parser.add_argument("--run", nargs=3, action="append", required=True, metavar=("CONFIG", "SOLVER", "KNOB"),
                        help="a run as the bench runs it (KNOB '-': the config's value)")
    parser.add_argument("--steps", type=int, default=200, help="steps per run (default 200)")
    args = parser.parse_args()
    print(f"{'run':<44}{'compared':>9}{'> 1e-6':>8}{'> 1e-3':>8}{'largest m/s':>12}{'missed':>7}{'rms m/s':>10}"
          f"{'unsolved':>9}")
    for path, solver, knob in args.run:
        m = compare(path, args.steps, solver, None if knob == "-" else int(knob))
        rms = "-" if m["rms"] is None else f"{m['rms']:.3g}"
        print(f"{Path(path).stem + ' ' + solver + ' ' + knob:<44}{m['compared']:>9}{m['apart'][0]:>8}"
              f"{m['apart'][1]:>8}{m['largest']:>12.2e}{m['missed']:>7}{rms:>10}{m['unsolved']:>9}")


if __name__ == "__main__":
    main()
