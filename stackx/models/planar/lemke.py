"""Lemke's complementary pivoting, and the planar contact problem written as the linear complementarity
problem it pivots on: the reference solve's last resort (``stackx.models.planar.reference``).

**Why a pivoting method at all.** The reference's Newton rounds read each point's mode (separating,
sticking, sliding either way) off the current answer. On a step where a heavy box lands on a pile, many
points change mode at once and the rounds can cycle between two mode combinations, neither of which solves
the step. Lemke's method walks from one complementary basis to the next along a path that cannot cycle
(in exact arithmetic, and given the perturbation below in floating point) and ends on a solution for the
class of matrices this problem has (Stewart and Trinkle, 1996, for the same formulation in 3D).

**The formulation** (``contact_lcp``). Per point four unknowns ``z = (pn, pt+, pt-, beta)``, all >= 0, with
``pt = pt+ - pt-`` and ``beta`` the slip speed, and four complementary slacks ``w = M z + q``:

- ``un - target``: the normal may push only while the point is exactly at its target speed;
- ``beta + ut`` and ``beta - ut``: friction acts in +t only while ``ut = -beta``, in -t only while
  ``ut = beta``; sticking (``ut = 0``) leaves both free;
- ``mu pn - pt+ - pt-``: the slip speed is positive only with friction at its bound.

These are exactly the contract's conditions (``stackx.models.planar.problem``): the normal's
complementarity and the 2D friction box with maximal dissipation.

**Cost.** The basis inverse is kept dense and updated by one rank-one step per pivot: ``O(n^2)`` a pivot for
``n = 4 x points`` unknowns, and the walks that end take one or two pivots per unknown: a few ms a walk for
20 points, while at 200 points a walk took 14 to 40 s. So it is used only when the Newton rounds fail, and
only up to ``reference.LEMKE_POINTS`` points.

**Degenerate problems.** Every resting point has a zero target and every ``beta`` row a zero constant, so
many ratio tests tie, which in floating point can end the walk on a ray. ``solve_lcp`` then tries again
with ``q`` perturbed by a tiny, fixed, strictly increasing vector (the textbook lexicographic
perturbation, numerically); the answer of a perturbed problem is only a start, which the reference's
Newton rounds then take to the exact solution of the true problem and check by its residual.
"""

from __future__ import annotations

import numpy as np

from stackx.models.planar.problem import ContactProblem, inverse_masses, jacobian

PIVOTS = 3  # most pivots per unknown before giving up (the walks that end take one or two)
PERTURBATIONS = (0.0, 1e-12, 1e-9, 1e-7)  # relative sizes of the perturbation of q, tried in turn


class RayTermination(RuntimeError):
    """Lemke's walk left along an unbounded ray (or ran out of pivots): no solution found this way."""


def lemke(m: np.ndarray, q: np.ndarray, tiny: float = 1e-12) -> np.ndarray:
    """``z >= 0`` with ``w = m z + q >= 0`` and ``z . w = 0``, by Lemke's method with covering vector 1.

    The tableau reads ``I w - m z - 1 z0 = q``. The artificial ``z0`` enters first at the most negative
    ``q``; afterwards the complement of each leaving variable enters, until ``z0`` leaves. Ties in the ratio
    test go to ``z0`` (ending the walk), else to the row with the largest pivot. Raises ``RayTermination``."""
    n = q.shape[0]
    if (q >= 0.0).all():
        return np.zeros(n)
    artificial = 2 * n  # variables: w_i = i, z_i = n + i, z0 = 2n
    basis = np.arange(n)
    inverse = np.eye(n)
    values = q.astype(np.float64).copy()
    entering = artificial
    row = int(np.argmin(q))
    for pivot in range(PIVOTS * n):
        if entering == artificial:
            column = -inverse.sum(axis=1)
        elif entering >= n:
            column = -(inverse @ m[:, entering - n])
        else:
            column = inverse[:, entering].copy()
        if pivot > 0:
            rising = column > tiny * max(1.0, float(np.abs(column).max()))
            if not rising.any():
                raise RayTermination(f"Lemke's walk left on a ray after {pivot} pivots")
            ratios = np.full(n, np.inf)
            ratios[rising] = values[rising] / column[rising]
            least = ratios.min()
            ties = np.flatnonzero(ratios <= least + tiny * max(1.0, abs(least)))
            ends = ties[basis[ties] == artificial]
            row = int(ends[0]) if ends.size else int(ties[np.argmax(column[ties])])
        step = values[row] / column[row]
        values -= step * column
        values[row] = step
        pivot_row = inverse[row] / column[row]
        inverse -= np.outer(column, pivot_row)
        inverse[row] = pivot_row
        leaving, basis[row] = basis[row], entering
        if leaving == artificial:
            z = np.zeros(n)
            unknowns = basis >= n
            z[basis[unknowns] - n] = values[unknowns]
            return np.maximum(z, 0.0)
        entering = leaving + n if leaving < n else leaving - n
    raise RayTermination(f"Lemke's walk did not end in {PIVOTS * n} pivots")


def contact_lcp(problem: ContactProblem) -> tuple[np.ndarray, np.ndarray]:
    """``(M, q)`` of the problem's LCP in ``z = (pn, pt+, pt-, beta)`` (4 x points unknowns; see the module
    text), dense, from the Delassus matrix ``W = J M^-1 J^T`` of the contract's Jacobian."""
    points = problem.points
    jac = jacobian(problem).toarray()
    w = (jac * inverse_masses(problem)) @ jac.T
    free = jac @ problem.velocity.reshape(-1)
    nn, nt, tn, tt = w[:points, :points], w[:points, points:], w[points:, :points], w[points:, points:]
    one, zero = np.eye(points), np.zeros((points, points))
    mu = np.diag(problem.friction)
    matrix = np.block([[nn, nt, -nt, zero],
                       [tn, tt, -tt, one],
                       [-tn, -tt, tt, one],
                       [mu, -one, -one, zero]])
    constant = np.concatenate([free[:points] - problem.target, free[points:], -free[points:], np.zeros(points)])
    return matrix, constant


def solve_lcp(problem: ContactProblem) -> list[tuple[np.ndarray, np.ndarray]]:
    """Candidate impulses ``(pn, pt)`` from Lemke's method on the problem's LCP: one per perturbation of
    ``q`` that ended on a solution (the unperturbed first), for the caller to polish and check."""
    matrix, constant = contact_lcp(problem)
    points, n = problem.points, constant.shape[0]
    scale = max(float(np.abs(constant).max()), 1e-12)
    ramp = 1.0 + np.arange(n) / n
    found = []
    for size in PERTURBATIONS:
        try:
            z = lemke(matrix, constant + size * scale * ramp)
        except RayTermination:
            continue
        found.append((z[:points], z[points:2 * points] - z[2 * points:3 * points]))
    return found
