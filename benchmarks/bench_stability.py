"""Do two benches of the same config agree? Verdicts, fronts and winners, back to back, on a loaded machine.

``python -m benchmarks.bench_stability [CONFIG] [--load N] [--json FILE]`` benches CONFIG (default
``configs/hard/tall-20.yaml``) twice in a row while N processes spin on the CPU (default: as many as there are
CPUs), and prints what differs between the two: every record's verdict, the Pareto front, the equal-cost
winners with their ties, the cheapest solver that passes; and how many timings each bench flagged unstable.
Then it times one run both ways the bench could (wall clock against the timing thread's CPU clock), repeated,
under the same load, to show what the CPU clock takes out. Verdicts never depend on timing; fronts and
winners should agree unless a figure moved by more than the tolerance.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

SPIN = "while True:\n    pass\n"


def _summary(results: list[Any]) -> dict[str, Any]:
    from stackx.bench.compare import outcomes, tied_with

    out = {}
    for res in results:
        shown = outcomes(res.records)
        best = shown[0] if shown and shown[0].passed else None
        out[res.name] = {
            "verdicts": {f"{r.solver}/{r.value}": {k: v["passed"] for k, v in r.criteria.items()}
                         for r in res.records},
            "front": [f"{r.solver}/{r.value}" for r in res.front],
            "winners": [sorted({row["winner"], *row["tied"]}) if row["winner"] else [] for row in res.equal_cost],
            "cheapest": sorted({best.solver, *(r.solver for r in tied_with(best, shown))}) if best else [],
            "unstable": sum(1 for r in res.records if r.timing.get("unstable")),
            "timed": sum(1 for r in res.records if r.us_per_step is not None),
        }
    return out


def _clocks(config: str, solver: str, repeats: int) -> dict[str, Any]:
    """One run timed ``repeats`` times with each clock, alternating: fastest, median, spread."""
    from stackx.bench import timing
    from stackx.bench.plan import CASE, load_case
    from stackx.bench.sweep import _runs
    from stackx.config.experiment import load

    case, _ = load_case(load(config), [solver])
    plan = case.plans[0]
    run = next(r for variant, value, r in _runs(case, plan) if variant == CASE and value == max(plan.values or [0]))
    figures: dict[str, list[float]] = {"wall": [], "cpu": []}
    with timing.one_thread():
        for _ in range(repeats):
            for name, clock in (("wall", time.perf_counter), ("cpu", time.thread_time)):
                timing.CLOCK = clock
                figures[name].append(timing.time_run(run, case.section.timing)["us_per_step"])
    timing.CLOCK = time.thread_time
    return {name: {"fastest": min(v), "median": statistics.median(v), "slowest": max(v), "figures": v}
            for name, v in figures.items()} | {"run": f"{solver}/{max(plan.values or [0])}"}


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_stability", description=__doc__.split("\n")[0])
    parser.add_argument("config", nargs="?", default="configs/hard/tall-20.yaml")
    parser.add_argument("--load", type=int, default=os.cpu_count() or 2, help="spinning processes while it runs")
    parser.add_argument("--solver", default="ngs", help="the solver whose run the clocks are compared on")
    parser.add_argument("--json", type=Path, default=None, help="write every figure here")
    args = parser.parse_args()
    os.environ.setdefault("STACKX_JIT", "1")
    from stackx.bench.command import bench

    spinners = [subprocess.Popen([sys.executable, "-c", SPIN]) for _ in range(args.load)]
    try:
        first = _summary(bench([args.config], None, None, quiet=True))
        second = _summary(bench([args.config], None, None, quiet=True))
        clocks = _clocks(args.config, args.solver, 7)
    finally:
        for p in spinners:
            p.kill()
            p.wait()
    print(f"{args.config}, two benches back to back under {args.load} spinning processes:")
    for case in first:
        a, b = first[case], second[case]
        for key in ("verdicts", "front", "winners", "cheapest"):
            print(f"  {case} {key}: {'same' if a[key] == b[key] else 'DIFFER'}"
                  + ("" if a[key] == b[key] else f" ({a[key]} / {b[key]})"))
        print(f"  {case} timings flagged unstable: {a['unstable']} of {a['timed']}, then {b['unstable']} of "
              f"{b['timed']}")
    for name in ("wall", "cpu"):
        c = clocks[name]
        print(f"  {clocks['run']} µs/step by the {name} clock, 7 times: fastest {c['fastest']:.3g}, median "
              f"{c['median']:.3g}, slowest {c['slowest']:.3g}")
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"first": first, "second": second, "clocks": clocks, "load": args.load},
                                        indent=1) + "\n")


if __name__ == "__main__":
    main()
