"""Lemke's complementary pivoting on a step's contact problem, sparse and revised: the reference solve's
(``stackx.models.planar.reference``) way out when its Newton rounds cycle between mode combinations.

**Why a pivoting method at all.** The reference's Newton rounds read each point's mode (separating,
sticking, sliding either way) off the current answer. On a step where many points change mode at once (a box
landing on a pile, a 20-row pyramid settling) the rounds can cycle between combinations, neither of which
solves the step. Lemke's method walks from one complementary basis to the next along a path that cannot
cycle (in exact arithmetic, its ties broken) and ends on a solution for the class of matrices this problem has
(Stewart and Trinkle, 1996, for the same formulation in 3D).

**The formulation** (``contact_lcp``). Per point four unknowns ``z = (qn, qt+, qt-, beta) >= 0``, with
``qt = qt+ - qt-`` and ``beta`` the slip speed, and four complementary slacks ``w = M z + q >= 0``:

- ``un - target``: the normal may push only while the point is exactly at its target speed;
- ``beta + ut`` and ``beta - ut``: friction acts in +t only while ``ut = -beta``, in -t only while
  ``ut = beta``; sticking (``ut = 0``) leaves both free;
- ``cone qn - qt+ - qt-``: the slip speed is positive only with friction at its bound.

These are exactly the contract's conditions (``stackx.models.planar.problem``): the normal's complementarity
and the 2D friction box with maximal dissipation. Impulses are scaled, ``q = p / k`` (m/s, as
``reference.ModeSystem`` keeps them), so every entry of ``M`` is of order 1; ``M`` is never dense: its blocks
are the sparse Delassus matrix ``W = J M^-1 J^T`` (a pile's point meets the points of its two boxes only).

**Revised pivoting** (``walk``). The walk keeps a basis ``B`` of columns of ``[I, -M, -d]`` (``d = 1``: the
covering vector of the artificial ``z0``) and its basic values ``x = B^-1 q``; the basis is held as a sparse LU
(SuperLU) of the basis it was last factored at, followed by one eta (the pivot row and the entering column's
representation) per pivot since; every ``REFACTOR`` pivots it is factored afresh and ``x`` recomputed from
``q``. A pivot costs one solve with the LU, the etas and a ratio test: the entering variable is always the
complement of the one that left (Lemke's rule), so there is no pricing. On a 20-row pyramid (900 points,
3,600 unknowns) a pivot costs about 0.5 ms.

**Degeneracy.** Resting points have zero targets and a sticking point a slack at zero, so ratio tests tie
everywhere and a walk may cycle. The walk runs on ``q`` perturbed by ``eps rho`` (``rho``: fixed, distinct, in
``[1, 2]``; ``eps`` a small share of the scale of ``q``), which breaks the ties (the lexicographic rule,
numerically); its answer is recomputed from the unperturbed ``q`` on the final basis (kept if it solves the
LCP more closely than the perturbed one), and the caller takes it to the exact answer of its modes. The first
walk's ``eps`` is 1e-12: the smaller it is, the nearer the final basis is to one of the unperturbed problem's
(on a step of ``stack-40`` and one of a row of dominoes, walks at 1e-10 end 1e-8 and 4e-10 m/s off, walks at
1e-12 on the answers themselves, 4e-14 and 7e-16 m/s); unperturbed, ties stay and the domino step's walk
leaves on a ray. A basic value that rounding leaves a hair below zero leaves the basis at zero: the step is
never taken backwards.

**Redundant contacts, and regularization** (``starts``). A box resting flat has two points on a face, four
rows for its three velocities, and a pile holds many more rows than its boxes have velocities (a 20-row
pyramid: 1,800 rows, 630 velocities): ``W`` is singular, and the bases of a walk on a pile are near singular,
so that on large piles rounding defeats the tie breaking and the walk runs on for tens of thousands of pivots
or leaves on a ray. A large problem is therefore walked with ``W + REGULARIZATION K^-1`` (each point's
effective mass ``K``): the LCP of the answer nearest zero impulses up to that weight, which the walk solves
to rounding; its answer lies within about ``REGULARIZATION`` m/s per m/s of impulse of the problem's
(4e-7 m/s on pyramid-20's steps), and the caller lands from there. Such a walk that ends takes 3,300 to 7,700
pivots on recorded pyramid-20 steps (at most 2.3 per unknown, 2 to 7 s); one that does not (a pile toppling under
``planar-xpbd`` at 4 substeps or ``planar-soft-step`` at 1) ran all its pivots, 20 to 47 s, so a large walk gives
up after ``LARGE_PIVOTS`` per unknown. At 1e-6 the perturbation, amplified by the
basis, spoils the answer; at 1e-8 the walk takes longer and its answer no longer leads Newton's rounds
home; at 1e-9 it does not end.

**Not warm-started.** A walk from the complementary basis of guessed modes (covering vector ``B 1``, so that
``z0`` covers every row at the start) is not sure to end: ``d`` is then not positive, and on recorded
pyramid-20 steps every such walk tried left on a ray, after 400 to 25,000 pivots, from the warm start's modes.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from stackx.models.planar.problem import ContactProblem, effective_masses, inverse_masses, jacobian

REFACTOR = 40  # pivots between fresh LU factorizations of the basis (each pivot adds one eta)
PIVOTS = 12  # most pivots per unknown before a walk gives up
LARGE_PIVOTS = 4  # most pivots per unknown of a large problem's regularized walk (those that end take at most 2.3)
PERTURBATIONS = (1e-12, 1e-10, 1e-8, 1e-6)  # relative sizes of q's perturbation ``starts`` walks with, in turn
PIVOT_TOLERANCE = 1e-10  # entries of the entering column below this (relative) do not limit the step
EXACT_POINTS = 300  # largest problem (points) walked on its own LCP; larger ones are regularized
REGULARIZATION = 1e-7  # the weight added to a large problem's scaled Delassus diagonal
LARGE_PERTURBATION = 1e-8  # the perturbation of a large problem's walk


class RayEnd(RuntimeError):
    """A walk left along an unbounded ray, or ran out of pivots: it found no answer."""


@dataclass
class ContactLCP:
    """The step's LCP ``w = M z + q`` in scaled unknowns (see the module text): ``matrix`` ``M`` (scipy CSC,
    ``4m x 4m``), ``constant`` ``q``, and the effective masses ``kn``, ``kt`` that read impulses back."""

    matrix: object
    constant: np.ndarray
    kn: np.ndarray
    kt: np.ndarray

    def impulses(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(pn, pt)`` of the unknowns ``z``."""
        m = self.kn.shape[0]
        return z[:m] * self.kn, (z[m:2 * m] - z[2 * m:3 * m]) * self.kt


