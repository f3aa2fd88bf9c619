"""Hostile configs in bulk: ``python3 -m benchmarks.fuzz_configs [--cases 10000] [--start 0] [--jobs 2]``.

Runs the seeded cases of ``tests/robust/fuzzgen.py`` (the suite runs the first few hundred) through ``stackx
run`` in-process and prints how many broke the contract, by kind: tracebacks, hangs (a case over 10 s;
one over 120 s is stopped), unlocated messages on exit 2, files left after a refusal, and folders left
incomplete after exit 0; then the exit codes, and the seed of every failure (``make(seed)`` replays it).

Each process first runs every shipped base config once, unjudged and untimed: a planar config's first run
compiles its kernels (tens of seconds), which is not a hang of the case that happens to come first. ``--jobs``
spreads the cases over that many processes (each warms up once, about half a minute): on two cores, 10,000
cases take about ten minutes with one job and about half that with two.
"""

from __future__ import annotations

import argparse
import multiprocessing
import signal
import tempfile
import time
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from tests.robust.fuzzgen import BASES, REPO, Case, attempt, make

KINDS = ("traceback in stderr", "traceback", "hang", "stopped after", "unlocated", "files left after a refusal",
         "incomplete", "files the manifest does not list", "exit 0 without a manifest",
         "exit 0 with an unreadable manifest", "exit 1 without one error line", "exit")
HANG_S = 10.0
STOP_S = 120
CHUNK = 50
"""Cases handed to a process at a time: small enough to keep both busy to the end, large enough that handing
them out costs nothing."""
PROGRESS = 500


class _Stopped(Exception):
    pass


def _stop(signum: int, frame: object) -> None:
    raise _Stopped


@dataclass(frozen=True)
class Seen:
    """One case's result: its exit code and every way it broke the contract."""

    seed: int
    code: int
    problems: list[str]
    about: str


def warm_up() -> None:
    """Run every base config once as shipped (not judged, not timed), so compiling is not counted as a hang."""
    signal.signal(signal.SIGALRM, _stop)
    for base in BASES:
        with tempfile.TemporaryDirectory() as folder:
            try:
                attempt(Case(-1, base, "as shipped", (REPO / base).read_bytes()), Path(folder))
            except Exception:  # noqa: BLE001 - a base that fails shows again, judged, in its mutations
                pass


def one(seed: int) -> Seen:
    """Run and judge the case of ``seed``, stopping it after ``STOP_S``."""
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
    if took > HANG_S:
        problems.append(f"hang: {took:.1f} s")
    return Seen(seed, code, problems, f"{case.base}: {case.how}")


def chunk(seeds: range) -> list[Seen]:
    return [one(seed) for seed in seeds]


def _chunks(start: int, cases: int) -> Iterator[range]:
    for first in range(start, start + cases, CHUNK):
        yield range(first, min(first + CHUNK, start + cases))


def results(start: int, cases: int, jobs: int) -> Iterator[Seen]:
    """Every case's result, in this process (``jobs`` 1) or spread over ``jobs`` processes (in any order)."""
    if jobs <= 1:
        warm_up()
        for seeds in _chunks(start, cases):
            yield from chunk(seeds)
        return
    with multiprocessing.get_context("fork").Pool(jobs, initializer=warm_up) as pool:
        for seen in pool.imap_unordered(chunk, _chunks(start, cases)):
            yield from seen


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=10_000)
    parser.add_argument("--start", type=int, default=0)
    parser.add_argument("--jobs", type=int, default=1, help="processes to spread the cases over (default 1)")
    args = parser.parse_args()
    if args.cases < 1 or args.jobs < 1:
        parser.error("--cases and --jobs are at least 1")
    counts: Counter[str] = Counter()
    codes: Counter[int] = Counter()
    failures: list[Seen] = []
    began = time.perf_counter()
    for done, seen in enumerate(results(args.start, args.cases, args.jobs), 1):
        codes[seen.code] += 1
        for problem in seen.problems:
            counts[next(k for k in KINDS if problem.startswith(k))] += 1
        if seen.problems:
            failures.append(seen)
        if done % PROGRESS == 0:
            print(f"{done} cases, {len(failures)} failing, {time.perf_counter() - began:.0f} s", flush=True)
    print(f"\n{args.cases} cases (seeds {args.start}..{args.start + args.cases - 1}) in "
          f"{time.perf_counter() - began:.0f} s with {args.jobs} process(es)")
    for kind in KINDS:
        print(f"  {kind}: {counts[kind]}")
    print(f"  exit codes: {dict(sorted(codes.items()))} (-1: stopped)")
    for seen in sorted(failures, key=lambda s: s.seed):
        print(f"seed {seen.seed} ({seen.about}): {'; '.join(seen.problems)}")


if __name__ == "__main__":
    main()
