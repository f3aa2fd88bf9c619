"""``python -m benchmarks.planar_batch``: the batched soft step's CPU cost per world-step, on one thread, beside
one row stepped alone and Box2D 3.1, so the batched target can be followed on a machine other work shares.

``benchmarks.planar``'s batched line is wall time on every thread numba has: on a machine where another
process holds a core it measures that process as much as the solver. This one times, on one thread and in
the process's CPU time (``time.process_time``, which other processes' load does not inflate), taking turns
(``benchmarks.timing.interleaved``), medians of ``--repeats``, each sample from a fresh state and solver as
``benchmarks.planar`` does:

- **batch**: ``--batch`` rows of pyramid-20 in one ``planar-soft-step`` batch (4 substeps), ``--calls`` calls of
  ``--steps`` steps on one solver, µs per world-step: rows that share their substeps step together
  (``soft_step.step_rows``); a fresh solver's first call also lays out the memory it keeps between calls, so
  ``--steps 1 --calls 20`` is a runner that records every step, and ``--steps 1`` alone mostly that first call;
- **one row**: the pile alone, ``--row-steps`` steps a call, µs per step;
- **Box2D**: Box2D 3.1 (pyb2d3, 4 substeps) stepping as many worlds one call each, as many steps, µs per
  world-step.

Printed with them: what the batch would cost on ``--cores`` cores that split the rows with no loss, and its
ratio to Box2D (the batched line of ``benchmarks.planar`` on an idle machine comes close to it: rows are
independent, each core steps its own).
"""

from __future__ import annotations

import argparse
import time

from benchmarks.planar import BOX2D, Box2D, Stackx, against, pyramid
from benchmarks.timing import Prepared, interleaved


def run(batch: int, steps: int, row_steps: int, repeats: int, calls: int = 1) -> dict[str, float]:
    """µs per world-step of the batch (``calls`` calls of ``steps`` steps) and of Box2D (as many steps), and
    per step of one row, all on one thread."""
    initial = pyramid(20)
    subjects = {"batch": (Stackx("planar-soft-step", {"substeps": 4}, initial, batch, 1), steps, calls, batch),
                "one row": (Stackx("planar-soft-step", {"substeps": 4}, initial), row_steps, 1, 1),
                BOX2D: (Box2D(initial, batch), steps * calls, 1, batch)}
    for subject, _, _, _ in subjects.values():
        subject.prepare(1)()  # compile (or load the cache) and import before anything is timed
    samples = interleaved({name: (lambda s=s, k=k, c=c: repeated(s.prepare(k), c), k * c * rows)
                           for name, (s, k, c, rows) in subjects.items()}, repeats, time.process_time)
    return {name: sample.per_unit * 1e6 for name, sample in samples.items()}


def repeated(go: Prepared, calls: int) -> Prepared:
    """``go`` called ``calls`` times in a row (on the same state and solver)."""
    if calls == 1:
        return go

    def again() -> None:
        for _ in range(calls):
            go()

    return again


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.planar_batch", description=(
        "CPU µs per world-step of a planar-soft-step batch of pyramid-20 on one thread, one row alone and Box2D "
        "3.1, with what the batch would cost split over some cores."))
    parser.add_argument("--batch", type=int, default=64, help="rows of the batch (default 64)")
    parser.add_argument("--steps", type=int, default=5, help="steps per call (default 5)")
    parser.add_argument("--calls", type=int, default=1,
                        help="calls per sample on one solver (default 1; Box2D steps as many steps in all)")
    parser.add_argument("--row-steps", type=int, default=20,
                        help="steps per sample of the row alone (default 20, as benchmarks.planar's table)")
    parser.add_argument("--repeats", type=int, default=7, help="samples per subject (default 7)")
    parser.add_argument("--cores", type=int, default=2, help="cores the projection splits the batch over (default 2)")
    args = parser.parse_args()
    if min(args.batch, args.steps, args.calls, args.row_steps, args.repeats, args.cores) < 1:
        parser.error("--batch, --steps, --calls, --row-steps, --repeats and --cores must be at least 1")
    us = run(args.batch, args.steps, args.row_steps, args.repeats, args.calls)
    split = us["batch"] / args.cores
    calls = f", {args.calls} calls of {args.steps} step{'s' if args.steps > 1 else ''}" if args.calls > 1 else ""
    print(f"pyramid-20, CPU µs on one thread: batch of {args.batch}{calls} {us['batch']:.1f} per world-step, one row "
          f"{us['one row']:.1f} per step, {BOX2D} {us[BOX2D]:.1f} per world-step; the batch split over "
          f"{args.cores} cores without loss: {split:.1f} per world-step ({against(split, us[BOX2D])})")


if __name__ == "__main__":
    main()
