"""Lemke's walk on the points whose mode is in doubt, the points that clearly stick held rigid: a start for the
reference's last Newton rounds (``stackx.solvers.planar.reference``) on a large step that its other tries miss.

**Where it helps.** On a 20-row pyramid that topples (``planar-xpbd`` at 4 substeps) the reference's paths
and its proximal point method come within 1e-6 to 1e-3 m/s of an answer and stall there, and Lemke's walk on
the whole problem (3,400 unknowns) wanders for tens of pivots per unknown. Most of the pile's points are
clear at such a near answer: they push and stick with room to spare, or are well apart. Which mode the
others take is what the near answer cannot settle.

**The reduced problem** (``doubtful_start``). A point is in doubt where its normal impulse and its gap are
both below ``DOUBT`` m/s (pushing or apart, unclear), where it slides, or where it pushes and sticks with its
friction within ``DOUBT`` of its bound and its slip below it. Every other point that pushes is held rigid in
its mode (normal at its target, no slip), with the proximal term of the reference's mode systems
(``reference.ModeSystem``: ``J v + d q = target + d q_near``), so that a redundant set of
such points still has one answer, the one nearest the near answer. The points in doubt then see the pile
through that one factored system: their Delassus matrix ``J_A S^-1 J_A^T K_A`` (``S`` the held points' mode
system in the bodies' velocities, a band) and their velocities with no impulse of their own. That is a
contact problem of the same formulation (``pivoting.assembled``) on a tenth to a third of the points, and of
the same class as the whole one (``S`` is symmetric positive definite, so ``J_A S^-1 J_A^T`` is a Delassus
matrix too), which Lemke's walk ends on: a few hundred to ten thousand pivots, a second or two. Its answer and
the held points' impulses that go with it are the start; whether they hold (a held point may now pull, or leave
its friction box, and a point apart approach) is the Newton rounds' business, which read the modes afresh.

**Tried and not kept.** Holding the sliding points too (friction at its bound, in their mode system): ``S``
is then not symmetric, and every walk left on a ray. Lemke's walk on the whole problem begun from the complementary
basis of the near answer's modes (covered by the near answer's own residual): rays within 4 to 235 pivots.
Releasing held points whose impulses the start makes pull or leave the box and walking again until none does:
the start then meets the conditions to 1e-5 m/s, but on 8 recorded steps none landed from it (one from this one).

**Measured** on the 24 steps of the first 30 of pyramid-20 under ``planar-xpbd`` at 4 substeps that the
reference's paths, proximal point method and walks on the whole problem missed (each solved alone and in full):
the reference now lands 7 of them from this start, each solve 2.6 to 14 s in all, where the whole problem's
failing walks take about 20 s (``python3 -m benchmarks.planar_reference --bench configs/planar/pyramid-20.yaml
--steps 30`` counts what lands a bench's steps).
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import compiled, enabled
from stackx.solvers.planar import banded, mode_rows, pivoting
from stackx.solvers.planar.problem import ContactProblem

DOUBT = 1e-4  # m/s: a point whose mode this little separates from another's is in doubt


def doubtful_start(problem: ContactProblem, system: object,
                   near: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Impulses ``(pn, pt)`` from Lemke's walk on the points in doubt at the scaled impulses ``near``
    (``q = p / k``), the clear points held (see the module text); None when no point is in doubt, the held
    points' system is singular, or the walk finds no answer. ``system``: the problem's
    ``reference.ModeSystem`` of the held points' proximal weight, factored here for the held points' modes."""
    from scipy import sparse

    m = problem.points
    kn, kt, d = system.k[:m], system.k[m:], system.proximal
    gap = system.gap(near)
    qn, qt, un, ut = near[:m], near[m:], gap[:m], gap[m:]
    modes = system.read(near)
    held, sliding = modes[:m], modes[m:2 * m] | modes[2 * m:]
    doubt = (((qn < DOUBT) & (un < DOUBT)) | (held & sliding)
             | (held & (np.abs(system.cone * qn - np.abs(qt)) < DOUBT) & (np.abs(ut) < DOUBT)))
    points = np.flatnonzero(doubt)
    if points.shape[0] == 0:
        return None
    kept = held & ~doubt
    none = np.zeros(m, bool)
    system.factor(kept, none, none)
    if system.factors is None:
        return None
    dof, free = system.dof, system.free
    rows = np.concatenate([points, m + points])
    values, columns, k = system.values[rows], system.columns[rows], system.k[rows]
    with compiled(enabled()):
        aim = system.target[free] - system.fixed_u[free] + d * near[free]
        momentum = system.v0 / system.inv + mode_rows.spread(system.j_rows, system.j_columns,
                                                             system.k[free] * aim / d, dof)
        base = banded.solve(system.factors, system.half, system.pivots, system.where, momentum)
        # each row in doubt's impulse direction, through the held pile: a column of S^-1 J_A^T K_A
        reach = np.empty((dof + 1, rows.shape[0]))
        for c in range(rows.shape[0]):
            push = mode_rows.spread(values[c:c + 1], columns[c:c + 1], k[c:c + 1], dof)
            reach[:, c] = banded.solve(system.factors, system.half, system.pivots, system.where, push)
        free_velocity = mode_rows.gathered(values, columns, base) + system.fixed_u[rows]
        delassus = np.stack([mode_rows.gathered(values, columns, reach[:, c]) for c in range(rows.shape[0])], axis=1)
    matrix, constant = pivoting.assembled(sparse.csr_matrix(delassus), free_velocity, problem.target[points],
                                          system.cone[points])
    for size in pivoting.PERTURBATIONS:
        try:
            walked = pivoting.walk(matrix, constant, size, pivoting.PIVOTS)
            break
        except pivoting.RayEnd:
            continue
    else:
        return None
    a = points.shape[0]
    z = walked.z
    doubtful = np.concatenate([z[:a], z[a:2 * a] - z[2 * a:3 * a]])
    v = base + reach @ doubtful
    q = np.zeros(2 * m)
    q[free] = (aim - mode_rows.gathered(system.j_rows, system.j_columns, v)) / d
    q[rows] = doubtful
    return q[:m] * kn, q[m:] * kt
