"""``python -m benchmarks.planar_pivoting``: what Lemke's walk (``stackx.solvers.planar.pivoting``) costs on
recorded step problems, and what of the reference solve lands them.

Per problem: its points; the walks ``pivoting.starts`` makes (``pivoting.plans``: on the problem's own LCP up to
``pivoting.EXACT_POINTS`` points, else on the regularized one; covered by 1, then by the step's approach) up to
the first that ends: its pivots, LU factorizations, cover and the contract's residual of its answer (m/s), and
the CPU ms of the walks made;
then ``reference.solve`` from the recorded warm start: the stage that landed (``Solution.attempt``: 0 the
central path, 1 the warm start's Newton rounds, 2 the proximal point method, 3 Lemke's pivoting, 4 Lemke's walk
on the points in doubt), its residual, and wall s. Problems: every step in ``tests/planar/data`` (``*.json``,
``*.npz``), or with ``--pickle FILE`` (repeatable) the steps of a list of records, each a dict with ``problem`` (the
``ContactProblem`` fields), ``pn``, ``pt`` and ``step`` (``--steps`` picks some).
"""

from __future__ import annotations

import argparse
import json
import pickle
import time
from pathlib import Path

import numpy as np

from stackx.solvers.planar import pivoting, reference
from stackx.solvers.planar.problem import ContactProblem, residual

DATA = Path(__file__).resolve().parent.parent / "tests" / "planar" / "data"
FIELDS = ("inv_mass", "inv_inertia", "velocity", "body_a", "body_b", "normal", "ra", "rb", "friction", "target")


def recorded() -> list[tuple[str, ContactProblem, np.ndarray, np.ndarray]]:
    """Every step in ``tests/planar/data``: (name, problem, warm pn, warm pt)."""
    found = []
    for path in sorted(DATA.glob("*.json")):
        steps = json.loads(path.read_text())
        for k, s in enumerate(steps if isinstance(steps, list) else [steps]):
            found.append((f"{path.stem}[{k}]", ContactProblem(*(np.array(s[f]) for f in FIELDS)), np.array(s["pn"]),
                          np.array(s["pt"])))
    for path in sorted(DATA.glob("*.npz")):
        data = np.load(path)
        found.append((path.stem, ContactProblem(*(data[f] for f in FIELDS)), data["pn"], data["pt"]))
    return found


def pickled(path: str, steps: list[int] | None) -> list[tuple[str, ContactProblem, np.ndarray, np.ndarray]]:
    """The records of a pickle (see the module text), those of ``steps`` only when given."""
    with open(path, "rb") as handle:
        records = pickle.load(handle)
    found = []
    for r in records:
        if steps is None or r["step"] in steps:
            p = ContactProblem(**r["problem"])
            pn = np.zeros(p.points) if r["pn"] is None else r["pn"]
            pt = np.zeros(p.points) if r["pt"] is None else r["pt"]
            found.append((f"{Path(path).stem}[{r['step']}]", p, pn, pt))
    return found


def measure(name: str, problem: ContactProblem, pn: np.ndarray, pt: np.ndarray) -> str:
    """One row of the table (see the module text)."""
    start = time.process_time()
    walked = f"{'ray':>6} {'':5} {'':>8} {'':9}"
    for lcp, walk, approach in pivoting.ended_walks(problem):  # the walks ``starts`` makes, to the first that ends
        walked = (f"{walk.pivots:6d} {walk.factorizations:5d} {'approach' if approach else '1':>8} "
                  f"{residual(problem, *lcp.impulses(walk.z)):9.1e}")
        break
    walked += f" {1e3 * (time.process_time() - start):8.0f}"
    start = time.perf_counter()
    try:
        found = reference.solve(problem, pn, pt)
        solved = f"{found.attempt:5d} {found.residual:9.1e}"
    except reference.ReferenceFailure as failure:
        solved = f"{'miss':>5} {failure.best:9.1e}"
    return f"{name:32} {problem.points:6d} {walked} {solved} {time.perf_counter() - start:7.1f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pickle", action="append", default=[], help="a pickle of recorded step problems")
    parser.add_argument("--steps", type=int, nargs="+", default=None, help="the recorded steps to measure")
    args = parser.parse_args()
    problems = [row for path in args.pickle for row in pickled(path, args.steps)] if args.pickle else recorded()
    pivoting.walk(np.eye(2), -np.ones(2))  # the compiled pivots loaded (or built) before any walk is timed
    print(f"{'problem':32} {'points':>6} {'pivots':>6} {'LUs':>5} {'cover':>8} {'walk res':>9} {'walks ms':>8} "
          f"{'stage':>5} {'residual':>9} {'solve s':>7}")
    for name, problem, pn, pt in problems:
        print(measure(name, problem, pn, pt), flush=True)


if __name__ == "__main__":
    main()
