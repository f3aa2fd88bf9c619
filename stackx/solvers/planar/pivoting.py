"""Lemke's complementary pivoting on a step's contact problem, sparse and revised: the reference solve's
(``stackx.solvers.planar.reference``) way out when its Newton rounds cycle between mode combinations.

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

These are exactly the contract's conditions (``stackx.solvers.planar.problem``): the normal's complementarity
and the 2D friction box with maximal dissipation. Impulses are scaled, ``q = p / k`` (m/s, as
``reference.ModeSystem`` keeps them), so every entry of ``M`` is of order 1; ``M`` is never dense: its blocks
are the sparse Delassus matrix ``W = J M^-1 J^T`` (a pile's point meets the points of its two boxes only).

**Revised pivoting** (``walk``). The walk keeps a basis ``B`` of columns of ``[I, -M, -d]`` (``d > 0``: the
covering vector of the artificial ``z0``, below) and its basic values ``x = B^-1 q``; the basis is held as a
sparse LU (SuperLU) of the basis it was last factored at, followed by one eta (the pivot row and the entering
column's representation) per pivot since; every ``REFACTOR`` pivots it is factored afresh and ``x`` recomputed
from ``q``. A pivot costs one solve with the LU and the etas (``substitute``: SuperLU's triangles as arrays,
the etas as rows of one array) and a ratio test (``leaving``): the entering variable is always the complement
of the one that left (Lemke's rule), so there is no pricing. The pivots between two factorizations run in one
compiled call (``pivot_run``). On a 20-row pyramid (850 points, 3,400 unknowns) a pivot costs 0.2 to 0.3 ms of
CPU, where SuperLU's own solve, the etas in numpy and a factorization every 40 pivots took 0.5 to 0.75 ms (the
same 20,328 pivots, the two taking turns).

**The covering vector.** Lemke's walk follows the answers of the problem with ``q + z0 d`` from ``z0`` large
to 0. With ``d = 1`` every row is raised alike, a resting point's and a fast one's. ``approach_cover`` takes
``d = -q`` where ``q`` is negative (at least ``COVER_FLOOR`` of the largest ``|q|``): at ``z0 = 1`` nothing
approaches and no friction row slips, and the walk follows the step with its approaches and slips scaled by
``1 - z0``, the whole pile's together. A walk covered so ends on steps where one covered by 1 wanders for
30 pivots per unknown and more (``z0`` rising and falling, no basis met twice): step 7 of a toppling 20-row
pyramid (``tests/planar/data/xpbd_pyramid20_answers_step.npz``, 847 points) after 51,802 pivots (15 per
unknown), and 2 of the 23 other steps of that run's first 30 that nothing else lands (at 20 and 23 per
unknown); the other 21 wander past 30 per unknown (7 of them tried past 60).
Where both end, the walk covered by 1 is mostly shorter (on the recorded 20-row steps 3,300 to 3,600 pivots
against 9,400 to 13,600), so it comes first, and the approach's walk second (``plans``).

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
(4e-7 m/s on pyramid-20's steps), and the caller lands from there. Such a walk covered by 1 that ends takes
3,300 to 7,700 pivots on recorded pyramid-20 steps (at most 2.3 per unknown); one that does not (a pile toppling
under ``planar-xpbd`` at 4 substeps or ``planar-soft-step`` at 1) runs on, so it gives up after ``LARGE_PIVOTS``
per unknown, and the walk covered by the approach after ``COVERED_PIVOTS``. At 1e-6 the perturbation, amplified by the
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

from stackx.kernel import compiled, enabled, kernel
from stackx.solvers.planar.problem import ContactProblem, effective_masses, inverse_masses, jacobian

REFACTOR = 200  # pivots between fresh LU factorizations of the basis (each pivot adds one eta)
PIVOTS = 12  # most pivots per unknown before a walk gives up
LARGE_PIVOTS = 4  # most pivots per unknown of a large problem's regularized walk (those that end take at most 2.3)
PERTURBATIONS = (1e-12, 1e-10, 1e-8, 1e-6)  # relative sizes of q's perturbation ``starts`` walks with, in turn
PIVOT_TOLERANCE = 1e-10  # entries of the entering column below this (relative) do not limit the step
EXACT_POINTS = 300  # largest problem (points) walked on its own LCP; larger ones are regularized
REGULARIZATION = 1e-7  # the weight added to a large problem's scaled Delassus diagonal
LARGE_PERTURBATION = 1e-8  # the perturbation of a large problem's walk
COVER_FLOOR = 1e-3  # the approach cover's least entry, as a share of the largest |q|
COVERED_PIVOTS = 25  # most pivots per unknown of a large problem's walk covered by the approach


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
    delassus = delassus + regularization * sparse.identity(2 * m)
    matrix, constant = assembled(delassus, jac @ problem.velocity.reshape(-1), problem.target,
                                 problem.friction * kn / kt)
    return ContactLCP(matrix, constant, kn, kt)


def assembled(delassus: object, free: np.ndarray, target: np.ndarray, cone: np.ndarray) -> tuple[object, np.ndarray]:
    """``(M, q)`` of the formulation (see the module text) for ``m`` points: ``delassus`` the scaled ``W K``
    (``2m x 2m``, sparse or dense, normals first), ``free`` the rows' velocities with no impulse, ``target``
    the normals' target speeds, ``cone`` each point's friction bound in scaled units (``mu kn / kt``)."""
    from scipy import sparse

    m = target.shape[0]
    delassus = sparse.csr_matrix(delassus)
    nn, nt = delassus[:m, :m], delassus[:m, m:]
    tn, tt = delassus[m:, :m], delassus[m:, m:]
    one = sparse.identity(m, format="csr")
    matrix = sparse.bmat([[nn, nt, -nt, None],
                          [tn, tt, -tt, one],
                          [-tn, -tt, tt, one],
                          [sparse.diags(cone), -one, -one, None]], format="csc")
    return matrix, np.concatenate([free[:m] - target, free[m:], -free[m:], np.zeros(m)])


@dataclass
class Walk:
    """A walk's end: the unknowns ``z``, and its cost (``pivots``, LU ``factorizations``)."""

    z: np.ndarray
    pivots: int
    factorizations: int


