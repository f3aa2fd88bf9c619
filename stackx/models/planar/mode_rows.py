"""The reference's per-round arithmetic on ``J`` held row by row, compiled: what a Newton round of a mode
system (``reference.ModeSystem``) does many times on a pile's 2m rows.

``J`` is held as two (2m, 6) arrays (``problem.jacobian_rows``, with columns renumbered to the movable
degrees of freedom, ``dof`` standing for none): each row's six entries and their columns. A round

- spreads impulses onto the velocities (``J^T y``) and gathers the rows' velocities back (``J v``), once per
  merit the line search asks for and per proximal step;
- builds the matrix it factors, ``diag(mass) + sum over free rows of g_r j_r^T / d``, as compressed columns.

In numpy each of these is a handful of array calls whose fixed cost (tens of microseconds) dwarfs their
arithmetic on a pile of a few hundred points, and the matrix went through scipy's COO to CSC conversion,
which sorts and sums duplicates in Python-facing objects: a 10-step bench of ``pyramid-10`` spent 9.5 s of
its 24 s in building and factoring mode matrices, 3.8 s in merits. Compiled, the same sums cost what their
arithmetic does.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import kernel


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
def matrix(diagonal: np.ndarray, g: np.ndarray, j_rows: np.ndarray, j_columns: np.ndarray,
           proximal: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``diag(diagonal) + sum_r g_r j_r^T / proximal`` over the free rows, as compressed columns
    ``(data, indices, indptr)`` with sorted row indices and no duplicates; entries on the column of no
    velocity (``dof = len(diagonal)``) are left out. Each column's entries are summed in the order the rows
    come, after its diagonal."""
    dof = diagonal.shape[0]
    rows = j_rows.shape[0]
    # which free rows reach each column (a row reaches six columns, two bodies')
    reach = np.zeros(dof + 1, np.int64)
    for r in range(rows):
        for jj in range(6):
            if j_columns[r, jj] < dof:
                reach[j_columns[r, jj] + 1] += 1
    for c in range(dof):
        reach[c + 1] += reach[c]
    by_column = np.empty(reach[dof], np.int64)
    slot = reach[:dof].copy()
    for r in range(rows):
        for jj in range(6):
            c = j_columns[r, jj]
            if c < dof:
                by_column[slot[c]] = r * 6 + jj
                slot[c] += 1
    where = np.full(dof, -1, np.int64)  # a column's entry per row index while that column is built
    indptr = np.zeros(dof + 1, np.int64)
    indices = np.empty(dof + 6 * reach[dof], np.int64)
    data = np.empty(dof + 6 * reach[dof])
    count = 0
    for c in range(dof):
        begin = count
        where[c] = count
        indices[count], data[count] = c, diagonal[c]
        count += 1
        for s in range(reach[c], reach[c + 1]):
            r, jj = by_column[s] // 6, by_column[s] % 6
            for i in range(6):
                row = j_columns[r, i]
                if row < dof:
                    value = g[r, i] * j_rows[r, jj] / proximal
                    if where[row] < begin:
                        where[row] = count
                        indices[count], data[count] = row, value
                        count += 1
                    else:
                        data[where[row]] += value
        # sort the column's entries by row (a pile's column holds a few tens): insertion sort
        for a in range(begin + 1, count):
            row, value = indices[a], data[a]
            b = a - 1
            while b >= begin and indices[b] > row:
                indices[b + 1], data[b + 1] = indices[b], data[b]
                b -= 1
            indices[b + 1], data[b + 1] = row, value
        for a in range(begin, count):
            where[indices[a]] = -1
        indptr[c + 1] = count
    return data[:count], indices[:count], indptr
