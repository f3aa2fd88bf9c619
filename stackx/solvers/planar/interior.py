"""A primal-dual interior point method on a step's contact problem: the reference's first stage.

**Why.** A pile's step problem has far more contact rows than its boxes have velocities (two points a face,
a box on two others), so the impulses that hold it are not unique and the Newton rounds that read each
point's mode off the current answer leap or cycle when started far from it (a bouncing pile, a box landing,
a pile seen through a speculative margin): the rounds' mode systems are near singular along the share of a
load between redundant points, and which share is right is decided by friction at the 1e-8 m/s scale. An
interior point method does not choose modes at all until the end. It follows the *central path*: every
complementary pair (a point's normal impulse and its normal gap; each friction bound's slack and the slip
that pushes against it) is held at the same product ``tau`` while ``tau`` shrinks, so every iterate is
strictly inside and the redundant shares stay spread evenly instead of swinging from one point to its
neighbour. Each iteration is one linear system in the bodies' velocities (3 unknowns a box, however many
points touch), of the same sparsity as a mode system; 10 to 30 iterations bring a pile from nothing to
within about 1e-5 m/s, where the modes are plain to read, and the reference's Newton rounds land from
there (``reference.solve``).

**The problem, written for it.** In scaled impulses (``q = p / k``, m/s, as ``reference.ModeSystem``) per
point: ``qn >= 0`` and the normal gap ``s = un - target >= 0`` with ``qn s = 0``; the friction bound's two
slacks ``f+ = cone qn - qt >= 0`` and ``f- = cone qn + qt >= 0`` (``cone = mu kn / kt``), each with a slip
multiplier ``b+, b- >= 0``, ``f+ b+ = f- b- = 0`` and ``ut = b- - b+``: a point slides only with its
friction at the bound, against its slip (maximal dissipation); this is the Stewart-Trinkle form of the 2D
problem with its two tangent directions folded into one signed ``qt``. The bodies' velocities ``v`` obey
``M (v - v0) = J^T p``.

**An iteration** (Mehrotra's predictor-corrector): a Newton step on those equations with the pairs'
products aimed at 0 (the predictor), then again aimed at ``sigma tau`` with the predictor's second-order
term (``sigma`` from how far the predictor could go), both on one factorization. Per point the unknowns are
eliminated in closed form, which leaves ``(M + sum J^T D J) dv = r`` with a 2 x 2 ``D`` per point; friction's
dependence on the normal impulse makes ``D`` unsymmetric, so the system is factored with row pivoting, as a
band (``banded``). Steps stop at 99.5% of the way to the nearest bound. The iterations run compiled
(``walk``): on a 20-row pyramid's step a path takes 27 to 48 ms (``benchmarks.planar_banded``), where the
same iterations in numpy around SuperLU took 167 to 190 ms.

**Where it stops.** Once ``tau`` is below ``TAU`` and the equations' residual below ``EQUATIONS``; or after
``ITERATIONS``; or when ``STALLED`` steps in a row went less than ``SHORT`` of the way, or ``tau`` fell by less
than ``CRAWL`` over ``PATIENCE`` iterations: with friction the problem is not monotone, and on some piles the
central path folds and its steps jam. On a recorded ``pyramid-10`` step under ``planar-xpbd`` (16 substeps)
the path loads two points that the exact answer leaves just apart (a gap opening at 1.4e-5 m/s) and starves
the one that carries the box, and a point's friction swings from one bound to the other from step to step.
Begun at the last step's answer instead (``start``: the impulses moved ``INSIDE`` their bounds), the path ends
on that step and on the 18 of the run's steps tried. The answer is returned with whether it is near the path's
end (``tau`` below ``USABLE``); the caller checks it.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import kernel
from stackx.solvers.planar.banded import add, band, factor, ordering, solve
from stackx.solvers.planar.mode_rows import gathered, spread

TAU = 1e-13  # (m/s)^2: the pairs' mean product at which the path is left ...
EQUATIONS = 1e-10  # m/s: ... once the equations hold this well too
USABLE = 1e-9  # a path left early (jammed, or out of iterations) with the mean product below this is near its end
ITERATIONS = 60  # most iterations
PATIENCE = 8  # iterations over which ...
CRAWL = 0.8  # ... the pairs' mean product must fall below this share of what it was, or the path has jammed
# (a settling 20-row pyramid's path crawls for a while and then ends: at 5 and 0.5 it was left before its end)
SHORT = 1e-3  # a step shorter than this share of its direction has jammed ...
STALLED = 4  # ... and this many of them in a row end the method
FRACTION = 0.995  # of the way to the nearest bound a step goes
INSIDE = 1e-2  # m/s: how far inside its bounds a path begun at given impulses puts each pair


# the rows of the per-point arrays a walk carries (``state``) and a step moves them by (``step``)
QN, QT, S, BP, BM, FP, FM = 0, 1, 2, 3, 4, 5, 6


def central_path(values: np.ndarray, columns: np.ndarray, k: np.ndarray, cone: np.ndarray, v0: np.ndarray,
                 inv: np.ndarray, fixed_u: np.ndarray, target: np.ndarray, start: np.ndarray | None = None,
                 order: tuple[np.ndarray, int] | None = None) -> tuple[np.ndarray, int, int]:
    """Follow the central path of a step problem given as ``reference.ModeSystem`` holds it (``J`` row by row
    over the movable degrees of freedom, effective masses ``k``, friction ``cone``, free velocities ``v0``,
    inverse masses ``inv``, the rows' velocities of immovable bodies ``fixed_u`` and targets), from every pair
    at 1 or, given ``start`` (scaled impulses, e.g. a warm start), from those impulses moved ``INSIDE`` into the
    interior with the gaps and slips they give. Returns the scaled impulses reached (``q``, normals then
    tangents), the iterations and whether it ended near the path's end (1) or jammed early (0). Each
    iteration's system is a band in the order ``order`` (``banded.ordering``'s; found here when None)."""
    where, half = ordering(columns, v0.shape[0]) if order is None else order
    begun = start is not None
    return walk(values, columns, k, cone, v0, inv, fixed_u, target, start if begun else np.zeros(2 * cone.shape[0]),
                begun, where, half)


@kernel
def walk(values: np.ndarray, columns: np.ndarray, k: np.ndarray, cone: np.ndarray, v0: np.ndarray,
         inv: np.ndarray, fixed_u: np.ndarray, target: np.ndarray, start: np.ndarray, begun: bool,
         where: np.ndarray, half: int) -> tuple[np.ndarray, int, int]:
    """``central_path``'s iterations, compiled (``start`` read only when ``begun``; the band's order ``where``
    and half width ``half``)."""
    m = cone.shape[0]
    dof = v0.shape[0]
    jn, cn = values[:m], columns[:m]
    jt, ct = values[m:], columns[m:]
    kn, kt = k[:m], k[m:]
    mass = 1.0 / inv
    base_n = fixed_u[:m] - target[:m]
    base_t = fixed_u[m:] - target[m:]
    rough = np.zeros(m)  # a frictionless point carries no tangent impulse: its pairs rest
    for i in range(m):
        if cone[i] > 0.0:
            rough[i] = 1.0
    v = v0.copy()
    state = np.ones((7, m))
    state[QT] = 0.0
    state[BP], state[BM] = rough, rough
    for i in range(m):
        if rough[i] > 0.0:
            state[FP, i], state[FM, i] = cone[i], cone[i]
    qn, qt, s, bp, bm, fp, fm = state[QN], state[QT], state[S], state[BP], state[BM], state[FP], state[FM]
    if begun:  # the given impulses, each pair moved INSIDE off its bound
        for i in range(m):
            qn[i] = max(start[i], 0.0) + INSIDE
            inside = min(INSIDE, 0.5 * cone[i] * qn[i])  # a narrow box (low friction) keeps its middle half
            qt[i] = min(max(start[m + i], -cone[i] * qn[i] + inside), cone[i] * qn[i] - inside) * rough[i]
        v = v0 + inv * (spread(jn, cn, kn * qn, dof) + spread(jt, ct, kt * qt, dof))
        vv = np.append(v, 0.0)
        un = gathered(jn, cn, vv)
        slip = gathered(jt, ct, vv)
        for i in range(m):
            s[i] = max(un[i] + base_n[i], 0.0) + INSIDE
            slide = slip[i] + base_t[i]
            if rough[i] > 0.0:
                fp[i], fm[i] = cone[i] * qn[i] - qt[i], cone[i] * qn[i] + qt[i]
            bp[i], bm[i] = (max(-slide, 0.0) + INSIDE) * rough[i], (max(slide, 0.0) + INSIDE) * rough[i]
    pairs = m + 2.0 * rough.sum()
    short = 0
    iteration = 0
    history = np.empty(ITERATIONS)
    pivots = np.zeros(dof, np.int64)
    rest = np.empty((4, m))  # the equations' residuals: normal gap, slip, the two bounds' slacks
    r_n, r_t, r_p, r_m = rest[0], rest[1], rest[2], rest[3]
    no = np.zeros((7, m))  # the predictor's own direction has no second-order terms
    for iteration in range(1, ITERATIONS + 1):
        vv = np.append(v, 0.0)
        un = gathered(jn, cn, vv)
        ut = gathered(jt, ct, vv)
        r_dyn = mass * (v - v0) - spread(jn, cn, kn * qn, dof) - spread(jt, ct, kt * qt, dof)
        # the bounds' slacks are carried, not recomputed from qn and qt: at a sliding point they are many orders
        # below the impulses, and the difference would lose them to rounding
        off = 0.0
        for c in range(dof):
            off = max(off, abs(r_dyn[c] * inv[c]))
        tau = 0.0
        for i in range(m):
            r_n[i] = un[i] + base_n[i] - s[i]
            r_t[i] = (ut[i] + base_t[i] - (bm[i] - bp[i])) * rough[i]
            r_p[i] = (fp[i] - (cone[i] * qn[i] - qt[i])) * rough[i]
            r_m[i] = (fm[i] - (cone[i] * qn[i] + qt[i])) * rough[i]
            off = max(off, abs(r_n[i]), abs(r_t[i]), abs(r_p[i]), abs(r_m[i]))
            tau += s[i] * qn[i] + fp[i] * bp[i] + fm[i] * bm[i]
        tau /= pairs
        if tau < TAU and off < EQUATIONS:
            return np.concatenate((qn, qt)), iteration, 1
        history[iteration - 1] = tau
        if iteration > PATIENCE and tau > CRAWL * history[iteration - 1 - PATIENCE]:
            break  # the products crawl: the path has folded here
        # per point: dqn = gn - an dun; dqt = gt - atn dun - att dut (see the module text)
        an = qn / s
        d = np.ones(m)
        for i in range(m):
            if rough[i] > 0.0:
                d[i] = bm[i] / fm[i] + bp[i] / fp[i]
        e = cone * (bp / fp - bm / fm)
        atn, att = e * an / d, rough / d
        ab = band(mass, where, half)
        add(ab, half, where, kn * an, jn, jn, cn)
        add(ab, half, where, kt * att, jt, jt, ct)
        add(ab, half, where, kt * atn, jt, jn, cn)
        if not factor(ab, half, pivots):
            break  # a system made singular by the path's far end (products at rounding level)
        dv, predictor = direction(0.0, False, no, state, rest, r_dyn, cone, rough, an, d, e, atn, att, jn, cn, jt,
                                  ct, kn, kt, ab, half, pivots, where)
        a = reach(state, predictor)
        aimed = 0.0
        for i in range(m):
            aimed += ((s[i] + a * predictor[S, i]) * (qn[i] + a * predictor[QN, i])
                      + (fp[i] + a * predictor[FP, i]) * (bp[i] + a * predictor[BP, i])
                      + (fm[i] + a * predictor[FM, i]) * (bm[i] + a * predictor[BM, i]))
        sigma = (aimed / pairs / tau) ** 3
        dv, step = direction(sigma * tau, True, predictor, state, rest, r_dyn, cone, rough, an, d, e, atn, att, jn,
                             cn, jt, ct, kn, kt, ab, half, pivots, where)
        a = min(1.0, FRACTION * reach(state, step))
        if not (np.isfinite(a) and np.isfinite(dv).all()):
            break
        v = v + a * dv[:dof]
        state += a * step
        short = short + 1 if a < SHORT else 0
        if short >= STALLED:
            break
    tau = 0.0
    for i in range(m):
        tau += s[i] * qn[i] + fp[i] * bp[i] + fm[i] * bm[i]
    return np.concatenate((qn, qt)), iteration, int(tau / pairs < USABLE)


@kernel
def direction(aim: float, second: bool, predictor: np.ndarray, state: np.ndarray, rest: np.ndarray,
              r_dyn: np.ndarray, cone: np.ndarray, rough: np.ndarray, an: np.ndarray, d: np.ndarray, e: np.ndarray,
              atn: np.ndarray, att: np.ndarray, jn: np.ndarray, cn: np.ndarray, jt: np.ndarray, ct: np.ndarray,
              kn: np.ndarray, kt: np.ndarray, ab: np.ndarray, half: int, pivots: np.ndarray,
              where: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The step towards pairs' products ``aim`` (with the ``predictor``'s second-order terms when ``second``):
    the velocities' change (with a 0 appended) and the per-point changes, rows as ``state``'s."""
    m = cone.shape[0]
    dof = ab.shape[0]
    qn, s, bp, bm, fp, fm = state[QN], state[S], state[BP], state[BM], state[FP], state[FM]
    r_n, r_t, r_p, r_m = rest[0], rest[1], rest[2], rest[3]
    c_n, c_p, c_m = aim - s * qn, (aim - fp * bp) * rough, (aim - fm * bm) * rough
    if second:
        c_n = c_n - predictor[S] * predictor[QN]
        c_p = c_p - predictor[FP] * predictor[BP]
        c_m = c_m - predictor[FM] * predictor[BM]
    c_p, c_m = c_p + bp * r_p, c_m + bm * r_m
    gn = (c_n - qn * r_n) / s
    gt = (c_m / fm - c_p / fp - r_t + e * gn) / d * rough
    dv = solve(ab, half, pivots, where,
                      -r_dyn + spread(jn, cn, kn * gn, dof) + spread(jt, ct, kt * gt, dof))
    dun, dut = gathered(jn, cn, dv), gathered(jt, ct, dv)
    step = np.empty((7, m))
    step[QN] = gn - an * dun
    step[QT] = gt - atn * dun - att * dut
    step[S] = dun + r_n
    step[BP] = (c_p - bp * (cone * step[QN] - step[QT])) / fp
    step[BM] = (c_m - bm * (cone * step[QN] + step[QT])) / fm
    step[FP] = (cone * step[QN] - step[QT] - r_p) * rough
    step[FM] = (cone * step[QN] + step[QT] - r_m) * rough
    return dv, step


@kernel
def reach(state: np.ndarray, step: np.ndarray) -> float:
    """How far along ``step`` every pair stays nonnegative (at most 1)."""
    longest = 1.0
    for row in range(7):
        if row != QT:
            for i in range(state.shape[1]):
                if step[row, i] < 0.0:
                    longest = min(longest, -state[row, i] / step[row, i])
    return longest
