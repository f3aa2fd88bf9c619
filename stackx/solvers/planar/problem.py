"""The contact problem of one step of one planar world, and how far a candidate answer is from solving it.

After gravity, a step's velocity solve asks for a normal impulse ``pn`` and a tangent impulse ``pt`` at every
contact point such that, with the velocities they give,

- no point approaches faster than it may, and a point pushes only while it is exactly that fast
  (``pn >= 0``, ``un - target >= 0``, ``pn (un - target) = 0``);
- friction holds the point while it can (``|pt| <= mu pn``), and a point slides only with its friction at the
  bound, opposing the slip (``pt = mu pn`` then ``ut <= 0``; ``pt = -mu pn`` then ``ut >= 0``). In 2D the
  friction cone has one tangent, so this box is Coulomb's law exactly, with maximal dissipation.

Every planar solver sets itself this problem, well or badly solved; the reference solver solves it to a
``residual`` below 1e-10 m/s, and the bench measures the others against that.

Conventions: body -1 is the ground (infinitely heavy, at rest); the normal points from ``a`` to ``b``; the
tangent is ``t = (-n_y, n_x)``; the relative velocity at a point is
``u = (v_b + w_b x r_b) - (v_a + w_a x r_a)`` with ``w x r = (-w r_y, w r_x)``; the impulse ``pn n + pt t``
acts on ``b`` at the point and its opposite on ``a``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

GROUND = -1


@dataclass
class ContactProblem:
    """The velocity problem of one step of one world (one batch row): ``n`` bodies, ``m`` contact points.

    - ``inv_mass`` (n,): 1/m, 0 for static bodies; ``inv_inertia`` (n,): 1/I about the centre, 0 for static
      bodies and bodies that may not rotate;
    - ``velocity`` (n, 3): vx, vy, w, the free velocity (after gravity, before contacts);
    - ``body_a``, ``body_b`` (m,) int64: the two bodies of each point, -1 the ground;
    - ``normal`` (m, 2): unit normal from a to b; ``ra``, ``rb`` (m, 2): the point minus the centre of a (b),
      ignored for -1;
    - ``friction`` (m,): the point's Coulomb coefficient, already mixed;
    - ``target`` (m,): slowest accepted relative normal velocity (0 touching, gap/dt < 0 speculative,
      positive to push apart).
    """

    inv_mass: np.ndarray
    inv_inertia: np.ndarray
    velocity: np.ndarray
    body_a: np.ndarray
    body_b: np.ndarray
    normal: np.ndarray
    ra: np.ndarray
    rb: np.ndarray
    friction: np.ndarray
    target: np.ndarray

    def __post_init__(self) -> None:
        for name in ("inv_mass", "inv_inertia", "velocity", "normal", "ra", "rb", "friction", "target"):
            setattr(self, name, np.ascontiguousarray(getattr(self, name), dtype=np.float64))
        for name in ("body_a", "body_b"):
            setattr(self, name, np.ascontiguousarray(getattr(self, name), dtype=np.int64))

    @property
    def bodies(self) -> int:
        return self.inv_mass.shape[0]

    @property
    def points(self) -> int:
        return self.body_a.shape[0]

    def tangent(self) -> np.ndarray:
        """``t = (-n_y, n_x)`` per point, (m, 2)."""
        return np.stack([-self.normal[:, 1], self.normal[:, 0]], axis=1)


def inverse_masses(problem: ContactProblem) -> np.ndarray:
    """``M^-1`` as a vector over the ``3n`` velocities of ``jacobian``'s columns: 1/m, 1/m, 1/I per body."""
    inv = np.repeat(problem.inv_mass, 3)
    inv[2::3] = problem.inv_inertia
    return inv


def jacobian_rows(problem: ContactProblem) -> tuple[np.ndarray, np.ndarray]:
    """``J`` row by row, as two (2m, 6) arrays: row ``k`` the normal of point ``k``, row ``m + k`` its
    tangent; per row the six entries of its two bodies (a's vx, vy, w, then b's) and their columns ``3i, 3i + 1,
    3i + 2`` of body ``i``. A ground side has column ``3n`` (no velocity) and entries 0. Dense in the rows, so
    products with ``J`` and ``J^T`` are a gather and a ``bincount``, with no sparse matrix object."""
    m, n = problem.points, problem.bodies
    values, columns = np.zeros((2 * m, 6)), np.full((2 * m, 6), 3 * n, np.int64)
    for offset, d in ((0, problem.normal), (m, problem.tangent())):
        for side, (body, r, sign) in enumerate(((problem.body_a, problem.ra, -1.0), (problem.body_b, problem.rb, 1.0))):
            moving = body != GROUND
            arm = r[:, 0] * d[:, 1] - r[:, 1] * d[:, 0]
            for axis, value in enumerate((d[:, 0], d[:, 1], arm)):
                values[offset:offset + m, 3 * side + axis] = np.where(moving, sign * value, 0.0)
                columns[offset:offset + m, 3 * side + axis] = np.where(moving, 3 * body + axis, 3 * n)
    return values, columns


