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
dependence on the normal impulse makes ``D`` unsymmetric, so the system is factored by SuperLU with
pivoting. Steps stop at 99.5% of the way to the nearest bound.

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

from stackx.models.planar import mode_rows

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


def central_path(values: np.ndarray, columns: np.ndarray, k: np.ndarray, cone: np.ndarray, v0: np.ndarray,
                 inv: np.ndarray, fixed_u: np.ndarray, target: np.ndarray,
                 start: np.ndarray | None = None) -> tuple[np.ndarray, int, int]:
    """Follow the central path of a step problem given as ``reference.ModeSystem`` holds it (``J`` row by row
    over the movable degrees of freedom, effective masses ``k``, friction ``cone``, free velocities ``v0``,
    inverse masses ``inv``, the rows' velocities of immovable bodies ``fixed_u`` and targets), from every pair
    at 1 or, given ``start`` (scaled impulses, e.g. a warm start), from those impulses moved ``INSIDE`` into the
    interior with the gaps and slips they give. Returns the scaled impulses reached (``q``, normals then
    tangents), the iterations and whether it ended near the path's end (1) or jammed early (0)."""
    from scipy import sparse
    from scipy.sparse.linalg import splu

    m = cone.shape[0]
    dof = v0.shape[0]
    jn, cn = values[:m], columns[:m]
    jt, ct = values[m:], columns[m:]
    kn, kt = k[:m], k[m:]
    mass = 1.0 / inv
    base_n = fixed_u[:m] - target[:m]
    base_t = fixed_u[m:] - target[m:]
    rows = np.concatenate([jn, jt, jn])
    cols = np.concatenate([cn, ct, cn])
    rough = (cone > 0.0).astype(np.float64)  # a frictionless point carries no tangent impulse: its pairs rest
    v = v0.copy()
    qn, qt, s, bp, bm = np.ones(m), np.zeros(m), np.ones(m), rough.copy(), rough.copy()
    fp, fm = np.where(rough > 0.0, cone, 1.0), np.where(rough > 0.0, cone, 1.0)
    if start is not None:  # the given impulses, each pair moved INSIDE off its bound
        qn = np.maximum(start[:m], 0.0) + INSIDE
        inside = np.minimum(INSIDE, 0.5 * cone * qn)  # a narrow box (low friction) keeps its middle half
        qt = np.clip(start[m:], -cone * qn + inside, cone * qn - inside) * rough
        v = v0 + inv * (mode_rows.spread(jn, cn, kn * qn, dof) + mode_rows.spread(jt, ct, kt * qt, dof))
        vv = np.append(v, 0.0)
        s = np.maximum(mode_rows.gathered(jn, cn, vv) + base_n, 0.0) + INSIDE
        slip = mode_rows.gathered(jt, ct, vv) + base_t
        fp, fm = np.where(rough > 0.0, cone * qn - qt, 1.0), np.where(rough > 0.0, cone * qn + qt, 1.0)
        bp, bm = (np.maximum(-slip, 0.0) + INSIDE) * rough, (np.maximum(slip, 0.0) + INSIDE) * rough
    pairs = m + 2 * rough.sum()
    short = 0
    iteration = 0
    history: list[float] = []
    for iteration in range(1, ITERATIONS + 1):
        vv = np.append(v, 0.0)
        un = mode_rows.gathered(jn, cn, vv) + base_n
        ut = mode_rows.gathered(jt, ct, vv) + base_t
        r_dyn = mass * (v - v0) - mode_rows.spread(jn, cn, kn * qn, dof) - mode_rows.spread(jt, ct, kt * qt, dof)
        # the bounds' slacks are carried, not recomputed from qn and qt: at a sliding point they are many orders
        # below the impulses, and the difference would lose them to rounding
        r_n, r_t = un - s, (ut - (bm - bp)) * rough
        r_p, r_m = (fp - (cone * qn - qt)) * rough, (fm - (cone * qn + qt)) * rough
        tau = (s @ qn + fp @ bp + fm @ bm) / pairs
        off = max(np.abs(r_dyn * inv).max(initial=0.0), np.abs(r_n).max(initial=0.0), np.abs(r_t).max(initial=0.0),
                  np.abs(r_p).max(initial=0.0), np.abs(r_m).max(initial=0.0))
        if tau < TAU and off < EQUATIONS:
            return np.concatenate([qn, qt]), iteration, 1
        history.append(tau)
        if len(history) > PATIENCE and tau > CRAWL * history[-1 - PATIENCE]:
            break  # the products crawl: the path has folded here
        # per point: dqn = gn - an dun; dqt = gt - atn dun - att dut (see the module text)
        an = qn / s
        d = np.where(rough > 0.0, bm / fm + bp / fp, 1.0)
        e = cone * (bp / fp - bm / fm)
        atn, att = e * an / d, rough / d
        weights = np.concatenate([(kn * an)[:, None] * jn, (kt * att)[:, None] * jt, (kt * atn)[:, None] * jt])
        try:
            lu = splu(sparse.csc_matrix(mode_rows.matrix(mass, weights, rows, cols, 1.0), shape=(dof, dof)),
                      permc_spec="MMD_AT_PLUS_A")
        except RuntimeError:  # a system made singular by the path's far end (products at rounding level)
            break

        def direction(aim: float, second: tuple[np.ndarray, ...] | None) -> tuple[np.ndarray, ...]:
            """The step towards pairs' products ``aim`` (with the predictor's second-order terms)."""
            c_n, c_p, c_m = aim - s * qn, (aim - fp * bp) * rough, (aim - fm * bm) * rough
            if second is not None:
                _, dqn_, _, ds_, dbp_, dbm_, dfp_, dfm_ = second
                c_n = c_n - ds_ * dqn_
                c_p = c_p - dfp_ * dbp_
                c_m = c_m - dfm_ * dbm_
            c_p, c_m = c_p + bp * r_p, c_m + bm * r_m
            gn = (c_n - qn * r_n) / s
            gt = (c_m / fm - c_p / fp - r_t + e * gn) / d * rough
            dv = lu.solve(-r_dyn + mode_rows.spread(jn, cn, kn * gn, dof) + mode_rows.spread(jt, ct, kt * gt, dof))
            dvv = np.append(dv, 0.0)
            dun, dut = mode_rows.gathered(jn, cn, dvv), mode_rows.gathered(jt, ct, dvv)
            dqn = gn - an * dun
            dqt = gt - atn * dun - att * dut
            ds = dun + r_n
            dbp = (c_p - bp * (cone * dqn - dqt)) / fp
            dbm = (c_m - bm * (cone * dqn + dqt)) / fm
            dfp = (cone * dqn - dqt - r_p) * rough
            dfm = (cone * dqn + dqt - r_m) * rough
            return dv, dqn, dqt, ds, dbp, dbm, dfp, dfm

        def reach(step: tuple[np.ndarray, ...]) -> float:
            """How far along ``step`` every pair stays nonnegative (at most 1)."""
            _, dqn, dqt, ds, dbp, dbm, dfp, dfm = step
            longest = 1.0
            for x, dx in ((qn, dqn), (s, ds), (bp, dbp), (bm, dbm), (fp, dfp), (fm, dfm)):
                falling = dx < 0.0
                if falling.any():
                    longest = min(longest, float((-x[falling] / dx[falling]).min()))
            return longest

        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            predictor = direction(0.0, None)
            a = reach(predictor)
            _, dqn, dqt, ds, dbp, dbm, dfp, dfm = predictor
            aimed = ((s + a * ds) @ (qn + a * dqn) + (fp + a * dfp) @ (bp + a * dbp)
                     + (fm + a * dfm) @ (bm + a * dbm)) / pairs
            sigma = (aimed / tau) ** 3
            step = direction(sigma * tau, predictor)
            a = min(1.0, FRACTION * reach(step))
        dv, dqn, dqt, ds, dbp, dbm, dfp, dfm = step
        if not (np.isfinite(a) and np.isfinite(dv).all()):
            break
        v, qn, qt, s = v + a * dv, qn + a * dqn, qt + a * dqt, s + a * ds
        bp, bm, fp, fm = bp + a * dbp, bm + a * dbm, fp + a * dfp, fm + a * dfm
        short = short + 1 if a < SHORT else 0
        if short >= STALLED:
            break
    tau = (s @ qn + fp @ bp + fm @ bm) / pairs
    return np.concatenate([qn, qt]), iteration, int(tau < USABLE)
