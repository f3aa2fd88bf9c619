"""``python -m benchmarks.planar_collide``: µs per call of the planar model's collision test on the piles of
``benchmarks.planar``, compiled, one thread, where ``--settle`` steps of ``planar-soft-step`` (4 substeps) left
them (a pile that has settled: boxes turned by a little, as the soft step tests them), the points written into
a contact table's columns as the soft step has them written (``contacts.find_contacts_near``).

Timed per pile, each as a compiled loop of ``--calls`` calls (so no Python call is in the figure), taking
turns (``benchmarks.timing.interleaved``, CPU time), medians of ``--repeats``:

- **collide**: ``collide.collide_near`` as a step calls it, its broad phase's candidates kept (the boxes are
  where they were found): the per-step cost of finding a pile's contacts (bounds, corners and faces, ground,
  the narrow phase on every candidate pair); also given per candidate pair;
- **broad phase**: ``broad.candidate_pairs`` alone, what a call pays on top when some box has left the
  bounds its candidates were found in.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from benchmarks.planar import scenes_names
from benchmarks.timing import interleaved

MARGIN = 0.02  # planar-soft-step's speculative margin (Box2D's 4 linear slops)


def timed_loops() -> tuple[Any, Any]:
    """Two compiled loops: ``calls`` collision tests with kept candidates, and ``calls`` broad phases."""
    import numba

    from stackx.models.planar.broad import candidate_pairs
    from stackx.models.planar.collide import collide_near

    collide, pairs = collide_near.build(), candidate_pairs.build()

    @numba.njit
    def collide_loop(calls: int, x: Any, y: Any, angle: Any, hx: Any, hy: Any, static: Any, fat: float, near: Any,
                     wide: Any, out: Any) -> int:
        found = 0
        for _ in range(calls):
            n, near = collide(x, y, angle, hx, hy, static, MARGIN, fat, near, wide, out[0], out[1], out[2],
                              out[3], out[4], out[5])
            found += n
        return found

    @numba.njit
    def broad_loop(calls: int, x: Any, y: Any, reach_x: Any, reach_y: Any, static: Any, fat: float,
                   keys: Any) -> int:
        found = 0
        for _ in range(calls):
            found += pairs(x, y, reach_x, reach_y, static, fat, keys)
        return found

    return collide_loop, broad_loop


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.planar_collide", description=__doc__.split("\n")[0])
    parser.add_argument("--piles", nargs="+", metavar="PILE", default=["pyramid-20", "pyramid-40", "brick wall 65"],
                        help=f"piles (default: pyramid-20, pyramid-40, brick wall 65): {', '.join(scenes_names())}")
    parser.add_argument("--calls", type=int, default=200, help="calls per timed sample (default 200)")
    parser.add_argument("--repeats", type=int, default=15, help="samples (default 15)")
    parser.add_argument("--settle", type=int, default=5,
                        help="steps of planar-soft-step before the piles are tested (default 5; 0: as built)")
    args = parser.parse_args(argv)

    from benchmarks.planar import Stackx, scenes
    from stackx.solvers.planar.contacts import A, B, DEPTH, FEATURE, LOOSENESS, NX, NY, PX, PY, contact_workspace, \
        near_workspace

    collide_loop, broad_loop = timed_loops()
    built = scenes(0)
    fat = MARGIN + 2.0 * LOOSENESS
    for name in args.piles:
        state = built[name]
        if args.settle > 0:
            settling = Stackx("planar-soft-step", {"substeps": 4}, state)
            settling.prepare(args.settle)()
            state = settling.last
        x, y, angle = state.x[0].copy(), state.y[0].copy(), state.angle[0].copy()
        hx, hy, static = state.hx[0].copy(), state.hy[0].copy(), state.inv_mass[0] == 0.0
        ids, table = contact_workspace(8 * len(x) + 8)
        out = (ids[:, A], ids[:, B], table[:, NX:NY + 1], table[:, PX:PY + 1], table[:, DEPTH], ids[:, FEATURE])
        near, wide = near_workspace(len(x))
        points = collide_loop(1, x, y, angle, hx, hy, static, fat, near, wide, out)  # finds the candidates
        keys = np.empty(near[0] + 1, np.int64)
        reach_x = np.abs(np.cos(angle)) * hx + np.abs(np.sin(angle)) * hy  # the bounding boxes' half-sizes
        reach_y = np.abs(np.sin(angle)) * hx + np.abs(np.cos(angle)) * hy
        broad_loop(1, x, y, reach_x, reach_y, static, fat, keys)

        def run(loop: Callable[..., int], *given: Any) -> Callable[[], None]:
            return lambda: loop(args.calls, *given)

        samples = interleaved({
            "collide": (lambda: run(collide_loop, x, y, angle, hx, hy, static, fat, near, wide, out), args.calls),
            "broad phase": (lambda: run(broad_loop, x, y, reach_x, reach_y, static, fat, keys), args.calls),
        }, args.repeats, clock=time.process_time)
        us = {key: s.per_unit * 1e6 for key, s in samples.items()}
        print(f"{name}: {len(x)} boxes, {near[0]} candidate pairs, {points} points: collide {us['collide']:.1f} µs "
              f"({us['collide'] * 1e3 / max(near[0], 1):.0f} ns per candidate pair), broad phase "
              f"{us['broad phase']:.1f} µs")


if __name__ == "__main__":
    main()
