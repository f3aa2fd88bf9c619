"""``python -m benchmarks.planar_reference``: what the planar reference solve costs per step, and which
steps it cannot solve.

The bench solves one reference problem per step of every planar run (``stackx.bench.error_planar``), so its
cost decides how long a planar bench takes, and a step it cannot solve is a gap in the measurement. By
default, for pyramids of 10 and 20 rows (the scene's ``pyramid`` generator), two runs of ``steps`` steps:
``planar-exact`` (a pile held at rest: the reference's own path) and ``planar-pgs`` at 10 iterations (a pile
that sags and slides: the hard path), each watched by the planar step log; with ``--run CONFIG SOLVER KNOB``
(repeatable), those runs instead, each as ``stackx bench`` runs it (the config's settings for the solver
and its ``bench.set``; KNOB ``-``: the config's value of the knob, else the solver's default). Printed per
run: the median and the largest time per reference solve (failed ones included; ``planar-exact`` runs its
own solve too) and their sum (what the run's reference solves add to a bench), Newton rounds and sweeps per
solved step, and the steps the reference could not solve of those the step log watched, the seconds their
solves took (``failed s``: on a pile the reference cannot follow, most of what the run costs), the run's RMS
error; the step log's whole cost per step (``log ms``: the reference solve, the monitors and the check of
the solver's own answer) and, of it, that check alone (``own us``: ``stackx.bench.error_planar.check_own``,
from velocities and, for a solver that exposes them, impulses); per pyramid, the ratio of the median solve on
the sagging path to that on the held path, both measured in this one run. ``--proximal D`` solves with another proximal weight
(``stackx.solvers.planar.reference.PROXIMAL``), to see what it trades.

``--bench CONFIG`` instead times a whole ``stackx bench CONFIG`` end to end in this one process (every
planar solver at every knob value, the timings, the report written to a temporary folder), with every run's
steps cut to ``--steps`` when given (``--set steps=N``: a bench's cost grows with its steps, so the full
bench takes about ``config steps / N`` times as long on a pile that stays as busy). Printed: the bench's
wall time and the step log's share of it, then per run its steps and, per step, the reference solve
(``ref ms``), the step log's whole cost (``log ms``: the run's own reference solves and checks, and its
share of the batch's monitors), the check of its own answer (``own us``: velocities and, for a solver
that exposes them, impulses; ``stackx.bench.error_planar.check_own``), and the steps it could not solve with the
seconds their solves took (``failed s``); then the step log's solves by class with their count and CPU seconds
(``stackx.solvers.planar.step_problem.ReferenceStep.measure``: ``path``, landed by the paths or a warm start's
Newton rounds; ``fallback``, by the proximal point method or the walk on the points in doubt; ``cold restart``;
``whole walk``, Lemke's walk on the whole problem after both starts missed, left out with ``--no-whole-walk``;
``unsolved``), and the second
solves for the nearest answer (``nearest``, ``nearest missed``). ``--fraction F`` sets the step log's stop
(``stackx.bench.error_planar.FRACTION``: residual <= max(1e-10, error / F)), to calibrate it; ``--run`` prints
each run's ``spread`` and how many steps had a second solve (``nearest``).
Measured with ``--bench configs/planar/pyramid-10.yaml`` (49 runs of 600 steps): 114 s CPU, the reference's
first solves 68 s and its second solves for the nearest answer 4 s, no step unsolved; with ``--bench
configs/planar/pyramid-20.yaml`` (50 runs): 1,179 s CPU, no step unsolved. docs/bench.md gives what they cost
before and the stop rule's calibration.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from collections import defaultdict
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from stackx.bench.plan import CASE, load_case
from stackx.config.experiment import load
from stackx.bench.criteria import Criteria
from stackx.kernel import compiled
from stackx.bench import error_planar as planar_log
from stackx.solvers.planar import reference, step_problem
from stackx.bench.error_planar import StepLog
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
    failed: list[float] = []  # the seconds of the solves that raised
    work: list[tuple[int, int]] = []
    plain = step_problem.ReferenceStep.measure

    def timed(self: step_problem.ReferenceStep, *args: object) -> object:
        t0 = time.perf_counter()
        found, how = plain(self, *args)  # type: ignore[arg-type]
        solves.append(time.perf_counter() - t0)
        if how == step_problem.UNSOLVED:
            failed.append(solves[-1])
        else:
            work.append((found.rounds, found.sweeps))
        return found, how

    logged: list[float] = []
    own: list[float] = []
    plain_log, plain_check = planar_log.log_step, planar_log.check_own

    def timed_log(*args: object) -> None:
        t0 = time.perf_counter()
        try:
            plain_log(*args)  # type: ignore[arg-type]
        finally:
            logged.append(time.perf_counter() - t0)

    def timed_check(*args: object) -> object:
        t0 = time.perf_counter()
        try:
            return plain_check(*args)  # type: ignore[arg-type]
        finally:
            own.append(time.perf_counter() - t0)

    step_problem.ReferenceStep.measure = timed  # type: ignore[method-assign]
    planar_log.log_step, planar_log.check_own = timed_log, timed_check  # type: ignore[assignment]
    try:
        log = StepLog(Criteria())
        t0 = time.perf_counter()
        with compiled(True):
            run_experiment(spec, None, log)
        total = time.perf_counter() - t0
    finally:
        step_problem.ReferenceStep.measure = plain  # type: ignore[method-assign]
        planar_log.log_step, planar_log.check_own = plain_log, plain_check  # type: ignore[assignment]
    (row,) = log.rows.values()
    timed_solves = solves[1:] or solves  # the first includes loading compiled code
    error = row.error()
    return {"median_ms": 1e3 * statistics.median(timed_solves), "max_ms": 1e3 * max(timed_solves),
            "total_s": sum(solves), "failed_s": sum(failed),
            "rounds": statistics.mean(r for r, _ in work) if work else 0.0,
            "sweeps": statistics.mean(s for _, s in work) if work else 0.0,
            "unsolved": error["unsolved"], "logged": error["steps"], "rms": error["rms"], "spread": error["spread"],
            "nearest": int(row.log.nearest[row.b]),
            "solves": len(solves), "run_s": total,
            "log_ms": 1e3 * statistics.mean(logged[1:] or logged), "own_us": 1e6 * statistics.mean(own[1:] or own)}


def warm_up_checks() -> None:
    """Load (or compile) the own-answer check's kernels before anything is timed, as the runner's warm-up
    does for a solver's: the first check of a process would otherwise carry it."""
    from stackx.solvers.planar.conditions import approach, matched, violations
    from stackx.solvers.planar.step_problem import step_problem
    from stackx.models.planar.state import PlanarState

    one = np.array([[1.0]])
    state = PlanarState(np.zeros((1, 1)), 0.5 * one, np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((1, 1)),
                        np.zeros((1, 1)), one, 6.0 * one, 0.5 * one, 0.5 * one, 0.5 * one)
    problem = step_problem(state, 0, -9.8, 1 / 60, 0.02)
    keys = np.zeros((problem.points, 3), np.int64)
    approach(problem, problem.velocity)
    violations(problem, *matched(keys, keys[1:], np.ones(problem.points - 1), np.zeros(problem.points - 1)))