class _Basis:
    """The basis of a walk: which variable is basic in each row (``w_i`` is ``i``, ``z_i`` is ``n + i``, ``z0``
    is ``2n``), the LU of the basis it was last factored at (its triangles as arrays, solved compiled by
    ``substitute``) and the etas of the pivots since (rows of one array, ``REFACTOR`` of them at most)."""

    def __init__(self, matrix: object, cover: np.ndarray) -> None:
        self.matrix = matrix  # M, CSC
        self.cover = cover  # d, the covering vector (positive)
        self.n = n = matrix.shape[0]
        self.columns = (matrix.indptr.astype(np.int64), matrix.indices.astype(np.int64), matrix.data)  # M's CSC
        self.variables = np.arange(n)  # the cold basis: every slack
        self.triangles: tuple[np.ndarray, ...] = ()
        self.eta_rows = np.zeros(REFACTOR, np.int64)
        self.etas = np.zeros((REFACTOR, n))
        self.count = 0  # etas since the last factorization
        self.factorizations = 0

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
            indices[indptr[col]:indptr[col + 1]], data[indptr[col]:indptr[col + 1]] = np.arange(n), -self.cover
        return sparse.csc_matrix((data, indices, indptr), shape=(n, n))

    def factor(self) -> None:
        """Factor the basis afresh (the etas are dropped). Raises ``RayEnd`` on an exactly singular basis."""
        from scipy.sparse.linalg import splu

        self.count = 0
        self.factorizations += 1
        try:
            factors = splu(self.build(), permc_spec="COLAMD", diag_pivot_thresh=1.0)
        except RuntimeError as error:
            raise RayEnd(f"the walk's basis became singular: {error}") from None
        lower, upper = factors.L, factors.U  # CSC; P_r B P_c = L U, L with its unit diagonal
        # indices unsigned, so the compiled substitutions test none for a negative value
        self.triangles = (lower.indptr.astype(np.uint64), lower.indices.astype(np.uint64), lower.data,
                          upper.indptr.astype(np.uint64), upper.indices.astype(np.uint64), upper.data,
                          upper.diagonal(), factors.perm_r.astype(np.uint64), factors.perm_c.astype(np.uint64))

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """``B^-1 rhs`` (FTRAN): the LU's triangles, then the etas in order, compiled."""
        with compiled(enabled()):
            return substitute(*self.triangles, self.eta_rows, self.etas, self.count, rhs)


