"""The reference's linear systems in the bodies' velocities, as a band: ordered, assembled and factored compiled.

**Why a band.** Every system the reference solves (a central path iteration's, a mode combination's) is
``diag(mass) + sum_r g_r j_r^T`` over the movable degrees of freedom (3 a box), a row coupling only the two
bodies of its point. In an order where touching bodies lie near each other (reverse Cuthill-McKee, on the graph
of degrees of freedom that share a row), every entry lies within a few rows of boxes of the diagonal: 23 on a
``pyramid-10`` step of 165 unknowns. LU on that band costs ``n l (2l + 1)`` multiply-adds (``l`` the band's half
width), with no object built per factorization, and every one of a step's 10 to 40 path iterations and tens
of Newton rounds factors one. ``benchmarks.planar_banded`` times it on recorded steps against LAPACK's band LU
(``dgbtrf``: the same algorithm and storage, through scipy) and SuperLU (a general sparse LU) on the same
matrices, side by side. On three 20-row pyramid steps and three 10-row ones (630 and 165 unknowns, half width
20 to 44) a factorization takes 0.58 to 0.82 times LAPACK's time and 0.13 to 0.28 times SuperLU's, a solve with the
factors 0.78 to 0.9 times LAPACK's and 0.3 to 0.4 times SuperLU's, Python's call into each included. Before
the update was written for the compiler (``factor``), they took 1.6 to 2.4 and 1.5 to 1.95 times LAPACK's.

**Pivoting.** A mode combination with a sliding point and every central path system is unsymmetric (a point's
friction follows its normal impulse), and near the path's end its coupling can outgrow the symmetric part, so
the factorization pivots by rows within the band (as LAPACK's ``gbtrf``): U's band widens to ``2l``, stored
beside it from the start. A pivot that is zero (a singular system) is reported, not divided by.

**Storage.** ``ab[j, d + i - j]`` holds entry ``(i, j)`` of the ordered matrix, ``d = lower + upper``: a column
is contiguous, which is what the elimination's inner loop walks.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import kernel


@kernel
def ordering(columns: np.ndarray, dof: int) -> tuple[np.ndarray, int]:
    """Reverse Cuthill-McKee on the degrees of freedom (two are adjacent when a row names both; a column ``dof``
    stands for none): ``where[c]``, the place of degree of freedom ``c`` in the order, and the band's half
    width in that order. Each connected part starts from a node of least degree, moved once to the last node
    of a breadth-first walk from it (a far end of the part: the walk from there makes narrow levels)."""
    # adjacency lists, with repeats (a pair sharing several rows is listed once per row)
    count = np.zeros(dof + 1, np.int64)
    for r in range(columns.shape[0]):
        for i in range(6):
            if columns[r, i] < dof:
                for jj in range(6):
                    if jj != i and columns[r, jj] < dof:
                        count[columns[r, i] + 1] += 1
    for c in range(dof):
        count[c + 1] += count[c]
    near = np.empty(count[dof], np.int64)
    slot = count[:dof].copy()
    for r in range(columns.shape[0]):
        for i in range(6):
            if columns[r, i] < dof:
                for jj in range(6):
                    if jj != i and columns[r, jj] < dof:
                        near[slot[columns[r, i]]] = columns[r, jj]
                        slot[columns[r, i]] += 1
    seen = np.full(dof, -1, np.int64)
    degree = np.zeros(dof, np.int64)
    for c in range(dof):  # distinct neighbours
        for s in range(count[c], count[c + 1]):
            if seen[near[s]] != c:
                seen[near[s]] = c
                degree[c] += 1
    placed = np.zeros(dof, np.bool_)
    order = np.empty(dof, np.int64)
    done = 0
    while done < dof:
        root = -1
        for c in range(dof):
            if not placed[c] and (root < 0 or degree[c] < degree[root]):
                root = c
        for sweep in range(2):  # the second walk starts from the first one's last node
            begin = done
            placed[root] = True
            order[done] = root
            end = done + 1
            head = done
            while head < end:
                c = order[head]
                head += 1
                fresh = end
                for s in range(count[c], count[c + 1]):
                    other = near[s]
                    if not placed[other]:
                        placed[other] = True
                        order[end] = other
                        end += 1
                # the new neighbours by degree (stable insertion sort: a node has a few tens)
                for a in range(fresh + 1, end):
                    node = order[a]
                    b = a - 1
                    while b >= fresh and degree[order[b]] > degree[node]:
                        order[b + 1] = order[b]
                        b -= 1
                    order[b + 1] = node
            if sweep == 0:
                root = order[end - 1]
                for a in range(begin, end):
                    placed[order[a]] = False
            else:
                done = end
    where = np.empty(dof + 1, np.int64)
    for a in range(dof):  # the walk's order reversed
        where[order[dof - 1 - a]] = a
    where[dof] = dof
    half = 0
    for r in range(columns.shape[0]):
        for i in range(6):
            if columns[r, i] < dof:
                for jj in range(6):
                    if columns[r, jj] < dof:
                        half = max(half, abs(where[columns[r, i]] - where[columns[r, jj]]))
    return where, half


@kernel
def band(diagonal: np.ndarray, where: np.ndarray, half: int) -> np.ndarray:
    """A band of half width ``half`` (with room for the pivoting's fill) holding ``diag(diagonal)``, in the
    order ``where``."""
    dof = diagonal.shape[0]
    ab = np.zeros((dof, 3 * half + 1))
    for c in range(dof):
        ab[where[c], 2 * half] = diagonal[c]
    return ab


@kernel
def add(ab: np.ndarray, half: int, where: np.ndarray, weight: np.ndarray, left: np.ndarray, right: np.ndarray,
        columns: np.ndarray) -> None:
    """``ab += sum_r weight_r left_r right_r^T`` (each row's six entries on its six columns, in the order
    ``where``; a column ``len(ab)`` stands for none). A row's six places in the order are looked up once, not
    once for each of its 36 products; the products are added in the same order."""
    dof = ab.shape[0]
    d = 2 * half
    place = np.empty(6, np.int64)  # the row's columns in the order, -1 for none
    for r in range(columns.shape[0]):
        w = weight[r]
        if w == 0.0:
            continue
        for i in range(6):
            place[i] = where[columns[r, i]] if columns[r, i] < dof else -1
        for jj in range(6):
            j = place[jj]
            if j >= 0:
                x = w * right[r, jj]
                for i in range(6):
                    if place[i] >= 0:
                        ab[j, d + place[i] - j] += left[r, i] * x


@kernel
def factor(ab: np.ndarray, half: int, pivots: np.ndarray) -> bool:
    """LU of the band in place, with row pivoting within it (``pivots[k]``: the row swapped with ``k``).
    False if a pivot is zero or not finite (a singular system; ``ab`` is then of no use).

    The elimination's update, where the time goes, is written for the compiler: each step's multipliers are
    copied into an array of their own, and the entries they update are reached through the band's flat buffer
    (``ab`` in C order, as ``band`` makes it, so that the flat view is ``ab`` itself) by unsigned offsets.
    numba corrects a signed index that could be negative (Python's ``a[-1]``) on every access, and that
    correction kept the loop from being turned into vector instructions; an unsigned one needs none. Every entry
    gets the same operations in the same order, so the factors are the same to the bit (see
    ``benchmarks.planar_banded`` for what it changed)."""
    n, width = ab.shape
    d = 2 * half
    flat = ab.reshape(-1)  # a view: ``ab`` is contiguous
    column = np.empty(half)
    for k in range(n):
        last = min(n - 1, k + half)
        p, big = k, abs(ab[k, d])
        for i in range(k + 1, last + 1):
            size = abs(ab[k, d + i - k])
            if size > big:
                p, big = i, size
        pivots[k] = p
        if not (big > 0.0 and big < np.inf):
            return False
        reach = min(n - 1, k + d)  # the last column row k can reach once a lower row is swapped in
        if p != k:
            for j in range(k, reach + 1):
                a, b = d + k - j, d + p - j
                ab[j, a], ab[j, b] = ab[j, b], ab[j, a]
        pivot = ab[k, d]
        below = np.uint64(last - k)
        for i in range(below):
            ab[k, d + 1 + i] /= pivot
            column[i] = ab[k, d + 1 + i]
        for j in range(k + 1, reach + 1):
            x = ab[j, d + k - j]
            if x != 0.0:
                start = np.uint64(j * width + d + k + 1 - j)  # entry (k + 1, j) in the flat buffer
                for i in range(below):
                    flat[start + i] -= column[i] * x
    return True


@kernel
def solve(ab: np.ndarray, half: int, pivots: np.ndarray, where: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """The answer of the factored system for ``rhs`` (in the degrees of freedom's own order), with a 0
    appended for the column of no velocity. The factors are read through the band's flat buffer by unsigned
    offsets, as ``factor`` reads them, and for the same reason."""
    n, width = ab.shape
    d = 2 * half
    flat = ab.reshape(-1)
    x = np.empty(n)
    for c in range(n):
        x[where[c]] = rhs[c]
    for k in range(n):
        p = pivots[k]
        if p != k:
            x[k], x[p] = x[p], x[k]
        xk = x[k]
        if xk != 0.0:
            start = np.uint64(k * width + d + 1)  # entry (k + 1, k): L's column k below its diagonal
            below = np.uint64(k + 1)
            for i in range(np.uint64(min(n - 1, k + half) - k)):
                x[below + i] -= flat[start + i] * xk
    for j in range(n - 1, -1, -1):
        x[j] /= flat[j * width + d]
        xj = x[j]
        if xj != 0.0:
            top = max(0, j - d)
            start = np.uint64(j * width + d + top - j)  # entry (top, j): U's column j above its diagonal
            above = np.uint64(top)
            for i in range(np.uint64(j - top)):
                x[above + i] -= flat[start + i] * xj
    out = np.zeros(n + 1)
    for c in range(n):
        out[c] = x[where[c]]
    return out