def bench_costs(path: str, steps: int | None) -> tuple[float, dict[str, dict[str, float]], dict[str, list[float]]]:
    """``stackx bench path`` (every solver, one process, the report written to a temporary folder), each run
    cut to ``steps`` (None: the config's): its wall time (s) and per run (by case and run name) the steps
    logged, the steps its reference did not solve and the seconds its reference solves (those failed among
    them), its step log and its own-answer checks took; and the solved steps counted by the stage that landed
    them (``Solution.attempt``)."""
    from stackx.bench.command import bench

    os.environ.setdefault("STACKX_JIT", "1")  # as the stackx bench command sets it
    names: dict[int, tuple[Any, list[str]]] = {}  # id(batch log) -> (the batch log, kept alive; its run names)
    spent: dict[tuple[int, int], dict[str, float]] = defaultdict(lambda: defaultdict(float))  # (batch, row)
    batch_log: dict[int, float] = defaultdict(float)  # step log seconds per batch
    current: list[Any] = [None, 0]  # the batch log whose step is being logged, and the row last measured
    landed: dict[str, list[float]] = defaultdict(lambda: [0, 0.0])  # by class: [solves, CPU seconds]
    plain_batch, plain_log, plain_check = StepLog.batch, planar_log.log_step, planar_log.check_own
    plain_measure, plain_nearest = step_problem.ReferenceStep.measure, step_problem.ReferenceStep.nearest

    def batch(self: StepLog, runs: list[Any], solver: object = None) -> Any:
        on_step = plain_batch(self, runs, solver)
        log = self.rows[runs[0].name].log
        names[id(log)] = (log, [r.name for r in runs])
        return on_step

    def log_step(log: Any, *args: Any, **kwargs: Any) -> None:
        current[0] = log
        t0 = time.perf_counter()
        try:
            plain_log(log, *args, **kwargs)
        finally:
            batch_log[id(log)] += time.perf_counter() - t0
            current[0] = None

    def measure(self: Any, b: int, *args: Any) -> Any:
        t0, c0 = time.perf_counter(), time.process_time()
        current[1] = b
        found, how = plain_measure(self, b, *args)
        took = time.perf_counter() - t0
        landed[how][0] += 1
        landed[how][1] += time.process_time() - c0
        row = spent[(id(current[0]), b)]
        row["reference"] += took
        if how == step_problem.UNSOLVED:
            row["unsolved"] += 1
            row["failed"] += took
        return found, how

    def nearest(self: Any, *args: Any) -> Any:
        t0, c0 = time.perf_counter(), time.process_time()
        found = plain_nearest(self, *args)
        landed["nearest" if found is not None else "nearest missed"][0] += 1
        landed["nearest" if found is not None else "nearest missed"][1] += time.process_time() - c0
        spent[(id(current[0]), current[1])]["reference"] += time.perf_counter() - t0
        return found

    def check_own(log: Any, b: int, *args: Any) -> Any:
        t0 = time.perf_counter()
        try:
            return plain_check(log, b, *args)
        finally:
            spent[(id(log), b)]["own"] += time.perf_counter() - t0

    warm_up_checks()
    StepLog.batch = batch  # type: ignore[method-assign]
    planar_log.log_step, planar_log.check_own = log_step, check_own  # type: ignore[assignment]
    step_problem.ReferenceStep.measure = measure  # type: ignore[method-assign]
    step_problem.ReferenceStep.nearest = nearest  # type: ignore[method-assign]
    try:
        with tempfile.TemporaryDirectory() as folder:
            t0, c0 = time.perf_counter(), time.process_time()
            results = bench([path], None, Path(folder) / "bench", quiet=True,
                            sets=None if steps is None else [f"steps={steps}"])
            wall = time.perf_counter() - t0
            landed["the whole bench's CPU"] = [1, time.process_time() - c0]
    finally:
        StepLog.batch = plain_batch  # type: ignore[method-assign]
        planar_log.log_step, planar_log.check_own = plain_log, plain_check  # type: ignore[assignment]
        step_problem.ReferenceStep.measure = plain_measure  # type: ignore[method-assign]
        step_problem.ReferenceStep.nearest = plain_nearest  # type: ignore[method-assign]
    case = results[0].name if results else Path(path).stem
    runs: dict[str, dict[str, float]] = defaultdict(lambda: defaultdict(float))
    for key, (log, run_names) in names.items():
        rest = batch_log[key] - sum(row["reference"] + row["own"] for (k, _), row in spent.items() if k == key)
        for b, name in enumerate(run_names):
            row, run = spent[(key, b)], runs[f"{case} {name}"]
            run["steps"] += log.steps
            run["reference"] += row["reference"]
            run["own"] += row["own"]
            run["unsolved"] += row["unsolved"]
            run["failed"] += row["failed"]
            run["log"] += row["reference"] + row["own"] + rest / len(run_names)
    return wall, runs, dict(landed)