def jacobian(problem: ContactProblem) -> object:
    """``J`` (2m x 3n, scipy CSR): row ``k`` the normal of point ``k``, row ``m + k`` its tangent; body ``i``'s
    columns ``3i, 3i + 1, 3i + 2`` (vx, vy, w). ``J v`` is the points' relative velocities."""
    from scipy import sparse

    values, columns = jacobian_rows(problem)
    m, n = problem.points, problem.bodies
    keep = columns < 3 * n
    rows = np.broadcast_to(np.arange(2 * m)[:, None], columns.shape)
    return sparse.csr_matrix((values[keep], (rows[keep], columns[keep])), shape=(2 * m, 3 * n))


def _side(problem: ContactProblem, body: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per point, one side's inverse mass, inverse inertia and arm ``r``, all 0 for the ground."""
    ground = body == GROUND
    index = np.where(ground, 0, body)
    if problem.bodies == 0:
        return np.zeros(body.shape), np.zeros(body.shape), np.zeros(r.shape)
    inv_m = np.where(ground, 0.0, problem.inv_mass[index])
    inv_i = np.where(ground, 0.0, problem.inv_inertia[index])
    return inv_m, inv_i, np.where(ground[:, None], 0.0, r)


def _cross(r: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``r x d`` (a scalar in 2D) per point."""
    return r[:, 0] * d[:, 1] - r[:, 1] * d[:, 0]


def effective_masses(problem: ContactProblem) -> tuple[np.ndarray, np.ndarray]:
    """``k_n = 1 / (n . K n)`` and ``k_t = 1 / (t . K t)`` per point: the impulse that changes the point's
    relative velocity along n (t) by 1 m/s when it acts alone (inf between two immovable bodies)."""
    t = problem.tangent()
    out = []
    for d in (problem.normal, t):
        total = np.zeros(problem.points)
        for body, r in ((problem.body_a, problem.ra), (problem.body_b, problem.rb)):
            inv_m, inv_i, arm = _side(problem, body, r)
            total += inv_m + inv_i * _cross(arm, d) ** 2
        with np.errstate(divide="ignore"):
            out.append(1.0 / total)
    return out[0], out[1]


def velocities_after(problem: ContactProblem, pn: np.ndarray, pt: np.ndarray) -> np.ndarray:
    """``velocity + M^-1 J^T p``: the bodies' velocities (n, 3) once the impulses have acted."""
    v = problem.velocity.copy()
    t = problem.tangent()
    impulse = pn[:, None] * problem.normal + pt[:, None] * t
    for body, r, sign in ((problem.body_a, problem.ra, -1.0), (problem.body_b, problem.rb, 1.0)):
        moving = body != GROUND
        idx, r_m, p_m = body[moving], r[moving], sign * impulse[moving]
        np.add.at(v[:, 0], idx, problem.inv_mass[idx] * p_m[:, 0])
        np.add.at(v[:, 1], idx, problem.inv_mass[idx] * p_m[:, 1])
        np.add.at(v[:, 2], idx, problem.inv_inertia[idx] * _cross(r_m, p_m))
    return v


def relative_velocities(problem: ContactProblem, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(un, ut)`` per point for body velocities ``v`` (n, 3)."""
    u = np.zeros((problem.points, 2))
    for body, r, sign in ((problem.body_a, problem.ra, -1.0), (problem.body_b, problem.rb, 1.0)):
        moving = body != GROUND
        vb = v[body[moving]]
        rm = r[moving]
        u[moving, 0] += sign * (vb[:, 0] - vb[:, 2] * rm[:, 1])
        u[moving, 1] += sign * (vb[:, 1] + vb[:, 2] * rm[:, 0])
    t = problem.tangent()
    return (u * problem.normal).sum(axis=1), (u * t).sum(axis=1)


def point_residuals(problem: ContactProblem, pn: np.ndarray, pt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per point, the normal and tangent terms of ``residual`` (m/s)."""
    kn, kt = effective_masses(problem)
    un, ut = relative_velocities(problem, velocities_after(problem, pn, pt))
    normal = np.abs(np.minimum(pn / kn, un - problem.target))
    bound = problem.friction * pn
    tangent = np.abs(pt - np.minimum(np.maximum(pt - kt * ut, -bound), bound)) / kt
    return normal, tangent


def residual(problem: ContactProblem, pn: np.ndarray, pt: np.ndarray) -> float:
    """How far impulses ``pn``, ``pt`` (m,) are from solving ``problem``, in m/s: the largest over points of
    ``|min(pn / k_n, un - target)|`` (complementarity of the normal) and
    ``|pt - clip(pt - k_t ut, -mu pn, mu pn)| / k_t`` (the friction box), with ``un``, ``ut`` from the
    velocities ``velocity + M^-1 J^T p``. 0 for a problem without points; NaN anywhere gives NaN."""
    if problem.points == 0:
        return 0.0
    normal, tangent = point_residuals(problem, np.asarray(pn, np.float64), np.asarray(pt, np.float64))
    worst = np.concatenate([normal, tangent])
    return float(np.nan) if np.isnan(worst).any() else float(worst.max())