@kernel
def substitute(l_ptr: np.ndarray, l_rows: np.ndarray, l_values: np.ndarray, u_ptr: np.ndarray, u_rows: np.ndarray,
               u_values: np.ndarray, u_diagonal: np.ndarray, perm_r: np.ndarray, perm_c: np.ndarray,
               eta_rows: np.ndarray, etas: np.ndarray, count: int, rhs: np.ndarray) -> np.ndarray:
    """``B^-1 rhs`` for ``P_r B P_c = L U`` (SuperLU's factors, as CSC arrays) followed by ``count`` etas: the
    row permutation, forward substitution with the unit lower triangle and back substitution with the upper
    one, column by column, the column permutation, then each eta's pivot (``y_r / alpha_r`` at its row, and
    ``alpha`` times it taken from the rest). Zeros are skipped: a pile's columns are sparse."""
    n = rhs.shape[0]
    y = np.empty(n)
    for i in range(n):
        y[perm_r[i]] = rhs[i]
    for j in range(np.uint64(n)):
        yj = y[j]
        if yj != 0.0:
            for k in range(l_ptr[j], l_ptr[j + np.uint64(1)]):
                i = l_rows[k]
                if i > j:
                    y[i] -= l_values[k] * yj
    for back in range(np.uint64(n)):
        j = np.uint64(n - 1) - back
        yj = y[j] / u_diagonal[j]
        y[j] = yj
        if yj != 0.0:
            for k in range(u_ptr[j], u_ptr[j + np.uint64(1)]):
                i = u_rows[k]
                if i < j:
                    y[i] -= u_values[k] * yj
    x = np.empty(n)
    for i in range(n):
        x[i] = y[perm_c[i]]
    flat = etas.reshape(-1)
    for e in range(count):
        row = eta_rows[e]
        pivot = x[row] / etas[e, row]
        if pivot != 0.0:
            at = np.uint64(e * n)  # unsigned: numba then needs no test for a negative index, and vectorizes
            for i in range(np.uint64(n)):
                x[i] -= pivot * flat[at + i]
            x[row] = pivot
    return x


@kernel
def leaving(x: np.ndarray, alpha: np.ndarray, basis: np.ndarray, artificial: int, tolerance: float) -> int:
    """The row that leaves when the variable of column representation ``alpha`` enters at basic values ``x``
    (the ratio test): of the rows whose ``alpha`` exceeds ``tolerance`` times its largest entry (at least 1),
    those whose ``max(x, 0) / alpha`` is least, the one where ``z0`` is basic if any, else the first with the
    largest ``alpha``; -1 when no row limits the step (a ray)."""
    n = x.shape[0]
    biggest = 1.0
    for i in range(n):
        biggest = max(biggest, abs(alpha[i]))
    limit = tolerance * biggest
    least = np.inf
    for i in range(n):
        if alpha[i] > limit:
            least = min(least, max(x[i], 0.0) / alpha[i])
    row, largest = -1, -np.inf
    for i in range(n):
        if alpha[i] > limit and max(x[i], 0.0) / alpha[i] <= least:
            if basis[i] == artificial:
                return i
            if alpha[i] > largest:
                row, largest = i, alpha[i]
    return row


ENDED, FULL, RAY, SPENT = 0, 1, 2, 3  # how a run of pivots (``pivot_run``) stops


