"""``python -m benchmarks.planar_reference``: what the planar reference solve costs per step, and which
steps it cannot solve.

The bench solves one reference problem per step of every planar run (``stackx.models.planar.error``), so its
cost decides how long a planar bench takes, and a step it cannot solve is a gap in the measurement. By
default, for pyramids of 10 and 20 rows (the scene's ``pyramid`` generator), two runs of ``steps`` steps:
``planar-exact`` (a pile held at rest: the reference's own path) and ``planar-pgs`` at 10 iterations (a pile
that sags and slides: the hard path), each watched by the planar step log; with ``--run CONFIG SOLVER KNOB``
(repeatable), those runs instead, each as ``stackx bench`` runs it (the config's settings for the solver
and its ``bench.set``; KNOB ``-``: the config's value of the knob, else the solver's default). Printed per
run: the median and the largest time per reference solve (failed ones included; ``planar-exact`` runs its
own solve too) and their sum (what the run's reference solves add to a bench), Newton rounds and sweeps per
solved step, and the steps the reference could not solve of those the step log watched, with the run's RMS
error; the step log's whole cost per step (``log ms``: the reference solve, the monitors and the check of
the solver's own answer) and, of it, that check alone (``own us``: ``stackx.models.planar.conditions``); per pyramid, the ratio of the median solve on the sagging path to that on the held path, both measured
in this one run. ``--proximal D`` solves with another proximal weight
(``stackx.models.planar.reference.PROXIMAL``), to see what it trades.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from stackx.bench.plan import CASE, load_case
from stackx.config.experiment import load
from stackx.bench.criteria import Criteria
from stackx.kernel import compiled
from stackx.models.planar import error as planar_log
from stackx.models.planar import reference, step_problem
from stackx.models.planar.error import StepLog
from stackx.run.runner import run_experiment


def load_run(path: str, steps: int, solver: str, knob: int | None) -> object:
    """The plan of ``path`` cut to one run of ``solver`` for ``steps`` steps, as ``stackx bench`` runs it (the
    config's own settings when it names the solver, and its ``bench.set``), at ``knob`` of its cost knob (None:
    the config's value for it, else the solver's default)."""
    spec = load(path)
    case, left_out = load_case(spec, [solver])
    if not case.plans:
        raise SystemExit(f"{solver} does not run {path}: {left_out[solver]}")
    (plan,) = case.plans
    params = next(iter(plan.params[CASE].values()))
    if plan.knob is not None:
        value = knob if knob is not None else plan.own
        if value is None:
            value = getattr(plan.solver_cls.Params(), plan.knob)
        params = params.model_copy(update={plan.knob: value})
    spec.runs = [replace(spec.runs[0], solver_cls=plan.solver_cls, solver_params=params, steps=steps)]
    return spec


def measure(path: str, steps: int, solver: str, knob: int | None) -> dict[str, float]:
    """Time every reference solve of a ``solver`` run of the config at ``path``, and the run's own steps."""
    spec = load_run(path, steps, solver, knob)
    solves: list[float] = []
    work: list[tuple[int, int]] = []
    plain = step_problem.ReferenceStep._solve

    def timed(self: step_problem.ReferenceStep, *args: object) -> object:
        t0 = time.perf_counter()
        try:
            found = plain(self, *args)  # type: ignore[arg-type]
        finally:
            solves.append(time.perf_counter() - t0)
        work.append((found.rounds, found.sweeps))
        return found

    logged: list[float] = []
    own: list[float] = []
    plain_log, plain_approach = planar_log.log_step, planar_log.approach

    def timed_log(*args: object) -> None:
        t0 = time.perf_counter()
        try:
            plain_log(*args)  # type: ignore[arg-type]
        finally:
            logged.append(time.perf_counter() - t0)

    def timed_approach(*args: object) -> float:
        t0 = time.perf_counter()
        try:
            return plain_approach(*args)  # type: ignore[arg-type]
        finally:
            own.append(time.perf_counter() - t0)

    step_problem.ReferenceStep._solve = timed  # type: ignore[method-assign]
    planar_log.log_step, planar_log.approach = timed_log, timed_approach  # type: ignore[assignment]
    try:
        log = StepLog(Criteria())
        t0 = time.perf_counter()
        with compiled(True):
            run_experiment(spec, None, log)
        total = time.perf_counter() - t0
    finally:
        step_problem.ReferenceStep._solve = plain  # type: ignore[method-assign]
        planar_log.log_step, planar_log.approach = plain_log, plain_approach  # type: ignore[assignment]
    (row,) = log.rows.values()
    timed_solves = solves[1:] or solves  # the first includes loading compiled code
    error = row.error()
    return {"median_ms": 1e3 * statistics.median(timed_solves), "max_ms": 1e3 * max(timed_solves),
            "total_s": sum(solves),
            "rounds": statistics.mean(r for r, _ in work) if work else 0.0,
            "sweeps": statistics.mean(s for _, s in work) if work else 0.0,
            "unsolved": error["unsolved"], "logged": error["steps"] + error["unsolved"], "rms": error["rms"],
            "solves": len(solves), "run_s": total,
            "log_ms": 1e3 * statistics.mean(logged[1:] or logged), "own_us": 1e6 * statistics.mean(own[1:] or own)}


def line(name: str, m: dict[str, float]) -> str:
    rms = "-" if m["rms"] is None else f"{m['rms']:.4g}"
    return (f"{name:<52}{m['median_ms']:>10.1f}{m['max_ms']:>10.1f}{m['total_s']:>9.1f}{m['rounds']:>8.1f}"
            f"{m['sweeps']:>8.0f}{m['unsolved']:>6d}/{m['logged']:<5d}{rms:>10}{m['log_ms']:>9.1f}{m['own_us']:>8.0f}")


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.planar_reference", description=__doc__)
    parser.add_argument("--steps", type=int, default=60, help="steps per run")
    parser.add_argument("--rows", type=int, nargs="+", default=[10, 20], help="pyramid sizes")
    parser.add_argument("--run", nargs=3, action="append", metavar=("CONFIG", "SOLVER", "KNOB"),
                        help="a run to measure instead of the pyramids, as the bench runs it (KNOB '-': the config's)")
    parser.add_argument("--proximal", type=float, default=reference.PROXIMAL,
                        help="the reference's proximal weight d (what it trades: reference.py's module text)")
    args = parser.parse_args()
    reference.PROXIMAL = args.proximal
    print(f"{'run':<52}{'ms/solve':>10}{'max ms':>10}{'total s':>9}{'rounds':>8}{'sweeps':>8}{'unsolved':>12}"
          f"{'rms m/s':>10}{'log ms':>9}{'own us':>8}")
    if args.run:
        for path, solver, knob in args.run:
            m = measure(path, args.steps, solver, None if knob == "-" else int(knob))
            print(line(f"{Path(path).stem} {solver} {knob}", m))
        return
    for rows in args.rows:
        medians = []
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "pyramid.yaml"
            path.write_text(f"scene: {{name: planar, pyramid: {{rows: {rows}}}}}\nsolver: {{name: planar-pgs}}\n"
                            f"dt: 1/60\nsteps: {args.steps}\n")
            for solver, knob in (("planar-exact", None), ("planar-pgs", 10)):
                m = measure(str(path), args.steps, solver, knob)
                medians.append(m["median_ms"])
                print(line(f"pyramid-{rows} {solver}{'' if knob is None else f' {knob}'}", m))
        print(f"pyramid-{rows}: a solve on the sagging path costs {medians[1] / medians[0]:.0f}x one on the held path")


if __name__ == "__main__":
    main()