def contact_lcp(problem: ContactProblem, regularization: float = 0.0) -> ContactLCP:
    """The problem's LCP, sparse, scaled by the effective masses (every diagonal entry of ``W K`` is 1), with
    ``regularization`` added to that diagonal (0: the problem's own)."""
    from scipy import sparse

    m = problem.points
    kn, kt = effective_masses(problem)
    jac = jacobian(problem)
    delassus = (jac.multiply(inverse_masses(problem)[None, :]) @ jac.T) @ sparse.diags(np.concatenate([kn, kt]))
    delassus = sparse.csr_matrix(delassus + regularization * sparse.identity(2 * m))
    nn, nt = delassus[:m, :m], delassus[:m, m:]
    tn, tt = delassus[m:, :m], delassus[m:, m:]
    one = sparse.identity(m, format="csr")
    matrix = sparse.bmat([[nn, nt, -nt, None],
                          [tn, tt, -tt, one],
                          [-tn, -tt, tt, one],
                          [sparse.diags(problem.friction * kn / kt), -one, -one, None]], format="csc")
    free = jac @ problem.velocity.reshape(-1)
    constant = np.concatenate([free[:m] - problem.target, free[m:], -free[m:], np.zeros(m)])
    return ContactLCP(matrix, constant, kn, kt)