def walk(matrix: object, constant: np.ndarray, perturbation: float = PERTURBATIONS[0],
         pivots_each: int = PIVOTS, cover: np.ndarray | None = None) -> Walk:
    """``z >= 0`` with ``w = matrix z + constant >= 0`` and ``z . w = 0`` by Lemke's walk from the cold basis
    (every slack basic) covered by ``cover`` (``d``, positive; 1 when None) on the constant perturbed by
    ``perturbation`` times its scale (see the module text); ``matrix``: scipy sparse, square. Raises ``RayEnd``
    when the walk ends without an answer, or after ``pivots_each`` pivots per unknown."""
    from scipy import sparse

    matrix = sparse.csc_matrix(matrix)
    constant = np.asarray(constant, np.float64)
    n = constant.shape[0]
    if (constant >= 0.0).all():
        return Walk(np.zeros(n), 0, 0)
    cover = np.ones(n) if cover is None else np.asarray(cover, np.float64)
    state = _Basis(matrix, cover)
    state.factor()
    scale = _scale(constant)
    rho = 1.0 + np.random.default_rng(0).random(n)  # fixed, so the same problem walks the same way
    perturbed = constant + perturbation * scale * rho
    x = perturbed.copy()
    artificial = 2 * n
    basis = state.variables
    # z0 enters: its column's representation is -d, the row whose value d covers least leaves
    row, entering, alpha = int(np.argmin(x / cover)), artificial, -cover
    pivots, most, resumed = 0, pivots_each * n, False
    while True:
        with compiled(enabled()):
            status, pivots, row, entering, state.count = pivot_run(
                *state.columns, cover, *state.triangles, state.eta_rows, state.etas, state.count, x, basis, row,
                entering, alpha, resumed, pivots, most, PIVOT_TOLERANCE)
        if status == ENDED:
            return _end(matrix, constant, state, x, pivots)
        if status == RAY:
            raise RayEnd(f"Lemke's walk left on a ray after {pivots} pivots")
        if status == SPENT:
            raise RayEnd(f"Lemke's walk did not end in {most} pivots")
        # the etas are full: the basis factored afresh and the values recomputed, and the walk goes on from there
        state.factor()
        x, resumed = state.solve(perturbed), True


@kernel
def tableau_column(m_ptr: np.ndarray, m_rows: np.ndarray, m_values: np.ndarray, cover: np.ndarray, variable: int,
                   out: np.ndarray) -> None:
    """The tableau column of a variable into ``out`` (dense): ``e_i`` for ``w_i``, ``-M_i`` for ``z_i`` (``M`` as
    its CSC arrays), ``-d`` for ``z0``."""
    n = out.shape[0]
    if variable == 2 * n:
        for i in range(n):
            out[i] = -cover[i]
        return
    out[:] = 0.0
    if variable < n:
        out[variable] = 1.0
    else:
        for k in range(m_ptr[variable - n], m_ptr[variable - n + 1]):
            out[m_rows[k]] = -m_values[k]


