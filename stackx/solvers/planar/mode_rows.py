"""The reference's per-round arithmetic on ``J`` held row by row, compiled: what a Newton round of a mode
system (``reference.ModeSystem``) does many times on a pile's 2m rows.

``J`` is held as two (2m, 6) arrays (``problem.jacobian_rows``, with columns renumbered to the movable
degrees of freedom, ``dof`` standing for none): each row's six entries and their columns. A round

- spreads impulses onto the velocities (``J^T y``) and gathers the rows' velocities back (``J v``), once per
  merit the line search asks for;
- takes its proximal steps, each a solve with the round's factorization (``banded``) between a spread and a
  gather.

In numpy each of these is a handful of array calls whose fixed cost (tens of microseconds) dwarfs their
arithmetic on a pile of a few hundred points: a 10-step bench of ``pyramid-10`` spent 3.8 s of its 24 s in
merits. Compiled, the same sums cost what their arithmetic does.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import kernel
from stackx.solvers.planar.banded import solve


@kernel
def spread(values: np.ndarray, columns: np.ndarray, weights: np.ndarray, dof: int) -> np.ndarray:
    """``sum_r weights_r J_r^T`` over the rows given, on the ``dof`` movable degrees of freedom (a column
    ``dof`` stands for none and is dropped): rows in order, each row's six entries in order."""
    out = np.zeros(dof + 1)
    for r in range(values.shape[0]):
        for i in range(6):
            out[columns[r, i]] += values[r, i] * weights[r]
    return out[:dof]


@kernel
def velocities(values: np.ndarray, columns: np.ndarray, weights: np.ndarray, v0: np.ndarray,
               inv: np.ndarray) -> np.ndarray:
    """``v0 + inv * J^T weights``, with a 0 appended for the column of no velocity."""
    dof = v0.shape[0]
    push = spread(values, columns, weights, dof)
    v = np.zeros(dof + 1)
    for c in range(dof):
        v[c] = v0[c] + inv[c] * push[c]
    return v


@kernel
def gathered(values: np.ndarray, columns: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``J_r v`` per row: the relative velocity along each row's direction."""
    out = np.empty(values.shape[0])
    for r in range(values.shape[0]):
        total = 0.0
        for i in range(6):
            total += values[r, i] * v[columns[r, i]]
        out[r] = total
    return out


@kernel
def gaps(values: np.ndarray, columns: np.ndarray, weights: np.ndarray, v0: np.ndarray, inv: np.ndarray,
         fixed_u: np.ndarray, target: np.ndarray) -> np.ndarray:
    """``J v + fixed_u - target`` per row for the velocities ``v0 + inv * J^T weights``: how much faster than
    its target each row moves (the velocities of no impulse carry the ``fixed_u`` of immovable bodies)."""
    out = gathered(values, columns, velocities(values, columns, weights, v0, inv))
    for r in range(out.shape[0]):
        out[r] = out[r] + fixed_u[r] - target[r]
    return out


@kernel
def merit(qn: np.ndarray, qt: np.ndarray, gap: np.ndarray, cone: np.ndarray) -> float:
    """The largest over points of ``|min(qn, gap_n)|`` and ``|qt - clip(qt - gap_t, -cone qn, cone qn)|``
    (scaled impulses and row gaps, m/s): the contract's residual; inf when any is not finite."""
    m = qn.shape[0]
    worst = 0.0
    for k in range(m):
        normal = abs(min(qn[k], gap[k]))
        bound = cone[k] * qn[k]
        tangent = abs(qt[k] - min(max(qt[k] - gap[m + k], -bound), bound))
        if not (np.isfinite(normal) and np.isfinite(tangent)):
            return np.inf
        worst = max(worst, normal, tangent)
    return worst


@kernel
def proximal_steps(ab: np.ndarray, half: int, pivots: np.ndarray, where: np.ndarray, g: np.ndarray,
                   j_rows: np.ndarray, j_columns: np.ndarray, base: np.ndarray, momentum: np.ndarray,
                   proximal: float, out: np.ndarray, most: int, stop: float, normal: np.ndarray,
                   drift: float) -> np.ndarray:
    """Up to ``most`` proximal steps of a factored mode system (``banded``: ``ab``, ``half``, ``pivots``,
    ``where``) from the free rows' scaled impulses ``out``: each solves ``(M + G J_F / d) v = M v0 + G h / d``
    for ``h = base + d out`` and moves to ``(h - J_F v) / d``, until no impulse moves by more than ``stop``.
    The mode combination's answer is their fixed point; one step from a center is the regularized problem's.

    **A system without an answer drifts.** Where held points close a loop whose targets disagree, no impulses
    meet every row, and the steps settle into a steady drift that moves load around the loop, each step as
    long as the last (within a share ``drift``). The answer then has a point of the loop apart, and the drift tells
    which: the steps are followed, in one stride, until the first held point (``normal``: which free rows are
    normals) is emptied, and the next round reads it as separating."""
    dof = momentum.shape[0]
    step = np.zeros_like(out)
    change, last = np.inf, np.inf
    for _ in range(most):
        h = base + proximal * out
        v = solve(ab, half, pivots, where, momentum + spread(g, j_columns, h, dof) / proximal)
        new = (h - gathered(j_rows, j_columns, v)) / proximal
        last, change = change, 0.0
        for r in range(new.shape[0]):
            step[r] = new[r] - out[r]
            change = max(change, abs(step[r]))
        out = new
        if change <= stop:
            return out
    if abs(change - last) < drift * last:
        stride = np.inf
        for r in range(out.shape[0]):
            if normal[r] and step[r] < 0.0 and out[r] > 0.0:
                stride = min(stride, out[r] / -step[r])
        if stride < np.inf:
            out = out + stride * step
    return out