@dataclass
class Walk:
    """A walk's end: the unknowns ``z``, and its cost (``pivots``, LU ``factorizations``)."""

    z: np.ndarray
    pivots: int
    factorizations: int


class _Basis:
    """The basis of a walk: which variable is basic in each row (``w_i`` is ``i``, ``z_i`` is ``n + i``, ``z0``
    is ``2n``), the LU of the basis it was last factored at and the etas of the pivots since."""

    def __init__(self, matrix: object) -> None:
        self.matrix = matrix  # M, CSC
        self.n = n = matrix.shape[0]
        self.variables = np.arange(n)  # the cold basis: every slack
        self.factors = None
        self.etas: list[tuple[int, np.ndarray]] = []
        self.factorizations = 0

    def column(self, variable: int) -> np.ndarray:
        """The tableau column of a variable (dense): ``e_i`` for ``w_i``, ``-M_i`` for ``z_i``, ``-1`` for
        ``z0``."""
        n = self.n
        if variable == 2 * n:
            return -np.ones(n)
        out = np.zeros(n)
        if variable < n:
            out[variable] = 1.0
        else:
            lo, hi = self.matrix.indptr[variable - n], self.matrix.indptr[variable - n + 1]
            out[self.matrix.indices[lo:hi]] = -self.matrix.data[lo:hi]
        return out

    def build(self) -> object:
        """The basis matrix ``B`` (CSC), assembled from ``M``'s arrays without a sparse product."""
        from scipy import sparse

        n, matrix, basis = self.n, self.matrix, self.variables
        slack, artificial = basis < n, basis == 2 * n
        unknown = ~slack & ~artificial
        j = basis[unknown] - n
        counts = np.where(slack, 1, np.where(artificial, n, 0))
        counts[unknown] = matrix.indptr[j + 1] - matrix.indptr[j]
        indptr = np.concatenate([[0], np.cumsum(counts)])
        indices, data = np.empty(indptr[-1], np.int64), np.empty(indptr[-1])
        indices[indptr[:-1][slack]], data[indptr[:-1][slack]] = basis[slack], 1.0
        lengths = counts[unknown]
        offsets = np.arange(lengths.sum()) - np.repeat(np.cumsum(lengths) - lengths, lengths)
        source = np.repeat(matrix.indptr[j], lengths) + offsets
        target = np.repeat(indptr[:-1][unknown], lengths) + offsets
        indices[target], data[target] = matrix.indices[source], -matrix.data[source]
        for col in np.flatnonzero(artificial):
            indices[indptr[col]:indptr[col + 1]], data[indptr[col]:indptr[col + 1]] = np.arange(n), -1.0
        return sparse.csc_matrix((data, indices, indptr), shape=(n, n))

    def factor(self) -> None:
        """Factor the basis afresh (the etas are dropped). Raises ``RayEnd`` on an exactly singular basis."""
        from scipy.sparse.linalg import splu

        self.etas = []
        self.factorizations += 1
        try:
            self.factors = splu(self.build(), permc_spec="COLAMD", diag_pivot_thresh=1.0)
        except RuntimeError as error:
            raise RayEnd(f"the walk's basis became singular: {error}") from None

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """``B^-1 rhs`` (FTRAN): the LU's solve, then the etas in order."""
        y = self.factors.solve(rhs)
        for row, alpha in self.etas:
            pivot = y[row] / alpha[row]
            if pivot != 0.0:
                y -= pivot * alpha
                y[row] = pivot
        return y


