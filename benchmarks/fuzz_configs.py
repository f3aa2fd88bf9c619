"""Hostile configs in bulk: ``python3 -m benchmarks.fuzz_configs [--cases 10000] [--start 0]``.

Runs the seeded cases of ``tests/robust/fuzzgen.py`` (the suite runs the first few hundred) through ``stackx
run`` in this process and prints how many broke the contract, by kind: tracebacks, hangs (a case over 10 s;
one over 120 s is stopped), unlocated messages on exit 2, files left after a refusal, and folders left
incomplete after exit 0; then the exit codes, and the seed of every failure (``make(seed)`` replays it).
"""

from __future__ import annotations

import argparse
import signal
import tempfile
import time
from collections import Counter
from pathlib import Path

from tests.robust.fuzzgen import attempt, make

KINDS = ("traceback in stderr", "traceback", "hang", "stopped after", "unlocated", "files left after a refusal",
         "incomplete", "files the manifest does not list", "exit 0 without a manifest",
         "exit 0 with an unreadable manifest", "exit 1 without one error line", "exit")
HANG_S = 10.0
STOP_S = 120


class _Stopped(Exception):
    pass


def _stop(signum: int, frame: object) -> None:
    raise _Stopped


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=10_000)
    parser.add_argument("--start", type=int, default=0)
    args = parser.parse_args()
    signal.signal(signal.SIGALRM, _stop)
    counts: Counter[str] = Counter()
    codes: Counter[int] = Counter()
    failures: list[str] = []
    began = time.perf_counter()
    for seed in range(args.start, args.start + args.cases):
        case = make(seed)
        with tempfile.TemporaryDirectory() as folder:
            t0 = time.perf_counter()
            signal.alarm(STOP_S)
            try:
                code, problems = attempt(case, Path(folder))
            except _Stopped:
                code, problems = -1, [f"stopped after {STOP_S} s"]
            finally:
                signal.alarm(0)
            took = time.perf_counter() - t0
        codes[code] += 1
        if took > HANG_S:
            problems.append(f"hang: {took:.1f} s")
        for problem in problems:
            counts[next(k for k in KINDS if problem.startswith(k))] += 1
        if problems:
            failures.append(f"seed {seed} ({case.base}: {case.how}): {'; '.join(problems)}")
        done = seed - args.start + 1
        if done % 500 == 0:
            print(f"{done} cases, {len(failures)} failing, {time.perf_counter() - began:.0f} s", flush=True)
    print(f"\n{args.cases} cases (seeds {args.start}..{args.start + args.cases - 1}) in "
          f"{time.perf_counter() - began:.0f} s")
    for kind in KINDS:
        print(f"  {kind}: {counts[kind]}")
    print(f"  exit codes: {dict(sorted(codes.items()))} (-1: stopped)")
    for line in failures:
        print(line)


if __name__ == "__main__":
    main()
