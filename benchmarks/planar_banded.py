"""``python -m benchmarks.planar_banded``: the reference's band LU (``stackx.solvers.planar.banded``) against
LAPACK's (``dgbtrf``, ``dgbtrs`` through scipy: the same algorithm, row pivoting within the band, in the same
storage) and SuperLU (``scipy.sparse.linalg.splu``, a general sparse LU) on the same matrices, side by side.

Per recorded step of ``tests/planar/data`` (``--steps`` picks some by name): the mode system a Newton round
factors (``reference.ModeSystem``, the modes read at the recorded warm start), its movable degrees of freedom and
the band's half width; µs to add the rows' products into the band (``banded.add``: stackx's alone), to
factor it and to solve with the factors, the median of interleaved repeats
(``timing.interleaved``; each factorization on a fresh copy, made outside the timed span; Python's call into
each included), and stackx's time over LAPACK's; ``backward``: the largest backward error of the three answers
(``|A x - b| / (|A| |x| + |b|)``, infinity norms), rounding's size when each solved the same system; ``path
ms``: the step's central path from its own start (``interior.central_path``, the reference's first stage), whose
iterations each factor and solve such a band.
"""

from __future__ import annotations

import argparse

import numpy as np

from benchmarks.planar_pivoting import recorded
from benchmarks.timing import Prepared, interleaved
from stackx.kernel import compiled
from stackx.solvers.planar import banded
from stackx.solvers.planar.interior import central_path
from stackx.solvers.planar.problem import ContactProblem, effective_masses
from stackx.solvers.planar.reference import ModeSystem

SOLVES = 20  # solves per timed span (one takes tens of µs)


def mode_band(problem: ContactProblem, pn: np.ndarray, pt: np.ndarray) -> tuple[np.ndarray, ModeSystem]:
    """The unfactored band of the mode system read at impulses ``pn``, ``pt``, and the system (its order)."""
    kn, kt = effective_masses(problem)
    system = ModeSystem(problem, kn, kt)
    m = problem.points
    modes = system.read(np.concatenate([pn / kn, pt / kt]))
    system.factor(modes[:m], modes[m:2 * m], modes[2 * m:])  # chooses the free rows
    return system.matrix(), system


def measure(name: str, problem: ContactProblem, pn: np.ndarray, pt: np.ndarray, repeats: int) -> str:
    """One table row: the step's band factored and solved by each."""
    from scipy.linalg import lapack
    from scipy.sparse import csc_matrix
    from scipy.sparse.linalg import splu

    ab, system = mode_band(problem, pn, pt)
    n, half = ab.shape[0], system.half
    dense = np.zeros((n, n))
    for j in range(n):
        for i in range(max(0, j - half), min(n, j + half + 1)):
            dense[i, j] = ab[j, 2 * half + i - j]
    matrix = csc_matrix(dense)
    rhs = np.random.default_rng(1).normal(size=n)  # in the band's order; ``where`` maps it to the system's
    in_order = rhs[system.where[:n]]

    with compiled(True):
        ours = ab.copy()
        pivots = np.zeros(n, np.int64)
        banded.factor(ours, half, pivots)
        mine = np.empty(n)
        mine[system.where[:n]] = banded.solve(ours, half, pivots, system.where, in_order)[:n]
    theirs, ipiv, info = lapack.dgbtrf(np.asfortranarray(ab.T), half, half)
    assert info == 0
    lapack_x, _ = lapack.dgbtrs(theirs, half, half, rhs, ipiv)
    lu = splu(matrix)
    super_x = lu.solve(rhs)
    # a mode system on a pile is near singular (redundant points, a small proximal weight), so answers may differ
    # by far more than rounding: each is checked by its backward error instead
    scale = np.abs(dense).sum(axis=1).max()
    agree = max(np.abs(dense @ x - rhs).max() / (scale * np.abs(x).max() + np.abs(rhs).max())
                for x in (mine, lapack_x, super_x))

    def ours_factor() -> Prepared:
        fresh = ab.copy()
        return lambda: banded.factor(fresh, half, pivots)

    def lapack_factor() -> Prepared:
        fresh = np.asfortranarray(ab.T)
        return lambda: lapack.dgbtrf(fresh, half, half, overwrite_ab=1)

    def super_factor() -> Prepared:
        return lambda: splu(matrix)

    def ours_add() -> Prepared:
        fresh = banded.band(1.0 / system.inv, system.where, half)
        weight = np.full(system.free.shape[0], 1.0 / system.proximal)
        return lambda: banded.add(fresh, half, system.where, weight, system.g, system.j_rows, system.j_columns)

    def ours_solve() -> Prepared:
        return lambda: [banded.solve(ours, half, pivots, system.where, in_order) for _ in range(SOLVES)]

    def lapack_solve() -> Prepared:
        return lambda: [lapack.dgbtrs(theirs, half, half, rhs, ipiv) for _ in range(SOLVES)]

    def super_solve() -> Prepared:
        return lambda: [lu.solve(rhs) for _ in range(SOLVES)]

    with compiled(True):
        ours_factor()()  # compiled (or loaded) before the clock starts
        timed = interleaved({"stackx add": (ours_add, 1), "stackx factor": (ours_factor, 1),
                             "LAPACK factor": (lapack_factor, 1), "SuperLU factor": (super_factor, 1),
                             "stackx solve": (ours_solve, SOLVES),
                             "LAPACK solve": (lapack_solve, SOLVES), "SuperLU solve": (super_solve, SOLVES)},
                            repeats)
        path = interleaved({"path": (lambda: lambda: central_path(
            system.values, system.columns, system.k, system.cone, system.v0, system.inv, system.fixed_u,
            system.target, None, (system.where, system.half)), 1)}, max(3, repeats // 8))["path"]
    us = {k: s.per_unit * 1e6 for k, s in timed.items()}
    return (f"{name:32} {n:5} {half:4} {us['stackx add']:7.0f} {us['stackx factor']:9.0f} "
            f"{us['LAPACK factor']:9.0f} {us['SuperLU factor']:9.0f} "
            f"{us['stackx factor'] / us['LAPACK factor']:7.2f} "
            f"{us['stackx solve']:8.1f} {us['LAPACK solve']:8.1f} {us['SuperLU solve']:8.1f} "
            f"{us['stackx solve'] / us['LAPACK solve']:7.2f} {agree:9.1e} {path.per_unit * 1e3:7.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", nargs="*", help="names of recorded steps (default: every one)")
    parser.add_argument("--repeats", type=int, default=41)
    args = parser.parse_args()
    print(f"{'step':32} {'dof':>5} {'half':>4} {'add':>7} {'factor µs: stackx':>19} {'LAPACK':>9} {'SuperLU':>9} "
          f"{'÷LAPACK':>7} {'solve µs: stackx':>8} {'LAPACK':>8} {'SuperLU':>8} {'÷LAPACK':>7} {'backward':>9} "
          f"{'path ms':>7}")
    for name, problem, pn, pt in recorded():
        if not args.steps or name in args.steps:
            print(measure(name, problem, pn, pt, args.repeats), flush=True)


if __name__ == "__main__":
    main()