@kernel
def pivot_run(m_ptr: np.ndarray, m_rows: np.ndarray, m_values: np.ndarray, cover: np.ndarray, l_ptr: np.ndarray,
              l_rows: np.ndarray, l_values: np.ndarray, u_ptr: np.ndarray, u_rows: np.ndarray, u_values: np.ndarray,
              u_diagonal: np.ndarray, perm_r: np.ndarray, perm_c: np.ndarray, eta_rows: np.ndarray, etas: np.ndarray,
              count: int, x: np.ndarray, basis: np.ndarray, row: int, entering: int, alpha: np.ndarray,
              resumed: bool, pivots: int, most: int, tolerance: float) -> tuple[int, int, int, int, int]:
    """Lemke's pivots, in place on the basic values ``x``, the ``basis`` and the etas, from the one at ``row``
    with ``entering`` (column representation ``alpha``) on; ``resumed``: ``entering`` is yet to be solved for and
    its row found (after a factorization). Until ``z0`` leaves (``ENDED``), the etas are full (``FULL``: the
    caller factors afresh and resumes), no row limits a step (``RAY``) or ``most`` pivots are done (``SPENT``).
    Returns ``(status, pivots, row, entering, count)``: the pivots done in all, the next pivot's row and
    entering variable, and the etas kept. Each pivot: the step to the leaving row (after the first, a basic value
    that rounding left below zero leaves at zero: the step is never taken backwards), the eta kept, the
    complement of the variable that left enters, its column (``tableau_column``) solved (``substitute``) and the
    ratio test (``leaving``). ``M`` comes as its CSC arrays."""
    n = x.shape[0]
    artificial = 2 * n
    column = np.empty(n)
    while True:
        if resumed:
            tableau_column(m_ptr, m_rows, m_values, cover, entering, column)
            alpha[:] = substitute(l_ptr, l_rows, l_values, u_ptr, u_rows, u_values, u_diagonal, perm_r, perm_c,
                                  eta_rows, etas, count, column)
            row = leaving(x, alpha, basis, artificial, tolerance)
            if row < 0:
                return RAY, pivots, row, entering, count
        resumed = True
        if pivots >= most:
            return SPENT, pivots, row, entering, count
        step = (x[row] if pivots == 0 else max(x[row], 0.0)) / alpha[row]
        for i in range(n):
            x[i] -= step * alpha[i]
        x[row] = step
        eta_rows[count] = row
        etas[count] = alpha
        count += 1
        left = basis[row]
        basis[row] = entering
        pivots += 1
        if left == artificial:
            return ENDED, pivots, row, entering, count
        entering = left + n if left < n else left - n
        if count >= etas.shape[0]:
            return FULL, pivots, row, entering, count


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


def approach_cover(constant: np.ndarray) -> np.ndarray:
    """The covering vector that scales the step's approaches (see the module text): ``-q`` where ``q`` is
    negative, at least ``COVER_FLOOR`` times the largest ``|q|``."""
    return np.maximum(-constant, COVER_FLOOR * _scale(constant))


def _scale(constant: np.ndarray) -> float:
    """The scale of ``q`` the perturbation and the approach's floor are shares of: its largest ``|q|``."""
    return max(float(np.abs(constant).max()), 1e-12)


def plans(problem: ContactProblem) -> tuple[ContactLCP, list[tuple[float, int, bool]]]:
    """The LCP a problem's walks run on and the walks, in turn: ``(perturbation, most pivots per unknown,
    whether the cover is the approach's)``. Up to ``EXACT_POINTS`` points: the problem's own LCP, covered by
    1 at each size of the perturbation (``PERTURBATIONS``: one at the smallest may cycle or leave on a ray in
    rounding, one at a larger size ends on a basis of a nearby problem), then by the approach. Larger: the
    problem regularized by ``REGULARIZATION`` (see the module text), covered by 1 within ``LARGE_PIVOTS``,
    then by the approach within ``COVERED_PIVOTS``."""
    if problem.points <= EXACT_POINTS:
        return contact_lcp(problem), [(size, PIVOTS, False) for size in PERTURBATIONS] + [
            (PERTURBATIONS[0], PIVOTS, True)]
    return contact_lcp(problem, REGULARIZATION), [(LARGE_PERTURBATION, LARGE_PIVOTS, False),
                                                  (LARGE_PERTURBATION, COVERED_PIVOTS, True)]


def ended_walks(problem: ContactProblem) -> Iterator[tuple[ContactLCP, Walk, bool]]:
    """The walks of ``plans`` that ended, one at a time as they are made: the LCP, the walk, and whether it was
    covered by the approach."""
    lcp, walks = plans(problem)
    for size, most, approach in walks:
        try:
            ended = walk(lcp.matrix, lcp.constant, size, most, approach_cover(lcp.constant) if approach else None)
        except RayEnd:
            continue
        yield lcp, ended, approach


def starts(problem: ContactProblem) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Impulses ``(pn, pt)`` from Lemke's walks (``ended_walks``), one walk at a time (the caller stops once one
    lands), for the caller to take to the exact answer of their modes and check."""
    for lcp, ended, _ in ended_walks(problem):
        yield lcp.impulses(ended.z)