def walk(matrix: object, constant: np.ndarray, perturbation: float = PERTURBATIONS[0],
         pivots_each: int = PIVOTS) -> Walk:
    """``z >= 0`` with ``w = matrix z + constant >= 0`` and ``z . w = 0`` by Lemke's walk from the cold basis
    (every slack basic, covering vector 1) on the constant perturbed by ``perturbation`` times its scale (see
    the module text); ``matrix``: scipy sparse, square. Raises ``RayEnd`` when the walk ends without an
    answer, or after ``pivots_each`` pivots per unknown."""
    from scipy import sparse

    matrix = sparse.csc_matrix(matrix)
    constant = np.asarray(constant, np.float64)
    n = constant.shape[0]
    if (constant >= 0.0).all():
        return Walk(np.zeros(n), 0, 0)
    state = _Basis(matrix)
    state.factor()
    scale = max(float(np.abs(constant).max()), 1e-12)
    rho = 1.0 + np.random.default_rng(0).random(n)  # fixed, so the same problem walks the same way
    perturbed = constant + perturbation * scale * rho
    x = perturbed.copy()
    artificial = 2 * n
    basis = state.variables
    # z0 enters: its column's representation is -1 in every row, the most negative basic value leaves
    row, entering, alpha = int(np.argmin(x)), artificial, -np.ones(n)
    for pivots in range(1, pivots_each * n + 1):
        # after z0 came in, a basic value that rounding left below zero leaves at zero (not stepping back)
        step = (x[row] if pivots == 1 else max(x[row], 0.0)) / alpha[row]
        x -= step * alpha
        x[row] = step
        state.etas.append((row, alpha))
        leaving, basis[row] = basis[row], entering
        if leaving == artificial:
            return _end(matrix, constant, state, x, pivots)
        if len(state.etas) >= REFACTOR:
            state.factor()
            x = state.solve(perturbed)
        entering = leaving + n if leaving < n else leaving - n
        alpha = state.solve(state.column(entering))
        rising = np.flatnonzero(alpha > PIVOT_TOLERANCE * max(1.0, float(np.abs(alpha).max())))
        if rising.size == 0:
            raise RayEnd(f"Lemke's walk left on a ray after {pivots} pivots")
        ratios = np.maximum(x[rising], 0.0) / alpha[rising]
        ties = rising[ratios <= ratios.min()]
        ends = ties[basis[ties] == artificial]
        row = int(ends[0]) if ends.size else int(ties[np.argmax(alpha[ties])])
    raise RayEnd(f"Lemke's walk did not end in {pivots_each * n} pivots")


def _end(matrix: object, constant: np.ndarray, state: _Basis, walked: np.ndarray, pivots: int) -> Walk:
    """The walk's answer on its final basis: the basic values recomputed from the unperturbed ``q`` on a fresh
    LU, or those the walk ended on (the perturbed problem's answer) when they solve the LCP more closely (on an
    ill-conditioned basis the perturbation, amplified, can make the recomputed values negative)."""
    n = constant.shape[0]
    state.factor()
    basis = state.variables
    unknown = (basis >= n) & (basis < 2 * n)
    best, kept = np.inf, np.zeros(n)
    for x in (state.solve(constant), walked):
        z = np.zeros(n)
        z[basis[unknown] - n] = np.maximum(x[unknown], 0.0)
        error = float(np.abs(np.minimum(z, matrix @ z + constant)).max())
        if error < best:
            best, kept = error, z
    return Walk(kept, pivots, state.factorizations)


def starts(problem: ContactProblem) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Impulses ``(pn, pt)`` from Lemke's walks, one walk at a time (the caller stops once one lands), for the
    caller to take to the exact answer of their modes and check. Up to ``EXACT_POINTS`` points: walks on the problem's own LCP, one per size of the perturbation
    (``PERTURBATIONS``, in turn) whose walk ended (one at the smallest may cycle or leave on a ray in rounding,
    one at a larger size ends on a basis of a nearby problem). Larger: one walk on the problem regularized by
    ``REGULARIZATION`` (see the module text), whose answer is about that close to the problem's."""
    exact = problem.points <= EXACT_POINTS
    lcp = contact_lcp(problem, 0.0 if exact else REGULARIZATION)
    for size in PERTURBATIONS if exact else (LARGE_PERTURBATION,):
        try:
            z = walk(lcp.matrix, lcp.constant, size, PIVOTS if exact else LARGE_PIVOTS).z
        except RayEnd:
            continue
        yield lcp.impulses(z)
