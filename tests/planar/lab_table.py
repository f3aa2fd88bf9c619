"""The lab's velocity pass as ``planar-pgs`` states it (``stackx.solvers.planar.pgs``, step 3), written on the
contact table in plain Python: the statement the solver's laid-out pass is checked against, bit for bit."""

from __future__ import annotations

import numpy as np

from stackx.solvers.planar.contacts import A, B, DEPTH, KN, KT, MU, NX, NY, PN, PT, manifold_impulse, manifold_velocity
from stackx.solvers.planar.wavefront import manifold_end


def lab_table_pass(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
                   ids: np.ndarray, table: np.ndarray, count: int, order: np.ndarray) -> None:
    """The lab's pass as ``planar-pgs`` states it, on the contact table: per-visit clamped impulses over the
    overlapping points, stopping the approach, then friction within ``mu`` times this visit's normal impulse;
    ``PN``/``PT`` add up what the visits gave. Plain Python, the statement the laid-out pass must equal.

    The points are visited manifold by manifold, each manifold's first point in ``order``; a manifold's two
    bodies' velocities are held in locals over its points (``manifold_velocity``, ``manifold_impulse``)."""
    for m in range(order.shape[0]):
        k = order[m]
        a, b = ids[k, A], ids[k, B]
        grounded = a < 0
        vax, vay, wa, ima, iia = 0.0, 0.0, 0.0, 0.0, 0.0
        if not grounded:
            vax, vay, wa, ima, iia = vx[a], vy[a], w[a], inv_mass[a], inv_inertia[a]
        vbx, vby, wb, imb, iib = vx[b], vy[b], w[b], inv_mass[b], inv_inertia[b]
        for i in range(k, manifold_end(ids, k, count)):
            if table[i, DEPTH] <= 0.0:
                continue
            nx, ny = table[i, NX], table[i, NY]
            un = manifold_velocity(vax, vay, wa, vbx, vby, wb, grounded, table, i, nx, ny)
            pn = 0.0
            if un < 0.0:
                pn = -un * table[i, KN]
                vax, vay, wa, vbx, vby, wb = manifold_impulse(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb,
                                                              iib, table, i, pn * nx, pn * ny)
                table[i, PN] += pn
            limit = table[i, MU] * pn
            if limit > 0.0:
                pt = -manifold_velocity(vax, vay, wa, vbx, vby, wb, grounded, table, i, -ny, nx) * table[i, KT]
                pt = min(max(pt, -limit), limit)
                vax, vay, wa, vbx, vby, wb = manifold_impulse(vax, vay, wa, vbx, vby, wb, grounded, ima, iia, imb,
                                                              iib, table, i, -pt * ny, pt * nx)
                table[i, PT] += pt
        if not grounded:
            vx[a], vy[a], w[a] = vax, vay, wa
        vx[b], vy[b], w[b] = vbx, vby, wb