def bench_main(path: str, steps: int | None) -> None:
    """Print ``bench_costs``: the wall time, then a line per run."""
    wall, runs, landed = bench_costs(path, steps)
    logged = sum(r["log"] for r in runs.values())
    cap = "" if steps is None else f" --set steps={steps}"
    unsolved = sum(r["unsolved"] for r in runs.values())
    failed = sum(r["failed"] for r in runs.values())
    print(f"stackx bench {path}{cap}: {wall:.1f} s wall, of which the step log {logged:.1f} s "
          f"({100 * logged / wall:.0f}%), {len(runs)} runs, {unsolved:.0f} steps the reference did not solve, "
          f"their solves {failed:.1f} s")
    print(f"{'run':<56}{'steps':>7}{'ref ms':>9}{'log ms':>9}{'own us':>9}{'unsolved':>9}{'failed s':>9}")
    for name, r in runs.items():
        n = max(r["steps"], 1)
        print(f"{name:<56}{r['steps']:>7.0f}{1e3 * r['reference'] / n:>9.2f}{1e3 * r['log'] / n:>9.2f}"
              f"{1e6 * r['own'] / n:>9.0f}{r['unsolved']:>9.0f}{r['failed']:>9.1f}")
    print("the step log's reference solves by class (solves, CPU s): "
          + ", ".join(f"{how} {n:.0f} ({cpu:.1f} s)" for how, (n, cpu) in sorted(landed.items())))


def line(name: str, m: dict[str, float]) -> str:
    rms = "-" if m["rms"] is None else f"{m['rms']:.4g}"
    spread = "-" if m["spread"] is None else f"{m['spread']:.2g}"
    return (f"{name:<52}{m['median_ms']:>10.1f}{m['max_ms']:>10.1f}{m['total_s']:>9.1f}{m['rounds']:>8.1f}"
            f"{m['sweeps']:>8.0f}{m['unsolved']:>6d}/{m['logged']:<5d}{m['failed_s']:>9.1f}{rms:>10}{m['log_ms']:>9.1f}"
            f"{m['own_us']:>8.0f}{spread:>9}{m['nearest']:>8d}")


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.planar_reference", description=__doc__)
    parser.add_argument("--steps", type=int, default=None,
                        help="steps per run (default 60; with --bench, the config's own)")
    parser.add_argument("--rows", type=int, nargs="+", default=[10, 20], help="pyramid sizes")
    parser.add_argument("--run", nargs=3, action="append", metavar=("CONFIG", "SOLVER", "KNOB"),
                        help="a run to measure instead of the pyramids, as the bench runs it (KNOB '-': the config's)")
    parser.add_argument("--proximal", type=float, default=reference.PROXIMAL,
                        help="the reference's proximal weight d (what it trades: reference.py's module text)")
    parser.add_argument("--bench", metavar="CONFIG",
                        help="time a whole 'stackx bench CONFIG' in this process instead, each run cut to --steps")
    parser.add_argument("--no-whole-walk", action="store_true",
                        help="leave out the last try on a measured step that both starts missed, Lemke's walk on "
                             "the whole problem (to see what it lands and costs)")
    parser.add_argument("--fraction", type=float, default=planar_log.FRACTION,
                        help="the step log's stop: residual <= max(1e-10, error / FRACTION) (docs/bench.md)")
    args = parser.parse_args()
    planar_log.FRACTION = args.fraction
    reference.PROXIMAL = args.proximal
    step_problem.WHOLE_WALK = not args.no_whole_walk
    if args.bench:
        bench_main(args.bench, args.steps)
        return
    args.steps = 60 if args.steps is None else args.steps
    print(f"{'run':<52}{'ms/solve':>10}{'max ms':>10}{'total s':>9}{'rounds':>8}{'sweeps':>8}{'unsolved':>12}"
          f"{'failed s':>9}{'rms m/s':>10}{'log ms':>9}{'own us':>8}{'spread':>9}{'nearest':>8}")
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
